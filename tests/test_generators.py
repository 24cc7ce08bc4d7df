"""Generated map families: determinism, valid connected far-apart queries, family structure."""

from __future__ import annotations

import numpy as np
import pytest

from planners.generators import FAMILIES, generate
from planners.gridsearch import distance_field, free_components, shortest_path_length


@pytest.mark.parametrize("family", FAMILIES)
def test_same_seed_same_problem_and_seeds_differ(family):
    a, b, c = generate(family, 7), generate(family, 7), generate(family, 8)
    assert np.array_equal(a.world.obstacles, b.world.obstacles)
    assert np.array_equal(a.start, b.start) and np.array_equal(a.goal, b.goal)
    assert not (np.array_equal(a.world.obstacles, c.world.obstacles) and np.array_equal(a.start, c.start))
    assert a.name == f"{family}-128-7"


@pytest.mark.parametrize("size, seeds", [(64, range(10)), (128, range(30)), (256, range(3))])
@pytest.mark.parametrize("family", FAMILIES)
def test_queries_are_free_connected_and_far_apart(family, size, seeds):
    for seed in seeds:
        p = generate(family, seed, size)
        g = p.world
        assert g.shape == (size, size)
        assert g.is_valid(p.start) and g.is_valid(p.goal)
        L = shortest_path_length(g, p.start, p.goal)
        assert np.isfinite(L) and L >= 0.5 * size
        assert p.reference_length == pytest.approx(L)
        assert np.linalg.norm(p.start - p.goal) > p.goal_tolerance
        lab = free_components(g.obstacles)
        assert lab[g.cell_of(p.start)] == lab[g.cell_of(p.goal)]


@pytest.mark.parametrize("seed", range(20))
def test_bugtrap_start_is_trapped_behind_the_back_wall(seed):
    p = generate("bugtrap", seed)
    # greed towards the goal is blocked and the way out is much longer than the straight line
    assert not p.world.check_motion(p.start, p.goal)
    assert p.reference_length > 1.4 * np.linalg.norm(p.goal - p.start)


@pytest.mark.parametrize("seed", range(20))
def test_narrow_passage_has_exactly_one_gap(seed):
    p = generate("narrow_passage", seed)
    obs = p.world.obstacles
    # the wall is the only full-length line of obstacles except for one gap
    for axis in (0, 1):
        cover = obs.mean(axis=axis)
        lines = np.flatnonzero(cover > 0.9)
        if len(lines):
            break
    assert len(lines) >= 2, "no wall found"
    wall = obs[:, lines] if axis == 0 else obs[lines, :].T
    open_rows = np.flatnonzero(~wall.any(axis=1))
    assert 2 <= len(open_rows) <= 3 and np.all(np.diff(open_rows) == 1)  # one gap of 2-3 cells
    closed = obs.copy()
    if axis == 0:
        closed[np.ix_(open_rows, lines)] = True
    else:
        closed[np.ix_(lines, open_rows)] = True
    lab = free_components(closed)
    assert lab[p.world.cell_of(p.start)] != lab[p.world.cell_of(p.goal)]


def test_maze_is_a_perfect_maze():
    p = generate("maze", 3, 64)
    field = distance_field(p.world.obstacles, p.world.cell_of(p.goal))
    free = ~p.world.obstacles
    assert np.isfinite(field[free]).all()  # every corridor is reachable


@pytest.mark.parametrize("bad, match", [(dict(family="lava"), "unknown map family 'lava'"),
                                        (dict(size=16), "size must be an integer >= 32"),
                                        (dict(size=64.0), "size")])
def test_bad_arguments(bad, match):
    args = dict(family="forest", seed=0, size=64) | bad
    with pytest.raises(ValueError, match=match):
        generate(**args)
