"""Safe file handling shared by every layer: atomic writes, output sets, run locks, JSON and the input error.

Every output SamplerGym writes (results, pictures, checkpoints, exported paths) goes through
:func:`atomic_path`, so a crash, a kill or a full disk never leaves a half-written file, and every
file gets the permissions the user's umask gives an ordinary new file. Outputs that belong together
(an encoder and its description, a results table and its summary) go through :func:`output_set`,
which replaces a whole folder at once; :func:`run_lock` keeps two commands from writing one folder;
:func:`check_output_place` finds an unusable output place before any work starts.
"""

from __future__ import annotations

import ctypes
import errno
import hashlib
import json
import math
import numbers
import os
import re
import secrets
import shutil
import socket
import sys
import time
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
        raise InputError(f"{name} must be {want}, got {short_repr(value)}")
    return int(value)


def check_int_flags(args, names, *, low: int = 1) -> None:
    """:func:`check_int` on each named attribute of parsed ``argparse`` args, naming its flag (``a_b`` -> ``--a-b``)."""
    for name in names:
        check_int(getattr(args, name), f"--{name.replace('_', '-')}", low=low)


def env_limit(name: str, default: int, *, low: int = 1) -> int:
    """The integer limit in environment variable ``name`` (``_`` separators allowed), else ``default``.

    A value that is not an integer >= ``low`` is an ``InputError`` naming the variable.
    """
    env = os.environ.get(name, "").strip()
    if not env:
        return default
    try:
        value = int(env.replace("_", ""))
    except ValueError:
        value = low - 1
    if value < low:
        raise InputError(f"environment variable {name}={env!r} must be an integer >= {low}")
    return value


def check_flags(check) -> None:
    """Run a command's argument checks (``check()``); an ``InputError`` becomes one ``error:`` line and exit 2."""
    try:
        check()
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None


def check_number(source, key: str, value, *, integer: bool = False, low: float | None = None,
                 high: float | None = None, low_open: bool = False) -> float | int:
    """``value`` as a finite number within bounds, or an ``InputError`` naming ``source`` (file or flag) and ``key``."""
    ok = isinstance(value, numbers.Integral if integer else numbers.Real)
    if isinstance(value, bool) or not ok or not math.isfinite(value):
        raise InputError(f"{source}: {key} = {short_repr(value)}, expected a finite "
                         f"{'integer' if integer else 'number'}")
    if (low is not None and (value <= low if low_open else value < low)) or (high is not None and value > high):
        lo = "" if low is None else f"{'>' if low_open else '>='} {low:g}"
        hi = "" if high is None else f"<= {high:g}"
        raise InputError(f"{source}: {key} = {short_repr(value)}, expected a number "
                         f"{' and '.join(s for s in (lo, hi) if s)}")
    return value


def short_repr(value, limit: int = 80) -> str:
    """``repr(value)`` cut to about ``limit`` characters, so an error message stays one short line."""
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


# --- JSON ------------------------------------------------------------------------------------------

#: Deepest nesting of lists and objects the JSON readers accept; the project's own files nest a few levels.
MAX_JSON_DEPTH = 64


def loads_json(text: str | bytes, source: str) -> object:
    """Parse JSON from a file or entry named ``source``; every failure is an ``InputError`` naming it.

    Nesting deeper than :data:`MAX_JSON_DEPTH` is refused before parsing (Python's parser would
    otherwise escape with ``RecursionError`` on a few thousand brackets).
    """
    if isinstance(text, bytes):
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise InputError(f"{source} is not UTF-8 text: {exc}") from None
    check_json_depth(text, source)
    try:
        return json.loads(text)
    except (ValueError, RecursionError) as exc:
        raise InputError(f"{source} is not JSON: {exc}") from None


def check_json_depth(text: str, source: str) -> None:
    """Refuse JSON ``text`` nested deeper than :data:`MAX_JSON_DEPTH`: an ``InputError`` naming ``source``."""
    depth = _json_depth(text)
    if depth > MAX_JSON_DEPTH:
        raise InputError(f"{source}: JSON nested {depth} levels deep, more than the {MAX_JSON_DEPTH} accepted")


