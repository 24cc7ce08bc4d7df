"""ROS map_server maps: a ``map.yaml`` and its image, read as ROS reads them, in metres and y up.

The YAML is parsed by a small reader of the subset map_server writes (flat ``key: value`` lines,
``#`` comments, quoted or bare strings, numbers, booleans and one-line ``[a, b, c]`` lists), so
SamplerGym needs no YAML library and nothing in the file is ever evaluated.

Pixels are classified as ROS map_server does (ROS 1 ``image_loader`` and ROS 2 ``nav2_map_server``):
with ``x`` the pixel's colour channels averaged (alpha excluded) on a 0..255 scale,
``p = (255 - x) / 255`` (``p = x / 255`` if ``negate``), and

* ``trinary`` (default): occupied if ``p > occupied_thresh``, free if ``p < free_thresh``, else unknown;
* ``scale``: the same, and transparent pixels (alpha below 255) are unknown; the graded values in
  between the thresholds are neither free nor occupied, so they are treated as unknown here;
* ``raw``: ``x`` (after ``negate``) is the occupancy value itself: 0..100 is a probability in
  percent, classified by the thresholds as above, and anything above 100 (255 is ROS's -1) is unknown.

Unknown cells are blocked by default (``unknown="free"`` makes them free). ``origin`` is the
lower-left pixel's corner, so the image rows are flipped: grid row 0 is the image's bottom row and
world coordinates are the map frame's (metres, y up), as read off RViz. A non-zero ``origin`` yaw is
refused: a rotated map would need a rotated grid; rotate the image instead.
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

import numpy as np

from planners.base.fileio import InputError
from planners.maps.readers import image_levels, open_image
from planners.worlds.grid import OccupancyGrid

MODES = ("trinary", "scale", "raw")
UNKNOWN_CHOICES = ("blocked", "free")
_REQUIRED = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh")
_NUMBER = re.compile(r"[+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?")
_SPECIAL = {".inf": math.inf, "+.inf": math.inf, "-.inf": -math.inf, ".nan": math.nan}  # YAML's spellings


def parse_map_yaml(path: str | os.PathLike) -> dict:
    """The ``key: value`` pairs of a map_server YAML file, values as str, float, bool or list.

    Raises:
        InputError: The file is not UTF-8, a line is not ``key: value``, a key is repeated, or a
            list or quoted string is malformed; the message names the file and line.
    """
    path = Path(path)
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not a UTF-8 text file (byte {exc.start} is {raw[exc.start]:#x}); "
                         f"expected a ROS map_server map.yaml") from None
    out: dict = {}
    for lineno, line in enumerate(text.splitlines(), start=1):
        body = _strip_comment(line).strip()
        if not body or body in ("---", "..."):
            continue
        key, sep, value = body.partition(":")
        key = key.strip()
        if not sep or not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", key) or line[:1].isspace():
            raise InputError(f"{path}, line {lineno}: expected a top-level 'key: value' line of a ROS map.yaml, "
                             f"got {line.strip()!r}")
        if key in out:
            raise InputError(f"{path}, line {lineno}: '{key}' is given twice")
        out[key] = _value(value.strip(), path, lineno, key)
    return out


def _strip_comment(line: str) -> str:
    quote = None
    for i, ch in enumerate(line):
        if quote:
            if ch == quote:
                quote = None
        elif ch in "'\"":
            quote = ch
        elif ch == "#" and (i == 0 or line[i - 1].isspace()):
            return line[:i]
    return line


def _value(text: str, path: Path, lineno: int, key: str):
    where = f"{path}, line {lineno}: '{key}'"
    if text.startswith("["):
        if not text.endswith("]"):
            raise InputError(f"{where} starts a list '[' that does not end with ']' on the same line: {text!r}")
        inner = text[1:-1].strip()
        return [] if not inner else [_value(item.strip(), path, lineno, key) for item in inner.split(",")]
    if text[:1] in ("'", '"'):
        if len(text) < 2 or text[-1] != text[0]:
            raise InputError(f"{where} has an unterminated quoted string: {text!r}")
        return text[1:-1]
    if text.lower() in ("true", "yes", "on"):
        return True
    if text.lower() in ("false", "no", "off"):
        return False
    if _NUMBER.fullmatch(text):
        return float(text)
    if text.lower() in _SPECIAL:
        return _SPECIAL[text.lower()]
    if text[:1] in "{&*!|>%@`":
        raise InputError(f"{where}: unsupported YAML value {text!r}; a ROS map.yaml holds plain values")
    return text


def _number(meta: dict, key: str, path: Path) -> float:
    v = meta[key]
    if isinstance(v, bool) or not isinstance(v, float) or not math.isfinite(v):
        raise InputError(f"{path}: '{key}' must be a finite number, got {v!r}")
    return v


def read_ros_yaml(path: str | os.PathLike) -> dict:
    """The validated fields of a map.yaml: image (a Path), resolution, origin (x, y), negate, thresholds, mode.

    Raises:
        InputError: A field is missing or has a value map_server would not accept (named in the message).
    """
    path = Path(path)
    meta = parse_map_yaml(path)
    missing = [k for k in _REQUIRED if k not in meta]
    if missing:
        raise InputError(f"{path}: a ROS map.yaml needs {', '.join(_REQUIRED)}; missing {', '.join(missing)}")
    image = meta["image"]
    if not isinstance(image, str) or not image.strip():
        raise InputError(f"{path}: 'image' must be a file name, got {image!r}")
    image_path = Path(image.strip())
    if not image_path.is_absolute():
        image_path = path.parent / image_path
    res = _number(meta, "resolution", path)
    if res <= 0:
        raise InputError(f"{path}: 'resolution' must be positive (metres per pixel), got {res}")
    origin = meta["origin"]
    if (not isinstance(origin, list) or len(origin) != 3
            or not all(isinstance(v, float) and math.isfinite(v) for v in origin)):
        raise InputError(f"{path}: 'origin' must be [x, y, yaw], three finite numbers, got {origin!r}")
    if origin[2] != 0.0:
        raise InputError(f"{path}: 'origin' yaw is {origin[2]:g} rad; only yaw 0 is supported (a rotated map "
                         f"would need a rotated grid): rotate the image and set yaw to 0")
    negate = meta["negate"]
    if isinstance(negate, float) and negate in (0.0, 1.0):
        negate = bool(negate)
    if not isinstance(negate, bool):
        raise InputError(f"{path}: 'negate' must be 0 or 1 (or true/false), got {negate!r}")
    occ = _number(meta, "occupied_thresh", path)
    free = _number(meta, "free_thresh", path)
    for key, v in (("occupied_thresh", occ), ("free_thresh", free)):
        if not 0.0 <= v <= 1.0:
            raise InputError(f"{path}: '{key}' must lie in [0, 1], got {v:g}")
    if free > occ:
        raise InputError(f"{path}: 'free_thresh' ({free:g}) must not exceed 'occupied_thresh' ({occ:g})")
    mode = meta.get("mode", "trinary")
    if mode not in MODES:
        raise InputError(f"{path}: 'mode' must be one of {', '.join(MODES)}, got {mode!r}")
    return dict(image=image_path, resolution=res, origin=(origin[0], origin[1]), negate=negate,
                occupied_thresh=occ, free_thresh=free, mode=mode)


def ros_occupancy(path: str | os.PathLike, *, max_pixels: int | None = None) -> tuple[np.ndarray, dict]:
    """The map as ROS sees it: (H, W) int8 in ROS's row order flipped to y up: 100 occupied, 0 free, -1 unknown.

    Returns:
        ``(occupancy, fields)``: row 0 of ``occupancy`` is the image's bottom row; ``fields`` is
        ``read_ros_yaml(path)``.
    """
    path = Path(path)
    fields = read_ros_yaml(path)
    image = fields["image"]
    if not image.is_file():
        if image.is_dir():
            raise InputError(f"{path}: 'image' names {str(image)!r}, which is a folder, expected an image file")
        if image.exists():
            raise InputError(f"{path}: 'image' names {str(image)!r}, which is not a regular file (a device or a "
                             "pipe?), expected an image file")
        raise InputError(f"{path}: 'image' names {str(image)!r}, which does not exist "
                         "(relative names are read from the yaml's folder)")
    apply, alpha = _pixels(image, max_pixels)
    negate, mode = fields["negate"], fields["mode"]
    occ, free = fields["occupied_thresh"], fields["free_thresh"]

    def classify(x: np.ndarray) -> np.ndarray:
        if negate:
            x = 255.0 - x
        out = np.full(x.shape, -1, dtype=np.int8)
        if mode == "raw":
            value = np.rint(x)
            known = value <= 100
            p = value / 100.0
        else:
            known = True
            p = (255.0 - x) / 255.0
        out[known & (p > occ)] = 100
        out[known & (p < free)] = 0
        return out

    occupancy = apply(classify)
    if mode == "scale" and alpha is not None:
        occupancy[alpha < 255] = -1
    return occupancy[::-1].copy(), fields


def _pixels(image: Path, max_pixels: int | None):
    """``(x, alpha)``: each pixel's colour average on 0..255 and its alpha (0..255, or None if opaque).

    ``x`` is a callable ``x(f)`` applying ``f`` to the averages elementwise: 8-bit images go through a
    lookup table over the channel sums, so a large map never becomes a float array.
    """
    with open_image(image, max_pixels) as img:
        levels = image_levels(img, image)  # 16-bit and float images
        if levels is not None:
            values, white = levels
            x = values * (255.0 / white)
            return (lambda f: f(x)), None
        try:
            mode = img.mode
            if mode == "P":
                img = img.convert("RGBA" if "transparency" in img.info else "RGB")
            elif mode not in ("L", "LA", "RGB", "RGBA"):
                img = img.convert("RGBA" if "A" in mode else "RGB")
            arr = np.asarray(img)
        except (OSError, ValueError) as exc:
            raise InputError(f"cannot read {image} as an image: {exc}") from None
    has_alpha = img.mode in ("LA", "RGBA")
    alpha = arr[..., -1] if has_alpha else None
    if arr.ndim == 2:
        sums, n = arr, 1
    else:
        colour = arr[..., :-1] if has_alpha else arr
        n = colour.shape[2]
        sums = colour.sum(axis=2, dtype=np.uint16) if n > 1 else colour[..., 0]
    table_x = np.arange(255 * n + 1, dtype=np.float64) / n
    return (lambda f: f(table_x)[sums]), alpha


def load_ros_map(path: str | os.PathLike, *, unknown: str = "blocked", max_pixels: int | None = None) -> OccupancyGrid:
    """Load a ROS map_server ``map.yaml`` as an ``OccupancyGrid`` in the map frame (metres, y up).

    Args:
        path: The map.yaml; its ``image`` is read relative to the yaml's folder.
        unknown: ``"blocked"`` (default) or ``"free"``: how unknown cells are treated.
        max_pixels: Largest image accepted, in pixels (see ``planners.maps.readers.max_pixels_limit``).

    Raises:
        FileNotFoundError: ``path`` does not exist.
        InputError: The yaml or its image is malformed (the message names the file and the value).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"ROS map {str(path)!r} does not exist")
    if unknown not in UNKNOWN_CHOICES:
        raise InputError(f"unknown must be one of {UNKNOWN_CHOICES}, got {unknown!r}")
    occupancy, fields = ros_occupancy(path, max_pixels=max_pixels)
    blocked = (occupancy == 100) | ((occupancy == -1) if unknown == "blocked" else False)
    return OccupancyGrid(blocked, fields["resolution"], origin=fields["origin"], y_up=True, source=str(path))
