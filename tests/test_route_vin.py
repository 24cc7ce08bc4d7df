"""The value-iteration route encoder (``learning.models.route_vin``) and its training losses."""

from __future__ import annotations

import contextlib
import math
import pickle

import numpy as np
import pytest
import torch
from conftest import fine_check_path, load_script
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from learning.models.route_net import load_route_net, make_route_net, route_input, save_route_net
from learning.models.route_vin import LENGTHS, MOVES, UNREACHED, RouteVIN, cell_steps
from learning.models.shipped import SHIPPED_ROUTE as SHIPPED
from learning.samplers.route import SHIPPED_SETTINGS, RouteSampler
from learning.training.route import cost_targets, train_route_net
from learning.training.vin_losses import block_targets, cost_losses, path_moves
from planners import RRT
from planners.base.fileio import InputError
from planners.maps.generators import TRAIN_SEEDS, generate


def _octile(dr: int, dc: int) -> float:
    return max(abs(dr), abs(dc)) + (math.sqrt(2) - 1) * min(abs(dr), abs(dc))


@settings(max_examples=25, deadline=None)
@given(h=st.integers(1, 9), w=st.integers(1, 9), data=st.data())
def test_value_iteration_on_move_lengths_is_the_octile_distance_in_blocks(h, w, data):
    gr, gc = data.draw(st.integers(0, h - 1)), data.draw(st.integers(0, w - 1))
    goal = torch.zeros(1, h, w, dtype=torch.bool)
    goal[0, gr, gc] = True
    costs = torch.tensor(LENGTHS, dtype=torch.float64).view(1, 8, 1, 1).expand(1, 8, h, w)
    v = RouteVIN.iterate(costs, goal, torch.zeros_like(goal))
    want = torch.tensor([[_octile(r - gr, c - gc) for c in range(w)] for r in range(h)], dtype=torch.float64)
    assert torch.allclose(v[0], want)


def test_blocks_without_a_free_cell_are_never_entered():
    goal = torch.zeros(1, 5, 5, dtype=torch.bool)
    goal[0, 2, 2] = True
    walls = torch.zeros_like(goal)
    walls[0, 1:4, 1:4] = True
    walls[0, 2, 2] = False  # the goal, walled in on every side
    costs = torch.ones(1, 8, 5, 5, dtype=torch.float64)
    v = RouteVIN.iterate(costs, goal, walls)
    assert v[0, 2, 2] == 0
    assert (v[0][walls[0]] == UNREACHED).all() and (v[0][~walls[0] & ~goal[0]] == UNREACHED).all()
    walls[0, 1, 2] = False  # a door to the north
    v = RouteVIN.iterate(costs, goal, walls)
    assert v[0, 1, 2] == 1 and v[0, 0, 2] == 2 and v[0, 4, 4] < UNREACHED


@settings(max_examples=60, deadline=None)
@given(h=st.integers(1, 12), w=st.integers(1, 12), seed=st.integers(0, 2**32 - 1),
       walls_p=st.sampled_from([0.0, 0.2, 0.5]), goals=st.integers(1, 3), wall_moves=st.booleans(),
       dtype=st.sampled_from([torch.float32, torch.float64]))
def test_settle_is_value_iterations_fixed_point_bit_for_bit(h, w, seed, walls_p, goals, wall_moves, dtype):
    rng = np.random.default_rng(seed)
    lengths = torch.tensor(LENGTHS, dtype=dtype).view(1, 8, 1, 1)
    costs = torch.from_numpy(rng.uniform(0.5, 45.0, (2, 8, h, w))).to(dtype) * lengths
    if wall_moves:  # moves priced as walls, as inference masks them
        costs = costs.masked_fill(torch.from_numpy(rng.random((2, 8, h, w)) < 0.3), UNREACHED)
    walls = torch.from_numpy(rng.random((2, h, w)) < walls_p)
    goal = torch.zeros(2, h, w, dtype=torch.bool)
    for b in range(2):
        for _ in range(goals):
            goal[b, rng.integers(h), rng.integers(w)] = True
    want = RouteVIN.iterate(costs, goal, walls)
    got = RouteVIN.settle(costs, goal, walls)
    assert got.dtype == want.dtype and torch.equal(got, want)


def test_settle_gives_the_shipped_encoders_value_iteration_on_generated_maps():
    net = load_route_net(SHIPPED)
    for family in ("maze", "bugtrap", "narrow_passage"):
        problem = generate(family, TRAIN_SEEDS[0], 96)
        x = torch.from_numpy(route_input(problem.world.obstacles, problem.world.cell_of(problem.goal), net.block)[None])
        x = x[:, :net.block * net.block + 1]
        with torch.inference_mode():
            goal, walls = net.goal_and_walls(x)
            _, costs = net.move_costs(x)
            costs = costs.masked_fill(~cell_steps(x, net.block), UNREACHED)
            assert torch.equal(RouteVIN.settle(costs, goal, walls), RouteVIN.iterate(costs, goal, walls))


def test_a_fixed_number_of_iterations_reaches_that_many_moves_and_keeps_the_goal_at_zero():
    goal = torch.zeros(1, 1, 6, dtype=torch.bool)
    goal[0, 0, 0] = True
    costs = torch.ones(1, 8, 1, 6, dtype=torch.float64)
    v = RouteVIN.iterate(costs, goal, torch.zeros_like(goal), steps=3)
    assert v[0, 0].tolist() == [0, 1, 2, 3, UNREACHED, UNREACHED]


def test_the_encoder_predicts_a_cost_per_cell_on_maps_of_any_size_and_round_trips(tmp_path):
    torch.manual_seed(0)
    net = make_route_net("vin", 4, 8, 2).eval()
    obs = np.zeros((50, 70), bool)
    obs[10:40, 30] = True
    field = net.predict(obs, (3, 4), 2)
    assert field.shape == (50, 70) and np.isfinite(field).all()
    save_route_net(net, tmp_path / "v.pt")
    back = load_route_net(tmp_path / "v.pt")
    assert isinstance(back, RouteVIN) and (back.block, back.channels, back.depth) == (4, 8, 2)
    assert np.array_equal(back.predict(obs, (3, 4), 2), field)


