"""The OMPL bridge (optional ``bench`` extra): world frame, seeds, paths. Skipped without OMPL."""

from __future__ import annotations

import numpy as np
import pytest

from planners import GeometricWorld, OccupancyGrid, Problem
from planners.tools import ompl_bridge

pytestmark = pytest.mark.skipif(not ompl_bridge.available(),
                                reason="OMPL's Python bindings are not installed: pip install -c constraints.txt "
                                       "-e '.[bench]' to run these")


def _wall_with_gap(origin=(0.0, 0.0), resolution: float = 0.5) -> Problem:
    obs = np.zeros((40, 60), bool)
    obs[:, 30:32] = True
    obs[18:22, 30:32] = False
    grid = OccupancyGrid(obs, resolution, origin=origin)
    o = np.asarray(origin, dtype=float)
    return Problem(grid, o + [2.0, 2.0], o + [28.0, 18.0], goal_tolerance=1.0)


def _run(problem: Problem, seed: int, planner: str = "RRT") -> ompl_bridge.OmplRun:
    return ompl_bridge.OmplGridPlanner(problem, planner, step_size=2.0, goal_bias=0.0, seed=seed).run(20_000)


@pytest.mark.parametrize("planner", ompl_bridge.OMPL_PLANNERS)
def test_a_map_with_an_origin_plans_in_its_world_frame(planner):
    # a ROS map's origin puts the start at negative x: read in the grid's own frame it would lie outside
    origin = (-20.0, 7.5)
    shifted, plain = _wall_with_gap(origin), _wall_with_gap()
    a, b = _run(shifted, 4, planner), _run(plain, 4, planner)
    assert a.solved and b.solved
    assert np.allclose(a.path[0], shifted.start) and np.linalg.norm(a.path[-1] - shifted.goal) <= 1.0
    assert all(shifted.world.is_valid(q) for q in a.path)
    # the same seed on the same map, moved: the same run, moved (up to rounding of the shift)
    assert a.iterations == b.iterations and a.num_vertices == b.num_vertices
    assert np.allclose(a.path - np.asarray(origin), b.path, atol=1e-9)


def test_the_same_seed_gives_the_same_run_however_many_ran_before():
    problem = _wall_with_gap()
    first, other, again = _run(problem, 3), _run(problem, 5), _run(problem, 3)
    assert (first.iterations, first.cost) == (again.iterations, again.cost)
    assert np.array_equal(first.path, again.path)
    assert (other.iterations, other.cost) != (first.iterations, first.cost)


def test_an_unsolved_run_has_no_path_and_infinite_cost():
    problem = _wall_with_gap()
    r = ompl_bridge.OmplGridPlanner(problem, "RRT", step_size=2.0, seed=0).run(3)
    assert not r.solved and r.cost == float("inf") and r.path.shape == (0, 2) and r.iterations == 3


def test_the_bridge_refuses_other_worlds_and_planners_by_name():
    with pytest.raises(TypeError, match="OccupancyGrid"):
        ompl_bridge.OmplGridPlanner(Problem(GeometricWorld(10, 10, []), [1, 1], [9, 9]), "RRT")
    with pytest.raises(ValueError, match="PRM"):
        ompl_bridge.OmplGridPlanner(_wall_with_gap(), "PRM")
