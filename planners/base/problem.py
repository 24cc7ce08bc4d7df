"""A planning query: world, start, goal region, metric (OMPL's ProblemDefinition)."""

from __future__ import annotations

import math
import os
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from planners.base.fileio import InputError
from planners.base.world import World
from planners.kernels.space import METRIC_NAMES
from planners.worlds.grid import OccupancyGrid


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
        """``(kind, metric, rot_weight)`` for the compiled kernels."""
        return (int(self.world.space_kind), int(METRIC_NAMES[self.metric]),
                float(getattr(self.world, "rot_weight", 1.0)))

    def distance(self, a, b) -> float:
        """Distance between two states in this problem's metric."""
        from planners.kernels.space import distance

        k, m, w = self.space
        return float(distance(k, m, w, np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)))

    def path_length(self, path) -> float:
        """Length of a path (sequence of states) in this problem's metric."""
        path = np.asarray(path, dtype=np.float64).reshape(-1, self.dim)
        return float(sum(self.distance(a, b) for a, b in zip(path[:-1], path[1:], strict=True)))

    def in_goal(self, q) -> bool:
        return self.distance(q, self.goal) <= self.goal_tolerance

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


def load_movingai_scenarios(
    path: str | os.PathLike,
    *,
    goal_tolerance: float = 1.0,
    map_path: str | os.PathLike | None = None,
    metric: str = "euclidean",
    limit: int | None = None,
) -> Iterator[Problem]:
    """Yield one ``Problem`` per line of a MovingAI ``.scen`` file.

    Start and goal are the centres of the scenario's cells (``x + 0.5, y + 0.5``); each problem's
    ``reference_length`` is the published octile optimum. The map is found by the basename of the
    scenario's map column next to the ``.scen`` file, unless ``map_path`` is given.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"MovingAI scenario file {path} does not exist")
    raw = path.read_bytes()
    try:
        lines = raw.decode("ascii").splitlines()
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not an ASCII MovingAI scenario file (byte {exc.start} is "
                         f"{raw[exc.start]:#x})") from None
    grids: dict[Path, OccupancyGrid] = {}
    count = 0
    for lineno, line in enumerate(lines, start=1):
        if not line.strip() or (lineno == 1 and line.lower().startswith("version")):
            continue
        fields = line.split("\t")
        if len(fields) != 9:
            raise InputError(f"{path}, line {lineno}: expected 9 tab-separated fields, got {len(fields)}: {line!r}")
        try:
            bucket = int(fields[0])
            w, h, sx, sy, gx, gy = (int(v) for v in fields[2:8])
            optimal = float(fields[8])
        except ValueError:
            raise InputError(f"{path}, line {lineno}: non-numeric field in {line!r}") from None
        if not (math.isfinite(optimal) and optimal >= 0):
            raise InputError(f"{path}, line {lineno}: optimal length must be a finite number >= 0, "
                             f"got {fields[8]!r}")
        mp = Path(map_path) if map_path is not None else path.parent / Path(fields[1].replace("\\", "/")).name
        if mp not in grids:
            if not mp.is_file():
                raise InputError(f"{path}, line {lineno}: its map {fields[1]!r} is looked up as {str(mp)!r}, "
                                 f"which does not exist; pass map_path=")
            grids[mp] = OccupancyGrid.from_movingai(mp)
        grid = grids[mp]
        if (w, h) != (grid.width, grid.height):
            raise InputError(f"{path}, line {lineno}: scenario size {w}x{h} does not match {mp} "
                             f"({grid.width}x{grid.height})")
        for label, (x, y) in (("start", (sx, sy)), ("goal", (gx, gy))):
            if not (0 <= x < w and 0 <= y < h) or grid.obstacles[y, x]:
                raise InputError(f"{path}, line {lineno}: {label} cell (x={x}, y={y}) is outside the map or blocked")
        yield Problem(
            grid,
            start=grid.cell_center(sy, sx),
            goal=grid.cell_center(gy, gx),
            goal_tolerance=goal_tolerance,
            metric=metric,
            name=f"{mp.stem}#{lineno}",
            reference_length=optimal,
        )
        _ = bucket
        count += 1
        if limit is not None and count >= limit:
            return