def read_json(path: str | os.PathLike, what: str = "JSON file") -> object:
    """The JSON value in ``path`` (:func:`loads_json`); an unreadable file is an ``InputError`` naming it."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"{what} {path} is not UTF-8 text: {exc}") from None
    except OSError as exc:
        raise InputError(f"cannot read {what} {path}: {exc.strerror or exc}") from None
    return loads_json(text, f"{what} {path}")


def _json_depth(text: str) -> int:
    """The deepest bracket nesting in ``text``, brackets inside strings not counted (linear time)."""
    if "[" not in text and "{" not in text:
        return 0
    depth = deepest = 0
    in_string = escaped = False
    for ch in text:
        if in_string:
            if escaped:
                escaped = False
            elif ch == "\\":
                escaped = True
            elif ch == '"':
                in_string = False
        elif ch == '"':
            in_string = True
        elif ch in "[{":
            depth += 1
            if depth > deepest:
                deepest = depth
                if deepest > MAX_JSON_DEPTH:
                    return deepest
        elif ch in "]}":
            depth -= 1
    return deepest


# --- output places ---------------------------------------------------------------------------------

#: Longest file stem made from a name (:func:`safe_file_stem`): with a suffix and the temporary name
#: :func:`atomic_path` writes first (about 30 characters more), well inside the 255 bytes of common file systems.
MAX_STEM = 120


def safe_file_stem(name: str, limit: int = MAX_STEM, *, taken: set[str] | None = None) -> str:
    """A file stem for ``name`` (a map set, a family): letters, digits, ``_.-`` only, at most ``limit`` characters.

    Other characters become ``_``; a name that does not fit is cut, and a short hash of the whole
    name added, so two long names that share their start keep two files. A stem already in ``taken``
    (compared without case) gets the hash too, and the stem is added to it. Empty: ``"unnamed"``.
    """
    stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("_.") or "unnamed"
    if len(stem) > limit or (taken is not None and stem.lower() in taken):
        digest = hashlib.sha256(name.encode("utf-8", "surrogatepass")).hexdigest()[:10]
        stem = f"{stem[:limit - len(digest) - 1]}-{digest}"
    if taken is not None:
        taken.add(stem.lower())
    return stem



#: Bytes the temporary names beside an output add to its name (``.<name>.<pid>-<token>-new.set``, the lock's
#: ``.<name>.lock.<pid>-<token>.tmp``, ``<name>.partial``).
_TEMP_DECORATION = 40


def _name_max(path: Path) -> int:
    """The longest file name (bytes) the file system under ``path`` takes; 255 where it cannot be told."""
    parent = path.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    try:
        return int(os.pathconf(parent, "PC_NAME_MAX"))
    except (OSError, ValueError, AttributeError):
        return 255


#: Endings of figure and animation files: a folder still to be made under such a name is a file name given by mistake.
FIGURE_SUFFIXES = (".png", ".gif", ".jpg", ".jpeg", ".svg", ".pdf")


def refuse_figure_name_for_folder(path: str | os.PathLike, name: str) -> None:
    """Refuse ``path``, a folder the command names its files in, where it is not there yet and ends like a figure.

    An ``InputError`` naming ``name`` (a flag): ``--out plan.png`` (``FIGURE_SUFFIXES``) would make a folder
    ``plan.png/``.
    """
    path = Path(path)
    if not path.exists() and path.suffix.lower() in FIGURE_SUFFIXES:
        raise InputError(f"{name} {path}: the folder the command writes its files into (it names them), but the "
                         f"name ends in {path.suffix} like a file's; give a folder")


def check_output_place(path: str | os.PathLike, name: str, *, folder: bool = True, need_bytes: int = 0) -> Path:
    """Refuse an output place before any work starts: an ``InputError`` naming ``name`` (a flag) and the path.

    ``path`` is a folder to create or fill (``folder=True``) or a file to create or replace. Refused:
    a file where a folder must go (or the reverse), a folder still to be made under a figure's name
    (``refuse_figure_name_for_folder``), a place below a file, a folder that cannot be written,
    a name too long for the temporary files written beside it, and fewer than ``need_bytes`` free on its
    disk (where ``shutil.disk_usage`` can tell).
    """
    path = Path(path)
    if folder:
        refuse_figure_name_for_folder(path, name)
    room = _name_max(path) - _TEMP_DECORATION
    if len(os.fsencode(path.name)) > room:
        raise InputError(f"{name} {short_repr(str(path))}: the name {short_repr(path.name, 40)} is "
                         f"{len(os.fsencode(path.name))} bytes long; the temporary files and locks written beside it "
                         f"need it to be at most {room}")
    if path.exists():
        if folder and not path.is_dir():
            raise InputError(f"{name} {path}: a file is there, expected a folder")
        if not folder and path.is_dir():
            raise InputError(f"{name} {path}: a folder is there, expected a file")
        if folder and not os.access(path, os.W_OK | os.X_OK):
            raise InputError(f"{name} {path}: the folder is not writable")
        if not folder and not os.access(path, os.W_OK):
            raise InputError(f"{name} {path}: the file is not writable")
    parent = path.parent if not path.exists() or not folder else path
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        raise InputError(f"{name} {path}: {parent} is a file, so nothing can be created below it")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"{name} {path}: the folder {parent} is not writable")
    if need_bytes:
        try:
            free = shutil.disk_usage(parent).free
        except OSError:
            free = None
        if free is not None and free < need_bytes:
            raise InputError(f"{name} {path}: {free / 2**20:.0f} MiB free on its disk, "
                             f"the outputs need about {need_bytes / 2**20:.0f} MiB")
    return path


# --- run locks -------------------------------------------------------------------------------------


class LockedError(InputError):
    """A folder is locked by another running command; the message names the holder."""


def lock_path(folder: str | os.PathLike) -> Path:
    """Where :func:`run_lock` keeps ``folder``'s lock: ``.<name>.lock`` beside it (so the folder can be swapped)."""
    folder = Path(folder).absolute()
    return folder.with_name(f".{folder.name}.lock")


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True
    return True


