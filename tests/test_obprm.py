"""OB-PRM: samples hug obstacles (checked independently), are free and counted; paths are valid."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import fine_check_path

from planners import PRM, Circle, GeometricWorld, OccupancyGrid, Problem, Rectangle
from planners.algorithms.obprm import OBPRM, ObstacleBasedSampler, compare_prm_variants, wall_with_gap


def _grid_clearance(grid: OccupancyGrid, pts: np.ndarray) -> np.ndarray:
    """Euclidean distance of each point to the nearest closed blocked cell or the map edge (numpy only)."""
    rows, cols = np.nonzero(grid.obstacles)
    x, y = pts[:, :1], pts[:, 1:2]
    dx = np.maximum(np.maximum(cols[None, :] - x, 0.0), x - (cols[None, :] + 1))
    dy = np.maximum(np.maximum(rows[None, :] - y, 0.0), y - (rows[None, :] + 1))
    cells = np.hypot(dx, dy).min(axis=1) if len(rows) else np.full(len(pts), np.inf)
    H, W = grid.shape
    edge = np.minimum.reduce([pts[:, 0], pts[:, 1], W - pts[:, 0], H - pts[:, 1]])
    return np.minimum(cells, edge)


def _shapes_clearance(world: GeometricWorld, pts: np.ndarray) -> np.ndarray:
    d = np.minimum.reduce([pts[:, 0], pts[:, 1], world.width - pts[:, 0], world.height - pts[:, 1]])
    for ob in world.obstacles:
        if isinstance(ob, Circle):
            d = np.minimum(d, np.maximum(np.hypot(pts[:, 0] - ob.x, pts[:, 1] - ob.y) - ob.r, 0.0))
        else:
            dx = np.maximum(np.maximum(ob.x0 - pts[:, 0], 0.0), pts[:, 0] - ob.x1)
            dy = np.maximum(np.maximum(ob.y0 - pts[:, 1], 0.0), pts[:, 1] - ob.y1)
            d = np.minimum(d, np.hypot(dx, dy))
    return d


@pytest.fixture(scope="module")
def gap_problem() -> Problem:
    return wall_with_gap(2, 64, seed=3)


def _draw(problem, sampler, n=400, seed=0):
    bound = sampler.bind(problem)
    batch = bound.draw(np.random.default_rng(seed), n, None)
    return bound, batch


@pytest.mark.parametrize("max_distance, walk_step", [(None, None), (0.25, None), (0.3, 2.0), (1.5, 1.5)])
def test_grid_samples_lie_near_obstacles_and_are_free(gap_problem, max_distance, walk_step):
    grid = gap_problem.world
    bound, batch = _draw(gap_problem, ObstacleBasedSampler(max_distance, uniform_fraction=0.0, walk_step=walk_step))
    pts = batch.points
    assert pts.shape == (400, 2)
    limit = grid.resolution if max_distance is None else max_distance
    assert bound.distance == pytest.approx(limit)
    clearance = _grid_clearance(grid, pts)
    assert np.all(clearance <= limit + 1e-9), clearance.max()
    assert np.all(clearance > 0)  # free: not touching any closed blocked cell
    assert all(fine_check_path(grid, p[None, :]) for p in pts[:100])
    assert all(grid.is_valid(p) for p in pts)


def test_shape_world_samples_lie_near_obstacles():
    world = GeometricWorld(100, 60, [Circle(30, 30, 8), Rectangle(60, 10, 70, 50), Circle(85, 15, 4)])
    problem = Problem(world, (5, 5), (95, 55))
    bound, batch = _draw(problem, ObstacleBasedSampler(0.5, uniform_fraction=0.0))
    d = _shapes_clearance(world, batch.points)
    assert np.all(d <= 0.5 + 1e-9) and np.all(d > 0)
    assert all(fine_check_path(world, p[None, :]) for p in batch.points[:100])


def test_candidates_count_every_attempt(gap_problem):
    bound, batch = _draw(gap_problem, ObstacleBasedSampler(uniform_fraction=0.0))
    # free candidates are discarded, so on a mostly free map each sample costs several attempts
    assert batch.candidates.min() >= 1
    assert batch.candidates.sum() > 2 * len(batch.points)
    assert bound.checks >= batch.candidates.sum()  # one check per discarded or kept candidate at least
    _, uni = _draw(gap_problem, ObstacleBasedSampler(uniform_fraction=1.0))
    assert np.all(uni.candidates == 1)
    lo, hi = gap_problem.world.bounds
    assert np.all((uni.points >= lo) & (uni.points < hi))


def test_uniform_fraction_mixes(gap_problem):
    _, batch = _draw(gap_problem, ObstacleBasedSampler(uniform_fraction=0.5), n=1000)
    far = _grid_clearance(gap_problem.world, batch.points) > 1.0
    # uniform samples far from obstacles (or inside them) exist, but only about half the samples are uniform
    assert 0.3 < far.mean() < 0.7


def test_sampler_is_seeded(gap_problem):
    a = _draw(gap_problem, ObstacleBasedSampler(), seed=7)[1]
    b = _draw(gap_problem, ObstacleBasedSampler(), seed=7)[1]
    c = _draw(gap_problem, ObstacleBasedSampler(), seed=8)[1]
    np.testing.assert_array_equal(a.points, b.points)
    np.testing.assert_array_equal(a.candidates, b.candidates)
    assert not np.array_equal(a.points, c.points)


def test_world_without_obstacles_falls_back_to_uniform():
    problem = Problem(GeometricWorld(10, 10), (1, 1), (9, 9))
    bound, batch = _draw(problem, ObstacleBasedSampler(uniform_fraction=0.0), n=8)
    assert batch.points.shape == (1, 2)
    assert batch.candidates[0] == 8 * 1000 + 1


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("gap", [1, 3])
def test_obprm_paths_are_valid(gap, seed):
    problem = wall_with_gap(gap, 64, seed=seed)
    r = OBPRM(problem, seed=seed).solve(max_iterations=5000)
    assert r.solved
    assert fine_check_path(problem.world, r.path, spacing=0.05)
    np.testing.assert_array_equal(r.path[0], problem.start)
    np.testing.assert_array_equal(r.path[-1], problem.goal)
    assert r.candidates >= r.iterations


def test_obprm_is_deterministic_and_counts_sampler_checks(gap_problem):
    r1 = OBPRM(gap_problem, seed=5).solve(max_iterations=3000)
    planner = OBPRM(gap_problem, seed=5)
    r2 = planner.solve(max_iterations=3000)
    for field in ("iterations", "candidates", "collision_checks", "num_vertices"):
        assert getattr(r1, field) == getattr(r2, field)
    np.testing.assert_array_equal(r1.path, r2.path)
    roadmap_checks = super(OBPRM, planner).collision_checks
    assert planner.collision_checks == roadmap_checks + planner.sampler.checks
    assert planner.sampler.checks > 0
    before = planner.collision_checks
    planner.query(gap_problem.goal, gap_problem.start, max_iterations=500)
    assert planner.collision_checks >= before  # the earlier sampler's checks stay counted
    planner.clear()
    assert planner.collision_checks == super(OBPRM, planner).collision_checks  # the sampler's count restarts


def test_obprm_beats_prm_on_a_one_cell_gap():
    problems = [wall_with_gap(1, 64, seed=s) for s in range(6)]
    ob = [OBPRM(p, seed=i).solve(max_iterations=4000) for i, p in enumerate(problems)]
    prm = [PRM(p, seed=i).solve(max_iterations=4000) for i, p in enumerate(problems)]
    assert all(r.solved for r in ob)
    assert np.median([r.iterations for r in ob]) < np.median([r.iterations for r in prm])


def test_argument_checks(gap_problem):
    with pytest.raises(ValueError, match="max_distance"):
        ObstacleBasedSampler(0)
    with pytest.raises(ValueError, match="uniform_fraction"):
        ObstacleBasedSampler(uniform_fraction=1.5)
    with pytest.raises(ValueError, match="walk_step"):
        ObstacleBasedSampler(walk_step=float("nan"))
    with pytest.raises(ValueError, match="either sampler"):
        OBPRM(gap_problem, max_distance=1.0, sampler=ObstacleBasedSampler())
    with pytest.raises(ValueError, match="gap"):
        wall_with_gap(0)


def test_compare_prm_variants_rows():
    maps = {"gap2": [wall_with_gap(2, 48, seed=0)], "forest": [wall_with_gap(6, 48, seed=1)]}
    rows, runs = compare_prm_variants(maps, max_iterations=500)
    assert [(r["map"], r["planner"]) for r in rows] == [(m, p) for m in maps for p in ("PRM", "LazyPRM", "OBPRM")]
    assert len(runs) == 6
    for r in rows:
        assert 0.0 <= r["success"] <= 1.0 and r["median_samples"] <= 500 and r["median_time_s"] >= 0
    ob = [r for r in runs if r["planner"] == "OBPRM"]
    assert all(r["candidates"] >= r["samples"] for r in ob)
