"""The 2-D occupancy map: from a numpy array, an image file, or a MovingAI ``.map`` file."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from planners import _geometry
from planners._space import SPACE_RN
from planners.world import WorldBase

#: Image suffixes ``OccupancyGrid.from_file`` reads with Pillow.
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".gif", ".tif", ".tiff", ".webp", ".pgm", ".ppm")

#: MovingAI terrain characters; '.', 'G', 'S' are passable, '@', 'O', 'T', 'W' blocked (see
#: ../shared/maps/README.md: water is "not passable from terrain", so it is blocked here).
MOVINGAI_FREE = frozenset(".GS")
MOVINGAI_BLOCKED = frozenset("@OTW")


class OccupancyGrid(WorldBase):
    """A 2-D occupancy map (True = obstacle), the one map type of SamplerGym.

    World coordinates: ``x`` is the column and ``y`` the row (y grows downwards, as in images and
    MovingAI maps); cell ``(r, c)`` covers ``[c, c+1) x [r, r+1)`` times ``resolution``. Everything
    outside the grid is blocked.

    Collision checking is exact: a motion is valid only if the segment meets no blocked cell,
    boundary included (cells are treated as closed sets, so a path never squeezes between two
    diagonally touching obstacles or grazes a corner), found by enumerating every cell the segment
    touches. A state is a zero-length motion.

    Args:
        obstacles: (H, W) array; bool, or integers/floats holding only 0 and 1.
        resolution: Side length of a cell in world units (> 0).
        source: Where the map came from, quoted in error messages.
    """

    dim = 2
    space_kind = SPACE_RN
    metrics = ("euclidean", "manhattan", "chebyshev")

    def __init__(self, obstacles, resolution: float = 1.0, *, source: str | None = None) -> None:
        where = f" (from {source})" if source else ""
        try:
            arr = np.asarray(obstacles)
        except Exception as exc:  # ragged lists and the like
            raise ValueError(f"obstacles{where} must be a 2-D array, got {type(obstacles).__name__}: {exc}") from None
        if arr.ndim != 2:
            raise ValueError(f"obstacles{where} must be a 2-D (H, W) array, got shape {arr.shape}")
        if arr.size == 0:
            raise ValueError(f"obstacles{where} is empty (shape {arr.shape}); a map needs at least one cell")
        if arr.dtype != np.bool_:
            if not (np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)):
                raise ValueError(f"obstacles{where} must be bool or numeric 0/1, got dtype {arr.dtype}")
            bad = ~np.isin(arr, (0, 1))
            if bad.any():
                r, c = np.argwhere(bad)[0]
                raise ValueError(
                    f"obstacles{where} must hold only 0/1 (or bool); found {arr[r, c]!r} at row {r}, col {c}"
                )
            arr = arr.astype(bool)
        resolution = float(resolution)
        if not np.isfinite(resolution) or resolution <= 0:
            raise ValueError(f"resolution must be a positive finite number, got {resolution}")
        self._obstacles = np.array(arr, dtype=bool, copy=True)
        self._obstacles.flags.writeable = False
        self.resolution = resolution
        self.source = source
        _, geom, body = _geometry.placeholder_arrays()
        grid_u8 = np.ascontiguousarray(self._obstacles, dtype=np.uint8)
        self._kernel = (_geometry.WORLD_GRID, grid_u8, geom, body, np.array([1.0 / resolution]))
        self._low = np.zeros(2)
        self._high = np.array([self.width * resolution, self.height * resolution])
        self._low.flags.writeable = False
        self._high.flags.writeable = False

    # --- construction from files -------------------------------------------------------------

    @classmethod
    def from_image(
        cls, path: str | os.PathLike, threshold: float = 0.5, resolution: float = 1.0, invert: bool = False
    ) -> OccupancyGrid:
        """Load a PNG/JPG/BMP map: pixels darker than ``threshold`` (0..1 gray) are obstacles.

        Transparent pixels count as white (free). ``invert=True`` makes light pixels obstacles.
        """
        from PIL import Image, UnidentifiedImageError  # Pillow ships with matplotlib

        path = Path(path)
        if not (0.0 < float(threshold) < 1.0):
            raise ValueError(f"threshold must lie in (0, 1), got {threshold}")
        if not path.is_file():
            raise FileNotFoundError(f"map image {path} does not exist")
        try:
            with Image.open(path) as img:
                img.load()
                if img.mode in ("RGBA", "LA", "PA") or (img.mode == "P" and "transparency" in img.info):
                    rgba = img.convert("RGBA")
                    white = Image.new("RGBA", rgba.size, (255, 255, 255, 255))
                    img = Image.alpha_composite(white, rgba)
                gray = np.asarray(img.convert("L"), dtype=np.float64) / 255.0
        except (UnidentifiedImageError, OSError) as exc:
            raise ValueError(f"cannot read {path} as an image: {exc}") from None
        obstacles = gray < threshold
        if invert:
            obstacles = ~obstacles
        return cls(obstacles, resolution, source=str(path))

    @classmethod
    def from_file(cls, path: str | os.PathLike, threshold: float = 0.5, resolution: float = 1.0,
                  invert: bool = False) -> OccupancyGrid:
        """Load any map file, by suffix: an image (``from_image``), a MovingAI ``.map``, or a ``.npy`` array.

        Raises:
            FileNotFoundError: ``path`` does not exist.
            ValueError: The file is not a readable map of a known kind (the message names the file).
        """
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"map file {str(path)!r} does not exist" if not path.exists()
                                    else f"map path {str(path)!r} is not a file")
        suffix = path.suffix.lower()
        if suffix == ".map":
            return cls.from_movingai(path, resolution)
        if suffix == ".npy":
            try:
                arr = np.load(path, allow_pickle=False)
            except (ValueError, OSError) as exc:
                raise ValueError(f"cannot read {str(path)!r} as a numpy array: {exc}") from None
            grid = cls(arr, resolution, source=str(path))
            return cls(~grid.obstacles, resolution, source=str(path)) if invert else grid
        if suffix not in IMAGE_SUFFIXES:
            raise ValueError(f"map file {str(path)!r}: unknown kind {suffix or '(no suffix)'!r}; "
                             f"use an image ({', '.join(IMAGE_SUFFIXES)}), a MovingAI .map or a .npy array")
        return cls.from_image(path, threshold=threshold, resolution=resolution, invert=invert)

    @classmethod
    def from_movingai(cls, path: str | os.PathLike, resolution: float = 1.0) -> OccupancyGrid:
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
            raise ValueError(f"{path}: not an ASCII MovingAI map (byte {exc.start} is {raw[exc.start]:#x})") from None
        lines = text.splitlines()
        return cls(_parse_movingai(lines, path), resolution, source=str(path))

    # --- geometry ------------------------------------------------------------------------------

    @property
    def obstacles(self) -> np.ndarray:
        """(H, W) read-only bool array, True = obstacle."""
        return self._obstacles

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
        return int(np.floor(q[1] / self.resolution)), int(np.floor(q[0] / self.resolution))

    def cell_center(self, row: int, col: int) -> np.ndarray:
        """World coordinates of the centre of cell (row, col)."""
        return np.array([(col + 0.5) * self.resolution, (row + 0.5) * self.resolution])

    def explain_invalid(self, q) -> str:
        q = self._state(q)
        if not np.all(np.isfinite(q)):
            return "is not finite"
        w, h = self._high
        if not (0.0 < q[0] < w and 0.0 < q[1] < h):
            return f"lies outside the map interior (0, {w:g}) x (0, {h:g})"
        if self.is_valid(q):
            return ""
        r, c = self.cell_of(q)
        if 0 <= r < self.height and 0 <= c < self.width and self._obstacles[r, c]:
            return f"lies in blocked cell (row {r}, col {c})"
        return f"touches a blocked cell or the map edge at the boundary of cell (row {r}, col {c})"

    def __repr__(self) -> str:
        src = f", source={self.source!r}" if self.source else ""
        return (f"OccupancyGrid({self.height}x{self.width}, resolution={self.resolution:g}, "
                f"free={1 - self._obstacles.mean():.3f}{src})")


def _parse_movingai(lines: list[str], path: Path) -> np.ndarray:
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
            raise ValueError(f"{path}, line {i}: expected 'type', 'height', 'width' or 'map', got {line!r}")
        header[key] = value.strip()
    else:
        raise ValueError(f"{path}: no 'map' line found; not a MovingAI .map file")
    dims = {}
    for key in ("height", "width"):
        if key not in header:
            raise ValueError(f"{path}: header has no '{key}' line")
        try:
            dims[key] = int(header[key])
        except ValueError:
            raise ValueError(f"{path}: '{key}' must be an integer, got {header[key]!r}") from None
        if dims[key] <= 0:
            raise ValueError(f"{path}: '{key}' must be positive, got {dims[key]}")
    H, W = dims["height"], dims["width"]
    rows = lines[i : i + H]
    if len(rows) < H:
        raise ValueError(f"{path}: header says height {H} but only {len(rows)} map rows follow (from line {i + 1})")
    extra = [j for j, line in enumerate(lines[i + H :], start=i + H + 1) if line.strip()]
    if extra:
        raise ValueError(f"{path}, line {extra[0]}: unexpected content after the {H} map rows")
    grid = np.empty((H, W), dtype=bool)
    allowed = MOVINGAI_FREE | MOVINGAI_BLOCKED
    for r, row in enumerate(rows):
        lineno = i + r + 1
        if len(row) != W:
            raise ValueError(f"{path}, line {lineno}: map row {r} has {len(row)} characters, header says width {W}")
        for c, ch in enumerate(row):
            if ch not in allowed:
                raise ValueError(
                    f"{path}, line {lineno}, column {c + 1}: unknown terrain {ch!r} "
                    f"(expected one of {''.join(sorted(allowed))})"
                )
        grid[r] = [ch in MOVINGAI_BLOCKED for ch in row]
    return grid
