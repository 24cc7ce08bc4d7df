"""The 2-D occupancy map: a world of square cells, built from a numpy array.

File formats (images, MovingAI ``.map``, ``.npy``, ROS ``map.yaml``) are read by ``planners.maps.readers``.
"""

from __future__ import annotations

import math
import os

import numba as nb
import numpy as np

from planners.base.fileio import InputError
from planners.base.world import WorldBase
from planners.kernels import geometry
from planners.kernels.space import SPACE_RN
from planners.maps.coarsen import block_any


class OccupancyGrid(WorldBase):
    """A 2-D occupancy map (True = obstacle), the one map type of SamplerGym.

    World coordinates: array row ``r``, column ``c`` covers
    ``x in [ox + c*res, ox + (c+1)*res)``, ``y in [oy + r*res, oy + (r+1)*res)`` where
    ``(ox, oy) = origin``: the row index grows with y. Image and MovingAI maps have origin 0 and are
    drawn with y growing downwards, as images are; ROS maps (``y_up=True``) have their image rows
    flipped on loading, so row 0 is the image's bottom row and y grows upwards, as in RViz.
    Everything outside the grid is blocked.

    Collision checking is exact: a motion is valid only if the segment meets no blocked cell,
    boundary included (cells are treated as closed sets, so a path never squeezes between two
    diagonally touching obstacles or grazes a corner), found by enumerating every cell the segment
    touches. A state is a zero-length motion.

    Args:
        obstacles: (H, W) array; bool, or integers/floats holding only 0 and 1.
        resolution: Side length of a cell in world units (> 0).
        origin: World coordinates ``(x, y)`` of the corner of cell (0, 0).
        y_up: Display flag only: draw the map with y growing upwards (ROS maps).
        source: Where the map came from, quoted in error messages.
    """

    dim = 2
    space_kind = SPACE_RN
    metrics = ("euclidean", "manhattan", "chebyshev")

    def __init__(self, obstacles, resolution: float = 1.0, *, origin=(0.0, 0.0), y_up: bool = False,
                 source: str | None = None) -> None:
        where = f" (from {source})" if source else ""
        try:
            arr = np.asarray(obstacles)
        except Exception as exc:  # ragged lists and the like
            raise InputError(f"obstacles{where} must be a 2-D array, got {type(obstacles).__name__}: {exc}") from None
        if arr.ndim != 2:
            raise InputError(f"obstacles{where} must be a 2-D (H, W) array, got shape {arr.shape}")
        if arr.size == 0:
            raise InputError(f"obstacles{where} is empty (shape {arr.shape}); a map needs at least one cell")
        if arr.dtype != np.bool_:
            if not (np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)):
                raise InputError(f"obstacles{where} must be bool or numeric 0/1, got dtype {arr.dtype}")
            bad = ~np.isin(arr, (0, 1))
            if bad.any():
                r, c = np.argwhere(bad)[0]
                raise InputError(
                    f"obstacles{where} must hold only 0/1 (or bool); found {arr[r, c]!r} at row {r}, col {c}"
                )
            arr = arr.astype(bool)
        try:
            resolution = float(resolution)
        except (TypeError, ValueError):
            raise InputError(f"resolution must be a positive finite number, got {resolution!r}") from None
        if not np.isfinite(resolution) or resolution <= 0:
            raise InputError(f"resolution must be a positive finite number, got {resolution}")
        try:
            org = np.array(origin, dtype=np.float64)
        except (TypeError, ValueError):
            raise InputError(f"origin must be two finite numbers (x, y), got {origin!r}") from None
        if org.shape != (2,) or not np.all(np.isfinite(org)):
            raise InputError(f"origin must be two finite numbers (x, y), got {origin!r}")
        self._obstacles = np.array(arr, dtype=bool, copy=True)
        self._obstacles.flags.writeable = False
        self.resolution = resolution
        self.source = source
        self.y_up = bool(y_up)
        _, geom, body = geometry.placeholder_arrays()
        grid_u8 = np.ascontiguousarray(self._obstacles, dtype=np.uint8)
        self._kernel = geometry.world_kernel(geometry.WORLD_GRID, grid_u8, geom, body,
                                             np.array([1.0 / resolution, org[0], org[1]]))
        self._origin = org
        self._low = org.copy()
        self._high = org + np.array([self.width * resolution, self.height * resolution])
        for a in (self._origin, self._low, self._high):
            a.flags.writeable = False
        self._walls: np.ndarray | None = None  # the map's own obstacles when this grid is an inflated copy
        self.inflation = 0.0

    # --- construction from files -------------------------------------------------------------

    @classmethod
    def from_image(cls, path: str | os.PathLike, threshold: float = 0.5, resolution: float = 1.0,
                   invert: bool = False, *, max_pixels: int | None = None) -> OccupancyGrid:
        """Load a PNG/JPG/BMP/TIFF map: pixels darker than ``threshold`` (0..1 gray) are obstacles.

        See ``planners.maps.readers.read_image``.
        """
        from planners.maps.readers import read_image

        return read_image(path, threshold=threshold, resolution=resolution, invert=invert, max_pixels=max_pixels)

    @classmethod
    def from_file(cls, path: str | os.PathLike, threshold: float = 0.5, resolution: float = 1.0,
                  invert: bool = False, *, robot_radius: float = 0.0, unknown: str = "blocked",
                  max_pixels: int | None = None) -> OccupancyGrid:
        """Load any map file, by suffix: an image, a MovingAI ``.map``, a ``.npy`` array or a ROS ``map.yaml``.

        See ``planners.maps.readers.read_map`` (the arguments are the same), where readers for other
        formats are registered.
        """
        from planners.maps.readers import read_map

        return read_map(path, threshold=threshold, resolution=resolution, invert=invert,
                        robot_radius=robot_radius, unknown=unknown, max_pixels=max_pixels)

    @classmethod
    def from_movingai(cls, path: str | os.PathLike, resolution: float = 1.0, *,
                      max_pixels: int | None = None) -> OccupancyGrid:
        """Load a MovingAI ``.map`` file; see ``planners.maps.readers.read_movingai``."""
        from planners.maps.readers import read_movingai

        return read_movingai(path, resolution=resolution, max_pixels=max_pixels)

    # --- derived maps --------------------------------------------------------------------------

    def inflate(self, radius: float) -> OccupancyGrid:
        """This map with every obstacle grown by a disc of ``radius`` world units (a round robot's footprint).

        Exact on the grid: for ``radius > 0`` a cell is blocked if its closed square lies within
        distance ``radius`` (``<=``) of the closed square of a blocked cell or of a cell outside the
        map (the edge is a wall). So a disc of that radius, centred anywhere a valid state of the
        new map can be, keeps a distance greater than ``radius`` from every blocked cell of this map
        and stays inside it. ``radius == 0`` returns an equal map.
        """
        if isinstance(radius, bool) or not isinstance(radius, (int, float, np.integer, np.floating)):
            raise InputError(f"robot radius must be a non-negative number of world units, got {radius!r}")
        r = float(radius)
        if not math.isfinite(r) or r < 0:
            raise InputError(f"robot radius must be a non-negative finite number of world units, got {radius!r}")
        obs = self._obstacles
        if r > 0:
            rc = r / self.resolution  # radius in cells
            if rc > 2 * max(obs.shape):
                obs = np.ones_like(obs)
            else:
                widths = _disc_half_widths(rc)
                padded = np.pad(obs, 1, constant_values=True)
                # the per-row distances are capped at widths[0] + 1, so 16 bits do for any practical radius
                near = np.empty(padded.shape, dtype=np.int16 if widths[0] < 32000 else np.int32)
                obs = _dilate(padded, widths, near)[1:-1, 1:-1]
        out = OccupancyGrid(obs, self.resolution, origin=self._origin, y_up=self.y_up, source=self.source)
        out._walls, out.inflation = self.walls, self.inflation + r
        return out

    @property
    def walls(self) -> np.ndarray:
        """The map's own obstacles (read-only): before ``inflate``, which records them; else ``obstacles``."""
        return self._obstacles if self._walls is None else self._walls

    def image_row(self, row: int) -> int:
        """The row of the map's image (row 0 at the top, as a viewer shows it) that grid row ``row`` comes from.

        The same row for images and MovingAI maps; ROS maps (``y_up``) are flipped on loading.
        """
        return self.height - 1 - int(row) if self.y_up else int(row)

    # --- geometry ------------------------------------------------------------------------------

    @property
    def obstacles(self) -> np.ndarray:
        """(H, W) read-only bool array, True = obstacle."""
        return self._obstacles

    @property
    def origin(self) -> np.ndarray:
        """Read-only (2,) world coordinates of the corner of cell (0, 0)."""
        return self._origin

    @property
    def shape(self) -> tuple[int, int]:
        return self._obstacles.shape

    @property
    def height(self) -> int:
        return self._obstacles.shape[0]

    @property
    def width(self) -> int:
        return self._obstacles.shape[1]

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self._low, self._high

    def free_volume(self) -> float:
        return float((~self._obstacles).sum()) * self.resolution**2

    def cell_of(self, q) -> tuple[int, int]:
        """(row, col) of the cell containing point ``q`` (may lie outside the grid)."""
        q = self._state(q)
        ox, oy = self._origin
        return int(np.floor((q[1] - oy) / self.resolution)), int(np.floor((q[0] - ox) / self.resolution))

    def cell_center(self, row: int, col: int) -> np.ndarray:
        """World coordinates of the centre of cell (row, col)."""
        return self._origin + np.array([(col + 0.5) * self.resolution, (row + 0.5) * self.resolution])

    def explain_invalid(self, q) -> str:
        q = self._state(q)
        if not np.all(np.isfinite(q)):
            return "is not finite"
        (x0, y0), (x1, y1) = self._low, self._high
        if not (x0 < q[0] < x1 and y0 < q[1] < y1):
            return f"lies outside the map interior ({x0:g}, {x1:g}) x ({y0:g}, {y1:g})"
        if self.is_valid(q):
            return ""
        r, c = self.cell_of(q)
        # rows as in the map's image (row 0 at the top), which ROS maps (y_up) flip on loading
        cell = f"(row {self.image_row(r)}, col {c}{' of the map image, row 0 at its top' if self.y_up else ''})"
        if 0 <= r < self.height and 0 <= c < self.width and self._obstacles[r, c]:
            if self._walls is not None and not self._walls[r, c]:
                return f"lies within the robot radius ({self.inflation:g}) of a wall, in inflated cell {cell}"
            return f"lies in blocked cell {cell}"
        return f"touches a blocked cell or the map edge at the boundary of cell {cell}"

    def __repr__(self) -> str:
        src = f", source={self.source!r}" if self.source else ""
        org = f", origin=({self._origin[0]:g}, {self._origin[1]:g})" if self._origin.any() else ""
        up = ", y_up=True" if self.y_up else ""
        return (f"OccupancyGrid({self.height}x{self.width}, resolution={self.resolution:g}{org}{up}, "
                f"free={1 - self._obstacles.mean():.3f}{src})")