@contextmanager
def run_lock(folder: str | os.PathLike, command: str | None = None, *, log=None) -> Iterator[Path]:
    """Hold ``folder``'s lock while the block runs; a second holder gets a ``LockedError`` naming the first.

    The lock is a file, ``.<name>.lock`` beside the folder, holding the pid, host, command and start
    time as JSON. It is created complete and atomically (written under a unique name, then hard-linked
    into place, which fails if the lock exists), so a kill never leaves a half-written lock. A lock
    whose process is gone (same host, pid no longer running) is stale: it is taken over with a message
    to ``log`` (default: standard error). A lock from another host is never taken over: the message says
    which file to remove once that run is known to be over.
    """
    path = lock_path(folder)
    path.parent.mkdir(parents=True, exist_ok=True)
    me = {"pid": os.getpid(), "host": socket.gethostname(), "command": command or " ".join(sys.argv),
          "started": time.strftime("%Y-%m-%d %H:%M:%S")}
    log = log or (lambda line: print(line, file=sys.stderr))
    for _ in range(10):
        tmp = path.with_name(f"{path.name}.{os.getpid()}-{secrets.token_hex(4)}.tmp")
        tmp.write_text(json.dumps(me) + "\n", encoding="utf-8")
        try:
            os.link(tmp, path)
        except FileExistsError:
            holder = _read_lock(path)
            if holder is None:  # removed in between: try again
                continue
            if holder.get("host") == me["host"] and isinstance(holder.get("pid"), int) and \
                    not _pid_alive(holder["pid"]):
                try:  # only one taker wins this rename; the others see the lock gone and retry
                    os.rename(path, tmp.with_suffix(".stale"))
                except FileNotFoundError:
                    continue
                os.unlink(tmp.with_suffix(".stale"))
                log(f"{Path(folder)}: took over the lock of pid {holder['pid']} ({holder.get('command')!s:.80}), "
                    "which is no longer running")
                continue
            raise LockedError(f"{Path(folder)} is in use by pid {holder.get('pid')} on {holder.get('host')} "
                              f"since {holder.get('started')} ({str(holder.get('command'))[:120]}); wait for it, "
                              f"or remove {path} if that run is over") from None
        finally:
            tmp.unlink(missing_ok=True)
        break
    else:
        raise LockedError(f"{Path(folder)}: could not take the lock {path} (it keeps changing hands)")
    try:
        yield path
    finally:
        if (_read_lock(path) or {}).get("pid") == me["pid"]:
            path.unlink(missing_ok=True)


