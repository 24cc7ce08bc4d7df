"""The 2-D occupancy map: from a numpy array, an image file, a MovingAI ``.map`` or a ROS ``map.yaml``."""

from __future__ import annotations

import math
import os
import threading
import warnings
from pathlib import Path

import numba as nb
import numpy as np

from planners.base.fileio import InputError, check_int
from planners.base.world import WorldBase
from planners.kernels import geometry
from planners.kernels.space import SPACE_RN

#: Image suffixes ``OccupancyGrid.from_file`` reads with Pillow.
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".gif", ".tif", ".tiff", ".webp", ".pgm", ".ppm")

#: Suffixes of ROS map_server map descriptions (see ``planners.maps.rosmap``).
ROS_SUFFIXES = (".yaml", ".yml")

#: MovingAI terrain characters; '.', 'G', 'S' are passable, '@', 'O', 'T', 'W' blocked (see
#: ../shared/maps/README.md: water is "not passable from terrain", so it is blocked here).
MOVINGAI_FREE = frozenset(".GS")
MOVINGAI_BLOCKED = frozenset("@OTW")

#: Largest map (cells) a loader accepts unless told otherwise: 10^8 cells, e.g. 10,000 x 10,000.
#: Loading a PNG peaks at about 5 bytes per cell (8000 x 8000: 0.47 GB with the interpreter), and a
#: ``robot_radius`` adds about 4 more; raise the limit with ``max_pixels=`` or ``SAMPLERGYM_MAX_PIXELS``.
DEFAULT_MAX_PIXELS = 100_000_000
MAX_PIXELS_ENV = "SAMPLERGYM_MAX_PIXELS"

# Pillow's own decompression-bomb limit is process-global; it is lifted only while a header is read
# under our own limit, and this lock keeps concurrent loads from seeing each other's setting.
_PIL_LOCK = threading.Lock()


def max_pixels_limit(max_pixels: int | None = None) -> int:
    """The cell limit in force: ``max_pixels`` if given, else ``$SAMPLERGYM_MAX_PIXELS``, else the default."""
    if max_pixels is None:
        env = os.environ.get(MAX_PIXELS_ENV)
        if env is None or not env.strip():
            return DEFAULT_MAX_PIXELS
        try:
            value = int(env.strip().replace("_", ""))
        except ValueError:
            raise InputError(f"environment variable {MAX_PIXELS_ENV}={env!r} must be a positive integer "
                             f"number of pixels") from None
        if value <= 0:
            raise InputError(f"environment variable {MAX_PIXELS_ENV}={env!r} must be a positive integer")
        return value
    return check_int(max_pixels, "max_pixels")


def check_map_size(path, width: int, height: int, max_pixels: int | None = None) -> None:
    """Refuse a ``width`` x ``height`` map from ``path`` above the cell limit, before anything is decoded."""
    limit = max_pixels_limit(max_pixels)
    if width * height > limit:
        raise InputError(
            f"{path}: the map is {width} x {height} = {width * height:,} pixels, more than the limit of "
            f"{limit:,}; loading it needs about {5 * width * height / 1e9:.1f} GB of memory. If that is "
            f"intended, pass max_pixels={width * height} or set {MAX_PIXELS_ENV}={width * height}"
        )


def open_image(path: Path, max_pixels: int | None = None):
    """Open and decode an image with Pillow, refusing it from its header if it has too many pixels.

    Returns:
        The loaded ``PIL.Image.Image``.

    Raises:
        InputError: Not an image Pillow can read, or over the pixel limit (checked before decoding).
    """
    from PIL import Image, UnidentifiedImageError  # Pillow ships with matplotlib

    bomb = Image.DecompressionBombError
    limit = max_pixels_limit(max_pixels)
    try:
        with _PIL_LOCK, warnings.catch_warnings():
            # our own limit replaces Pillow's (which raises DecompressionBombError at twice its default)
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            saved, Image.MAX_IMAGE_PIXELS = Image.MAX_IMAGE_PIXELS, None
            try:
                img = Image.open(path)
            finally:
                Image.MAX_IMAGE_PIXELS = saved
        try:
            check_map_size(path, *img.size, max_pixels=limit)
            img.load()
        except BaseException:
            img.close()
            raise
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError, EOFError, bomb) as exc:
        if isinstance(exc, InputError):
            raise
        raise InputError(f"cannot read {path} as an image: {exc}") from None
    return img


