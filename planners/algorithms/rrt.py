"""RRT and RRT-Connect."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from planners.base.fileio import InputError, env_limit
from planners.base.planner import Planner, PlannerData, TreeView, VertexStore, require_problem
from planners.base.problem import Problem
from planners.base.registry import register_planner
from planners.base.samplers import FAMILY_BIDIRECTIONAL, Sampler
from planners.base.world import DEFAULT_RANGE_FRACTION
from planners.kernels import rrt as rrt_kernels
from planners.kernels import state as slots

#: Most steps across the sampling box's diagonal a planner accepts unless raised: RRT-Connect reserves
#: room for one connect across the whole box (two trees x (diagonal / step) vertices of 80 bytes in 2-D,
#: about 300 in 6-DoF): 10^5 steps is 16 MB in 2-D and 60 MB in 6-DoF (twice that while an array grows).
DEFAULT_MAX_STEPS = 100_000
#: The environment variable that raises (or lowers) ``DEFAULT_MAX_STEPS``.
MAX_STEPS_ENV = "SAMPLERGYM_MAX_STEPS"


def max_steps_limit() -> int:
    """Most steps across the diagonal in force: ``$SAMPLERGYM_MAX_STEPS`` if set, else ``DEFAULT_MAX_STEPS``."""
    return env_limit(MAX_STEPS_ENV, DEFAULT_MAX_STEPS)


def diagonal_step(problem: Problem, fraction: float) -> float:
    """``fraction`` of the diagonal of the problem's sampling box: a step given as OMPL gives its default range."""
    low, high = problem.world.bounds
    return fraction * float(np.linalg.norm(np.asarray(high, dtype=float) - np.asarray(low, dtype=float)))


def default_step(problem: Problem, step_size: float | None) -> float:
    """Validate ``step_size``; None means the world's ``range_fraction`` of the sampling box's diagonal (0.2, OMPL's
    default range, unless the world sets its own: a mesh world's is 0.02).
    """
    if step_size is None:  # a world of the user's own may not set a fraction
        return diagonal_step(problem, getattr(problem.world, "range_fraction", DEFAULT_RANGE_FRACTION))
    try:
        step = float(step_size)
    except (TypeError, ValueError):
        raise ValueError(f"step_size must be a positive number, got {step_size!r}") from None
    if not math.isfinite(step) or step <= 0:
        raise ValueError(f"step_size must be a positive finite number, got {step_size!r}")
    diag = diagonal_step(problem, 1.0)
    limit = max_steps_limit()
    if diag / step > limit:
        raise InputError(f"step_size = {step:g} is {diag / step:.3g} steps across the map's diagonal ({diag:g}); "
                         f"at most {limit} are accepted (RRT-Connect reserves memory for one connect across it). "
                         f"Use a step of at least {diag / limit:.3g}, or set {MAX_STEPS_ENV}={math.ceil(diag / step)}")
    return step


def path_to_root(parent: np.ndarray, v: int) -> np.ndarray:
    """Vertex indices from the root to ``v`` (a path is short: a Python loop, nothing to compile).

    The parents are read through a memoryview, whose items are Python ints: a third of the time of indexing the
    array (about 40 ns a vertex against 120).
    """
    parents = memoryview(np.ascontiguousarray(parent, dtype=np.int64))
    out = []
    while v >= 0:
        out.append(v)
        v = parents[v]
    return np.array(out[::-1], dtype=np.int64)


@register_planner
class RRT(Planner):
    """Rapidly-exploring random tree.

    Each iteration draws a sample, finds the nearest tree vertex, steers at most ``step_size``
    towards the sample and adds the new state if the motion is collision-free. Solved when a vertex
    lies within ``goal_tolerance`` of the goal; the path ends at that vertex.

    S. M. LaValle, "Rapidly-exploring random trees: a new tool for path planning", TR 98-11, 1998.

    Args:
        problem: The planning problem.
        step_size: Maximum extension per iteration (OMPL's ``range``); None: the world's default (``default_step``).
        sampler: Where to sample; default ``UniformSampler()``. Goal bias is
            ``GoalBiasedSampler(p)``.
        seed: Seed of the planner's generator.
    """

    name = "RRT"
    step_parameter = "step_size"
    fusable_loop = "rrt"

    def __init__(self, problem: Problem, *, step_size: float | None = None, sampler: Sampler | None = None,
                 seed: int | None = None) -> None:
        require_problem(problem)
        self.step_size = default_step(problem, step_size)
        super().__init__(problem, sampler=sampler, seed=seed)

    def _reset(self) -> None:
        self._tree = VertexStore(self.problem, 1024, tree=True)
        # the kernels' sample, embedding and new-state buffers (``planners.kernels.rrt.scratch_rows``)
        self._scratch = np.empty((3, max(self._tree.X.shape[1], self._tree.E.shape[1])))
        self._add_root(self._tree, self.problem.start, slots.I_N)
        d = self.problem.distance(self.problem.start, self.problem.goal)
        self._fstate[slots.F_BEST_D] = d
        self._istate[slots.I_BEST_V] = 0
        if d <= self.problem.goal_tolerance:
            self._istate[slots.I_SOLVED] = 1
            self._istate[slots.I_GOAL_V] = 0
            self._istate[slots.I_FIRST] = 0
            self._fstate[slots.F_BEST_COST] = 0.0

    def _add_root(self, store: VertexStore, q: np.ndarray, slot: int) -> None:
        self._istate[slot] = store.add_root(q)

    def _reserve(self, iterations: int) -> None:
        self._tree.reserve(self.num_vertices, 1)

    def _run(self, points, anchored) -> int:
        return rrt_kernels.rrt_run(points, anchored, self._tree.as_tree(), self._istate, self._fstate, self._last,
                         self.problem.world.kernel, self._space, self._goal, self.step_size,
                         self.problem.goal_tolerance, self._low, self._high, True, self._stack, self._stack_b,
                         self._scratch)

    def loop_args(self) -> tuple:
        """Arguments of ``rrt_iterate`` (``planners.kernels.rrt``) after the sample and its anchor code."""
        return (self._tree.as_tree(), self._istate, self._fstate, self._last, self.problem.world.kernel, self._space,
                self._goal, self.step_size, self.problem.goal_tolerance, self._low, self._high, self._stack,
                self._stack_b)

    def _vertex_store(self) -> VertexStore:
        return self._tree

    def _path(self) -> np.ndarray:
        idx = path_to_root(self._tree.parent, int(self._istate[slots.I_GOAL_V]))
        return self._tree.X[idx].copy()

    def planner_data(self) -> PlannerData:
        n = self.num_vertices
        child = np.arange(1, n)
        edges = np.stack([self._tree.parent[1:n], child], axis=1) if n > 1 else np.empty((0, 2), np.int64)
        return PlannerData(self._tree.X[:n].copy(), edges, np.zeros(n, dtype=np.int64))


