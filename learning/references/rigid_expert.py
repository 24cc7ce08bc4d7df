"""The 6-DoF privileged expert: samples along a solution of the query found beforehand by long runs.

It shows how much room a 6-DoF sampler has, as the 2-D expert does with the grid search's shortest path: there
is no exact search of the 6-DoF configuration space, so its "answer" is a solution that long runs of
RRT-Connect found (``solve_reference``: the centred workspace route with uniform angles as their sampler, up to
``attempts`` runs of ``budget`` iterations each, seeded from fixed seeds so that every planner seed of a query
shares one answer), shortened as OMPL's path simplifier does (``planners.algorithms.smoothing.smooth``). It is a
reference, not a competitor: it knows a solution before the run starts.

Per sample: the goal with probability ``goal_share``; else with probability ``1 - uniform_share`` a state of the
solution (uniform in its arc length, the planner's own interpolation between its states) with Gaussian noise of
the world's ``route_spread`` on the position and a random rotation of about ``angle_noise`` radians per axis; else
a uniform state. Where the long runs find no solution, every sample is uniform and ``solved_reference`` is False.
Where ``rigid_route``'s samples follow the trees (``follow``: a box world's trees), so do the expert's: its states
are drawn within ``follow`` body radii of the solution's arc length (its positions') about the start tree's greatest
arc position reached along it, and with RRT-Connect half of them about the goal tree's least, so that it bounds the
learned sampler's room where the samples go and when.

Its long runs are kept per query (``SOLUTIONS``, keyed by the world's content and the query): later binds of the
same query, in the same process, take them from there. The time a run of it reports includes them at the first
bind of a query in a process; its iterations are what it is for.
"""

from __future__ import annotations

import copy
import hashlib
import time
from collections import OrderedDict

import numpy as np

from planners.base.fileio import InputError, check_int, check_number
from planners.base.problem import Problem
from planners.base.samplers import FAMILY_ROADMAP, SamplerBase
from planners.guidance.rigid_orientation import euler_from_matrices, small_rotations, wrap_angles
from planners.guidance.route_draws import watch_reach
from planners.guidance.workspace_route import box_muller
from planners.worlds.mesh import rotation_matrices
from planners.worlds.rigid3d import densify, seed_step

#: Seeds of the long runs: fixed, so the reference's solution belongs to the query, not to a planner's seed.
REFERENCE_SEEDS = tuple(7919 + k for k in range(16))
#: Solutions kept per process, most recent first out.
KEPT_SOLUTIONS = 64
#: The expert's long runs' sampler (``rigid_route_ablation``'s settings): the route positions crowded where the route
#: is tight, along the whole route (the runs behind the expert's rows in the docs).
REFERENCE_ABLATION = {"follow": 0.0}
#: The long runs that label the orientation model's training examples (``learning.training.rigid``): the route
#: positions at uniform arc length along the whole route, as the ablation drew them when the shipped model was
#: trained, whatever it ships with now.
LABEL_ABLATION = {"passage_weight": 0.0, "follow": 0.0}
#: Most samples one draw returns where the draws follow the trees (``follow``), as ``rigid_route``'s.
FOLLOW_BATCH = 64
#: query key -> (dense states of the solution or None, seconds its long runs took, iterations they ran).
SOLUTIONS: OrderedDict[str, tuple[np.ndarray | None, float, int]] = OrderedDict()


def query_key(problem: Problem, attempts: int, budget: int) -> str:
    """A digest of the world's content (its boxes or meshes, body, bounds), the query, and the long runs' budget."""
    world = problem.world
    h = hashlib.sha256(type(world).__name__.encode())
    for name in ("boxes", "body", "env_vertices", "env_faces", "body_vertices", "body_faces"):
        if hasattr(world, name):
            a = np.ascontiguousarray(getattr(world, name))
            h.update(name.encode() + str(a.shape).encode() + str(a.dtype).encode() + a.tobytes())
    for a in (*world.bounds, problem.start, problem.goal):
        h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
    h.update(f"{attempts} {budget}".encode())
    return h.hexdigest()


