"""Grid searches against brute force, hand-made cases and the MovingAI published optima."""

from __future__ import annotations

import heapq
import math
import time
from collections import deque

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from planners import OccupancyGrid, load_movingai_scenarios
from planners.maps.gridsearch import (
    block_steps,
    connected,
    distance_field,
    free_components,
    shortest_path,
    shortest_path_length,
)

STEPS = [(dr, dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if (dr, dc) != (0, 0)]


def legal_step(obs, r, c, dr, dc) -> bool:
    """The octile move rule, written out independently: in range, free, no corner cutting."""
    H, W = obs.shape
    rr, cc = r + dr, c + dc
    if not (0 <= rr < H and 0 <= cc < W) or obs[rr, cc]:
        return False
    return not (dr and dc and (obs[rr, c] or obs[r, cc]))


def brute_dijkstra(obs, goal):
    H, W = obs.shape
    dist = np.full((H, W), np.inf)
    dist[goal] = 0.0
    heap = [(0.0, goal)]
    while heap:
        d, (r, c) = heapq.heappop(heap)
        if d > dist[r, c]:
            continue
        for dr, dc in STEPS:
            if legal_step(obs, r, c, dr, dc):
                nd = d + (math.sqrt(2) if dr and dc else 1.0)
                if nd < dist[r + dr, c + dc]:
                    dist[r + dr, c + dc] = nd
                    heapq.heappush(heap, (nd, (r + dr, c + dc)))
    return dist


def brute_reachable(obs, a):
    """Cells 4-connected to ``a`` by breadth-first search."""
    seen = np.zeros(obs.shape, bool)
    seen[a] = True
    todo = deque([a])
    while todo:
        r, c = todo.popleft()
        for dr, dc in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            rr, cc = r + dr, c + dc
            if 0 <= rr < obs.shape[0] and 0 <= cc < obs.shape[1] and not obs[rr, cc] and not seen[rr, cc]:
                seen[rr, cc] = True
                todo.append((rr, cc))
    return seen


@given(seed=st.integers(0, 2**32 - 1), h=st.integers(1, 14), w=st.integers(1, 14), p=st.floats(0, 0.6))
def test_distance_field_and_components_match_brute_force(seed, h, w, p):
    rng = np.random.default_rng(seed)
    obs = rng.random((h, w)) < p
    free = np.argwhere(~obs)
    if len(free) == 0:
        with pytest.raises(ValueError, match="is blocked"):
            distance_field(obs, (0, 0))
        return
    goal = tuple(int(v) for v in free[rng.integers(len(free))])
    field = distance_field(obs, goal)
    expected = brute_dijkstra(obs, goal)
    assert field.shape == obs.shape and field.dtype == np.float64
    np.testing.assert_allclose(field, expected, rtol=1e-12)
    reach = brute_reachable(obs, goal)
    # octile moves without corner cutting reach exactly the 4-connected component
    assert np.array_equal(np.isfinite(field), reach)
    labels = free_components(obs)
    assert labels.dtype == np.int32 and np.array_equal(labels == -1, obs)
    assert np.array_equal(labels == labels[goal], reach)
    assert labels.max() + 1 == len(np.unique(labels[~obs]))
    other = tuple(int(v) for v in free[rng.integers(len(free))])
    assert connected(obs, goal, other) == bool(reach[other])


@given(seed=st.integers(0, 2**32 - 1), p=st.floats(0, 0.45))
def test_shortest_path_is_legal_and_optimal(seed, p):
    rng = np.random.default_rng(seed)
    obs = rng.random((16, 20)) < p
    free = np.argwhere(~obs)
    if len(free) < 2:
        return
    a, b = (tuple(int(v) for v in free[i]) for i in rng.choice(len(free), 2, replace=False))
    grid = OccupancyGrid(obs, resolution=0.5)
    start, goal = grid.cell_center(*a), grid.cell_center(*b)
    expected = brute_dijkstra(obs, b)[a] * 0.5
    assert shortest_path_length(grid, start, goal) == pytest.approx(expected, rel=1e-12)
    if not np.isfinite(expected):
        with pytest.raises(ValueError, match="not connected"):
            shortest_path(grid, start, goal)
        return
    path = shortest_path(grid, start, goal)
    assert path.shape[1] == 2 and np.array_equal(path[0], start) and np.array_equal(path[-1], goal)
    cells = [grid.cell_of(q) for q in path]
    for (r, c), (rr, cc) in zip(cells[:-1], cells[1:], strict=True):
        assert max(abs(rr - r), abs(cc - c)) == 1 and legal_step(obs, r, c, rr - r, cc - c)
    assert np.linalg.norm(np.diff(path, axis=0), axis=1).sum() == pytest.approx(expected, rel=1e-9)
    assert grid.path_valid(path)  # octile steps without corner cutting are valid continuous motions


def test_corner_cutting_is_not_allowed():
    # two diagonally touching obstacles: no way through, although corner cutting would give sqrt(2)
    obs = np.array([[False, True], [True, False]])
    assert distance_field(obs, (0, 0))[1, 1] == math.inf
    assert not connected(obs, (0, 0), (1, 1))
    # one obstacle beside the diagonal forces the long way round: 2, not sqrt(2)
    obs = np.array([[False, True], [False, False]])
    assert distance_field(obs, (0, 0))[1, 1] == 2.0
    field = distance_field(np.zeros((3, 4), bool), (0, 0))
    assert field[2, 3] == pytest.approx(2 * math.sqrt(2) + 1)


def test_world_units_and_start_point_inside_a_cell():
    obs = np.zeros((4, 10), bool)
    obs[0:3, 5] = True
    grid = OccupancyGrid(obs, resolution=2.0)
    # points anywhere in a cell count as that cell. From (0, 0) to (0, 9) round the wall: 3 diagonal
    # steps and 1 straight to (3, 4), two straight steps past the wall's end, 3 diagonal steps up
    L = shortest_path_length(grid, (0.3, 1.9), (19.9, 0.1))
    assert L == pytest.approx(2.0 * (6 * math.sqrt(2) + 3))
    assert L == pytest.approx(2.0 * distance_field(obs, (0, 9))[0, 0])
    path = shortest_path(grid, (0.3, 1.9), (19.9, 0.1))
    assert np.array_equal(path[0], [1.0, 1.0]) and np.array_equal(path[-1], [19.0, 1.0])


def test_disconnected_cells():
    obs = np.zeros((5, 5), bool)
    obs[:, 2] = True
    assert not connected(obs, (0, 0), (0, 4)) and connected(obs, (0, 0), (4, 1))
    labels = free_components(obs)
    assert labels[0, 0] == 0 and labels[0, 4] == 1 and (labels[:, 2] == -1).all()
    grid = OccupancyGrid(obs)
    assert shortest_path_length(grid, (0.5, 0.5), (4.5, 0.5)) == math.inf
    with pytest.raises(ValueError, match=r"start cell \(0, 0\) and goal cell \(0, 4\) are not connected"):
        shortest_path(grid, (0.5, 0.5), (4.5, 0.5))


@pytest.mark.parametrize(
    "obstacles, cell, match",
    [
        (np.zeros((5, 5), bool), (9, 0), r"goal cell \(9, 0\) lies outside the 5x5 grid"),
        (np.zeros((5, 5), bool), (0, -1), r"goal cell \(0, -1\) lies outside"),
        (np.eye(5, dtype=bool), (2, 2), r"goal cell \(2, 2\) is blocked"),
        (np.zeros((5, 5), bool), (1.5, 2), r"goal cell must be a \(row, col\) pair of integers, got \(1.5, 2\)"),
        (np.zeros((5, 5), bool), (1, 2, 3), r"got \(1, 2, 3\)"),
        (np.zeros((5, 5), np.uint8), (0, 0), "must be a bool array .* got dtype uint8"),
        (np.zeros(5, bool), (0, 0), r"2-D .* got shape \(5,\)"),
        (np.zeros((0, 4), bool), (0, 0), r"got shape \(0, 4\)"),
    ],
)
def test_distance_field_rejects_bad_input(obstacles, cell, match):
    with pytest.raises(ValueError, match=match):
        distance_field(obstacles, cell)


def test_other_functions_reject_bad_input():
    obs = np.zeros((4, 4), bool)
    obs[1, 1] = True
    with pytest.raises(ValueError, match=r"b cell \(1, 1\) is blocked"):
        connected(obs, (0, 0), (1, 1))
    with pytest.raises(ValueError, match="got dtype int64"):
        free_components(obs.astype(np.int64))
    grid = OccupancyGrid(obs)
    with pytest.raises(ValueError, match=r"start \(1.5, 1.5\) lies in blocked cell \(1, 1\)"):
        shortest_path_length(grid, (1.5, 1.5), (3.5, 3.5))
    with pytest.raises(ValueError, match=r"goal \(9.0, 0.5\) lies outside the 4x4 grid"):
        shortest_path(grid, (0.5, 0.5), (9.0, 0.5))
    with pytest.raises(TypeError, match="OccupancyGrid"):
        shortest_path_length(obs, (0.5, 0.5), (3.5, 3.5))


def test_full_map_dijkstra_at_512_is_fast():
    rng = np.random.default_rng(1)
    obs = rng.random((512, 512)) < 0.2
    obs[0, 0] = False
    distance_field(obs, (0, 0))  # compile, or load the cache
    best = math.inf
    for _ in range(3):
        t = time.perf_counter()
        distance_field(obs, (0, 0))
        best = min(best, time.perf_counter() - t)
    assert best < 0.5, f"512x512 distance field took {best:.3f} s"


def test_matches_movingai_published_optima(movingai):
    scens = sorted(movingai.glob("*.scen"))
    assert scens, f"no scenario files in {movingai}"
    rng = np.random.default_rng(0)
    mismatches, checked = [], 0
    for scen in scens:
        problems = list(load_movingai_scenarios(scen))
        lengths = np.array([p.reference_length for p in problems])
        # a random sample plus the shortest and the longest problem of every map
        picks = set(rng.choice(len(problems), min(8, len(problems)), replace=False).tolist())
        picks |= {int(lengths.argmin()), int(lengths.argmax())}
        for i in sorted(picks):
            p = problems[i]
            L = shortest_path_length(p.world, p.start, p.goal)
            checked += 1
            if L != pytest.approx(p.reference_length, rel=1e-5, abs=0.01):
                mismatches.append(f"{p.name}: computed {L:.6f}, published {p.reference_length}")
    assert not mismatches, "\n".join(mismatches)
    assert checked >= 10 * len(scens)


def test_move_cost_field_on_move_lengths_is_the_octile_distance_and_refuses_bad_shapes():
    from planners.maps.gridsearch import MOVES, move_cost_field

    lengths = np.array([np.hypot(dr, dc) for dr, dc in MOVES]).reshape(8, 1, 1) * np.ones((8, 5, 7))
    goal = np.zeros((5, 7), dtype=bool)
    goal[2, 3] = True
    walls = np.zeros((5, 7), dtype=bool)
    v = move_cost_field(lengths, goal, walls, 1e6)
    rows, cols = np.mgrid[0:5, 0:7]
    dr, dc = np.abs(rows - 2), np.abs(cols - 3)
    assert np.allclose(v, np.maximum(dr, dc) + (np.sqrt(2) - 1) * np.minimum(dr, dc))
    walls[:, 5] = True  # a wall column: what lies beyond it is unreached
    v = move_cost_field(lengths, goal, walls, 1e6)
    assert (v[:, 5:] == 1e6).all() and (v[:, :5] < 1e6).all()
    with pytest.raises(ValueError, match="8, h, w"):
        move_cost_field(lengths[:4], goal, walls, 1e6)
    with pytest.raises(ValueError, match="grid shape"):
        move_cost_field(lengths, goal[:4], walls, 1e6)
    with pytest.raises(ValueError, match="float32 or float64"):
        move_cost_field(lengths.astype(np.int64), goal, walls, 1e6)


@given(seed=st.integers(0, 10_000), rows=st.integers(1, 12), cols=st.integers(1, 12), block=st.sampled_from([1, 2, 3]),
       density=st.floats(0.0, 0.7))
def test_block_steps_look_up_what_the_cell_pairs_give(seed, rows, cols, block, density):
    """The window table's moves are the moves each block's cell pairs allow, on any map (blocks past the table's size
    test their pairs either way)."""
    free = np.random.default_rng(seed).random((rows * block, cols * block)) >= density
    assert np.array_equal(block_steps(free, block), block_steps(free, block, lookup=False))
