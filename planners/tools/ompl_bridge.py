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
    #: OMPL's solution, start first: (n, 2) world points on a grid, (n, 6) states of a rigid body; no rows if unsolved
    path: np.ndarray


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


def _axis_angle(R: np.ndarray) -> tuple[float, float, float, float]:
    """``(ax, ay, az, theta)`` of a rotation matrix (axis x for the identity)."""
    c = max(-1.0, min(1.0, (float(np.trace(R)) - 1.0) / 2.0))
    theta = math.acos(c)
    if theta < 1e-12:
        return 1.0, 0.0, 0.0, 0.0
    if math.pi - theta < 1e-6:  # a half turn: the axis from the symmetric part
        B = (R + np.eye(3)) / 2.0
        axis = np.sqrt(np.maximum(np.diag(B), 0.0))
        k = int(np.argmax(axis))
        for j in range(3):
            if j != k and B[k, j] < 0:
                axis[j] = -axis[j]
        return float(axis[0]), float(axis[1]), float(axis[2]), theta
    axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / (2.0 * math.sin(theta))
    return float(axis[0]), float(axis[1]), float(axis[2]), theta


#: OMPL's planners that ``ompl_rigid`` runs on mesh problems.
OMPL_RIGID_PLANNERS = ("RRTConnect", "RRT")


def ompl_rigid(problem: Problem, planner: str = "RRTConnect", *, seed: int = 0, time_limit: float = 10.0,
               goal_bias: float = 0.05) -> OmplRun:
    """OMPL's RRT-Connect or RRT on a ``MeshWorld`` problem, as OMPL.app sets it up, with our state check.

    The state space is OMPL's SE(3) (quaternions) over the world's bounds; a state is valid as
    ``MeshWorld.is_valid`` says (the world's exact contact test, one Python call per state); motions are checked
    by OMPL's default discrete validator, every 1% of the space's extent with no clearance asked, as in
    OMPL.app (a motion may pass through an obstacle thinner than that), and the range is OMPL's default.
    RRT samples the goal with probability ``goal_bias`` (OMPL's default 0.05). Iterations are counted
    through the termination condition, which OMPL's planners query once per iteration. Returns the
    run; ``path`` holds the solution's states as ``(x, y, z, tx, ty, tz)`` (our angles; OMPL interpolates them as
    quaternions, so a motion between two of them is OMPL's, not ours).
    """
    from planners.worlds.mesh import MeshWorld
    from planners.worlds.omplapp import quaternion_matrix
    from planners.worlds.rigid3d import euler_from_matrix, rotation_matrix

    ob, og, ou = _require()
    world = problem.world
    if not isinstance(world, MeshWorld):
        raise TypeError("ompl_rigid handles MeshWorld problems only")
    if planner not in OMPL_RIGID_PLANNERS:
        raise ValueError(f"planner must be one of {OMPL_RIGID_PLANNERS}, got {planner!r}")
    ou.setLogLevel(ou.LogLevel.LOG_NONE)
    ou.RNG.setSeed(int(seed) + 1)  # OMPL rejects seed 0
    ou.setLogLevel(ou.LogLevel.LOG_ERROR)
    space = ob.SE3StateSpace()
    bounds = ob.RealVectorBounds(3)
    for i in range(3):
        bounds.setLow(i, float(world.low3[i]))
        bounds.setHigh(i, float(world.high3[i]))
    space.setBounds(bounds)

    def valid(state) -> bool:
        r = state.rotation()
        angles = euler_from_matrix(quaternion_matrix(r.x, r.y, r.z, r.w))
        return world.is_valid(np.array([state.getX(), state.getY(), state.getZ(), *angles]))

    si = ob.SpaceInformation(space)
    si.setStateValidityChecker(valid)
    si.setup()
    ends = []
    for q in (problem.start, problem.goal):
        st = space.allocState()
        st.setXYZ(float(q[0]), float(q[1]), float(q[2]))
        st.rotation().setAxisAngle(*_axis_angle(np.asarray(rotation_matrix(q[3], q[4], q[5]))))
        ends.append(st)
    pdef = ob.ProblemDefinition(si)
    pdef.setStartAndGoalStates(ends[0], ends[1], problem.goal_tolerance)
    p = getattr(og, planner)(si)
    if planner == "RRT":
        p.setGoalBias(float(goal_bias))
    p.setProblemDefinition(pdef)
    p.setup()
    iterations = 0
    t0 = time.perf_counter()
    deadline = t0 + float(time_limit)

    def stop() -> bool:
        nonlocal iterations
        iterations += 1
        return time.perf_counter() > deadline

    status = p.solve(ob.PlannerTerminationCondition(stop))
    dt = time.perf_counter() - t0
    solved = bool(pdef.hasExactSolution()) and str(status) == "Exact solution"
    path = np.empty((0, 6))
    cost = float("inf")
    if solved:
        solution = pdef.getSolutionPath()
        path = np.array([(s.getX(), s.getY(), s.getZ(), *euler_from_matrix(quaternion_matrix(
            s.rotation().x, s.rotation().y, s.rotation().z, s.rotation().w))) for s in solution.getStates()])
        cost = float(solution.length())
    data = ob.PlannerData(si)
    p.getPlannerData(data)
    return OmplRun(solved, max(iterations - 1, 0), dt, cost, int(data.numVertices()), path)