def test_half_step_blocks_predict_in_steps_round_trip_and_fit_only_their_step(tmp_path):
    torch.manual_seed(0)
    net = make_route_net("vin", 2, 8, 2, step=4).eval()
    assert (net.block, net.step) == (2, 4)
    obs = np.zeros((40, 40), bool)
    obs[5:35, 20] = True
    x = torch.from_numpy(route_input(obs, (3, 4), 2))[None]
    with torch.inference_mode():
        blocks = net(x)[0].numpy()
    assert np.allclose(net.predict(obs, (3, 4)), blocks / 2, atol=1e-6)  # blocks of 2 cells, steps of 4
    save_route_net(net, tmp_path / "half.pt")
    back = load_route_net(tmp_path / "half.pt")
    assert (back.block, back.step) == (2, 4)
    assert np.array_equal(back.predict(obs, (3, 4)), net.predict(obs, (3, 4)))
    p = generate("rooms", TRAIN_SEEDS[0] + 1, 32)
    assert RRT(p, step_size=4.0, sampler=RouteSampler(net, **SHIPPED_SETTINGS), seed=0).solve(2000).iterations > 0
    # a step of 2 cells: the encoder reads the map at twice its resolution, a step of 4 of those cells
    assert RRT(p, step_size=2.0, sampler=RouteSampler(net, step_size=2.0), seed=0).solve(2000).iterations > 0
    with pytest.raises(ValueError, match="whole blocks"):
        make_route_net("vin", 3, 8, 2, step=4)
    with pytest.raises(ValueError, match="one step"):
        make_route_net("unet", 2, 8, 2, step=4)


@pytest.mark.parametrize("config, needle", [
    ({"kind": "transformer", "block": 4, "channels": 8, "depth": 2}, "kind"),
    ({"kind": "vin", "block": 4, "channels": 8, "depth": 2, "attention": 2}, "attention"),
    ({"kind": "vin", "block": 3, "channels": 8, "depth": 2, "step": 4}, "whole blocks"),
    ({"kind": "vin", "block": 2, "channels": 8, "depth": 2, "step": 0}, "step"),
])
def test_a_bad_kind_is_refused_by_name(tmp_path, config, needle):
    torch.save({"config": config, "state": {}}, tmp_path / "bad.pt")
    with pytest.raises(InputError, match=needle):
        load_route_net(tmp_path / "bad.pt")


def test_the_path_move_of_every_block_leads_down_the_search_cost_to_go():
    p = generate("maze", TRAIN_SEEDS[0] + 3, 64)
    goal = p.world.cell_of(p.goal)
    cells = torch.from_numpy(cost_targets(p.world.obstacles, goal, 4))[None]
    tb, move = block_targets(cells, 4), path_moves(cells, 4)
    known = torch.isfinite(tb[0]) & (tb[0] > 0)
    assert (move[0][known] >= 0).all()
    for r, c in zip(*np.nonzero(known.numpy()), strict=True):
        dr, dc = MOVES[int(move[0, r, c])]
        assert tb[0, r + dr, c + dc] < tb[0, r, c]  # the next block is nearer the goal


def test_the_drops_as_move_costs_give_the_search_cost_to_go_and_no_loss():
    p = generate("rooms", TRAIN_SEEDS[0] + 5, 64)
    goal = p.world.cell_of(p.goal)
    cells = torch.from_numpy(cost_targets(p.world.obstacles, goal, 4)).float()[None]
    tb, move = block_targets(cells, 4), path_moves(cells, 4)
    lengths = torch.tensor(LENGTHS).view(1, 8, 1, 1)
    costs = torch.full((1, 8, 16, 16), 1000.0) * lengths  # every move a wall ...
    for r, c in zip(*np.nonzero((move[0] >= 0).numpy()), strict=True):  # ... but the path's, at its drop
        dr, dc = MOVES[int(move[0, r, c])]
        costs[0, move[0, r, c], r, c] = max(float(tb[0, r, c] - tb[0, r + dr, c + dc]), 0.5 * LENGTHS[move[0, r, c]])
    eq, hinge = cost_losses(costs, cells, 4)
    assert eq.item() < 1e-6 and hinge.item() < 1e-6
    x = torch.from_numpy(route_input(p.world.obstacles, goal, 4))[None]
    walls = x[:, :16].amin(1) > 0.5
    v = RouteVIN.iterate(costs.double(), x[:, 16] > 0.5, walls)
    known = torch.isfinite(tb)
    assert (v[known] >= tb[known] - 1e-5).all()  # no move cheaper than its drop: no shortcut
    assert (v[known] - tb[known]).max() < 1.0  # drops below half a move are counted at half
    costs[0, :, 0, 0] = 0.5  # a move cheaper than the drop it makes
    assert cost_losses(costs, cells, 4)[1].item() > 0


@pytest.mark.parametrize("block", [4, 2])
def test_vin_training_is_seeded_and_the_loss_falls(block):
    problems = [generate(f, TRAIN_SEEDS[0] + i, 32) for f in ("maze", "rooms") for i in range(3)]
    logs: list[list[str]] = [[], []]
    nets = [train_route_net(problems, kind="vin", channels=8, depth=2, epochs=3, batch=2, seed=1, block=block,
                            step=4, log=logs[i].append) for i in range(2)]
    assert (nets[0].block, nets[0].step) == (block, 4)
    a, b = (n.state_dict() for n in nets)
    assert all(torch.equal(a[k], b[k]) for k in a)
    assert [line.split(" (")[0] for line in logs[0]] == [line.split(" (")[0] for line in logs[1]]
    losses = [float(line.split("loss ")[1].split()[0].rstrip(",")) for line in logs[0]]
    assert losses[-1] < losses[0]


def test_the_route_sampler_plans_valid_seeded_paths_with_a_vin():
    torch.manual_seed(0)
    net = make_route_net("vin", 4, 8, 2).eval()
    p = generate("bugtrap", TRAIN_SEEDS[0] + 2, 64)
    runs = [RRT(p, step_size=4.0, sampler=RouteSampler(net, **SHIPPED_SETTINGS), seed=3).solve(max_iterations=20000)
            for _ in range(2)]
    assert runs[0].solved and runs[0].iterations == runs[1].iterations
    assert np.array_equal(runs[0].path, runs[1].path)
    assert np.allclose(runs[0].path[0], p.start) and np.linalg.norm(runs[0].path[-1] - p.goal) <= p.goal_tolerance
    assert fine_check_path(p.world, runs[0].path)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000), size=st.sampled_from([32, 64, 128]))
def test_caves_are_seeded_training_maps_with_a_far_query_and_no_shifted_variant(seed, size):
    from planners.maps.generators import FAMILIES, TRAINING_FAMILIES

    a, b = generate("caves", seed, size), generate("caves", seed, size)
    assert np.array_equal(a.world.obstacles, b.world.obstacles) and np.array_equal(a.start, b.start)
    assert a.world.obstacles[0].all() and a.world.obstacles[:, -1].all()  # the edge is a wall
    assert a.reference_length >= size / 2  # start and goal half the map apart along the route
    assert "caves" in TRAINING_FAMILIES and "caves" not in FAMILIES  # trained on, never tested on
    with pytest.raises(ValueError, match="no shifted variant"):
        generate("caves", seed, size, shifted=True)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000), size=st.sampled_from([32, 64, 128]))
