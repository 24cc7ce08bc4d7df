"""The route encoder and its sampler (``learning.samplers.route``): inputs, targets, files, planning."""

from __future__ import annotations

import json
import pickle
from pathlib import Path

import numpy as np
import pytest
import torch
from conftest import fine_check_path, load_script
from hypothesis import given, settings
from hypothesis import strategies as st

from learning.device import full_float32, move_to
from learning.models.route_net import RouteNet, load_route_net, route_input, save_route_net
from learning.models.shipped import SHIPPED_ROUTE, SHIPPED_ROUTE_TEACHER
from learning.samplers.route import (
    ABLATION_SETTINGS,
    R_GSEEN,
    SHIPPED,
    SHIPPED_SETTINGS,
    RouteSampler,
    fine_frontier,
    interpolated_field,
    obstacles_at_inf,
    ranked_where_unreached,
    ready_fine_frontier,
    shipped_ablation,
    shipped_sampler,
    straight_field,
    straight_line_sampler,
    straight_where_unreached,
)
from learning.training.route import cost_targets, train_route_net
from planners import RRT, GeometricWorld, OccupancyGrid, Problem, RRTConnect
from planners.base.fileio import InputError
from planners.maps.coarsen import block_any
from planners.maps.generators import FAMILIES, TEST_SEED0, VALIDATION_SEED0, generate
from planners.maps.gridsearch import distance_field

#: How far, in steps, the shipped encoder's field on a GPU may lie from the CPU's (convolutions in full float32).
GPU_FIELD_TOLERANCE = 1e-3


def test_the_input_holds_every_cell_of_each_block_and_pads_with_blocked_cells():
    obs = np.zeros((6, 10), bool)
    obs[1, 2] = True  # block (0, 0), cell (1, 2) of it
    x = route_input(obs, (5, 9), 4)
    assert x.shape == (16 + 3, 2, 3)
    assert x[1 * 4 + 2, 0, 0] == 1 and x[:16, 0, 0].sum() == 1
    assert x[:16, 1, 2].reshape(4, 4)[2:, :].all()  # rows 6, 7 lie outside the map: blocked
    assert x[:16, 1, 2].reshape(4, 4)[:, 2:].all()  # and so do columns 10, 11
    assert x[16].sum() == 1 and x[16, 1, 2] == 1  # the goal's block