def _disc_half_widths(rc: float) -> np.ndarray:
    """``w[d]``: the largest column offset of a cell within ``rc`` cells of another ``d`` rows away (closed squares).

    Two cells ``(dr, dc)`` apart have closed squares ``hypot(max(|dc| - 1, 0), max(|dr| - 1, 0))``
    apart; the gaps are integers, so the test is exact in integer arithmetic on ``rc**2``.
    """
    r2 = rc * rc
    k = int(math.floor(rc)) + 1  # farthest row offset with a gap <= rc
    widths = np.empty(k + 1, dtype=np.int64)
    for d in range(k + 1):
        gy = max(d - 1, 0)
        room = r2 - gy * gy
        gx = int(math.isqrt(int(math.floor(room)))) if room >= 0 else -1
        while (gx + 1) ** 2 + gy * gy <= r2:  # isqrt of the floor may fall one short of a fractional r2
            gx += 1
        widths[d] = gx + 1
    return widths


@nb.njit(cache=True)
def _dilate(padded, widths, near):
    """Blocked cells grown by the cell offsets ``|dr| <= len(widths) - 1``, ``|dc| <= widths[|dr|]``.

    ``near`` is scratch of ``padded``'s shape: per row, the column distance to the nearest blocked
    cell, capped at ``widths[0] + 1`` (larger distances never matter).
    """
    H, W = padded.shape
    k = widths.shape[0] - 1
    cap = widths[0] + 1
    for r in range(H):
        last = -(cap + 1)
        for c in range(W):
            if padded[r, c]:
                last = c
            near[r, c] = min(c - last, cap)
        last = W + cap + 1
        for c in range(W - 1, -1, -1):
            if padded[r, c]:
                last = c
            near[r, c] = min(near[r, c], last - c, cap)
    out = np.zeros((H, W), dtype=np.bool_)
    for r in range(H):
        for c in range(W):
            for d in range(-k, k + 1):
                rr = r + d
                if 0 <= rr < H and near[rr, c] <= widths[abs(d)]:
                    out[r, c] = True
                    break
    return out




