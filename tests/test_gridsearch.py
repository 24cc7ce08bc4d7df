"""Grid searches against a brute-force Dijkstra and the MovingAI published optima."""

from __future__ import annotations

import heapq
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from planners import OccupancyGrid, load_movingai_scenarios
from planners.gridsearch import connected, distance_field, free_components, shortest_path, shortest_path_length


def brute_dijkstra(obs, goal):
    H, W = obs.shape
    dist = np.full((H, W), np.inf)
    dist[goal] = 0.0
    heap = [(0.0, goal)]
    while heap:
        d, (r, c) = heapq.heappop(heap)
        if d > dist[r, c]:
            continue
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                rr, cc = r + dr, c + dc
                if (dr, dc) == (0, 0) or not (0 <= rr < H and 0 <= cc < W) or obs[rr, cc]:
                    continue
                if dr and dc and (obs[r + dr, c] or obs[r, c + dc]):
                    continue
                nd = d + (math.sqrt(2) if dr and dc else 1.0)
                if nd < dist[rr, cc]:
                    dist[rr, cc] = nd
                    heapq.heappush(heap, (nd, (rr, cc)))
    return dist


@given(seed=st.integers(0, 10**6), h=st.integers(1, 12), w=st.integers(1, 12), p=st.floats(0, 0.5))
def test_distance_field_matches_brute_force(seed, h, w, p):
    rng = np.random.default_rng(seed)
    obs = rng.random((h, w)) < p
    free = np.argwhere(~obs)
    if len(free) == 0:
        return
    goal = tuple(free[rng.integers(len(free))])
    assert np.allclose(distance_field(obs, goal), brute_dijkstra(obs, goal))
    lab = free_components(obs)
    reach = np.isfinite(brute_dijkstra(obs, goal))
    assert np.array_equal(lab == lab[goal], reach)


def test_shortest_path_is_valid_and_optimal():
    rng = np.random.default_rng(0)
    g = OccupancyGrid(rng.random((40, 40)) < 0.25)
    free = np.argwhere(~g.obstacles)
    field = distance_field(g.obstacles, tuple(free[0]))
    ends = free[np.isfinite(field[free[:, 0], free[:, 1]])]
    a, b = g.cell_center(*ends[0]), g.cell_center(*ends[-1])
    path = shortest_path(g, a, b)
    assert np.array_equal(path[0], a) and np.array_equal(path[-1], b)
    assert sum(np.linalg.norm(np.diff(path, axis=0), axis=1)) == pytest.approx(shortest_path_length(g, a, b))
    assert g.path_valid(path)  # octile steps without corner cutting are valid continuous motions


def test_errors_and_connectivity():
    obs = np.zeros((5, 5), bool)
    obs[:, 2] = True
    assert not connected(obs, (0, 0), (0, 4)) and connected(obs, (0, 0), (4, 1))
    with pytest.raises(ValueError, match=r"goal cell \(0, 2\) is blocked"):
        distance_field(obs, (0, 2))
    with pytest.raises(ValueError, match="outside the 5x5 grid"):
        distance_field(obs, (9, 0))
    g = OccupancyGrid(obs)
    assert shortest_path_length(g, (0.5, 0.5), (4.5, 0.5)) == math.inf
    with pytest.raises(ValueError, match="not connected"):
        shortest_path(g, (0.5, 0.5), (4.5, 0.5))


def test_matches_movingai_published_optima(movingai):
    checked = 0
    for scen in sorted(movingai.glob("*.scen")):
        problems = list(load_movingai_scenarios(scen))
        rng = np.random.default_rng(0)
        picks = list(rng.choice(len(problems), 5, replace=False)) + [int(np.argmax([p.reference_length for p in problems]))]
        for i in picks:
            p = problems[i]
            L = shortest_path_length(p.world, p.start, p.goal)
            assert L == pytest.approx(p.reference_length, rel=1e-5, abs=0.01), p.name
            checked += 1
    assert checked >= 12 * 6
