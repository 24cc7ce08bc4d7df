"""A geometric 2-D world of circles and axis-aligned rectangles (the textbook RRT/PRM demos)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from planners.base.world import WorldBase
from planners.kernels import geometry
from planners.kernels.space import SPACE_RN


@dataclass(frozen=True)
class Circle:
    """Closed disc of radius ``r`` centred at ``(x, y)``."""

    x: float
    y: float
    r: float


@dataclass(frozen=True)
class Rectangle:
    """Closed axis-aligned rectangle ``[x0, x1] x [y0, y1]``."""

    x0: float
    y0: float
    x1: float
    y1: float


class GeometricWorld(WorldBase):
    """Circles and rectangles in the open box ``(0, width) x (0, height)``.

    Collision checks are exact (segment-disc distance, segment-box clipping); obstacles are
    closed, so touching one is a collision.

    Args:
        width: Extent in x (> 0).
        height: Extent in y (> 0).
        obstacles: ``Circle`` and ``Rectangle`` instances.
    """

    dim = 2
    space_kind = SPACE_RN
    metrics = ("euclidean", "manhattan", "chebyshev")

    def __init__(self, width: float, height: float, obstacles: Sequence[Circle | Rectangle] = ()) -> None:
        width, height = float(width), float(height)
        for label, v in (("width", width), ("height", height)):
            if not np.isfinite(v) or v <= 0:
                raise ValueError(f"{label} must be a positive finite number, got {v}")
        rows = []
        for i, ob in enumerate(obstacles):
            if isinstance(ob, Circle):
                vals = (ob.x, ob.y, ob.r)
                if not np.all(np.isfinite(vals)) or ob.r <= 0:
                    raise ValueError(f"obstacle {i}: circle needs finite centre and radius > 0, got {ob}")
                rows.append((0.0, ob.x, ob.y, ob.r, 0.0))
            elif isinstance(ob, Rectangle):
                vals = (ob.x0, ob.y0, ob.x1, ob.y1)
                if not np.all(np.isfinite(vals)) or ob.x1 < ob.x0 or ob.y1 < ob.y0:
                    raise ValueError(f"obstacle {i}: rectangle needs finite x0 <= x1 and y0 <= y1, got {ob}")
                rows.append((1.0, ob.x0, ob.y0, ob.x1, ob.y1))
            else:
                raise TypeError(f"obstacle {i} must be a Circle or Rectangle, got {type(ob).__name__}")
        self.width = width
        self.height = height
        self.obstacles: tuple[Circle | Rectangle, ...] = tuple(obstacles)
        geom = np.array(rows, dtype=np.float64).reshape(-1, 5)
        grid, _, body = geometry.placeholder_arrays()
        self._kernel = geometry.world_kernel(geometry.WORLD_SHAPES, grid, geom, body,
                                             np.array([0.0, 0.0, width, height]))
        self._low = np.zeros(2)
        self._high = np.array([width, height])
        self._low.flags.writeable = False
        self._high.flags.writeable = False

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self._low, self._high

    def free_volume(self) -> float:
        """Box area minus obstacle area, estimated on a fixed 512 x 512 lattice (overlaps counted once)."""
        xs = (np.arange(512) + 0.5) / 512 * self.width
        ys = (np.arange(512) + 0.5) / 512 * self.height
        X, Y = np.meshgrid(xs, ys)
        blocked = np.zeros_like(X, dtype=bool)
        for ob in self.obstacles:
            if isinstance(ob, Circle):
                blocked |= (X - ob.x) ** 2 + (Y - ob.y) ** 2 <= ob.r**2
            else:
                blocked |= (X >= ob.x0) & (X <= ob.x1) & (Y >= ob.y0) & (Y <= ob.y1)
        return float((~blocked).mean()) * self.width * self.height

    def explain_invalid(self, q) -> str:
        q = self._state(q)
        if not np.all(np.isfinite(q)):
            return "is not finite"
        if not (0.0 < q[0] < self.width and 0.0 < q[1] < self.height):
            return f"lies outside the world interior (0, {self.width:g}) x (0, {self.height:g})"
        for i, ob in enumerate(self.obstacles):
            if not self.check_motion(q, q) and _inside(ob, q):
                return f"lies in obstacle {i} ({ob})"
        return ""

    def __repr__(self) -> str:
        return f"GeometricWorld({self.width:g}x{self.height:g}, {len(self.obstacles)} obstacles)"


def _inside(ob: Circle | Rectangle, q: np.ndarray) -> bool:
    if isinstance(ob, Circle):
        return (q[0] - ob.x) ** 2 + (q[1] - ob.y) ** 2 <= ob.r**2
    return ob.x0 <= q[0] <= ob.x1 and ob.y0 <= q[1] <= ob.y1