def solve_reference(problem: Problem, attempts: int = 4, budget: int = 100_000,
                    settings: dict | None = None) -> tuple[np.ndarray | None, float, int]:
    """A solution of ``problem`` by long runs, densified: ``(states or None, seconds, iterations run)``.

    RRT-Connect at the seed set-up's step (0.01 of the workspace's longest side) on the ``cossin`` metric, with
    the centred workspace route and uniform angles as its sampler (``rigid_route_ablation`` with ``settings``,
    by default ``REFERENCE_ABLATION``; the training labels take ``LABEL_ABLATION``), seeds
    ``REFERENCE_SEEDS`` in turn until one solves within ``budget`` iterations; the path is shortened
    (``smooth``) and densified to half a step between states.
    """
    from learning.samplers.registry import make_sampler
    from planners import RRTConnect
    from planners.algorithms.smoothing import smooth

    world = problem.world
    step = seed_step(world)
    p = problem.with_query(problem.start, problem.goal, metric="cossin")
    t0, ran = time.perf_counter(), 0
    given = REFERENCE_ABLATION if settings is None else settings
    for k, seed in enumerate(REFERENCE_SEEDS[:attempts]):
        result = RRTConnect(p, step_size=step, sampler=make_sampler("rigid_route_ablation", **given),
                            seed=seed).solve(max_iterations=budget)
        ran += int(result.iterations)
        if result.solved:
            path = smooth(result.path, p, seed=k)
            return densify(path, p, 0.5 * step), time.perf_counter() - t0, ran
    return None, time.perf_counter() - t0, ran