def test_strokes_are_seeded_training_maps_of_thin_walls_in_no_test_set(seed, size):
    from planners.maps.generators import FAMILIES, TRAINING_FAMILIES
    from planners.maps.unseen import UNSEEN_FAMILIES

    a, b = generate("strokes", seed, size), generate("strokes", seed, size)
    assert np.array_equal(a.world.obstacles, b.world.obstacles) and np.array_equal(a.start, b.start)
    assert 0.08 <= a.world.obstacles.mean() <= 0.40  # the drawing stops just past its target cover of 8-25%
    assert a.reference_length >= size / 2
    assert "strokes" in TRAINING_FAMILIES and "strokes" not in FAMILIES + UNSEEN_FAMILIES  # trained on, never tested on
    with pytest.raises(ValueError, match="no shifted variant"):
        generate("strokes", seed, size, shifted=True)


@pytest.mark.parametrize("wall_cost, reached", [(32.0, False), (None, True)])
def test_a_move_priced_above_the_wall_cost_is_a_wall_at_inference(monkeypatch, wall_cost, reached):
    """Every move costs its length but those out of block column 4, priced 40 per length: a wall at 32."""
    net = RouteVIN(block=2, channels=4, depth=1, step=4).eval()
    x = torch.from_numpy(route_input(np.zeros((8, 16), dtype=bool), (1, 1), 2)[None])

    def priced(x):
        costs = net.lengths.expand(1, 8, 4, 8).clone()
        costs[:, :, :, 4] *= 40.0
        return torch.zeros(1, net.channels, 4, 8), costs

    monkeypatch.setattr(net, "move_costs", priced)
    net.wall_cost = wall_cost
    with torch.inference_mode():
        field = net(x)[0].numpy()
    beyond = field[:, 10:]  # block columns 5-7 reach the goal only through column 4
    assert (beyond.max() < 1e3) if reached else (beyond.min() > 1e5)
    assert field[:, :8].max() < 1e3  # the goal's side is reached either way
    assert RouteVIN.wall_cost == 32.0  # the shipped inference



def _door_priced_as_wall(monkeypatch) -> RouteVIN:
    """An encoder on an open 8 x 16 map whose moves out of block column 4 cost 40 per length: a wall at 32."""
    net = RouteVIN(block=2, channels=4, depth=1, step=4).eval()

    def priced(x):
        costs = net.lengths.expand(1, 8, 4, 8).clone()
        costs[:, :, :, 4] *= 40.0
        return torch.zeros(1, net.channels, 4, 8), costs

    monkeypatch.setattr(net, "move_costs", priced)
    monkeypatch.setattr(net, "map_cache_bytes", 0)  # the reuse runs the real local network, not the patched one
    return net


def test_where_the_learned_walls_shut_every_route_from_the_start_the_sampler_ranks_without_them(monkeypatch):
    """The start beyond a door the encoder prices as a wall: a second pass without the learned walls, kept apart."""
    from learning.samplers.route import FieldCache
    from planners import OccupancyGrid, Problem

    net = _door_priced_as_wall(monkeypatch)
    grid = OccupancyGrid(np.zeros((8, 16), dtype=bool))
    beyond = Problem(grid, start=(14.5, 4.5), goal=(1.5, 1.5), goal_tolerance=1.0)
    near = Problem(grid, start=(5.5, 4.5), goal=(1.5, 1.5), goal_tolerance=1.0)
    shut = net.predict(grid.obstacles, grid.cell_of(beyond.goal))
    assert shut[grid.cell_of(beyond.start)] >= 0.5 * net.unreached_steps
    with net.open_walls():
        assert net.wall_cost is None
        opened = net.predict(grid.obstacles, grid.cell_of(beyond.goal))
    assert net.wall_cost == 32.0 and "wall_cost" not in net.__dict__  # back to the class's value
    field, was_opened = net.predict_reaching(grid.obstacles, grid.cell_of(beyond.goal), grid.cell_of(beyond.start))
    assert was_opened and np.array_equal(field, opened)  # in one pass: the second pass's field
    cache = FieldCache()
    s = RouteSampler(net, fields=cache).bind(beyond)
    assert s.forward_passes == 2 and len(cache) == 1  # one field for this start's query: the open one
    assert np.array_equal(s.field, opened) and s.field.max() < 1e3
    again = RouteSampler(net, fields=cache).bind(beyond)
    assert again.forward_passes == 2 and cache.hits == 1 and np.array_equal(again.field, opened)
    assert again.reused_seconds > 0
    filled = FieldCache()  # the walled field filled ahead (as on a GPU): the open one computed at the bind, kept apart
    assert RouteSampler(net, fields=filled).prefill([beyond], batch=True) == 1
    s = RouteSampler(net, fields=filled).bind(beyond)
    assert s.forward_passes == 2 and len(filled) == 2 and np.array_equal(s.field, opened) and s.reused_seconds > 0
    s = RouteSampler(net).bind(near)  # the start is reached: one pass, the walls kept
    assert s.forward_passes == 1 and s.field[:, 10:].min() > s.field[:, :8].max()
    net.wall_cost = None
    assert net.open_walls() is None


