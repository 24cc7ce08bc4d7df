"""RRT* and Informed RRT*."""

from __future__ import annotations

import math

import numpy as np

from planners.algorithms.rrt import RRT
from planners.base.planner import require_problem
from planners.base.problem import Problem
from planners.base.registry import register_planner
from planners.base.samplers import FAMILY_OPTIMIZING, InformedSampler, Sampler
from planners.kernels import rrtstar as rrtstar_kernels
from planners.kernels.state import I_N_GOAL


def unit_ball_volume(d: int) -> float:
    """Lebesgue measure of the unit ball in R^d."""
    return math.pi ** (d / 2) / math.gamma(d / 2 + 1)


@register_planner
class RRTStar(RRT):
    """Asymptotically optimal RRT.

    Each new state connects to the cheapest collision-free parent among the vertices within radius
    ``r_n = min(gamma (log n / n)^(1/d), step_size)``, and the neighbours are rewired through it when
    that lowers their cost; cost changes propagate to all descendants. ``gamma = rewire_factor *
    (2 (1 + 1/d) mu(X_free) / zeta_d)^(1/d)`` is the bound of Karaman & Frazzoli (as in OMPL).

    RRT* is anytime: ``solve`` keeps improving until its budget is spent, unless
    ``stop_on_first_solution``. ``PlanResult.first_solution_iteration`` gives iterations-to-solution.

    S. Karaman, E. Frazzoli, "Sampling-based algorithms for optimal motion planning", IJRR 30(7),
    2011, doi:10.1177/0278364911406761.

    Args:
        problem: The planning problem.
        step_size: Maximum extension per iteration; also caps the rewiring radius.
        sampler: Where to sample; default uniform.
        seed: Seed of the planner's generator.
        rewire_factor: Multiplier (> 1 for the optimality guarantee) on the radius constant.
        stop_on_first_solution: Stop ``solve`` at the first solution, like RRT.
    """

    name = "RRTstar"
    anytime = True  # per instance: False with stop_on_first_solution
    family = FAMILY_OPTIMIZING
    fusable_loop = "rrtstar"  # up to the first solution (planners.fused)

    def __init__(self, problem: Problem, *, step_size: float | None = None, sampler: Sampler | None = None,
                 seed: int | None = None, rewire_factor: float = 1.1, stop_on_first_solution: bool = False) -> None:
        require_problem(problem)
        if not (np.isfinite(rewire_factor) and rewire_factor > 0):
            raise ValueError(f"rewire_factor must be a positive number, got {rewire_factor}")
        self.rewire_factor = float(rewire_factor)
        self.anytime = not stop_on_first_solution
        d = problem.dim
        mu = problem.world.free_volume()
        self.gamma = self.rewire_factor * (2.0 * (1.0 + 1.0 / d) * mu / unit_ball_volume(d)) ** (1.0 / d)
        super().__init__(problem, step_size=step_size, sampler=sampler, seed=seed)

    def _reset(self) -> None:
        super()._reset()
        self._aux_cap = 0
        self._alloc_aux()
        self._first_child[0] = -1
        if self.solved:  # start already in the goal region
            self._goal_nodes[0] = 0
            self._istate[I_N_GOAL] = 1

    def _alloc_aux(self) -> None:
        cap = self._tree.capacity
        n = self._aux_cap

        def grown(name, dtype, fill):
            new = np.full(cap, fill, dtype=dtype)
            if n:
                new[:n] = getattr(self, name)[:n]
            return new

        self._elen = grown("_elen", np.float64, 0.0)
        self._first_child = grown("_first_child", np.int64, -1)
        self._next_sib = grown("_next_sib", np.int64, -1)
        self._prev_sib = grown("_prev_sib", np.int64, -1)
        self._goal_nodes = grown("_goal_nodes", np.int64, -1)
        self._nbr = np.empty(cap, dtype=np.int64)
        self._nbr_cost = np.empty(cap)
        self._nbr_ok = np.empty(cap, dtype=np.int8)
        self._dfs = np.empty(cap, dtype=np.int64)
        self._aux_cap = cap

    def _reserve(self, iterations: int) -> None:
        if self._tree.reserve(self.num_vertices, 1):
            self._alloc_aux()

    def _run(self, points, anchored) -> int:
        aux = (self._elen, self._first_child, self._next_sib, self._prev_sib, self._goal_nodes)
        return rrtstar_kernels.rrtstar_run(points, anchored, self._tree.as_tree(), aux, self._istate, self._fstate,
                                           self._last,
                              self.problem.world.kernel, self._space, self._goal, self.step_size,
                              self.problem.goal_tolerance, self._low, self._high, self.gamma,
                              float(self.problem.dim), self._nbr, self._nbr_cost, self._nbr_ok, self._dfs,
                              self._stack, self._stack_b)

    def loop_args(self) -> tuple:
        """Arguments of ``rrtstar_run`` (``planners.kernels.rrtstar``) after the samples and their anchor codes."""
        aux = (self._elen, self._first_child, self._next_sib, self._prev_sib, self._goal_nodes)
        return (self._tree.as_tree(), aux, self._istate, self._fstate, self._last, self.problem.world.kernel,
                self._space, self._goal, self.step_size, self.problem.goal_tolerance, self._low, self._high, self.gamma,
                float(self.problem.dim), self._nbr, self._nbr_cost, self._nbr_ok, self._dfs, self._stack,
                self._stack_b)

    def edge_lengths(self) -> np.ndarray:
        """(n,) length of each vertex's parent edge (0 for the root), read-only copy."""
        return self._elen[: self.num_vertices].copy()

    def costs(self) -> np.ndarray:
        """(n,) cost-to-come of each vertex, read-only copy."""
        return self._tree.cost[: self.num_vertices].copy()

    def parents(self) -> np.ndarray:
        """(n,) parent index of each vertex (-1 for the root), read-only copy."""
        return self._tree.parent[: self.num_vertices].copy()


@register_planner
class InformedRRTStar(RRTStar):
    """RRT* that, once a solution exists, samples only the informed set (no pruning).

    J. D. Gammell, S. S. Srinivasa, T. D. Barfoot, "Informed RRT*", IROS 2014,
    doi:10.1109/IROS.2014.6942976. The default sampler is ``InformedSampler()``; passing another
    sampler makes this plain RRT*.
    """

    name = "InformedRRTstar"
    own_sampler = True

    def __init__(self, problem: Problem, *, step_size: float | None = None, sampler: Sampler | None = None,
                 seed: int | None = None, rewire_factor: float = 1.1, stop_on_first_solution: bool = False) -> None:
        super().__init__(problem, step_size=step_size, sampler=sampler or InformedSampler(), seed=seed,
                         rewire_factor=rewire_factor, stop_on_first_solution=stop_on_first_solution)