def _read_lock(path: Path) -> dict | None:
    """The holder recorded in a lock file, ``{}`` if unreadable (treated as held), None if there is none."""
    try:
        holder = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return None
    except (OSError, ValueError):
        return {}
    return holder if isinstance(holder, dict) else {}


# --- output sets -----------------------------------------------------------------------------------

#: The file :func:`output_set` writes last into each set: the names and sizes of the set's files.
MANIFEST = "MANIFEST.json"
_RENAME_EXCHANGE = 2


def _exchange(a: Path, b: Path) -> bool:
    """Swap two existing paths atomically (Linux ``renameat2(RENAME_EXCHANGE)``); False where unsupported."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd = -100
    if renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.EOPNOTSUPP):
        return False
    raise OSError(err, os.strerror(err), str(b))


def _fsync_dir(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def recover_output_set(target: str | os.PathLike) -> None:
    """Put ``target`` back in order after a kill inside :func:`output_set`; remove the leftovers of dead writers.

    Where the target is missing and a complete set of a dead writer is waiting beside it (the
    two-rename fallback was killed between its renames), the complete set goes into place: the newer
    one if it has its manifest, else the older. Temporary folders of dead writers are removed.
    """
    target = Path(target)
    for leftover in sorted(target.parent.glob(f".{target.name}.*.set")):
        pid = leftover.name.rsplit(".", 2)[-2].split("-")[0]
        if pid.isdigit() and _pid_alive(int(pid)) and int(pid) != os.getpid():
            continue
        kind = leftover.name.rsplit(".", 2)[-2].split("-")[-1]  # "new" or "old"
        if not target.exists() and kind == "new" and (leftover / MANIFEST).is_file():
            os.rename(leftover, target)
            continue
        if not target.exists() and kind == "old":
            os.rename(leftover, target)
            continue
        shutil.rmtree(leftover, ignore_errors=True)


@contextmanager
def output_set(target: str | os.PathLike) -> Iterator[Path]:
    """Yield an empty temporary folder beside ``target``; on success it replaces ``target`` as a whole.

    The caller writes every file of the set into the yielded folder. On success the files are
    flushed, :data:`MANIFEST` (names and sizes) is written last, and the folder takes ``target``'s
    place by one atomic exchange of the two names (Linux ``renameat2``); the old set is then deleted.
    On failure the temporary folder is deleted and ``target`` is untouched.

    The guarantee: a kill or power cut at any instant leaves ``target`` holding either the complete
    old set or the complete new set with its manifest, never a mix. Where the atomic exchange is not
    available the swap takes two renames; a kill between them leaves ``target`` missing with both sets
    beside it, and :func:`recover_output_set` (which every ``output_set`` runs first) puts the complete
    set into place. Files that should survive a swap (a checkpoint for resuming) do not belong in ``target``.
    """
    target = Path(target).absolute()
    target.parent.mkdir(parents=True, exist_ok=True)
    recover_output_set(target)
    token = f"{os.getpid()}-{secrets.token_hex(4)}"
    new = target.with_name(f".{target.name}.{token}-new.set")
    new.mkdir()
    try:
        yield new
        files = sorted(p for p in new.rglob("*") if p.is_file())
        for f in files:
            with open(f, "rb+") as fh:
                os.fsync(fh.fileno())
        manifest = {"files": {str(f.relative_to(new)): f.stat().st_size for f in files},
                    "written": time.strftime("%Y-%m-%d %H:%M:%S")}
        with atomic_path(new / MANIFEST) as tmp:
            tmp.write_text(json.dumps(manifest, indent=1) + "\n", encoding="utf-8")
        _fsync_dir(new)
        if not target.exists():
            os.rename(new, target)
        elif target.is_dir() and _exchange(new, target):
            pass  # ``new`` now holds the old set
        elif target.is_dir():
            old = target.with_name(f".{target.name}.{token}-old.set")
            os.rename(target, old)
            os.rename(new, target)
            os.rename(old, new)
        else:
            raise InputError(f"{target}: a file is there, expected a folder")
        _fsync_dir(target.parent)
    finally:
        shutil.rmtree(new, ignore_errors=True)