def _steps_by_hand(obstacles: np.ndarray, block: int) -> np.ndarray:
    """``cell_steps`` cell by cell: (8, h, w), whether a free cell of a block steps into the block a move away."""
    H, W = obstacles.shape
    h, w = -(-H // block), -(-W // block)
    free = np.zeros((h * block, w * block), dtype=bool)
    free[:H, :W] = ~obstacles
    out = np.zeros((8, h, w), dtype=bool)
    for r in range(h * block):
        for c in range(w * block):
            for er in (-1, 0, 1):
                for ec in (-1, 0, 1):
                    rr, cc = r + er, c + ec
                    if not (er or ec) or not (0 <= rr < h * block and 0 <= cc < w * block):
                        continue
                    if not (free[r, c] and free[rr, cc]) or (er and ec and not (free[rr, c] and free[r, cc])):
                        continue
                    move = (rr // block - r // block, cc // block - c // block)
                    if move != (0, 0):
                        out[MOVES.index(move), r // block, c // block] = True
    return out


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), shape=st.tuples(st.integers(2, 13), st.integers(2, 13)),
       block=st.sampled_from([1, 2, 3]), density=st.floats(0.0, 0.6))
def test_cell_steps_are_the_grids_own_steps_between_blocks(seed, shape, block, density):
    obstacles = np.random.default_rng(seed).random(shape) < density
    x = torch.from_numpy(route_input(obstacles, (0, 0), block)[None])
    assert np.array_equal(cell_steps(x, block)[0].numpy(), _steps_by_hand(obstacles, block))


def test_a_staircase_wall_stops_the_moves_across_it_but_not_along_it():
    """A diagonal wall one cell thick (4-connected, so solid without corner cutting) through 2-cell blocks."""
    obstacles = np.zeros((8, 8), dtype=bool)
    for i in range(8):
        obstacles[i, 7 - i] = True
        if i:
            obstacles[i, 8 - i] = True  # each cell of the wall touches the next by a side
    steps = cell_steps(torch.from_numpy(route_input(obstacles, (0, 0), 2)[None]), 2)[0].numpy()
    assert ndimage.label(~obstacles)[1] == 2  # 4-connected free cells: two sides
    # block (1, 1) holds cells of the upper side only, block (2, 2) of the lower side only: no step between them
    assert not steps[MOVES.index((1, 1)), 1, 1] and not steps[MOVES.index((-1, -1)), 2, 2]
    # block (1, 2) keeps one upper cell, (2, 4), beside block (1, 1)'s (2, 3): a step along the wall's side
    assert steps[MOVES.index((0, 1)), 1, 1] and steps[MOVES.index((0, -1)), 1, 2]


@pytest.mark.parametrize("step_walls, reached", [(True, False), (False, True)])
def test_a_move_no_cell_can_step_is_a_wall_at_inference(monkeypatch, step_walls, reached):
    """Every move costs its length; a wall one cell thick down cell column 8 leaves no step between block columns
    3 and 4, and only the network's price would carry value iteration across it."""
    net = RouteVIN(block=2, channels=4, depth=1, step=4).eval()
    obstacles = np.zeros((8, 16), dtype=bool)
    obstacles[:, 8] = True
    x = torch.from_numpy(route_input(obstacles, (1, 1), 2)[None])
    monkeypatch.setattr(net, "move_costs", lambda x: (torch.zeros(1, net.channels, 4, 8),
                                                      net.lengths.expand(1, 8, 4, 8).clone()))
    net.step_walls = step_walls
    with torch.inference_mode():
        field = net(x)[0].numpy()
    beyond = field[:, 9:]
    assert (beyond.max() < 1e3) if reached else (beyond.min() > 1e5)
    assert field[:, :8].max() < 1e3
    assert RouteVIN.step_walls  # the shipped inference


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 10_000), size=st.sampled_from([64, 128, 256]))
def test_long_mazes_keep_the_training_corridors_at_any_side(seed, size):
    from planners.maps.generators import FAMILIES, TRAINING_FAMILIES, long_maze

    a, b = long_maze(seed, size), long_maze(seed, size)
    assert np.array_equal(a.world.obstacles, b.world.obstacles) and np.array_equal(a.start, b.start)
    assert a.name == f"long-maze-{size}-{seed}"
    # every free cell lies within 8 cells of a wall: corridors 16 wide at every side
    assert ndimage.distance_transform_cdt(~a.world.obstacles, metric="chessboard").max() <= 9
    assert "long_maze" not in TRAINING_FAMILIES + FAMILIES  # validation only
    with pytest.raises(InputError, match="size"):
        long_maze(seed, 16)
    with pytest.raises(ValueError, match="goal_tolerance"):
        long_maze(seed, size, goal_tolerance=-1.0)


@settings(max_examples=4, deadline=None)
@given(seed=st.integers(0, 10_000), size=st.sampled_from([64, 128]))
def test_diagonal_mazes_are_seeded_validation_mazes_with_walls_at_a_slant(seed, size):
    from planners.maps.generators import FAMILIES, TRAINING_FAMILIES, diagonal_maze
    from planners.maps.gridsearch import connected

    a, b = diagonal_maze(seed, size), diagonal_maze(seed, size)
    assert np.array_equal(a.world.obstacles, b.world.obstacles) and np.array_equal(a.start, b.start)
    assert a.name == f"diagonal-maze-{size}-{seed}" and a.reference_length >= size / 2
    assert connected(a.world.obstacles, a.world.cell_of(a.start), a.world.cell_of(a.goal))
    # the walls are those of 16-cell corridors turned by 45 degrees: a free cell is at most 8 cells from a wall
    # along the turned axes, so within 8 * sqrt(2) + 2 cells in chessboard distance
    assert ndimage.distance_transform_cdt(~a.world.obstacles, metric="chessboard").max() <= 14
    assert "diagonal_maze" not in TRAINING_FAMILIES + FAMILIES  # validation only
    with pytest.raises(ValueError, match="goal_tolerance"):
        diagonal_maze(seed, size, goal_tolerance=0.0)


@pytest.mark.experiments
def test_the_long_mazes_script_prints_a_row_per_side_and_refuses_a_bad_wall_cost(capsys):
    script = load_script("experiments/long_mazes")
    assert script.main(["--sides", "64", "--maps", "1", "--seeds", "1", "--wall-cost", "none"]) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| 64 |")]
    assert len(rows) == 1 and len(rows[0].strip("|").split("|")) == 4
    assert script.main(["--sides", "64", "--maps", "1", "--seeds", "1", "--diagonal", "--step-walls", "on"]) == 0
    assert len([line for line in capsys.readouterr().out.splitlines() if line.startswith("| 64 |")]) == 1
    for bad in (["--wall-cost", "-1"], ["--wall-cost", "lots"], ["--maps", "0"], ["--step-walls", "maybe"]):
        with pytest.raises(SystemExit) as stop:
            script.main(bad)
        assert stop.value.code == 2


@pytest.mark.experiments
def test_the_field_leaks_script_compares_one_query_and_refuses_an_unknown_map(movingai, capsys):
    script = load_script("experiments/field_leaks")
    assert script.main(["maze-32-32-2", "--movingai", str(movingai), "--step-walls", "on"]) == 0
    out = capsys.readouterr().out
    assert "cost-to-go at the start: learned" in out and "rank correlation over the free cells" in out
    assert "block moves no cell can step" in out
    with pytest.raises(SystemExit) as stop:
        script.main(["no-such-map", "--movingai", str(movingai)])
    assert stop.value.code == 2 and "no-such-map" in capsys.readouterr().err


