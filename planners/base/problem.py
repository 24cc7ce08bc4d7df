"""A planning query: world, start, goal region, metric (OMPL's ProblemDefinition)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from planners.base.fileio import InputError
from planners.base.world import World
from planners.kernels.space import METRIC_NAMES, distance_of, make_space


@dataclass(frozen=True, eq=False)
class Problem:
    """Start, goal region and cost metric on a world.

    The goal region is the closed ball of radius ``goal_tolerance`` around ``goal`` in ``metric``;
    path cost is path length in ``metric``.

    Args:
        world: An ``OccupancyGrid``, ``GeometricWorld`` or ``RigidBodyWorld`` (any ``World``).
        start: Start state, shape ``(world.dim,)``; must be valid.
        goal: Goal state, shape ``(world.dim,)``; must be valid.
        goal_tolerance: Radius of the goal region (> 0).
        metric: One of ``world.metrics``; ``None`` picks the world's default (the first).
        name: Label used in tables and plots.
        reference_length: A published shortest-path length, e.g. a MovingAI scenario's octile
            optimum (8-connected, no corner cutting); ``None`` when unknown.
    """

    world: World
    start: np.ndarray
    goal: np.ndarray
    goal_tolerance: float = 1.0
    metric: str | None = None
    name: str = ""
    reference_length: float | None = field(default=None)

    def __post_init__(self) -> None:
        world = self.world
        if not isinstance(world, World):
            raise TypeError(f"world must implement planners.World (e.g. OccupancyGrid), got {type(world).__name__}")
        for label in ("start", "goal"):
            raw = getattr(self, label)
            try:
                q = np.array(raw, dtype=np.float64)
            except (TypeError, ValueError):
                raise InputError(f"{label} must be {world.dim} numbers, got {raw!r}") from None
            if q.shape != (world.dim,):
                raise InputError(f"{label} must have shape ({world.dim},), got {q.shape} from {raw!r}")
            if not np.all(np.isfinite(q)):
                raise InputError(f"{label} {tuple(q.tolist())} contains NaN or infinity")
            why = world.explain_invalid(q)
            if why:
                raise InputError(f"{label} {tuple(np.round(q, 6).tolist())} is not a valid state: it {why}")
            q.flags.writeable = False
            object.__setattr__(self, label, q)
        tol = self.goal_tolerance
        try:
            tol = float(tol)
        except (TypeError, ValueError):
            raise InputError(f"goal_tolerance must be a positive number, got {self.goal_tolerance!r}") from None
        if not np.isfinite(tol) or tol <= 0:
            raise InputError(f"goal_tolerance must be a positive finite number, got {tol}")
        object.__setattr__(self, "goal_tolerance", tol)
        metric = world.metrics[0] if self.metric is None else self.metric
        if metric not in world.metrics:
            raise InputError(f"metric {metric!r} is not available on {type(world).__name__}; "
                             f"choose from {world.metrics}")
        object.__setattr__(self, "metric", metric)

    @property
    def dim(self) -> int:
        return self.world.dim

    @property
    def space(self) -> tuple[int, int, float]:
        """``(kind, metric, rot_weight)`` for the compiled kernels (made once per rotation weight of the world)."""
        weight = float(getattr(self.world, "rot_weight", 1.0))
        kept = self.__dict__.get("_space")
        if kept is None or kept[0] != weight:
            kept = weight, make_space(int(self.world.space_kind), int(METRIC_NAMES[self.metric]), weight)
            object.__setattr__(self, "_space", kept)
        return kept[1]

    def distance(self, a, b) -> float:
        """Distance between two states in this problem's metric."""
        # writable copies: one compiled signature whatever the caller passes (SE3 compiles it)
        return distance_of(self.space, np.array(a, dtype=np.float64), np.array(b, dtype=np.float64))

    def path_length(self, path) -> float:
        """Length of a path (sequence of states) in this problem's metric."""
        path = np.asarray(path, dtype=np.float64).reshape(-1, self.dim)
        return float(sum(self.distance(a, b) for a, b in zip(path[:-1], path[1:], strict=True)))

    def in_goal(self, q) -> bool:
        return self.distance(q, self.goal) <= self.goal_tolerance

    def iteration_lower_bound(self, step_size: float) -> int | None:
        """``ceil((reference_length - goal_tolerance) / step_size)``, at least 1: iterations no sampler can beat.

        One iteration adds at most one step of length ``step_size``, so reaching the goal region
        along the shortest path takes at least this many. None when ``reference_length`` is unknown.
        """
        if self.reference_length is None:
            return None
        return max(1, math.ceil((self.reference_length - self.goal_tolerance) / step_size))

    def with_query(self, start, goal, **changes) -> Problem:
        """The same world with another start and goal (and optionally other fields)."""
        fields = dict(world=self.world, start=start, goal=goal, goal_tolerance=self.goal_tolerance,
                      metric=self.metric, name=self.name, reference_length=None)
        fields.update(changes)
        return Problem(**fields)

    def __repr__(self) -> str:
        s = np.round(self.start, 3).tolist()
        g = np.round(self.goal, 3).tolist()
        label = f"{self.name!r}, " if self.name else ""
        return f"Problem({label}{self.world!r}, start={s}, goal={g}, tol={self.goal_tolerance:g}, metric={self.metric})"