def _input_in_numpy(obstacles, goal_cell, block):
    """``route_input`` in numpy: the padded map's blocks laid out as channels, the goal's block, the offsets to it."""
    H, W = obstacles.shape
    h, w = -(-H // block), -(-W // block)
    out = np.empty((block * block + 3, h, w), dtype=np.float32)
    pad = np.ones((h * block, w * block), dtype=np.float32)
    pad[:H, :W] = obstacles
    out[:block * block] = pad.reshape(h, block, w, block).transpose(1, 3, 0, 2).reshape(block * block, h, w)
    gr, gc = goal_cell[0] // block, goal_cell[1] // block
    out[block * block] = 0.0
    if 0 <= gr < h and 0 <= gc < w:
        out[block * block, gr, gc] = 1.0
    out[block * block + 1] = ((gc - np.arange(w)) / w)[None, :]
    out[block * block + 2] = ((gr - np.arange(h)) / h)[:, None]
    return out


@settings(max_examples=80, deadline=None)
@given(h=st.integers(1, 30), w=st.integers(1, 30), block=st.integers(1, 4), seed=st.integers(0, 2**16),
       kind=st.sampled_from(["bool", "uint8", "float", "reversed"]),
       goal=st.tuples(st.integers(-3, 33), st.integers(-3, 33)))
def test_the_compiled_input_is_the_numpy_layout_bit_for_bit(h, w, block, seed, kind, goal):
    rng = np.random.default_rng(seed)
    obstacles = rng.random((h, w)) < 0.3
    obstacles = {"bool": obstacles, "uint8": obstacles.astype(np.uint8), "float": rng.random((h, w)),
                 "reversed": obstacles[:, ::-1]}[kind]  # and a view with negative strides
    got, want = route_input(obstacles, goal, block), _input_in_numpy(obstacles, goal, block)
    assert got.dtype == np.float32 and np.array_equal(got, want)


def test_cost_targets_are_the_distance_field_in_steps():
    p = generate("bugtrap", TEST_SEED0, 64)
    goal = p.world.cell_of(p.goal)
    t = cost_targets(p.world.obstacles, goal, 4)
    D = distance_field(p.world.obstacles, goal)
    assert t.shape == (64, 64)
    assert np.array_equal(np.isnan(t), ~np.isfinite(D))
    assert np.allclose(t[np.isfinite(D)], D[np.isfinite(D)] / 4)


def test_the_encoder_predicts_a_cost_per_cell_on_maps_of_any_size():
    net = RouteNet(4, 8, 3).eval()
    obs = np.zeros((50, 70), bool)
    assert net.predict(obs, (3, 4)).shape == (50, 70)


@pytest.mark.parametrize("k", range(8))
def test_the_prediction_averaged_over_the_symmetries_turns_with_the_map(k):
    """At 8 symmetries the predicted cost-to-go is equivariant, as the true one is; at 1 it is one pass."""
    from learning.models.route_net import symmetry, unturn

    net = RouteNet(4, 8, 2).eval()  # untrained: nothing about its weights is symmetric
    p = generate("bugtrap", 3, 64)
    obs = np.pad(p.world.obstacles, ((0, 0), (0, 6)), constant_values=True)  # 64x70: the turns change its shape
    goal = p.world.cell_of(p.goal)
    turned, g = symmetry(obs, goal, k)
    assert np.allclose(unturn(net.predict(turned, g, 8), k), net.predict(obs, goal, 8), atol=1e-5)
    one = net.predict(turned, g)
    assert np.array_equal(one, net.predict(turned, g, 1))
    assert (k == 0) == np.allclose(unturn(one, k), net.predict(obs, goal), atol=1e-5)
    with pytest.raises(InputError, match="symmetries"):
        net.predict(obs, goal, 9)


def test_training_is_seeded_and_learns():
    problems = [generate(f, 7, 64) for f in ("forest", "maze")]
    losses: list[str] = []
    a = train_route_net(problems, channels=8, depth=2, epochs=3, seed=1, log=losses.append)
    b = train_route_net(problems, channels=8, depth=2, epochs=3, seed=1, log=lambda _: None)
    assert all(torch.equal(x, y) for x, y in zip(a.state_dict().values(), b.state_dict().values(), strict=True))
    first, last = (float(s.split("loss ")[1].split()[0]) for s in (losses[0], losses[-1]))
    assert last < first


@pytest.mark.parametrize("attention", [0, 2])
def test_a_saved_encoder_loads_with_the_same_predictions(tmp_path, attention):
    net = RouteNet(4, 8, 2, attention).eval()
    save_route_net(net, tmp_path / "r.pt")
    back = load_route_net(tmp_path / "r.pt")
    assert back.attention_layers == attention
    # a file written before attention existed holds no such key, and still loads
    assert ("attention" in torch.load(tmp_path / "r.pt", weights_only=True)["config"]) == bool(attention)
    obs = generate("rooms", 3, 64).world.obstacles
    assert np.array_equal(net.predict(obs, (5, 5)), back.predict(obs, (5, 5)))
    assert not list(tmp_path.glob("*.tmp"))


def test_attention_at_a_coarser_level_round_trips_and_still_reaches_the_whole_grid(tmp_path):
    torch.manual_seed(0)
    net = RouteNet(4, 8, 3, 1, attention_level=1).eval()
    save_route_net(net, tmp_path / "r.pt")
    back = load_route_net(tmp_path / "r.pt")
    assert (back.attention_layers, back.attention_level) == (1, 1)
    obs = generate("maze", 3, 64).world.obstacles
    assert np.array_equal(net.predict(obs, (5, 5)), back.predict(obs, (5, 5)))
    # level 0 writes no key, as files before levels existed
    save_route_net(RouteNet(4, 8, 3, 1), tmp_path / "r0.pt")
    assert "attention_level" not in torch.load(tmp_path / "r0.pt", weights_only=True)["config"]
    x = torch.randn(1, 19, 16, 16, requires_grad=True)
    net(x)[0, 60, 60].backward()  # a cell of the last block
    assert x.grad[0, :, 0, 0].abs().sum() > 0
    with pytest.raises(ValueError, match="attention_level = 3"):
        RouteNet(4, 8, 3, 1, attention_level=3)


def test_the_field_is_scaled_up_on_maps_larger_than_the_training_ones_and_the_side_round_trips(tmp_path):
    torch.manual_seed(0)
    net = RouteNet(4, 8, 2).eval()
    obs = generate("rooms", 3, 128).world.obstacles
    plain = net.predict(obs, (5, 5), 2)
    net.trained_side = 128  # the map's own side: nothing changes
    assert np.array_equal(net.predict(obs, (5, 5), 2), plain)
    net.trained_side = 64
    assert np.allclose(net.predict(obs, (5, 5), 2), 2 * plain, rtol=1e-12)
    save_route_net(net, tmp_path / "r.pt")
    assert load_route_net(tmp_path / "r.pt").trained_side == 64
    net.trained_side = 0  # unknown: written as before, never scaled
    save_route_net(net, tmp_path / "r0.pt")
    assert "trained_side" not in torch.load(tmp_path / "r0.pt", weights_only=True)["config"]
    assert load_route_net(tmp_path / "r0.pt").trained_side == 0
    # training records the largest side it saw
    problems = [generate("maze", 7, 64), generate("forest", 7, 96)]
    assert train_route_net(problems, channels=4, depth=2, epochs=1, log=lambda _: None).trained_side == 96


@pytest.mark.parametrize("chunk", [1, 3, 7])
def test_attention_in_chunks_without_gradients_is_the_whole_pass_bit_for_bit(chunk, monkeypatch):
    from learning.models.route_net import AxialAttention

    torch.manual_seed(0)
    net = RouteNet(4, 8, 2, attention=2).eval()
    x = torch.rand(3, 16 + 3, 20, 13)  # 3 maps of 20 x 13 blocks: 60 row and 39 column sequences
    monkeypatch.setattr(AxialAttention, "CHUNK_FLOATS", 1 << 40)
    with torch.inference_mode():
        whole = net(x)
    # chunk sequences of rows (13 long) and columns (20 long) at a time: uneven last chunks included
    monkeypatch.setattr(AxialAttention, "CHUNK_FLOATS", chunk * AxialAttention.HEADS * 13 * 13)
    with torch.inference_mode():
        assert torch.equal(net(x), whole)


def test_axial_attention_lets_one_cell_reach_the_whole_grid_at_full_resolution():
    """After a row pass and a column pass, the output at one pixel depends on a pixel in another row and column."""
    from learning.models.route_net import AxialAttention

    torch.manual_seed(0)
    layer = AxialAttention(8).eval()
    x = torch.randn(1, 8, 6, 7, requires_grad=True)
    layer(x)[0, :, 5, 6].sum().backward()
    assert x.grad[0, :, 0, 0].abs().sum() > 0  # another row and another column
    assert layer(x).shape == x.shape


class _Boom:
    def __reduce__(self):
        return (exec, ("open('PWNED', 'w').write('x')",))


@pytest.mark.filterwarnings("ignore:Detected pickle protocol")
@pytest.mark.parametrize("content, needle", [
    (b"not a torch file", "is not a route encoder file"),
    ("pickle", "is not a route encoder file"),
    ({"config": {"block": 4, "channels": 8}, "state": {}}, "config depth"),
    ({"config": {"block": 4, "channels": 8, "depth": 2}, "state": {"inp.weight": torch.zeros(1)}}, "do not fit"),
    ({"config": {"block": 4, "channels": 8, "depth": 2, "attention": -1}, "state": {}}, "config attention"),
    ({"config": {"block": 4, "channels": 7, "depth": 2, "attention": 1}, "state": {}}, "multiple of 2"),
    ({"config": {"block": 4, "channels": 8, "depth": 2, "attention": 1, "attention_level": 2}, "state": {}},
     "attention_level = 2"),
    ({"config": {"block": 4, "channels": 8, "depth": 2, "trained_side": -1}, "state": {}}, "config trained_side"),
    ({"config": {"block": 4, "channels": 8, "depth": 2, "trained_side": 12.5}, "state": {}}, "config trained_side"),
    ([1, 2], "expected {'config'"),
    ({"config": {"block": 4, "channels": 8, "depth": 2, "x" * 60000: 1}, "state": {}}, r"unknown keys \['xxx"),
    ({"config": {"block": list(range(20000)), "channels": 8, "depth": 2}, "state": {}}, "config block"),
    ({"config": {"block": 2, "channels": 4, "depth": 1},
      "state": {**RouteNet(2, 4, 1).state_dict(), "inp.bias": torch.tensor([0.0, float("nan"), 0.0, 0.0])}},
     "tensor 'inp.bias' holds NaN or infinite"),
    ({"config": {"block": 2, "channels": 4, "depth": 1},
      "state": {**RouteNet(2, 4, 1).state_dict(), "out.weight": torch.full((4, 4, 3, 3), float("inf"))}},
     "tensor 'out.weight' holds NaN or infinite"),
])
def test_a_bad_encoder_file_is_refused_by_name_and_runs_nothing(tmp_path, monkeypatch, content, needle):
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "bad.pt"
    if isinstance(content, bytes):
        path.write_bytes(content)
    elif content == "pickle":
        path.write_bytes(pickle.dumps(_Boom()))
    else:
        torch.save(content, path)
    with pytest.raises(InputError, match=needle) as exc:
        load_route_net(path)
    assert "bad.pt" in str(exc.value) and len(str(exc.value)) < 600  # one short line, whatever the file holds
    assert not (tmp_path / "PWNED").exists()
    with pytest.raises(FileNotFoundError):
        load_route_net(tmp_path / "missing.pt")


@pytest.fixture(scope="module")
def small_net(tmp_path_factory) -> Path:
    """A small encoder trained in seconds (no encoder is shipped), saved as train_route.py saves one."""
    problems = [generate(f, s, 96) for f in ("forest", "narrow_passage", "bugtrap", "maze", "rooms")
                for s in range(4)]
    path = tmp_path_factory.mktemp("route") / "route.pt"
    save_route_net(train_route_net(problems, channels=8, depth=3, epochs=4, seed=0, log=lambda _: None), path)
    return path


@pytest.fixture(scope="module")
def shipped(small_net) -> RouteSampler:
    return RouteSampler.load(small_net)


@pytest.mark.parametrize("learned", [True, False])
@pytest.mark.parametrize("family", ["forest", "narrow_passage", "bugtrap", "maze", "rooms"])
def test_the_route_sampler_and_its_ablation_plan_valid_seeded_paths(shipped, family, learned):
    p = generate(family, TEST_SEED0 + 11, 96)
    sampler = shipped if learned else straight_line_sampler()
    runs = [RRT(p, step_size=4.0, sampler=sampler, seed=s).solve(max_iterations=20000) for s in (0, 0, 1)]
    assert all(r.solved for r in runs)
    assert runs[0].iterations == runs[1].iterations and np.array_equal(runs[0].path, runs[1].path)
    for r in runs:
        assert np.allclose(r.path[0], p.start) and np.linalg.norm(r.path[-1] - p.goal) <= p.goal_tolerance
        assert fine_check_path(p.world, r.path)


@pytest.mark.parametrize("learned", [True, False])
@pytest.mark.parametrize("batch", [1, 8])
def test_the_fused_loop_plans_the_same_runs_as_draw(small_net, batch, learned):
    runs = []
    for fuse in (True, False):
        sampler = RouteSampler.load(small_net, batch=batch) if learned else RouteSampler(None, batch=batch)
        if not fuse:
            sampler.fuse = lambda planner: None
        for family in ("narrow_passage", "rooms"):
            p = generate(family, TEST_SEED0 + 5, 128)
            r = RRT(p, step_size=4.0, sampler=sampler, seed=2).solve(max_iterations=20000)
            runs.append((r.iterations, r.num_vertices, r.path.tobytes()))
    assert runs[:2] == runs[2:]


def test_a_fused_run_in_pieces_is_the_run_in_one_piece(shipped):
    """Single steps, then solves in pieces of odd sizes across the refill boundaries: the same run as one solve."""
    p = generate("bugtrap", TEST_SEED0 + 1, 128)
    whole = RRT(p, step_size=4.0, sampler=shipped, seed=3).solve(max_iterations=20000)
    planner = RRT(p, step_size=4.0, sampler=shipped, seed=3)
    for _ in range(13):
        planner.step()
    for size in (5, 51, 7, 130):
        planner.solve(max_iterations=size)
    r = planner.solve(max_iterations=20000)
    assert whole.solved and (r.iterations, r.path.tobytes()) == (whole.iterations, whole.path.tobytes())
    assert planner.sampler.forward_passes == 8


def test_the_ablation_follows_the_straight_line_distance_to_the_goal():
    p = generate("forest", TEST_SEED0, 64)
    sampler = straight_line_sampler().bind(p)
    field = sampler.field
    free = ~p.world.obstacles
    rows, cols = np.nonzero(free)
    centres = p.world.origin + (np.stack([cols, rows], axis=1) + 0.5) * p.world.resolution
    assert np.allclose(field[free], np.linalg.norm(centres - p.goal, axis=-1) / 4.0, rtol=1e-14, atol=0)
    assert np.isinf(field[p.world.obstacles]).all()


def test_the_encoders_field_leads_the_progress_and_ranks_the_frontier(shipped):
    """The encoder's field (mean over the 8 symmetries) is the progress field and the frontier's ranking."""
    p = generate("bugtrap", TEST_SEED0 + 3, 96)
    learned = shipped.net.predict(p.world.obstacles, p.world.cell_of(p.goal), 8)
    s = shipped.bind(p)
    free = np.isfinite(s.field)
    assert np.allclose(s.field[free], learned[free]) and np.array_equal(free, ~p.world.obstacles)
    cost = s.draw_state[5][12]  # the frontier's cost per frontier cell of one step, at each cell's centre
    r, c = np.argwhere(free[2:-2:4, 2:-2:4])[0] * 4 + 2
    assert cost[(r // 4) * (96 // 4) + c // 4] == pytest.approx(learned[r, c])
    assert straight_line_sampler().bind(p).draw_state[5][12].size == 0  # the follower ranks by the straight line
    r = RRT(p, step_size=4.0, sampler=shipped, seed=0).solve(max_iterations=20000)
    assert r.solved and fine_check_path(p.world, r.path)


def test_the_geodesic_route_reference_ranks_the_frontier_by_the_exact_cost_to_go():
    """The follower whose frontier knows the route: a reference that must beat the follower on traps and mazes."""
    from learning.references.expert import GeodesicRouteSampler

    its = {"follower": [], "geodesic": []}
    for i, family in enumerate(("bugtrap", "maze") * 3):
        p = generate(family, TEST_SEED0 + 20 + i, 128)
        for name, sampler in (("follower", RouteSampler(None, stuck=1)), ("geodesic", GeodesicRouteSampler(stuck=1))):
            r = RRT(p, step_size=4.0, sampler=sampler, seed=i).solve(max_iterations=20000)
            assert r.solved and fine_check_path(p.world, r.path) and np.allclose(r.path[0], p.start)
            its[name].append(r.iterations)
    assert np.median(its["geodesic"]) < 0.8 * np.median(its["follower"]), its


def test_a_stalled_search_widens_to_a_frontier_of_grid_cells_and_passes_a_tunnel_narrower_than_a_step():
    """Validation narrow passage 201121: a tunnel 2 cells tall and 4 long whose step-wide frontier cells have blocked
    centres. Without widening the exact reference fills the start side and never finds it; widened, it passes."""
    from learning.references.expert import GeodesicRouteSampler

    p = generate("narrow_passage", VALIDATION_SEED0 + 1121, 128)
    runs = {w: RRT(p, step_size=4.0, sampler=GeodesicRouteSampler(**{**SHIPPED_SETTINGS, "widen": w}),
                   seed=0).solve(max_iterations=20000) for w in ("off", "stalled")}
    assert not runs["off"].solved
    assert runs["stalled"].solved and fine_check_path(p.world, runs["stalled"].path)
    assert runs["stalled"].iterations < 5000


def test_widening_leaves_every_run_that_never_turns_to_the_fine_frontier_as_it_was():
    """The widened frontier takes none of the random stream: a run that never looks at the frontier of grid cells
    (its progress never stalled for ``patience`` iterations in frontier mode, its step-wide frontier never empty
    there) is the same run with widening on or off."""
    untouched = 0
    for i, family in enumerate(("forest", "maze", "rooms", "bugtrap", "narrow_passage") * 2):
        p = generate(family, VALIDATION_SEED0 + 50 + i, 64)
        runs = []
        for w in ("off", "stalled"):
            planner = RRT(p, step_size=4.0, sampler=RouteSampler(None, **{**ABLATION_SETTINGS, "widen": w}), seed=i)
            runs.append(planner.solve(max_iterations=20000))
        if planner.sampler._state[7][R_GSEEN] == 0:  # the widened run never looked at the fine frontier
            untouched += 1
            assert runs[0].iterations == runs[1].iterations and np.array_equal(runs[0].path, runs[1].path)
    assert untouched >= 3
    with pytest.raises(InputError, match="widen = 'sometimes'"):
        RouteSampler(None, widen="sometimes")


def test_cells_the_encoder_sees_no_route_from_follow_the_straight_line_behind_every_reached_cell():
    field = np.array([[0.0, 2.0, 5e5], [3.0, np.inf, 5e5 + 3]])
    straight = np.array([[1.0, 2.0, 4.0], [2.0, 3.0, 5.0]])
    out = straight_where_unreached(field, straight, 2.5e5)
    assert np.array_equal(out, [[0.0, 2.0, 3.0 + 4.0], [3.0, np.inf, 3.0 + 5.0]])
    assert np.array_equal(straight_where_unreached(field[:, :2], straight[:, :2], 2.5e5), field[:, :2])


@settings(max_examples=40, deadline=None)
@given(h=st.integers(1, 12), w=st.integers(1, 12), seed=st.integers(0, 2**16), res=st.sampled_from([0.05, 1.0, 2.5]),
       step=st.sampled_from([1.0, 4.0]), ranked=st.booleans())
def test_the_fine_frontier_made_at_its_first_use_is_numpys_ranking_bit_for_bit(h, w, seed, res, step, ranked):
    rng = np.random.default_rng(seed)
    walls = rng.random((h, w)) < 0.3
    field = rng.random((h, w)) * 50
    field[rng.random((h, w)) < 0.1] = np.inf
    grid = OccupancyGrid(walls, resolution=res)
    fine = fine_frontier(grid, field if ranked else None)
    ready_fine_frontier(fine, grid.kernel.grid, step, res)
    assert (fine[2] == -1).all()  # no cell in the frontier yet
    if ranked:
        expected = np.where(walls, np.inf, field * step / res).ravel()
        assert np.array_equal(fine[5], np.where(np.isfinite(expected), expected, 1e9))
    else:
        assert fine[5].size == 0  # ranked by the straight line
    at_inf = field.copy()
    obstacles_at_inf(at_inf, walls)
    expected = field.copy()
    expected[walls] = np.inf
    assert np.array_equal(at_inf, expected)


@settings(max_examples=60, deadline=None)
@given(h=st.integers(1, 12), w=st.integers(1, 12), seed=st.integers(0, 2**16), cut=st.floats(0.0, 1.0),
       blocked=st.floats(0.0, 0.5), res=st.sampled_from([0.05, 1.0, 2.5]), step=st.sampled_from([1.0, 4.0]))
def test_the_compiled_ranking_of_unreached_cells_is_the_straight_lines_bit_for_bit(h, w, seed, cut, blocked, res, step):
    rng = np.random.default_rng(seed)
    field = rng.random((h, w)) * 50
    field[rng.random((h, w)) < cut] = 5e5 + rng.random() * 10  # cells the encoder sees no route from
    field[rng.random((h, w)) < 0.1] = np.inf
    walls = (rng.random((h, w)) < blocked).astype(np.uint8)
    gx, gy = rng.random() * w, rng.random() * h
    expected = straight_where_unreached(field, straight_field(walls, gx, gy, res, step), 2.5e5)
    got = ranked_where_unreached(field, walls, gx, gy, res, step, 2.5e5)
    assert np.array_equal(got, expected)
    if not np.any(np.isfinite(field) & (field >= 2.5e5)):
        assert got is field  # nothing to rank: the field itself, as the definition returns it


def test_the_route_sampler_refuses_what_it_cannot_plan_on(shipped):
    with pytest.raises(InputError, match="OccupancyGrid"):
        RRT(Problem(GeometricWorld(10, 10, []), [1, 1], [9, 9]), step_size=4.0, sampler=shipped, seed=0)
    with pytest.raises(InputError, match="step_size"):
        shipped.at_step(float("inf"))
    at = shipped.at_step(1.0)
    assert at.at_step(1.0) is at and at.at_step(2.0).step_size == 2.0  # the same step: the same sampler
    for bad in (True, "1.0", np.nan):  # another type, or no number, is refused even where it compares equal
        with pytest.raises(InputError, match="step_size"):
            at.at_step(bad)
    with pytest.raises(InputError, match="stuck"):
        RouteSampler(shipped.net, stuck=0)
    with pytest.raises(InputError, match="tau"):
        RouteSampler(None, tau=0.0)
    for gone in ("uses", "symmetries", "lazy", "stall"):  # experiments' knobs, not the product's
        with pytest.raises(TypeError, match=gone):
            RouteSampler(shipped.net, **{gone: 1})


def test_the_step_is_the_planners_in_any_maps_units():
    """make_sampler("route") at its own step of 4 serves a planner's step of 0.2 on a 0.05 m map, as 4 on 1 m cells."""
    from learning import make_sampler

    obstacles = np.zeros((120, 160), bool)
    obstacles[60, :130] = True  # a wall with a gap at its end
    runs = {}
    for resolution, step in ((1.0, 4.0), (0.05, 0.2)):
        grid = OccupancyGrid(obstacles, resolution)
        p = Problem(grid, np.array([5.0, 5.0]) * resolution, np.array([5.0, 110.0]) * resolution,
                    goal_tolerance=4 * resolution)
        for planner in (RRT, RRTConnect):
            r = planner(p, step_size=step, sampler=make_sampler("route"), seed=0).solve(max_iterations=20000)
            assert r.solved and r.iterations > 0
            runs[(resolution, planner.name)] = r.iterations
    assert runs[(1.0, RRT.name)] == runs[(0.05, RRT.name)] and runs[(1.0, "RRTConnect")] == runs[(0.05, "RRTConnect")]


@pytest.mark.parametrize("cells_per_step", [6.7, 2.0, 13.0])
def test_a_step_of_another_number_of_cells_reads_the_map_resampled_to_the_encoders_step(shipped, cells_per_step):
    obstacles = np.zeros((100, 100), bool)
    obstacles[50, 10:] = True  # a wall from the goal's side to the start's, with a gap at columns 0-9
    grid = OccupancyGrid(obstacles, 0.03)
    p = Problem(grid, [0.3, 0.3], [0.3, 2.7], goal_tolerance=0.12)
    planner = RRT(p, step_size=0.03 * cells_per_step, sampler=shipped, seed=1)
    sampler = planner.sampler
    assert sampler.step_size == pytest.approx(0.03 * cells_per_step)  # the planner's, not the sampler's own 4
    obstacles, goal, factor, k = sampler._encoder_map(grid)
    assert k == 1  # 100 cells a side is read at full resolution
    assert factor == pytest.approx(cells_per_step / 4)
    assert obstacles.shape == tuple(int(np.ceil(100 / factor - 1e-6)) for _ in range(2)) and obstacles.any()
    assert sampler.field.shape == (100, 100) and np.isfinite(sampler.field[~grid.obstacles]).all()
    # the field leads through the gap: past it is cheaper than before it, and before it, far from it dearer
    assert sampler.field[70, 5] < sampler.field[30, 5] < sampler.field[30, 60]
    assert planner.solve(max_iterations=20000).solved


def test_a_large_map_whose_passages_allow_it_is_read_coarser_and_its_field_still_leads():
    shipped = RouteSampler.load(SHIPPED_ROUTE)  # the shipped encoder: the field's values are compared
    obstacles = np.zeros((512, 512), bool)
    obstacles[256, 40:] = True  # a wall across, with a gap of 40 cells at columns 0-39
    grid = OccupancyGrid(obstacles)
    p = Problem(grid, [480.5, 30.5], [480.5, 480.5], goal_tolerance=4.0)
    planner = RRT(p, step_size=4.0, sampler=shipped, seed=0)
    coarse = planner.sampler
    assert coarse._encoder_map(grid)[3] == 4  # 512 cells read as 128
    full = RRT(p, step_size=4.0, sampler=shipped._copy_with(coarse_side=0), seed=0).sampler
    assert full._encoder_map(grid)[3] == 1
    free = ~obstacles
    assert np.isfinite(coarse.field[free]).all()
    # the same route: past the gap cheaper than before it, far from it dearer; the values close to full resolution's
    f = coarse.field
    assert f[300, 20] < f[200, 20] < f[200, 400] and f[480, 480] < f[30, 480]
    assert np.corrcoef(f[free], full.field[free])[0, 1] > 0.999
    assert np.abs(f[free] - full.field[free]).max() < 5  # steps, on routes of up to 270
    assert planner.solve(max_iterations=20000).solved


def _interpolated_by_definition(coarse, shut, blocked, factor, cell, unreached):
    """``interpolated_field`` as its docstring says, cell by cell in Python (small maps only)."""
    H, W = blocked.shape
    h, w = coarse.shape
    out, band = np.full((H, W), np.inf), []
    ok = ~shut & (coarse < unreached)
    for r in range(H):
        for c in range(W):
            ia, ja = min(int((r + 0.5) / factor), h - 1), min(int((c + 0.5) / factor), w - 1)
            if blocked[r, c]:
                continue
            if shut[ia, ja]:
                band.append((r, c))
                continue
            if not coarse[ia, ja] < unreached:
                out[r, c] = coarse[ia, ja]
                continue
            y, x = (r + 0.5) / factor - 0.5, (c + 0.5) / factor - 0.5
            i0, j0, fy, fx = int(np.floor(y)), int(np.floor(x)), y - np.floor(y), x - np.floor(x)
            if 0 <= i0 < h - 1 and 0 <= j0 < w - 1 and ok[i0:i0 + 2, j0:j0 + 2].all():
                top = coarse[i0, j0] + fx * (coarse[i0, j0 + 1] - coarse[i0, j0])
                bottom = coarse[i0 + 1, j0] + fx * (coarse[i0 + 1, j0 + 1] - coarse[i0 + 1, j0])
                out[r, c] = top + fy * (bottom - top)
                continue
            total = weight = 0.0
            for i, wy in ((i0, 1.0 - fy), (i0 + 1, fy)):
                for j, wx in ((j0, 1.0 - fx), (j0 + 1, fx)):
                    if 0 <= i < h and 0 <= j < w and ok[i, j] and not (i != ia and j != ja and shut[i, ja]
                                                                      and shut[ia, j]):
                        total += (wy * wx + 1e-12) * coarse[i, j]
                        weight += wy * wx + 1e-12
            out[r, c] = total / weight
    for sweep in range(4):  # Gauss-Seidel over the band, forwards then backwards, twice
        for r, c in (band if sweep % 2 == 0 else band[::-1]):
            for dr in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    r2, c2 = r + dr, c + dc
                    if (dr or dc) and 0 <= r2 < H and 0 <= c2 < W and not blocked[r2, c2] and not (
                            dr and dc and (blocked[r2, c] or blocked[r, c2])):
                        out[r, c] = min(out[r, c], out[r2, c2] + cell * (np.sqrt(2.0) if dr and dc else 1.0))
    return out


@settings(max_examples=40, deadline=None)
@given(side=st.integers(4, 10), factor=st.sampled_from([2, 4]), seed=st.integers(0, 2**16),
       density=st.floats(0.0, 0.4), unreached=st.sampled_from([np.inf, 30.0]))
def test_the_interpolated_field_is_its_definition_bit_for_bit(side, factor, seed, density, unreached):
    rng = np.random.default_rng(seed)
    blocked = (rng.random((side * factor, side * factor + factor)) < density).astype(np.uint8)
    shut = block_any(blocked.astype(bool), factor)
    # a free coarse cell at inf: one the encoder's field does not reach
    coarse = np.where(shut | (rng.random(shut.shape) < 0.1), np.inf, rng.random(shut.shape) * 40)
    cell = 1.0 / factor
    got, high = interpolated_field(coarse, shut, blocked, float(factor), cell, unreached)
    expected = _interpolated_by_definition(coarse, shut, blocked, factor, cell, unreached)
    assert np.array_equal(got, expected)
    assert high == bool((got[np.isfinite(got)] >= unreached).any())  # what ranked_where_unreached would rank


def test_a_map_read_coarser_keeps_its_start_and_goal_in_free_coarse_cells(shipped):
    obstacles = np.zeros((512, 512), bool)
    obstacles[256, 40:] = True
    grid = OccupancyGrid(obstacles)
    p = Problem(grid, [100.5, 257.5], [480.5, 480.5], goal_tolerance=4.0)  # the start right below the wall
    sampler = RRT(p, step_size=4.0, sampler=shipped, seed=0).sampler
    obstacles_read, goal, factor, k = sampler._encoder_map(grid)
    assert k == 1  # rows 256 and 257 share a coarse cell at 2 already
    p = Problem(grid, [100.5, 259.5], [480.5, 480.5], goal_tolerance=4.0)
    assert RRT(p, step_size=4.0, sampler=shipped, seed=0).sampler._encoder_map(grid)[3] == 2


@pytest.mark.parametrize("side", [-1, 1.5, True, "128"])
def test_coarse_side_must_be_a_whole_number_of_cells(small_net, side):
    with pytest.raises(InputError, match="coarse_side"):
        RouteSampler.load(small_net, coarse_side=side)
    with pytest.raises(InputError, match="coarse_most"):
        RouteSampler.load(small_net, coarse_most=0)


def test_the_registry_takes_coarse_side_for_the_encoders_samplers():
    from learning.samplers.registry import make_sampler

    assert make_sampler("route", coarse_side=0).coarse_side == 0
    assert make_sampler("route_lazy", coarse_side=0).coarse_side == 0
    assert make_sampler("route").coarse_side == make_sampler("route_lazy").coarse_side == 128


def test_a_step_too_fine_for_the_encoders_limit_is_refused_saying_to_take_a_larger_step(shipped, monkeypatch):
    monkeypatch.setenv("SAMPLERGYM_MAX_ROUTE_BLOCKS", str(64 * 64))
    p = generate("forest", TEST_SEED0, 64)  # 16 x 16 blocks of 4 cells at a step of 4 cells; 128 x 128 at 0.5
    assert RRT(p, step_size=4.0, sampler=shipped, seed=0).solve(max_iterations=20000).solved
    with pytest.raises(InputError, match=r"step 0.5 is 0.5 cells.*resampled to 512 x 512 cells.*Take a larger step"):
        RRT(p, step_size=0.5, sampler=shipped, seed=0)


def test_a_map_above_the_encoders_limit_is_refused_naming_its_size_the_limit_and_the_variable(shipped, monkeypatch):
    monkeypatch.setenv("SAMPLERGYM_MAX_ROUTE_BLOCKS", str(16 * 16))
    big = generate("forest", TEST_SEED0, 68)  # 17 x 17 blocks
    with pytest.raises(InputError, match=r"68 x 68 map is 17 x 17 = 289 blocks.*limit of 256.*MAX_ROUTE_BLOCKS"):
        RRT(big, step_size=4.0, sampler=shipped, seed=0)
    assert RRT(generate("forest", TEST_SEED0, 64), step_size=4.0, sampler=shipped, seed=0).solve(
        max_iterations=20000).solved
    monkeypatch.delenv("SAMPLERGYM_MAX_ROUTE_BLOCKS")
    assert RRT(big, step_size=4.0, sampler=shipped, seed=0).solve(max_iterations=20000).solved
    monkeypatch.setenv("SAMPLERGYM_MAX_ROUTE_BLOCKS", "lots")
    with pytest.raises(InputError, match="SAMPLERGYM_MAX_ROUTE_BLOCKS = 'lots'"):
        RRT(big, step_size=4.0, sampler=shipped, seed=0)


def test_batched_passes_for_many_queries_give_each_querys_prediction(shipped, monkeypatch):
    import learning.models.route_net as route_net

    maps = [generate(f, TEST_SEED0 + i, 64) for i, f in enumerate(("forest", "maze", "rooms"))]
    queries = [(p.world.obstacles, p.world.cell_of(p.goal)) for p in maps] + [(maps[0].world.obstacles[:, :40], (3, 5))]
    one = [shipped.net.predict(obs, goal, 8) for obs, goal in queries]
    many = shipped.net.predict_many(queries, 8)
    assert all(np.allclose(a, b, rtol=1e-5, atol=1e-5) for a, b in zip(one, many, strict=True))
    monkeypatch.setattr(route_net, "BATCH_BYTES", 1)  # one symmetry per batch: bounded memory, same field
    assert np.allclose(shipped.net.predict(*queries[0], 8), one[0], rtol=1e-5, atol=1e-5)


def test_the_encoder_runs_at_the_planning_thread_count_and_restores_the_callers(small_net, shipped, monkeypatch):
    from learning.models.threads import planning_thread_count

    seen = []
    forward = type(shipped.net).forward
    monkeypatch.setattr(type(shipped.net), "forward", lambda self, x: seen.append(torch.get_num_threads()) or
                        forward(self, x))
    before = torch.get_num_threads()
    p = generate("forest", TEST_SEED0, 64)
    RouteSampler.load(small_net, device="cpu").bind(p)
    monkeypatch.setenv("SAMPLERGYM_TORCH_THREADS", "2")
    RouteSampler.load(small_net).bind(p)
    RouteSampler.load(small_net, threads=3).bind(p)
    assert seen == [1, 2, 3] and torch.get_num_threads() == before
    for bad in (0, "two", 2.5, True):
        with pytest.raises(InputError, match="thread"):
            planning_thread_count(bad)
    with pytest.raises(InputError, match="threads = 0"):
        RouteSampler(None, threads=0)


def test_models_are_built_at_the_planning_thread_count_and_the_callers_comes_back(small_net, monkeypatch):
    # a sampler loads its model per run: at the machine's thread count, two planners side by side spun each
    # other's threads (make_sampler("rigid_route") 53 ms against 3 ms in two processes)
    import learning.models.rigid_orientation as rigid_orientation
    import learning.models.route_net as route_net
    from learning.models.shipped import SHIPPED_RIGID_ORIENTATION

    seen = []
    for module in (route_net, rigid_orientation):
        load = module.load_finite_state
        monkeypatch.setattr(module, "load_finite_state",
                            lambda *a, load=load: seen.append(torch.get_num_threads()) or load(*a))
    before = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        route_net.load_route_net(small_net)
        rigid_orientation.load_orientation_net(SHIPPED_RIGID_ORIENTATION)
        assert seen == [1, 1] and torch.get_num_threads() == 2
    finally:
        torch.set_num_threads(before)


def test_the_device_follows_sb3s_convention_and_the_cpu_gives_the_validated_runs(small_net):
    p = generate("bugtrap", TEST_SEED0 + 4, 96)
    runs = [RRT(p, step_size=4.0, sampler=RouteSampler.load(small_net, device=d), seed=1).solve(max_iterations=20000)
            for d in ("cpu", "auto")]
    assert runs[0].iterations == runs[1].iterations
    with pytest.raises(InputError, match="device = 'gpu'"):
        RouteSampler(None, device="gpu")
    if not torch.cuda.is_available():
        with pytest.raises(InputError, match="device = cuda: torch sees no CUDA GPU"):
            RouteSampler.load(small_net, device="cuda")
    from learning.samplers.registry import make_sampler

    assert make_sampler("route", path=str(small_net), device="cpu").device == torch.device("cpu")


def test_full_float32_turns_cudnns_tf32_off_on_a_gpu_only_and_restores_the_switch():
    conv = getattr(torch.backends.cudnn, "conv", None)
    new_api = conv is not None and hasattr(conv, "fp32_precision")

    def read():
        return conv.fp32_precision if new_api else torch.backends.cudnn.allow_tf32

    before = read()
    with full_float32(torch.device("cpu")):
        assert read() == before
    with full_float32(torch.device("cuda")):  # only the process's switch: no GPU is touched
        assert read() == ("ieee" if new_api else False)
    assert read() == before
    with pytest.raises(RuntimeError, match="inside"), full_float32(torch.device("cuda")):
        raise RuntimeError("inside")
    assert read() == before
    net = load_route_net(SHIPPED_ROUTE)
    key = net.inference_key()
    net.full_float32 = False  # a field kept under one setting is not served for the other
    assert net.inference_key() != key


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA GPU; torch sees none on this machine")
def test_on_a_gpu_the_shipped_encoder_gives_the_cpus_field_one_query_or_many():
    cpu = load_route_net(SHIPPED_ROUTE)
    gpu = move_to(load_route_net(SHIPPED_ROUTE), torch.device("cuda"))
    for family in FAMILIES:
        p = generate(family, VALIDATION_SEED0 + 7, 128)
        obstacles, goal = np.asarray(p.world.obstacles), p.world.cell_of(p.goal)
        a, b = cpu.predict(obstacles, goal), gpu.predict(obstacles, goal)
        reached = a < cpu.unreached_steps / 2
        assert np.array_equal(reached, b < cpu.unreached_steps / 2), family
        assert np.abs(a - b)[reached].max() <= GPU_FIELD_TOLERANCE, family
    free = np.argwhere(~obstacles.astype(bool))[::97][:8]
    queries = [(obstacles, (int(r), int(c))) for r, c in free]
    for one, many in zip([gpu.predict(*q) for q in queries], gpu.predict_many(queries), strict=True):
        reached = one < gpu.unreached_steps / 2
        assert np.array_equal(reached, many < gpu.unreached_steps / 2)
        assert np.abs(one - many)[reached].max() <= GPU_FIELD_TOLERANCE


@pytest.mark.experiments
def test_the_gpu_probe_compares_reached_cells_and_refuses_a_machine_without_cuda(tmp_path, capsys):
    probe = load_script("experiments/gpu_route")
    net = load_route_net(SHIPPED_ROUTE)
    a = np.array([[1.0, 2.0], [3.0, net.unreached_steps]])
    b = np.array([[1.5, 2.0], [net.unreached_steps, net.unreached_steps]])
    d = probe._difference(net, a, b)
    assert (d["max"], d["median"], d["reach_differs"], d["cells"]) == (0.5, 0.25, 1, 2)
    if torch.cuda.is_available():
        pytest.skip("this machine has a GPU")
    with pytest.raises(SystemExit) as stop:
        probe.main(["--out", str(tmp_path / "gpu.json")])
    assert stop.value.code == 2 and "torch sees no CUDA GPU" in capsys.readouterr().err
    assert not (tmp_path / "gpu.json").exists()


@given(family=st.sampled_from(FAMILIES), seed=st.integers(0, 10**6), size=st.sampled_from([32, 64, 96]))
@settings(max_examples=25)
def test_every_path_of_the_follower_is_valid_starts_at_start_and_ends_at_the_goal(family, seed, size):
    p = generate(family, seed, size)
    r = RRT(p, step_size=4.0, sampler=RouteSampler(None), seed=seed).solve(max_iterations=5000)
    assert r.solved or r.iterations == 5000
    if r.solved:
        assert np.allclose(r.path[0], p.start) and np.linalg.norm(r.path[-1] - p.goal) <= p.goal_tolerance
        assert fine_check_path(p.world, r.path)


@pytest.mark.experiments
def test_route_variants_build_the_ranked_sampler_its_ablation_and_the_reference(monkeypatch, small_net, tmp_path):
    from learning.references.expert import GeodesicRouteSampler

    variants = load_script("experiments/route_variants")
    monkeypatch.setattr(variants, "TRAINED", small_net)
    ranked, ablation, exact = variants.ranked(), variants.ranked_ablation(), variants.ranked_exact()
    assert ranked.net is not None and ranked.uses == "frontier" and ablation.net is None
    assert isinstance(exact, GeodesicRouteSampler)
    assert {(s.stuck, s.tau) for s in (ranked, ablation, exact)} == {(1, 0.5)}  # one rule, three rankings
    assert (variants.ranked_exact_tau1().stuck, variants.ranked_exact_tau1().tau) == (1, 1.0)
    both8, both1, exact_both = variants.both_symmetric(), variants.both(), variants.exact_both()
    assert type(both8) is RouteSampler and (both1.uses, both1.symmetries, exact_both.uses) == ("both", 1, "both")
    assert {(s.stuck, s.tau) for s in (both8, both1, exact_both)} == {(1, 0.5)}
    assert variants.ranked_symmetric().symmetries == 8
    grid = getattr(variants, "grid_encoder_l2.5_s0.25")(), variants.grid_ablation_l3_s1()
    assert [(s.net is None, s.lookahead, s.sigma, s.uses) for s in grid] == [(False, 2.5, 0.25, "both"),
                                                                           (True, 3.0, 1.0, "progress")]
    with pytest.raises(AttributeError, match="grid_encoder_l2"):
        getattr(variants, "grid_encoder_l2")  # noqa: B009 - the name is what is tested
    assert [getattr(variants, f"both_sym{k}")().symmetries for k in (1, 4)] == [1, 4]
    walks = [getattr(variants, name)() for name in ("walk_0_0", "walk_0.1_0", "walk_0.1_0.01_nosight")]
    assert [(w.ripple, w.ripple_growth, w.sight, w.lookahead, w.net is not None) for w in walks] == [
        (0, 0, True, 3.0, True), (0.1, 0, True, 3.0, True), (0.1, 0.01, False, 3.0, True)]  # the shipped encoder
    assert variants.no_wall_cost().net.wall_cost is None and shipped_sampler().net.wall_cost == 32.0
    p = generate("bugtrap", TEST_SEED0 + 3, 64)
    one = variants.both().bind(p)
    assert one.forward_passes == 1 and np.allclose(one.field[~p.world.obstacles],
                                                   one.net.predict(p.world.obstacles, p.world.cell_of(p.goal))[
                                                       ~p.world.obstacles])
    assert (variants.ranked_exact().uses, variants.exact_both().uses) == ("frontier", "both")
    monkeypatch.setattr(variants, "TRAINED", tmp_path / "missing.pt")
    with pytest.raises(FileNotFoundError, match="train_route.py"):
        variants.ranked()


@pytest.mark.parametrize("k", range(8))
def test_augmentation_turns_the_map_and_its_goal_together(k):
    """Under each of the square's symmetries the cost-to-go targets turn with the map: nothing else changes."""
    from learning.models.route_net import symmetry

    p = generate("bugtrap", 17, 64)
    goal = p.world.cell_of(p.goal)
    obs, g = symmetry(p.world.obstacles, goal, k)
    turned = np.rot90(distance_field(p.world.obstacles, goal), k % 4)
    turned = turned.T if k >= 4 else turned
    assert obs.shape == p.world.obstacles.shape[::-1] if k % 2 else obs.shape == p.world.obstacles.shape
    assert np.array_equal(distance_field(obs, g), turned)
    assert (k == 0) == (np.array_equal(obs, p.world.obstacles) and g == goal)


@pytest.mark.experiments
def test_validate_samplers_reports_validation_medians_and_refuses_bad_specs(capsys, monkeypatch):
    script = load_script("experiments/validate_samplers")
    # as `python scripts/experiments/...`
    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[1] / "scripts" / "experiments"))
    rows = script.main(["--sampler", "ablation=route_variants:ranked_ablation", "--families", "forest", "bugtrap",
                        "--maps", "2", "--seeds", "1", "--size", "64", "--processes", "1"])
    assert [r["sampler"] for r in rows] == ["ablation"] and set(rows[0]) == {"sampler", "forest", "bugtrap"}
    assert "validation maps" in capsys.readouterr().out
    for bad, needle in ((["--sampler", "x=route_variants:nothing"], "nothing"),
                        (["--sampler", "a=route_variants:ranked_ablation", "--sampler",
                          "a=route_variants:ranked_ablation"], "given twice"),
                        (["--sampler", "a=route_variants:ranked_ablation", "--maps", "0"], "--maps")):
        with pytest.raises(SystemExit) as exc:
            script.main(bad)
        assert exc.value.code == 2 and needle in capsys.readouterr().err


@pytest.mark.parametrize("family", FAMILIES)
def test_the_shipped_encoder_and_its_ablation_plan_valid_paths(family):
    """The shipped checkpoint loads safely, at its recorded recipe, and both samplers plan valid seeded paths."""
    recipe = json.loads(SHIPPED.with_suffix(".json").read_text())["recipe"]  # a distilled student's
    teacher = json.loads(SHIPPED_ROUTE_TEACHER.with_suffix(".json").read_text())["recipe"]
    net = load_route_net(SHIPPED)
    assert (net.channels, net.depth, net.attention_layers) == (recipe["channels"], teacher["depth"], 0)
    learned, ablation = shipped_sampler(), shipped_ablation()
    assert {k: getattr(learned, k) for k in SHIPPED_SETTINGS} == SHIPPED_SETTINGS
    assert ablation.net is None and (ablation.stuck, ablation.tau) == (learned.stuck, learned.tau)
    assert (ablation.lookahead, learned.lookahead) == (ABLATION_SETTINGS["lookahead"], SHIPPED_SETTINGS["lookahead"])
    p = generate(family, TEST_SEED0 + 3, 64)
    for sampler in (learned, ablation):
        runs = [RRT(p, step_size=4.0, sampler=sampler, seed=1).solve(max_iterations=20000) for _ in range(2)]
        assert runs[0].solved and runs[0].iterations == runs[1].iterations
        assert np.allclose(runs[0].path[0], p.start)
        assert np.linalg.norm(runs[0].path[-1] - p.goal) <= p.goal_tolerance
        assert fine_check_path(p.world, runs[0].path)


@pytest.mark.experiments
def test_encoder_seeds_prints_each_files_medians_on_the_validation_maps(capsys):
    script = load_script("experiments/encoder_seeds")
    assert script.main([str(SHIPPED), str(SHIPPED), "--maps", "1", "--sides", "64"]) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| ")]
    assert len(rows) == 1 + 7 + 1  # header, a row per family, pooled
    pooled = rows[-1].split("|")
    assert pooled[3] == pooled[4] and "(" in pooled[3]  # the same file twice: the same runs


@pytest.mark.experiments
def test_open_walls_refuses_a_map_not_in_the_comparison_and_prints_a_row_per_map(movingai, capsys):
    script = load_script("experiments/open_walls")
    with pytest.raises(SystemExit):
        script.main(["--maps", "nowhere", "--movingai", str(movingai)])
    assert "nowhere" in capsys.readouterr().err
    assert script.main(["--maps", "random-32-32-10", "--seeds", "1", "--movingai", str(movingai)]) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| random")]
    assert len(rows) == 1 and rows[0].split("|")[2].strip() == "0/5"  # no door shut on an open map: one pass
    assert rows[0].split("|")[3] == rows[0].split("|")[4]  # so the same runs either way
    assert all(float(cell) > 0 for cell in rows[0].split("|")[5:7])  # the field's time, one pass and two calls
    with pytest.raises(SystemExit):
        script.main(["--maps", "random-32-32-10", "--repeat", "0", "--movingai", str(movingai)])
    assert "--repeat 0" in capsys.readouterr().err


@settings(max_examples=40, deadline=None)
@given(h=st.integers(1, 40), w=st.integers(1, 40), density=st.floats(0.0, 1.0), seed=st.integers(0, 2**31 - 1),
       gx=st.floats(-5.0, 45.0), gy=st.floats(-5.0, 45.0), res=st.sampled_from([0.05, 0.5, 1.0, 3.0]),
       step=st.floats(0.1, 20.0))
def test_the_straight_field_with_its_obstacles_in_one_pass_is_the_field_then_the_mask(h, w, density, seed, gx, gy,
                                                                                     res, step):
    blocked = (np.random.default_rng(seed).random((h, w)) < density).astype(np.uint8)
    dx = np.arange(w) + 0.5 - gx
    dy = (np.arange(h) + 0.5 - gy)[:, None]
    expected = np.sqrt(dx * dx + dy * dy) * res / step  # the field, the same operations in the same order
    expected[blocked.astype(bool)] = np.inf  # then the mask
    assert np.array_equal(straight_field(blocked, gx, gy, res, step), expected)


def test_the_route_benchmark_times_the_sampler_a_planner_gets_with_its_coarse_read(capsys):
    bench = load_script("benchmark_route")
    assert bench.main(["--sides", "256", "--families", "maze", "--repeat", "1", "--sampler"]) == 0
    lines = capsys.readouterr().out.splitlines()
    header = next(line for line in lines if line.startswith("| family"))
    row = [line for line in lines if line.startswith("| maze | 256")][-1]
    cells = dict(zip([c.strip() for c in header.strip("|").split("|")], [c.strip() for c in row.strip("|").split("|")],
                     strict=True))
    assert cells["coarser"] == "2" and float(cells["sampler_ms"]) > 0  # a generated maze's corridors: 256 read as 128
