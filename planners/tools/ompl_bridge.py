"""Run OMPL's C++ planners on SamplerGym grid problems, for side-by-side benchmarks.

Optional: needs ``pip install ompl`` (the ``bench`` extra); nothing else in ``planners`` imports this
module. OMPL drives a Python validity checker (the cheapest possible one: a list-of-lists lookup of
the cell containing the point, blocked outside the grid) and checks motions by sampling states
every half cell (``setStateValidityCheckingResolution``), which OMPL's default of 1% of the map
extent would exceed on any map wider than 50 cells. Iterations are counted exactly through the
planner termination condition, which OMPL's planners query once per iteration.

Maps with an origin (ROS ``map.yaml``) plan in their world frame: states, bounds and the returned
path are world coordinates, as everywhere in SamplerGym (``tests/test_ompl_bridge.py``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from planners.base.problem import Problem
from planners.worlds.grid import OccupancyGrid

#: OMPL's PRM is left out: it grows its roadmap in a second thread that calls the Python validity
#: checker while ``solve`` holds the GIL, which deadlocks.
OMPL_PLANNERS = ("RRT", "RRTConnect", "RRTstar")


def available() -> bool:
    """True if OMPL's Python bindings import."""
    try:
        import ompl.geometric  # noqa: F401
    except ImportError:
        return False
    return True


def _require():
    try:
        from ompl import base as ob
        from ompl import geometric as og
        from ompl import util as ou
    except ImportError as exc:
        raise ImportError("OMPL is not installed: pip install -c constraints.txt -e '.[bench]'") from exc
    ou.setLogLevel(ou.LogLevel.LOG_ERROR)
    return ob, og, ou


@dataclass
class OmplRun:
    """One OMPL planning run."""

    solved: bool
    iterations: int
    time: float
    cost: float
    num_vertices: int
    path: np.ndarray  # (n, 2) world points of OMPL's solution, start first; (0, 2) if unsolved


class OmplGridPlanner:
    """One OMPL planner on a 2-D occupancy-grid ``Problem``.

    Args:
        problem: Must be on an ``OccupancyGrid`` with the euclidean metric.
        planner: One of ``OMPL_PLANNERS``.
        step_size: OMPL's ``range``.
        goal_bias: OMPL's goal bias (RRT, RRT*).
        seed: OMPL's global RNG seed, set before the planner is built.
        goal: Override the goal state (e.g. an unreachable one for growth timing).
    """

    def __init__(self, problem: Problem, planner: str = "RRT", *, step_size: float = 4.0, goal_bias: float = 0.05,
                 seed: int = 0, goal: np.ndarray | None = None) -> None:
        ob, og, ou = _require()
        grid = problem.world
        if not isinstance(grid, OccupancyGrid):
            raise TypeError("the OMPL bridge handles OccupancyGrid problems only")
        if planner not in OMPL_PLANNERS:
            raise ValueError(f"planner must be one of {OMPL_PLANNERS}, got {planner!r}")
        # OMPL logs an error on every reseed after its first RNG exists, yet the planner built next
        # does draw from the new seed (the same seed gives the same run, tested), so it is silenced
        ou.setLogLevel(ou.LogLevel.LOG_NONE)
        ou.RNG.setSeed(int(seed) + 1)  # OMPL rejects seed 0
        ou.setLogLevel(ou.LogLevel.LOG_ERROR)
        H, W = grid.shape
        res = grid.resolution
        blocked = grid.obstacles.tolist()
        inv = 1.0 / res
        ox, oy = (float(v) for v in grid.origin)
        (xlo, ylo), (xhi, yhi) = grid.bounds

        def valid(state) -> bool:
            c = math.floor((state[0] - ox) * inv)
            r = math.floor((state[1] - oy) * inv)
            return 0 <= r < H and 0 <= c < W and not blocked[r][c]

        space = ob.RealVectorStateSpace(2)
        bounds = ob.RealVectorBounds(2)
        bounds.setLow(0, float(xlo))
        bounds.setHigh(0, float(xhi))
        bounds.setLow(1, float(ylo))
        bounds.setHigh(1, float(yhi))
        space.setBounds(bounds)
        si = ob.SpaceInformation(space)
        si.setStateValidityChecker(valid)
        si.setStateValidityCheckingResolution(0.5 * res / space.getMaximumExtent())
        si.setup()
        pdef = ob.ProblemDefinition(si)
        s = space.allocState()
        g = space.allocState()
        goal = problem.goal if goal is None else goal
        for i in range(2):
            s[i] = float(problem.start[i])
            g[i] = float(goal[i])
        pdef.setStartAndGoalStates(s, g, problem.goal_tolerance)
        p = getattr(og, planner)(si)
        p.setRange(step_size)
        if planner in ("RRT", "RRTstar"):
            p.setGoalBias(goal_bias)
        p.setProblemDefinition(pdef)
        p.setup()
        self._ob, self._si, self._pdef, self._planner = ob, si, pdef, p
        # keep Python objects OMPL refers to alive as long as the planner
        self._keep = (valid, space, bounds, s, g)
        self.iterations = 0

    def run(self, max_iterations: int) -> OmplRun:
        """Run until solved (RRT*: until the budget is spent) or ``max_iterations`` more iterations."""
        ob = self._ob
        limit = self.iterations + int(max_iterations)

        def stop() -> bool:
            self.iterations += 1
            return self.iterations > limit

        ptc = ob.PlannerTerminationCondition(stop)
        t0 = time.perf_counter()
        status = self._planner.solve(ptc)
        dt = time.perf_counter() - t0
        self.iterations = min(self.iterations, limit)
        solved = bool(self._pdef.hasExactSolution()) and str(status) == "Exact solution"
        cost, path = float("inf"), np.empty((0, 2))
        if solved:
            solution = self._pdef.getSolutionPath()
            cost = float(solution.length())
            path = np.array([(st[0], st[1]) for st in solution.getStates()], dtype=np.float64)
        data = ob.PlannerData(self._si)
        self._planner.getPlannerData(data)
        return OmplRun(solved, self.iterations, dt, cost, int(data.numVertices()), path)
