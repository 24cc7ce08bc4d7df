"""Map file readers: one function per format, registered by file suffix; ``read_map`` picks by suffix.

Readers turn a file into an ``OccupancyGrid``; ``OccupancyGrid.from_file`` (and ``plan.py``, the
``Files`` and ``Planning`` environments) go through ``read_map``. To read another format, write a
function ``reader(path, *, threshold, resolution, invert, unknown, max_pixels) -> OccupancyGrid``
here and decorate it with ``@register_reader(".ext", description="...")``: nothing else changes.
Every reader refuses a map over the cell limit (``max_pixels_limit``) before decoding it, and names
the file in every error.
"""

from __future__ import annotations

import os
import threading
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np

from planners.base.fileio import InputError, check_int, env_limit
from planners.worlds.grid import OccupancyGrid

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
        return env_limit(MAX_PIXELS_ENV, DEFAULT_MAX_PIXELS)
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


Reader = Callable[..., OccupancyGrid]

#: Registered readers by lower-case suffix, and a description of each format for messages.
MAP_READERS: dict[str, Reader] = {}
#: File endings of a 6-DoF problem (an OMPL.app ``.cfg``, a box ``.scene``), never a 2-D map.
SCENE_SUFFIXES = (".cfg", ".scene")
_DESCRIPTIONS: dict[Reader, str] = {}


def register_reader(*suffixes: str, description: str) -> Callable[[Reader], Reader]:
    """Register ``reader`` for files with these suffixes (``".png"``, ...); a suffix is registered once."""
    def add(reader: Reader) -> Reader:
        for suffix in suffixes:
            if not suffix.startswith(".") or suffix != suffix.lower():
                raise ValueError(f"suffixes are lower case and start with a dot, got {suffix!r}")
            if suffix in MAP_READERS:
                raise ValueError(f"{suffix} is already read by {MAP_READERS[suffix].__name__}")
            MAP_READERS[suffix] = reader
        _DESCRIPTIONS[reader] = description
        return reader
    return add


def read_map(path: str | os.PathLike, *, threshold: float = 0.5, resolution: float = 1.0, invert: bool = False,
             robot_radius: float = 0.0, unknown: str = "blocked", max_pixels: int | None = None) -> OccupancyGrid:
    """Load any map file with the reader registered for its suffix (see ``MAP_READERS``).

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
    reader = MAP_READERS.get(suffix)
    if suffix in SCENE_SUFFIXES:
        raise InputError(f"map file {str(path)!r}: a {suffix} file is a 6-DoF problem (an OMPL.app .cfg or a box "
                         f"scene), not a 2-D map; plan it with scripts/plan3d.py, or load it with "
                         f"planners.worlds.omplapp.load_omplapp or planners.worlds.rigid3d.load_scene")
    if reader is None:
        kinds = ", ".join(dict.fromkeys(_DESCRIPTIONS.values()))
        raise InputError(f"map file {str(path)!r}: unknown kind {suffix or '(no suffix)'!r}; use {kinds}")
    grid = reader(path, threshold=threshold, resolution=resolution, invert=invert, unknown=unknown,
                  max_pixels=max_pixels)
    return grid.inflate(robot_radius) if robot_radius else grid


@register_reader(*IMAGE_SUFFIXES, description=f"an image ({', '.join(IMAGE_SUFFIXES)})")
def read_image(path: str | os.PathLike, *, threshold: float = 0.5, resolution: float = 1.0, invert: bool = False,
               max_pixels: int | None = None, **_ignored) -> OccupancyGrid:
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
    return OccupancyGrid(obstacles, resolution, source=str(path))


@register_reader(".map", description="a MovingAI .map")
def read_movingai(path: str | os.PathLike, *, resolution: float = 1.0, max_pixels: int | None = None,
                  **_ignored) -> OccupancyGrid:
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
    return OccupancyGrid(_parse_movingai(text.splitlines(), path, max_pixels), resolution, source=str(path))


@register_reader(".npy", description="a .npy array")
def read_npy(path: str | os.PathLike, *, resolution: float = 1.0, invert: bool = False,
             max_pixels: int | None = None, **_ignored) -> OccupancyGrid:
    """Load a 2-D boolean-like ``.npy`` array (True = obstacle), never unpickling."""
    path = Path(path)
    try:
        arr = np.load(path, allow_pickle=False, mmap_mode="r")
        if arr.ndim == 2:
            check_map_size(path, arr.shape[1], arr.shape[0], max_pixels)
        arr = np.array(arr)
    except InputError:
        raise
    except (ValueError, OSError, EOFError) as exc:
        raise InputError(f"cannot read {str(path)!r} as a numpy array: {exc}") from None
    grid = OccupancyGrid(arr, resolution, source=str(path))
    return OccupancyGrid(~grid.obstacles, resolution, source=str(path)) if invert else grid


@register_reader(*ROS_SUFFIXES, description="a ROS map.yaml")
def read_ros(path: str | os.PathLike, *, threshold: float = 0.5, resolution: float = 1.0, invert: bool = False,
             unknown: str = "blocked", max_pixels: int | None = None) -> OccupancyGrid:
    """Load a ROS map_server ``map.yaml`` (``planners.maps.rosmap.load_ros_map``).

    It brings its own resolution, origin and thresholds, so ``threshold``, ``resolution`` and
    ``invert`` must keep their defaults; its unknown cells are blocked unless ``unknown="free"``.
    """
    from planners.maps.rosmap import load_ros_map

    changed = [f"{k}={v!r}" for k, v, d in (("threshold", threshold, 0.5), ("resolution", resolution, 1.0),
                                           ("invert", invert, False)) if v != d]
    if changed:
        raise InputError(f"{path}: a ROS map.yaml sets its own thresholds, resolution and negate; "
                         f"{', '.join(changed)} cannot be applied to it")
    return load_ros_map(path, unknown=unknown, max_pixels=max_pixels)


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