@register_planner
class RRTConnect(RRT):
    """Bidirectional RRT with greedy connection.

    Two trees grow from start and goal; each iteration extends one tree a step towards the sample
    and then extends the other tree towards the new vertex until it is reached or blocked; the trees
    swap roles every iteration. The path ends exactly at the goal.

    J. J. Kuffner, S. M. LaValle, "RRT-Connect: An efficient approach to single-query path
    planning", ICRA 2000, doi:10.1109/ROBOT.2000.844730.

    Args: as ``RRT``. ``TreeView`` and anchored samples refer to the start tree; the view's ``tree`` says
    which tree the next sample extends and its ``goal_tree`` holds the goal tree's states.
    """

    name = "RRTConnect"
    fusable_loop = "connect"
    family = FAMILY_BIDIRECTIONAL

    def view(self) -> TreeView:
        """As ``Planner.view``, with the tree the next sample extends and the goal tree's states."""
        v = super().view()
        goal_tree = self._gtree.X[:int(self._istate[slots.I_N_B])].view()
        goal_tree.flags.writeable = False
        return replace(v, tree=int(self._istate[slots.I_SWAP]), goal_tree=goal_tree)

    def vertex_counts(self) -> tuple[int, ...]:
        """Vertices of the start tree and of the goal tree (``PlannerData`` tags 0 and 1)."""
        return int(self._istate[slots.I_N]), int(self._istate[slots.I_N_B])

    def _reset(self) -> None:
        super()._reset()
        self._gtree = VertexStore(self.problem, 1024, tree=True)
        self._add_root(self._gtree, self.problem.goal, slots.I_N_B)
        if self.solved:  # start within tolerance of the goal: the path is [start]
            self._istate[slots.I_JOIN_B] = -1
        low, high = self.problem.world.bounds
        diag = self.problem.distance(np.asarray(low), np.asarray(high) - 1e-9)
        # the connect phase can add one vertex per step across the whole box
        self._max_connect = int(math.ceil(diag / self.step_size)) + 2

    def _reserve(self, iterations: int) -> None:
        self._tree.reserve(int(self._istate[slots.I_N]), self._max_connect + 1)
        self._gtree.reserve(int(self._istate[slots.I_N_B]), self._max_connect + 1)

    def loop_args(self) -> tuple:
        """Arguments of ``connect_run`` (``planners.kernels.rrt``) after the samples and their anchor codes."""
        return (self._tree.as_tree(), self._gtree.as_tree(), self._istate, self._fstate, self._last,
                self.problem.world.kernel, self._space, self._goal, self.step_size, self._low, self._high,
                self._max_connect, self._stack, self._stack_b, self._scratch)

    def _run(self, points, anchored) -> int:
        return rrt_kernels.connect_run(points, anchored, self._tree.as_tree(), self._gtree.as_tree(), self._istate,
                             self._fstate, self._last, self.problem.world.kernel, self._space, self._goal,
                             self.step_size, self._low, self._high, self._max_connect, self._stack, self._stack_b,
                             self._scratch)

    @property
    def num_vertices(self) -> int:
        return int(self._istate[slots.I_N] + self._istate[slots.I_N_B])

    def _path(self) -> np.ndarray:
        a = self._tree.X[path_to_root(self._tree.parent, int(self._istate[slots.I_GOAL_V]))]
        jb = int(self._istate[slots.I_JOIN_B])
        if jb < 0:
            return a.copy()
        b = self._gtree.X[path_to_root(self._gtree.parent, jb)][::-1]
        if np.array_equal(a[-1], b[0]):
            b = b[1:]
        return np.concatenate([a, b])

    def planner_data(self) -> PlannerData:
        na, nb = int(self._istate[slots.I_N]), int(self._istate[slots.I_N_B])
        V = np.concatenate([self._tree.X[:na], self._gtree.X[:nb]])
        ea = np.stack([self._tree.parent[1:na], np.arange(1, na)], axis=1)
        eb = np.stack([self._gtree.parent[1:nb], np.arange(1, nb)], axis=1) + na
        tags = np.concatenate([np.zeros(na, np.int64), np.ones(nb, np.int64)])
        return PlannerData(V, np.concatenate([ea, eb]).astype(np.int64), tags)
