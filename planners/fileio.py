"""Safe file handling shared by every layer: atomic writes and the library's input error.

Every output SamplerGym writes (results, pictures, checkpoints, exported paths) goes through
:func:`atomic_path`, so a crash, a kill or a full disk never leaves a half-written file, and every
file gets the permissions the user's umask gives an ordinary new file.
"""

from __future__ import annotations

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
