"""The route encoder's local network and heads compiled (``learning.models.local_net``) against torch's."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from learning.models import local_net
from learning.models.route_net import load_route_net, make_route_net
from learning.models.route_vin import WALL_LOG, RouteVIN
from learning.models.shipped import SHIPPED_ROUTE as SHIPPED
from planners.maps.generators import TRAIN_SEEDS, generate


def _torch_local(x: np.ndarray, convs: list[torch.nn.Conv2d], pads: tuple[int, int, int, int]) -> np.ndarray:
    """The definition: each 3x3 layer pads the sides ``pads`` names with zeros, reads the region's own blocks at the
    others, and rectifies."""
    top, bottom, left, right = pads
    y = torch.from_numpy(x)[None]
    with torch.no_grad():
        for conv in convs:
            y = torch.relu(torch.nn.functional.conv2d(torch.nn.functional.pad(y, (left, right, top, bottom)),
                                                      conv.weight, conv.bias))
    return y[0].numpy()


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**16), cin=st.integers(1, 6), channels=st.integers(1, 9), depth=st.integers(1, 4),
       h=st.integers(1, 14), w=st.integers(1, 14), pads=st.tuples(*[st.integers(0, 1)] * 4))
def test_the_compiled_layers_give_torchs_features_on_any_region_and_padding(seed, cin, channels, depth, h, w, pads):
    top, bottom, left, right = pads
    h, w = h + 2 * depth * (2 - top - bottom), w + 2 * depth * (2 - left - right)  # room for the unpadded sides
    torch.manual_seed(seed)
    convs = [torch.nn.Conv2d(cin if i == 0 else channels, channels, 3) for i in range(depth)]
    x = np.random.default_rng(seed).random((cin, h, w)).astype(np.float32)
    first = local_net.grouped(convs[0].weight.detach().numpy(), convs[0].bias.detach().numpy())
    rest = [local_net.grouped(c.weight.detach().numpy(), c.bias.detach().numpy(), len(first[0])) for c in convs[1:]]
    width = len(first[0])
    assert width % local_net.GROUP == 0 and width >= channels
    ws = np.stack([r[0] for r in rest]) if rest else np.zeros((0, width, width, 3, 3), np.float32)
    bs = np.stack([r[1] for r in rest]) if rest else np.zeros((0, width), np.float32)
    got = local_net.local_features(x, *first, ws, bs, pads)
    want = _torch_local(x, convs, pads)
    assert got.shape == (width, *want.shape[1:])
    assert not got[channels:].any()  # the padded channels stay zero
    assert np.abs(got[:channels] - want).max() <= 1e-5 * max(1.0, np.abs(want).max())


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**16), channels=st.integers(1, 20), h=st.integers(1, 12), w=st.integers(1, 12),
       scale=st.sampled_from([0.1, 3.0, 30.0]))
def test_the_compiled_heads_give_torchs_costs_and_head_inputs(seed, channels, h, w, scale):
    torch.manual_seed(seed)
    net = make_route_net("vin", block=2, channels=channels, depth=1, step=2).eval()
    f = torch.from_numpy((np.random.default_rng(seed).standard_normal((1, channels, h, w)) * scale).astype(np.float32))
    with torch.no_grad():
        costs, pre = net.prices(f)[0].numpy(), net.head_inputs(f)[0].numpy()
    arrays = net.local_arrays()
    got_costs, got_pre = local_net.block_heads(np.concatenate([f[0].numpy(), np.ones((3, h, w), np.float32)]),
                                               channels, *arrays[4:6], net.head_arrays()[0], WALL_LOG, *arrays[6:8])
    assert np.allclose(got_costs, costs, rtol=1e-5, atol=0) and got_costs.min() >= 0.5 * min(net.lengths.view(-1))
    assert np.abs(got_pre - pre).max() <= 1e-5 * max(1.0, np.abs(pre).max())


def test_the_compiled_exp_is_float32s_exp_within_two_roundings():
    t = np.linspace(-40.0, WALL_LOG, 200_001).astype(np.float32)
    row, bits = t.copy(), np.empty(len(t), np.int32)
    local_net._exp_costs(row, np.float32(1.0), np.float32(WALL_LOG), bits)
    want = 0.5 + np.exp(np.maximum(t.astype(np.float64), local_net._LEAST_LOG))
    assert np.all(np.abs(row - want) <= 2 * np.spacing(want.astype(np.float32)))
    assert row[0] == np.float32(0.5)  # far below: exactly half a length, whatever exp gives


def test_the_encoder_runs_the_compiled_layers_on_small_regions_only_and_follows_its_weights():
    net = load_route_net(SHIPPED)
    side = math.isqrt(net.numba_local_blocks)
    small, large = torch.zeros(1, 5, side, side), torch.zeros(1, 5, side + 1, side + 1)
    with torch.no_grad():
        assert net.compiled_local(small) and not net.compiled_local(large)
        assert net.compiled_local(large, (3, 4, 3, 4))  # a later query's window on the larger map: its region
        assert not net.compiled_local(small.double())
    assert not net.compiled_local(small)  # with gradients: training's torch pass

    class OwnPrices(RouteVIN):
        def prices(self, f):
            return super().prices(f)

    with torch.no_grad():
        assert not OwnPrices(block=2, channels=8, depth=2, step=4).compiled_local(small)
    problem = generate("rooms", TRAIN_SEEDS[0] + 3, 48)
    obstacles, goal = problem.world.obstacles, problem.world.cell_of(problem.goal)
    reference = load_route_net(SHIPPED)
    reference.numba_local_blocks = 0  # torch's layers
    compiled = net.predict(obstacles, goal)
    assert np.abs(compiled - reference.predict(obstacles, goal))[compiled < 1e5].max() < 1e-4
    with torch.no_grad():
        net.local[0].weight.mul_(0.5)  # in place, in evaluation mode: the caller says so
    net.weights_changed()
    reference.load_state_dict(net.state_dict())
    changed, want = net.predict(obstacles, goal), reference.predict(obstacles, goal)
    assert not np.allclose(changed, compiled) and np.abs(changed - want)[want < 1e5].max() < 1e-4


@pytest.mark.experiments
def test_the_compiled_local_script_times_both_ways_and_refuses_bad_counts(capsys):
    from conftest import load_script

    script = load_script("experiments/compiled_local")
    assert script.main(["--sides", "32", "--maps", "1", "--rounds", "1", "--extra", "1", "--no-between"]) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| 32 |")]
    assert len(rows) == 1
    cells = rows[0].strip("| ").split(" | ")
    assert cells[1] == "16 x 16" and all(float(c) > 0 for c in cells[2:8]) and float(cells[8]) < 1e-4
    with pytest.raises(SystemExit) as stop:
        script.main(["--maps", "0"])
    assert stop.value.code == 2


def test_the_heads_run_compiled_over_torchs_layers_unless_turned_off():
    problem = generate("maze", TRAIN_SEEDS[0] + 4, 128)  # above the compiled layers' limit: torch's layers
    obstacles, goal = problem.world.obstacles, problem.world.cell_of(problem.goal)
    compiled, through_torch = load_route_net(SHIPPED), load_route_net(SHIPPED)
    through_torch.compiled_heads = False
    a, b = compiled.predict(obstacles, goal), through_torch.predict(obstacles, goal)
    reached = b < 1e5
    assert np.array_equal(reached, a < 1e5) and 0 < np.abs(a - b)[reached].max() < 1e-4