def test_a_pass_in_strips_of_rows_gives_the_one_piece_field_and_refuses_gradients(monkeypatch):
    net = load_route_net(SHIPPED)
    problem = generate("maze", TRAIN_SEEDS[0] + 3, 96)
    obstacles, goal = problem.world.obstacles, problem.world.cell_of(problem.goal)
    whole = net.predict(obstacles, goal)
    monkeypatch.setattr(net, "strip_blocks", 48 * 7)  # strips of 3 block rows of the 48 x 48 block grid
    assert net.strip_rows(48, 48) == 3
    strips = net.predict(obstacles, goal)
    reached = whole < 1e5
    assert np.array_equal(reached, strips < 1e5)
    assert np.abs(strips - whole)[reached].max() < 1e-4  # the rounding of another shape, no more
    x = torch.from_numpy(route_input(obstacles, goal, net.block)[None])
    with pytest.raises(ValueError, match="strips, at inference only"):
        net(x)  # gradients on: a training pass never runs in strips
    assert 1 << 30 < net.pass_bytes(2048, 2048) < 1.5 * 2**30  # a 4096 x 4096 map within 1.5 GB (1.25 to 1.29 measured)


def _whole_and_reused(net: RouteVIN, obstacles: np.ndarray, goal: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    keep = net.map_cache_bytes
    try:
        net.map_cache_bytes, net.compiled_inference = 0, False  # one whole pass in torch, as before any map was kept
        whole = net.predict(obstacles, goal)
    finally:
        net.map_cache_bytes = keep
        del net.compiled_inference  # back to the class's value
    return whole, net.predict(obstacles, goal)


#: How a compiled pass runs the local network on these small maps: through torch's dense layers, its prepacked
#: ones, or compiled with its heads (``RouteVIN.numba_local_blocks``).
LAYERS = ("dense", "prepacked", "compiled")


def _with_layers(net: RouteVIN, layers: str) -> RouteVIN:
    net.prepacked_blocks = 0 if layers == "prepacked" else 10**9
    net.numba_local_blocks = 10**9 if layers == "compiled" else 0
    return net


@settings(max_examples=40, deadline=None)
@given(h=st.integers(4, 40), w=st.integers(4, 40), depth=st.integers(1, 4), density=st.sampled_from([0.0, 0.2, 0.4]),
       seed=st.integers(0, 2**16), goals=st.lists(st.tuples(st.floats(0, 1), st.floats(0, 1)), min_size=1, max_size=3),
       wall_cost=st.sampled_from([None, 1.2, 32.0]), step_walls=st.booleans(), layers=st.sampled_from(LAYERS))
def test_a_kept_map_gives_every_goal_the_whole_pass_field(h, w, depth, density, seed, goals, wall_cost, step_walls,
                                                          layers):
    torch.manual_seed(seed)  # the weights only; the map and goals come from the seeded generator below
    net = _with_layers(make_route_net("vin", block=2, channels=8, depth=depth, step=2).eval(), layers)
    net.wall_cost, net.step_walls = wall_cost, step_walls  # 1.2: many moves priced as walls, on both paths
    obstacles = np.random.default_rng(seed).random((h, w)) < density
    corner = next((tuple(int(i) for i in c) for c in np.argwhere(~obstacles)), None)
    if corner is not None:  # a first query on the map, so that the goals below find it kept from their first
        net.predict(obstacles, corner)
    for fr, fc in goals:  # goals anywhere, the map's edges and corners included; later ones reuse the kept map
        goal = (min(h - 1, int(fr * h)), min(w - 1, int(fc * w)))
        obstacles[goal] = False
        whole, reused = _whole_and_reused(net, obstacles, goal)
        reached = whole < 1e5
        assert np.array_equal(reached, reused < 1e5)
        assert np.abs(reused - whole)[reached].max(initial=0.0) < 1e-4


@settings(max_examples=25, deadline=None)
@given(h=st.integers(4, 40), w=st.integers(4, 40), density=st.sampled_from([0.0, 0.2, 0.4]), seed=st.integers(0, 2**16),
       goal=st.tuples(st.floats(0, 1), st.floats(0, 1)), other=st.tuples(st.floats(0, 1), st.floats(0, 1)),
       layers=st.sampled_from(LAYERS))
def test_the_same_goal_again_reads_the_held_parts_as_the_whole_pass_made_them(h, w, density, seed, goal, other, layers):
    torch.manual_seed(seed)
    net = _with_layers(make_route_net("vin", block=2, channels=8, depth=2, step=2).eval(), layers)
    net.wall_cost = 1.2  # many moves priced as walls, so the pass without them differs
    obstacles = np.random.default_rng(seed).random((h, w)) < density
    g = (min(h - 1, int(goal[0] * h)), min(w - 1, int(goal[1] * w)))
    o = (min(h - 1, int(other[0] * h)), min(w - 1, int(other[1] * w)))
    obstacles[g] = obstacles[o] = False

    def whole(goal_cell, open_walls):  # one whole compiled pass, nothing kept before it
        net.clear_map_cache()
        with net.open_walls() if open_walls else contextlib.nullcontext():
            return net.predict(obstacles, goal_cell)

    expected = [whole(g, False), whole(g, True), whole(g, False), whole(o, False)]
    net.clear_map_cache()
    first = net.predict(obstacles, g)  # a whole pass, its parts held with this goal in them

    def no_window(*args):
        raise AssertionError("the same goal again computed a goal's window")

    net.window_parts = net.window_field = no_window  # the parts hold this goal already: no window is computed
    with net.open_walls():
        again = net.predict(obstacles, g)  # the route sampler's second pass: the same goal, without the learned walls
    assert np.array_equal(first, expected[0]) and np.array_equal(again, expected[1])
    assert np.array_equal(net.predict(obstacles, g), expected[2])  # and again, from the parts now kept
    del net.window_parts, net.window_field  # back to the class's methods
    later = net.predict(obstacles, o)  # another goal: the held goal's window taken out, its own put in
    reached = expected[3] < 1e5
    assert np.array_equal(reached, later < 1e5) and np.abs(later - expected[3])[reached].max(initial=0.0) < 1e-4


def test_kept_maps_stay_within_their_bytes_and_go_with_new_weights():
    net = load_route_net(SHIPPED)
    problems = [generate("forest", TRAIN_SEEDS[0] + i, 64) for i in range(3)]
    for p in problems:  # a map queried once keeps nothing: it is held as the recent map until the next map's query
        net.predict(p.world.obstacles, p.world.cell_of(p.goal))
        assert net._maps.recent[0] is not None and len(net._maps) == 0 and net._maps.bytes == 0
    for p in problems:  # a second query keeps the map's parts (the last map's from where they are held)
        net.predict(p.world.obstacles, p.world.cell_of(p.goal))
    assert len(net._maps) == 3 and net._maps.recent is None

    def total_kept() -> int:  # the running total the cache keeps is the sum over what it holds
        return sum(p.nbytes() for p in net._maps.parts.values())

    assert net._maps.bytes == total_kept() > 0
    one = next(iter(net._maps.parts.values())).nbytes()
    net.map_cache_bytes = 2 * one  # room for two maps: the least recently used one goes
    net.predict(problems[0].world.obstacles, problems[0].world.cell_of(problems[0].goal))
    assert len(net._maps) == 2 and net._maps.bytes == total_kept()
    other = tuple(int(i) for i in np.argwhere(~problems[2].world.obstacles)[0])
    net.predict(problems[2].world.obstacles, other)  # a later query on a kept map: its parts replaced
    assert len(net._maps) == 2 and net._maps.bytes == total_kept()
    copy = pickle.loads(pickle.dumps(net))  # a copy sent to another process starts with no kept map
    assert len(copy._maps) == 0 and len(net._maps) == 2
    obstacles, goal = problems[1].world.obstacles, problems[1].world.cell_of(problems[1].goal)
    before = net.predict(obstacles, goal)
    state = {k: v * 1.5 if k.startswith("local.0") else v for k, v in net.state_dict().items()}
    net.load_state_dict(state)  # other weights: nothing kept from the old ones may serve them
    assert len(net._maps) == 0 and net._maps.bytes == 0
    whole, changed = _whole_and_reused(net, obstacles, goal)
    reached = whole < 1e5
    assert np.abs(changed - whole)[reached].max() < 1e-4 and np.array_equal(reached, changed < 1e5)
    assert not np.allclose(before, changed)
    net.map_cache_bytes = 1 << 20
    net.predict(obstacles, goal)
    net.train()
    assert len(net._maps) == 0  # training changes the weights in place


@pytest.mark.experiments
def test_the_breakdown_script_times_every_part_of_a_pass_and_refuses_a_tiny_map(capsys):
    script = load_script("experiments/route_breakdown")
    assert script.main(["--side", "32", "--families", "forest", "maze", "--repeat", "1"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split(" | ")[2:] == ["whole first query", "convolutions", "dense convolutions", "step walls",
                                       "Dijkstra", "cell head |"]
    rows = [line for line in out if line.startswith(("| forest |", "| maze |"))]
    assert len(rows) == 2 and all(float(cell) > 0 for row in rows for cell in row.strip("| ").split(" | ")[2:])
    with pytest.raises(SystemExit) as stop:
        script.main(["--side", "8"])
    assert stop.value.code == 2


@pytest.mark.experiments
def test_cheaper_arithmetic_moves_the_field_by_its_rounding(capsys):
    script = load_script("experiments/cheap_arithmetic")
    assert script.main(["--check", "fields", "--maps", "1", "--sides", "32", "--families", "forest", "maze"]) == 0
    rows = {line.split(" | ")[0].strip("| "): float(line.split(" | ")[1])
            for line in capsys.readouterr().out.splitlines()
            if line.startswith(("| prepacked", "| compiled", "| channels", "| bfloat16"))}
    # float32 in another layout or order differs by rounding only; bfloat16 keeps 8 bits of mantissa: it moves further
    assert set(rows) == {"prepacked", "compiled heads", "compiled", "channels-last float32", "bfloat16"}
    assert max(v for k, v in rows.items() if k != "bfloat16") < 1e-3 < rows["bfloat16"]
    with torch.no_grad():  # torch's dense layers against the compiled ones, on any map
        assert script.encoder(script.CompiledLocal).compiled_local(torch.zeros(1, 5, 512, 512))
        assert not script.encoder().compiled_local(torch.zeros(1, 5, 8, 8))
    assert not script.encoder().prepacked and script.encoder(script.Prepacked).prepacked  # dense against prepacked
    shipped, layout = script.encoder(), script.encoder(script.ChannelsLast)  # another layout, the same weights
    pairs = zip(shipped.state_dict().values(), layout.state_dict().values(), strict=True)
    assert all(torch.equal(a, b) for a, b in pairs)
    with pytest.raises(SystemExit) as stop:
        script.main(["--check", "fields", "--maps", "0"])
    assert stop.value.code == 2


@pytest.mark.parametrize("local", ["torch", "compiled"])
@pytest.mark.parametrize("family", ["maze", "bugtrap", "forest"])
def test_the_compiled_inference_gives_the_torch_pass_field(family, local, monkeypatch):
    """Walls gating the Dijkstra, the compiled cell head and the strips of rows (or the compiled local network): the
    torch pass's field within 1e-4."""
    net = load_route_net(SHIPPED)
    net.numba_local_blocks = 10**9 if local == "compiled" else 0  # the local network compiled, or torch's in strips
    problem = generate(family, TRAIN_SEEDS[0] + 5, 96)
    obstacles = problem.world.obstacles
    free = np.argwhere(~obstacles)
    goals = [problem.world.cell_of(problem.goal), tuple(free[len(free) // 3]), tuple(free[-1])]
    monkeypatch.setattr(net, "feature_bytes", 1)  # strips of the least rows (32 of the 48 block rows, then 16)
    for goal in goals:  # the first query takes a whole pass, later ones the kept map with the first goal taken out
        compiled = net.predict(obstacles, goal)
        with monkeypatch.context() as m:
            m.setattr(net, "compiled_inference", False)
            m.setattr(net, "map_cache_bytes", 0)
            torch_pass = net.predict(obstacles, goal)
        reached = torch_pass < 1e5
        assert np.array_equal(reached, compiled < 1e5)
        assert np.abs(compiled - torch_pass)[reached].max() < 1e-4


@pytest.mark.parametrize("low, high", [(0.5, 45.0), (1e-3, 0.1)])
def test_the_search_by_buckets_and_by_heap_give_value_iterations_values(low, high):
    """Prices of at least half a block settle by buckets; cheaper ones (too fine for buckets) by the heap."""
    rng = np.random.default_rng(7)
    costs = torch.from_numpy(rng.uniform(low, high, (1, 8, 30, 40)).astype(np.float32))
    costs = costs.masked_fill(torch.from_numpy(rng.random((1, 8, 30, 40)) < 0.2), UNREACHED)
    walls = torch.from_numpy(rng.random((1, 30, 40)) < 0.2)
    goal = torch.zeros(1, 30, 40, dtype=torch.bool)
    goal[0, 3, 5] = goal[0, 20, 30] = True
    assert torch.equal(RouteVIN.settle(costs, goal, walls), RouteVIN.iterate(costs, goal, walls))


@pytest.mark.parametrize("family", ["maze", "rooms"])
def test_the_prepacked_convolutions_give_the_dense_field_and_follow_the_weights(family):
    """oneDNN's prepacked layers: the dense pass's field within rounding, first and later queries; new weights (a
    load, training, a pickled copy) are packed again, and an encoder that prices its own moves keeps its own."""
    dense, packed = load_route_net(SHIPPED), load_route_net(SHIPPED)
    dense.prepacked = False
    dense.numba_local_blocks = packed.numba_local_blocks = 0  # torch's layers on every map and window
    problem = generate(family, TRAIN_SEEDS[0] + 7, 128)
    obstacles = problem.world.obstacles
    free = np.argwhere(~obstacles)
    for goal in (problem.world.cell_of(problem.goal), tuple(free[len(free) // 2]), tuple(free[0])):
        want, got = dense.predict(obstacles, goal), packed.predict(obstacles, goal)
        reached = want < 1e5
        assert np.array_equal(reached, got < 1e5)
        assert np.abs(got - want)[reached].max() < 2e-4  # another order of summation (see RouteVIN.prepacked)
    x = torch.from_numpy(route_input(obstacles, goal, packed.block))[None][:, :packed.block ** 2 + 1]
    with torch.no_grad():
        f = packed.packed_local(x)
        assert f.layout == torch.strided and f.shape == packed.local(x).shape
        assert 0 < (f - packed.local(x)).abs().max() < 1e-4  # prepacked indeed, and the same features up to rounding
    copy = pickle.loads(pickle.dumps(packed))  # packs its own weights
    packed.clear_map_cache()  # a first query each: the same pass, bit for bit
    assert np.array_equal(copy.predict(obstacles, goal), packed.predict(obstacles, goal))
    state = {k: v * 1.5 if k.startswith("local.2") else v for k, v in packed.state_dict().items()}
    for net in (dense, packed):
        net.load_state_dict(state)  # other weights: the packed ones of the old weights may not serve
    want, got = dense.predict(obstacles, goal), packed.predict(obstacles, goal)
    assert np.abs(got - want)[want < 1e5].max() < 2e-4
    with torch.no_grad():
        packed.local[0].weight.mul_(0.5)  # in place, in evaluation mode: the caller says so
    packed.weights_changed()
    dense.load_state_dict(packed.state_dict())
    want, got = dense.predict(obstacles, goal), packed.predict(obstacles, goal)
    assert np.abs(got - want)[want < 1e5].max() < 2e-4
    assert packed.packs(x) and not dense.packs(x)

    class OwnPrices(RouteVIN):
        def move_costs(self, x):
            return super().move_costs(x)

    assert not OwnPrices(block=2, channels=8, depth=2, step=4).packs(x)
    small = generate(family, TRAIN_SEEDS[0] + 7, 32)  # below prepacked_blocks: the dense layers, bit for bit
    small_goal = small.world.cell_of(small.goal)
    assert not packed.packs(x[..., :16, :16])
    assert np.array_equal(packed.predict(small.world.obstacles, small_goal),
                          dense.predict(small.world.obstacles, small_goal))


def test_a_pass_into_kept_buffers_gives_the_same_fields_and_never_the_callers_arrays():
    """Above ``strip_blocks`` (no map kept) a compiled pass writes into buffers kept for the next pass of its shape:
    the same fields bit for bit, a field already returned is never written again, and the buffers go on request,
    with new weights and in a pickled copy."""
    net, fresh = load_route_net(SHIPPED), load_route_net(SHIPPED)
    for n in (net, fresh):
        n.strip_blocks = 48 * 7  # strips of 3 block rows of the 48 x 48 block grid: no map's parts kept
        n.feature_bytes = 1  # the convolutions in strips of their least height (32 block rows)
    fresh.keep_buffers = False
    problem = generate("rooms", TRAIN_SEEDS[0] + 5, 96)
    obstacles = problem.world.obstacles
    free = np.argwhere(~obstacles)
    goals = [problem.world.cell_of(problem.goal), tuple(free[0]), tuple(free[len(free) // 2])]
    fields = [net.predict(obstacles, goal) for goal in goals]
    kept = {name: a.ctypes.data for name, a in net._work.items()}
    assert set(kept) >= {"costs", "pre", "field", "incoming", "dist"}
    assert not fresh._work
    for goal, field in zip(goals, fields, strict=True):
        assert np.array_equal(field, fresh.predict(obstacles, goal))  # and not overwritten by the later passes
    net.predict(obstacles, goals[0])
    assert {name: a.ctypes.data for name, a in net._work.items()} == kept  # reused, not made again
    net.predict(obstacles[:80], goals[0])  # another shape: buffers of that shape replace them
    assert net._work["field"].shape == (1, 80, 96) and set(net._work) == set(kept)
    assert not pickle.loads(pickle.dumps(net))._work
    net.release_buffers()
    assert not net._work
    net.predict(obstacles, goals[0])
    net.load_state_dict(net.state_dict())
    assert not net._work


@settings(max_examples=30, deadline=None)
@given(h=st.integers(1, 12), w=st.integers(1, 12), seed=st.integers(0, 2**16), dtype=st.sampled_from(["f4", "f8"]))
def test_the_search_gives_the_same_values_with_kept_working_arrays(h, w, seed, dtype):
    from planners.maps.gridsearch import move_cost_field

    rng = np.random.default_rng(seed)
    work: dict = {}
    for _ in range(3):  # three searches through the same arrays, whatever the last one left in them
        costs = rng.uniform(0.5, 4.0, (8, h, w)).astype(dtype)
        goal, walls = rng.random((h, w)) < 0.1, rng.random((h, w)) < 0.2
        gate = rng.random((8, h, w)) < 0.9
        want = move_cost_field(costs, goal, walls, 1e6, open_moves=gate, most=np.full(8, 3.5))
        got = move_cost_field(costs, goal, walls, 1e6, open_moves=gate, most=np.full(8, 3.5), work=work)
        assert np.array_equal(want, got) and got.dtype == costs.dtype
    assert work["incoming"].shape == (h * w, 8)
    assert work.get("dist", np.empty((h + 2) * (w + 2))).shape == ((h + 2) * (w + 2),)  # none where the heap ran


def test_the_cell_head_writes_into_the_array_given_and_refuses_one_that_does_not_fit():
    from learning.models.cell_head import cell_head_field

    rng = np.random.default_rng(3)
    v, pre = rng.random((5, 7)).astype(np.float32), rng.random((4, 5, 7)).astype(np.float32)
    weights = rng.random((4, 8)), rng.random((4, 4)), rng.random(4)
    out = np.full((10, 14), np.nan, dtype=np.float32)
    got = cell_head_field(v, pre, *weights, 2, 4.0, 1e6, out)
    assert got is out and np.array_equal(out, cell_head_field(v, pre, *weights, 2, 4.0, 1e6))
    for bad in (np.empty((10, 13), np.float32), np.empty((10, 14)), np.empty((14, 10), np.float32).T):
        with pytest.raises(ValueError, match="out must be a C-contiguous"):
            cell_head_field(v, pre, *weights, 2, 4.0, 1e6, bad)


@settings(max_examples=30, deadline=None)
@given(h=st.integers(1, 9), w=st.integers(1, 9), block=st.sampled_from([1, 2, 3]), channels=st.integers(1, 6),
       seed=st.integers(0, 2**16), unreached=st.floats(0.0, 0.5))
def test_the_cell_head_at_one_cell_is_the_whole_heads_value_there(h, w, block, channels, seed, unreached):
    from learning.models.cell_head import cell_head_at, cell_head_field

    rng = np.random.default_rng(seed)
    v = (rng.random((h, w)) * 20).astype(np.float32)
    v[rng.random((h, w)) < unreached] = 1e6  # blocks the goal does not reach, beside reached ones
    pre = rng.normal(size=(channels, h, w)).astype(np.float32)
    weights = rng.normal(size=(channels, 8)), rng.normal(size=(block * block, channels)), rng.normal(size=block * block)
    whole = cell_head_field(v, pre, *weights, block, 4.0, 1e6)
    for cell in np.ndindex(whole.shape):
        assert cell_head_at(v, pre, *weights, block, 4.0, 1e6, cell) == whole[cell]  # bit for bit
    with pytest.raises(ValueError, match="outside"):
        cell_head_at(v, pre, *weights, block, 4.0, 1e6, (h * block, 0))


def _two_calls(net: RouteVIN, obstacles, goal, start):
    """``FieldEncoder.predict_reaching``: ``predict``, and ``predict`` again inside ``open_walls`` where it shuts."""
    from learning.models.field import FieldEncoder

    return FieldEncoder.predict_reaching(net, obstacles, goal, start)


@settings(max_examples=40, deadline=None)
@given(h=st.integers(4, 36), w=st.integers(4, 36), density=st.sampled_from([0.0, 0.2, 0.35]),
       seed=st.integers(0, 2**16), queries=st.lists(st.tuples(*[st.floats(0, 1)] * 4), min_size=1, max_size=3),
       kept=st.sampled_from(["kept", "none", "strips"]), step_walls=st.booleans())
def test_one_pass_that_checks_the_start_gives_the_two_passes_field_and_answer(h, w, density, seed, queries, kept,
                                                                             step_walls):
    torch.manual_seed(seed)
    net = make_route_net("vin", block=2, channels=8, depth=2, step=2).eval()
    net.wall_cost, net.step_walls = 1.2, step_walls  # many moves priced as walls: starts shut and open both
    if kept == "none":
        net.map_cache_bytes = 0  # every pass whole, into the kept buffers
    elif kept == "strips":
        net.map_cache_bytes, net.strip_blocks = 0, 8  # and in strips of rows
    obstacles = np.random.default_rng(seed).random((h, w)) < density
    for gr, gc, sr, sc in queries:  # later queries on the same map read its kept parts (where kept)
        goal = (min(h - 1, int(gr * h)), min(w - 1, int(gc * w)))
        start = (min(h - 1, int(sr * h)), min(w - 1, int(sc * w)))
        obstacles[goal] = obstacles[start] = False
        for _ in range(2):  # the same query again: the same goal's parts
            field, opened = net.predict_reaching(obstacles, goal, start)
            net.clear_map_cache()
            expected, was_opened = _two_calls(net, obstacles, goal, start)
            assert opened == was_opened and np.array_equal(field, expected)
            assert opened == bool(net.predict(obstacles, goal)[start] >= 0.5 * net.unreached_steps)


def test_the_shipped_encoder_in_one_pass_opens_the_walls_where_two_passes_would():
    net = load_route_net(SHIPPED)
    p = generate("rooms", 9, 32)  # a generated map whose start the learned walls shut
    obstacles, goal, start = p.world.obstacles, p.world.cell_of(p.goal), p.world.cell_of(p.start)
    field, opened = net.predict_reaching(obstacles, goal, start)
    expected, was_opened = _two_calls(net, obstacles, goal, start)
    assert opened and was_opened and np.array_equal(field, expected) and field[start] < 1e3
    other = generate("rooms", 0, 32)
    field, opened = net.predict_reaching(other.world.obstacles, other.world.cell_of(other.goal),
                                         other.world.cell_of(other.start))
    assert not opened and np.array_equal(field, net.predict(other.world.obstacles, other.world.cell_of(other.goal)))
    with net.open_walls():  # without a learned wall rule there is nothing to open: the plain pass
        assert net.predict_reaching(obstacles, goal, start)[1] is False
    for bad, match in (((32, 0), r"\(32, 0\) is outside the 32 x 32 map"), ((0, -1), "outside"), ("a", "row, column")):
        with pytest.raises(InputError, match=match):
            net.predict_reaching(obstacles, goal, bad)
        with pytest.raises(InputError, match=match), net.open_walls():  # the two calls' path refuses it alike
            net.predict_reaching(obstacles, goal, bad)


def test_a_query_on_a_small_map_makes_no_torch_call_and_gives_the_torch_pass_field(monkeypatch):
    net = load_route_net(SHIPPED)
    p = generate("rooms", 9, 32)  # a map the learned walls shut the start of: every step of the one pass taken
    obstacles, goal, start = p.world.obstacles, p.world.cell_of(p.goal), p.world.cell_of(p.start)
    free = np.argwhere(~obstacles)
    queries = [(goal, start), (tuple(free[0]), start), (tuple(free[-1]), tuple(free[len(free) // 2]))]
    with torch.inference_mode():  # the fields the torch pass gives (kept parts and all), before torch is shut
        net.clear_map_cache()
        want = [_two_calls(net, obstacles, g, s) for g, s in queries]

    def no_torch(*args, **kwargs):
        raise AssertionError("a query on a small map called torch")

    net.clear_map_cache()
    for name in ("from_numpy", "inference_mode", "no_grad"):
        monkeypatch.setattr(torch, name, no_torch)
    got = [net.predict_reaching(obstacles, g, s) for g, s in queries]  # a first query, then later ones on its parts
    monkeypatch.undo()
    for (field, opened), (expected, was_opened) in zip(got, want, strict=True):
        assert opened == was_opened and np.array_equal(field, expected)
