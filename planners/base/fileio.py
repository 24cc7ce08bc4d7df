"""Safe file handling shared by every layer: atomic writes and the library's input error.

Every output SamplerGym writes (results, pictures, checkpoints, exported paths) goes through
:func:`atomic_path`, so a crash, a kill or a full disk never leaves a half-written file, and every
file gets the permissions the user's umask gives an ordinary new file.
"""

from __future__ import annotations

import math
import numbers
import os
import secrets
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


class InputError(ValueError):
    """A file or argument handed to SamplerGym is invalid; the message names it and what was expected.

    A subclass of ``ValueError``, so code that catches ``ValueError`` keeps working.
    """


@contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success move it onto ``path``, else delete it.

    The caller writes the temporary file in any way it likes (``open``, ``np.save``, ``model.save``,
    a Pillow or matplotlib writer). It is flushed to disk before the rename, so a power cut leaves
    either the old file or the new one, never an empty or partial one.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # pid + random token: unique across threads and processes; the leading dot hides it from globs.
    # The suffix is kept, since some writers (Pillow, matplotlib, np.save) choose the format by it.
    tmp = path.with_name(f".{path.stem}.{os.getpid()}-{secrets.token_hex(4)}.tmp{path.suffix}")
    try:
        yield tmp
        with open(tmp, "rb+") as f:
            os.fsync(f.fileno())
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (see :func:`atomic_path`)."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically (see :func:`atomic_path`)."""
    atomic_write_bytes(path, text.encode("utf-8"))


def check_int(value, name: str, *, low: int = 1) -> int:
    """``value`` as an ``int`` (bools refused) that is at least ``low``, or an ``InputError`` naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < low:
        want = {0: "a non-negative integer", 1: "a positive integer"}.get(low, f"an integer >= {low}")
        raise InputError(f"{name} must be {want}, got {value!r}")
    return int(value)


def check_int_flags(args, names, *, low: int = 1) -> None:
    """:func:`check_int` on each named attribute of parsed ``argparse`` args, naming its flag (``a_b`` -> ``--a-b``)."""
    for name in names:
        check_int(getattr(args, name), f"--{name.replace('_', '-')}", low=low)


def check_number(source, key: str, value, *, integer: bool = False, low: float | None = None,
                 high: float | None = None, low_open: bool = False) -> float | int:
    """``value`` as a finite number within bounds, or an ``InputError`` naming ``source`` (file or flag) and ``key``."""
    ok = isinstance(value, numbers.Integral if integer else numbers.Real)
    if isinstance(value, bool) or not ok or not math.isfinite(value):
        raise InputError(f"{source}: {key} = {value!r}, expected a finite {'integer' if integer else 'number'}")
    if (low is not None and (value <= low if low_open else value < low)) or (high is not None and value > high):
        lo = "" if low is None else f"{'>' if low_open else '>='} {low:g}"
        hi = "" if high is None else f"<= {high:g}"
        raise InputError(f"{source}: {key} = {value!r}, expected a number {' and '.join(s for s in (lo, hi) if s)}")
    return value