def image_levels(img, path) -> tuple[np.ndarray, float] | None:
    """``(values, white)`` of a 16-bit or float single-channel image: gray level = ``values / white``.

    16-bit images (``I;16*``, and ``I`` whose values fit 16 bits) have ``white`` 65535; float
    images (``F``) must hold levels in [0, 1] (``white`` 1). Other modes (8-bit, colour, palette)
    return None: Pillow converts those to 8-bit gray without loss of range.
    """
    mode = img.mode
    if mode.startswith("I;16") or mode == "I":
        arr = np.asarray(img)
        if arr.size and (int(arr.min()) < 0 or int(arr.max()) > 65535):
            raise InputError(f"{path}: 32-bit integer image with values {int(arr.min())}..{int(arr.max())}; "
                             f"expected 8- or 16-bit gray levels (0..65535)")
        return arr.astype(np.uint16, copy=False), 65535.0
    if mode == "F":
        arr = np.asarray(img, dtype=np.float64)
        if not np.all(np.isfinite(arr)):
            raise InputError(f"{path}: float image holds NaN or infinite values; expected gray levels in [0, 1]")
        lo, hi = float(arr.min()), float(arr.max())
        if lo < 0.0 or hi > 1.0:
            raise InputError(f"{path}: float image with values {lo:g}..{hi:g}; expected gray levels in [0, 1] "
                             f"(0 black = obstacle, 1 white = free); rescale it or save it as 8- or 16-bit")
        return arr, 1.0
    return None


def _below(values: np.ndarray, white: float, threshold: float) -> np.ndarray:
    """``values / white < threshold`` elementwise; integer images go through a lookup table (no float copy)."""
    if np.issubdtype(values.dtype, np.integer):
        table = np.arange(int(white) + 1, dtype=np.float64) / white < threshold
        return table[values]
    return values / white < threshold


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
        self._kernel = (geometry.WORLD_GRID, grid_u8, geom, body, np.array([1.0 / resolution, org[0], org[1]]))
        self._origin = org
        self._low = org.copy()
        self._high = org + np.array([self.width * resolution, self.height * resolution])
        for a in (self._origin, self._low, self._high):
            a.flags.writeable = False

    # --- construction from files -------------------------------------------------------------

    @classmethod
    def from_image(
        cls, path: str | os.PathLike, threshold: float = 0.5, resolution: float = 1.0, invert: bool = False,
        *, max_pixels: int | None = None,
    ) -> OccupancyGrid:
        """Load a PNG/JPG/BMP/TIFF map: pixels darker than ``threshold`` (0..1 gray) are obstacles.

        Gray levels are scaled by the image's own range: 8-bit by 255, 16-bit by 65535; float images
        must hold levels in [0, 1]. Transparent pixels count as white (free). ``invert=True`` makes
        light pixels obstacles. Images over ``max_pixels`` (see ``max_pixels_limit``) are refused
        from their header, before decoding.
        """
        path = Path(path)
        try:
            ok = 0.0 < float(threshold) < 1.0
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise InputError(f"threshold must lie in (0, 1), got {threshold!r}")
        if not path.is_file():
            raise FileNotFoundError(f"map image {path} does not exist")
        from PIL import Image

        with open_image(path, max_pixels) as img:
            levels = image_levels(img, path)
            if levels is None:
                try:
                    if img.mode in ("RGBA", "LA", "PA") or (img.mode == "P" and "transparency" in img.info):
                        rgba = img.convert("RGBA")
                        white = Image.new("RGBA", rgba.size, (255, 255, 255, 255))
                        img = Image.alpha_composite(white, rgba)
                    levels = np.asarray(img.convert("L")), 255.0
                except (OSError, ValueError) as exc:
                    raise InputError(f"cannot read {path} as an image: {exc}") from None
        obstacles = _below(*levels, float(threshold))
        if invert:
            obstacles = ~obstacles
        return cls(obstacles, resolution, source=str(path))

    @classmethod
    def from_file(cls, path: str | os.PathLike, threshold: float = 0.5, resolution: float = 1.0,
                  invert: bool = False, *, robot_radius: float = 0.0, unknown: str = "blocked",
                  max_pixels: int | None = None) -> OccupancyGrid:
        """Load any map file, by suffix: an image, a MovingAI ``.map``, a ``.npy`` array or a ROS ``map.yaml``.

        A ROS ``map.yaml`` (``planners.maps.rosmap.load_ros_map``) brings its own resolution, origin and
        thresholds, so ``threshold``, ``resolution`` and ``invert`` must keep their defaults for it;
        its unknown cells are blocked unless ``unknown="free"``.

        Args:
            path: The map file.
            threshold: Gray level (0..1) below which an image pixel is an obstacle.
            resolution: Cell size in world units (images, ``.map``, ``.npy``).
            invert: Swap obstacles and free space (images, ``.npy``).
            robot_radius: Inflate the obstacles by a disc of this radius in world units (``inflate``).
            unknown: ``"blocked"`` or ``"free"``: how ROS unknown cells are treated.
            max_pixels: Largest map accepted, in cells (default ``max_pixels_limit()``).

        Raises:
            FileNotFoundError: ``path`` does not exist.
            InputError: The file is not a readable map of a known kind (the message names the file).
        """
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"map file {str(path)!r} does not exist" if not path.exists()
                                    else f"map path {str(path)!r} is not a file")
        suffix = path.suffix.lower()
        if suffix in ROS_SUFFIXES:
            from planners.maps.rosmap import load_ros_map

            changed = [f"{k}={v!r}" for k, v, d in (("threshold", threshold, 0.5), ("resolution", resolution, 1.0),
                                                   ("invert", invert, False)) if v != d]
            if changed:
                raise InputError(f"{path}: a ROS map.yaml sets its own thresholds, resolution and negate; "
                                 f"{', '.join(changed)} cannot be applied to it")
            grid = load_ros_map(path, unknown=unknown, max_pixels=max_pixels)
        elif suffix == ".map":
            grid = cls.from_movingai(path, resolution, max_pixels=max_pixels)
        elif suffix == ".npy":
            try:
                arr = np.load(path, allow_pickle=False, mmap_mode="r")
                if arr.ndim == 2:
                    check_map_size(path, arr.shape[1], arr.shape[0], max_pixels)
                arr = np.array(arr)
            except InputError:
                raise
            except (ValueError, OSError, EOFError) as exc:
                raise InputError(f"cannot read {str(path)!r} as a numpy array: {exc}") from None
            grid = cls(arr, resolution, source=str(path))
            grid = cls(~grid.obstacles, resolution, source=str(path)) if invert else grid
        elif suffix in IMAGE_SUFFIXES:
            grid = cls.from_image(path, threshold=threshold, resolution=resolution, invert=invert,
                                  max_pixels=max_pixels)
        else:
            raise InputError(f"map file {str(path)!r}: unknown kind {suffix or '(no suffix)'!r}; use an image "
                             f"({', '.join(IMAGE_SUFFIXES)}), a MovingAI .map, a .npy array or a ROS map.yaml")
        return grid.inflate(robot_radius) if robot_radius else grid

    @classmethod
    def from_movingai(cls, path: str | os.PathLike, resolution: float = 1.0, *,
                      max_pixels: int | None = None) -> OccupancyGrid:
        """Load a MovingAI ``.map`` file (``type``/``height``/``width``/``map`` header, then rows).

        Accepts LF and CRLF line endings and a missing final newline. Errors name the line.
        """
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"MovingAI map {path} does not exist")
        raw = path.read_bytes()
        try:
            text = raw.decode("ascii")
        except UnicodeDecodeError as exc:
            raise InputError(f"{path}: not an ASCII MovingAI map (byte {exc.start} is {raw[exc.start]:#x})") from None
        lines = text.splitlines()
        return cls(_parse_movingai(lines, path, max_pixels), resolution, source=str(path))

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
        return OccupancyGrid(obs, self.resolution, origin=self._origin, y_up=self.y_up, source=self.source)

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
        if 0 <= r < self.height and 0 <= c < self.width and self._obstacles[r, c]:
            return f"lies in blocked cell (row {r}, col {c})"
        return f"touches a blocked cell or the map edge at the boundary of cell (row {r}, col {c})"

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