class RigidExpertSampler(SamplerBase):
    """Samples along a solution found by long runs (see the module doc): a privileged reference.

    Args:
        attempts: Long runs tried, each from the next of ``REFERENCE_SEEDS``, until one solves.
        budget: Iterations of each long run.
        uniform_share: Probability in [0, 1] of a uniform state (the share not along the solution).
        goal_share: Probability in [0, 1] of the goal state.
        angle_noise: Standard deviation, radians, of each component of the rotation vector turning a solution's
            orientation.
        spread: Standard deviation of the position noise; None: the world's ``route_spread``.
        follow: Half-width, in body radii, of the window of the solution's arc length its states are drawn in,
            about the trees' reach along it (``rigid_route``'s ``follow``; 0: the whole solution; None: as
            ``rigid_route`` on the world, a box world's trees 2, a mesh world's 0). A roadmap ignores it.
    """

    def __init__(self, attempts: int = 4, budget: int = 100_000, uniform_share: float = 0.1,
                 goal_share: float = 0.05, angle_noise: float = 0.1, spread: float | None = None,
                 follow: float | None = None) -> None:
        who = "RigidExpertSampler"
        self.attempts = check_int(attempts, f"{who}: attempts", low=1)
        if self.attempts > len(REFERENCE_SEEDS):
            raise InputError(f"{who}: attempts = {attempts}: at most {len(REFERENCE_SEEDS)}")
        self.budget = check_int(budget, f"{who}: budget", low=1)
        self.uniform_share = float(check_number(who, "uniform_share", uniform_share, low=0, high=1))
        self.goal_share = float(check_number(who, "goal_share", goal_share, low=0, high=1))
        self.angle_noise = float(check_number(who, "angle_noise", angle_noise, low=0))
        self.spread = None if spread is None else float(check_number(who, "spread", spread, low=0))
        self.follow = None if follow is None else float(check_number(who, "follow", follow, low=0))

    def for_planner(self, family: str) -> SamplerBase:
        """A roadmap keeps every sample: it draws along the whole solution (``follow`` 0); the trees as given."""
        if family != FAMILY_ROADMAP or self.follow == 0.0:
            return self
        out = copy.copy(self)
        out.follow = 0.0
        return out

    def _setup(self) -> None:
        world = self.problem.world
        if not (hasattr(world, "high3") and hasattr(world, "route_spread") and self.problem.dim == 6):
            raise InputError("RigidExpertSampler plans on 6-DoF box and mesh worlds (RigidBodyWorld, MeshWorld)")
        key = query_key(self.problem, self.attempts, self.budget)
        if key in SOLUTIONS:
            SOLUTIONS.move_to_end(key)
        else:
            SOLUTIONS[key] = solve_reference(self.problem, self.attempts, self.budget)
            while len(SOLUTIONS) > KEPT_SOLUTIONS:
                SOLUTIONS.popitem(last=False)
        self.states, self.reference_seconds, self.reference_iterations = SOLUTIONS[key]
        self.solved_reference = self.states is not None
        self.sd = world.route_spread if self.spread is None else self.spread
        if self.follow is None:  # as rigid_route's trees on this world
            from learning.samplers.rigid_route import SHIPPED_RIGID_ROADMAP, SHIPPED_RIGID_SETTINGS

            self.follow = (SHIPPED_RIGID_SETTINGS if hasattr(world, "boxes") else SHIPPED_RIGID_ROADMAP)["follow"]
        # the trees' reach along the solution's positions (``follow``): arc positions, vertices seen, a goal tree
        pos = np.zeros((0, 3)) if self.states is None else np.ascontiguousarray(self.states[:, :3])
        self._pos = pos
        self._arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pos, axis=0), axis=1))]) \
            if len(pos) else np.zeros(1)
        self._reach, self._seen, self._two = [0.0, float(self._arc[-1])], [0, 0], False
        self._span = self.follow * float(world.radius)

    def draw(self, rng, n, view):
        # one row of uniforms per sample, whatever its kind: a coin, a place on the solution, a uniform state,
        # two Box-Muller pairs for the position and two for the rotation
        d = self.problem.dim
        following = self.follow > 0 and self.states is not None and len(self.states) > 1
        if following:
            n = min(n, FOLLOW_BATCH)
            self._watch(view)
        u = rng.random((n, 2 + d + 8))
        pts = self._uniform(u[:, 2:2 + d])
        if self.states is not None:
            along = (u[:, 0] >= self.goal_share) & (u[:, 0] < self.goal_share + (1.0 - self.goal_share)
                                                   * (1.0 - self.uniform_share))
            m = int(along.sum())
            if m:
                idx = (self._window_states(u[along, 1]) if following else
                       np.minimum((u[along, 1] * len(self.states)).astype(np.int64), len(self.states) - 1))
                base = self.states[idx]
                z = box_muller(u[along, 2 + d:2 + d + 8])
                pos = base[:, :3] + self.sd * z[:, :3]
                pts[along, :3] = np.clip(pos, self.low[:3], np.nextafter(self.high[:3], -np.inf))
                R = small_rotations(self.angle_noise * z[:, 3:6]) @ rotation_matrices(base[:, 3:6])
                pts[along, 3:] = nearest_cover(euler_from_matrices(R), base[:, 3:6])
        pts[u[:, 0] < self.goal_share] = self.problem.goal
        return pts

    def _watch(self, view) -> None:
        """The trees' reach along the solution's positions from the planner's ``view`` (``follow``)."""
        if view is not None:
            two = watch_reach(view, self._pos, self._arc, self._reach, self._seen, self._span, True)
            self._two = self._two or two

    def _window_states(self, v: np.ndarray) -> np.ndarray:
        """Indices of solution states for uniforms ``v``: uniform among those within the trees' windows."""
        reach = np.full(len(v), self._reach[0])
        if self._two:  # half about the goal tree's reach
            goal = v >= 0.5
            reach[goal] = self._reach[1]
            v = np.where(goal, 2.0 * v - 1.0, 2.0 * v)
        last = len(self.states) - 1
        lo = np.minimum(np.searchsorted(self._arc, reach - self._span, side="left"), last)
        hi = np.maximum(np.searchsorted(self._arc, reach + self._span, side="right"), lo + 1)
        return np.minimum(lo + (v * (hi - lo)).astype(np.int64), hi - 1)

    def __repr__(self) -> str:
        sd = "the world's" if self.spread is None else f"{self.spread:g}"
        follow = "" if self.follow is None else f", follow={self.follow:g}"
        return (f"RigidExpertSampler(attempts={self.attempts}, budget={self.budget}, "
                f"uniform_share={self.uniform_share:g}, goal_share={self.goal_share:g}, "
                f"angle_noise={self.angle_noise:g}, spread={sd}{follow})")


def nearest_cover(angles: np.ndarray, near: np.ndarray) -> np.ndarray:
    """Each row of ``angles`` written on whichever of its two Euler covers lies nearer ``near``'s row.

    ``(tx, ty, tz)`` and ``(pi - tx, ty + pi, tz + pi)`` are one rotation; the planners' metrics tell them apart,
    so a turned state of the solution is written as the solution writes its orientation.
    """
    other = wrap_angles(np.stack([np.pi - angles[:, 0], angles[:, 1] + np.pi, angles[:, 2] + np.pi], axis=1))
    closer = np.abs(wrap_angles(other - near)).sum(axis=1) < np.abs(wrap_angles(angles - near)).sum(axis=1)
    return np.where(closer[:, None], other, angles)