def resampled_shape(shape: tuple[int, int], factor: float) -> tuple[int, int]:
    """The shape ``resample_obstacles`` gives a map of ``shape`` cells at ``factor``: ``(ceil(H / factor), ceil(W /
    factor))``, at least one cell a side.
    """
    if not (math.isfinite(factor) and factor > 0):
        raise ValueError(f"factor must be a positive number of cells, got {factor!r}")
    # one part in a million absorbs the rounding of i * factor at whole numbers
    return max(1, math.ceil(shape[0] / factor - 1e-6)), max(1, math.ceil(shape[1] / factor - 1e-6))


def resample_obstacles(obstacles: np.ndarray, factor: float) -> np.ndarray:
    """The map on cells ``factor`` times as wide, conservatively: a cell is blocked where any cell it overlaps is.

    Args:
        obstacles: (H, W) bool, True = blocked.
        factor: Cells of ``obstacles`` per side of a new cell (> 0; below 1 the new cells are finer).

    Returns:
        (ceil(H / factor), ceil(W / factor)) bool. New cell (i, j) covers rows ``[i * factor, (i + 1) * factor)``
        and the columns alike; a part of it beyond the map counts as free (the map's edge is a wall anyway).
        A gap narrower than a new cell can close; a wall never opens.
    """
    obstacles = np.asarray(obstacles, dtype=bool)
    H, W = obstacles.shape
    h, w = resampled_shape((H, W), factor)
    if float(factor).is_integer():  # whole cells to a new cell: one compiled pass, the same cells
        return block_any(np.ascontiguousarray(obstacles), int(factor))
    total = np.zeros((H + 1, W + 1), dtype=np.int64)
    total[1:, 1:] = obstacles.cumsum(0).cumsum(1)

    def spans(n: int, size: int) -> tuple[np.ndarray, np.ndarray]:
        i = np.arange(n)
        lo = np.clip(np.floor(i * factor + 1e-6).astype(np.int64), 0, size)
        hi = np.clip(np.ceil((i + 1) * factor - 1e-6).astype(np.int64), 0, size)
        return lo, np.maximum(hi, np.minimum(lo + 1, size))

    r0, r1 = spans(h, H)
    c0, c1 = spans(w, W)
    count = total[r1][:, c1] - total[r0][:, c1] - total[r1][:, c0] + total[r0][:, c0]
    return count > 0