def _parse_movingai(lines: list[str], path: Path, max_pixels: int | None = None) -> np.ndarray:
    header: dict[str, str] = {}
    i = 0
    while i < len(lines):
        line = lines[i].strip()
        i += 1
        if not line:
            continue
        key, _, value = line.partition(" ")
        key = key.lower()
        if key == "map":
            break
        if key not in ("type", "height", "width"):
            raise InputError(f"{path}, line {i}: expected 'type', 'height', 'width' or 'map', got {line!r}")
        if key in header:
            raise InputError(f"{path}, line {i}: '{key}' is given twice "
                             f"(first {header[key]!r}, again {value.strip()!r})")
        header[key] = value.strip()
    else:
        raise InputError(f"{path}: no 'map' line found; not a MovingAI .map file")
    dims = {}
    for key in ("height", "width"):
        if key not in header:
            raise InputError(f"{path}: header has no '{key}' line")
        try:
            dims[key] = int(header[key])
        except ValueError:
            raise InputError(f"{path}: '{key}' must be an integer, got {header[key]!r}") from None
        if dims[key] <= 0:
            raise InputError(f"{path}: '{key}' must be positive, got {dims[key]}")
    H, W = dims["height"], dims["width"]
    check_map_size(path, W, H, max_pixels)
    rows = lines[i : i + H]
    if len(rows) < H:
        raise InputError(f"{path}: header says height {H} but only {len(rows)} map rows follow (from line {i + 1})")
    extra = [j for j, line in enumerate(lines[i + H :], start=i + H + 1) if line.strip()]
    if extra:
        raise InputError(f"{path}, line {extra[0]}: unexpected content after the {H} map rows")
    grid = np.empty((H, W), dtype=bool)
    allowed = MOVINGAI_FREE | MOVINGAI_BLOCKED
    for r, row in enumerate(rows):
        lineno = i + r + 1
        if len(row) != W:
            raise InputError(f"{path}, line {lineno}: map row {r} has {len(row)} characters, header says width {W}")
        for c, ch in enumerate(row):
            if ch not in allowed:
                raise InputError(
                    f"{path}, line {lineno}, column {c + 1}: unknown terrain {ch!r} "
                    f"(expected one of {''.join(sorted(allowed))})"
                )
        grid[r] = [ch in MOVINGAI_BLOCKED for ch in row]
    return grid
