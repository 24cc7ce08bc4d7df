"""Where compiled kernels are cached, and the one-line notice when a first call has to compile.

The cache folder is keyed by a hash of every ``planners`` source file, so an edited kernel, or an
edited helper another kernel imports from a different file (which numba's own per-file timestamp
check misses), lands in a fresh folder and is recompiled: a stale cache cannot be loaded. The folder
is ``planners/__pycache__/numba/<hash>`` next to the sources; when that is not writable (a
read-only install) it is ``$XDG_CACHE_HOME/samplergym/numba/<hash>`` (``~/.cache`` by default),
and a line on stderr says so once. A ``NUMBA_CACHE_DIR`` set by the user is left alone (numba's own
staleness rules then apply).

Before a planner's first compiled call with a world kind and space it has not run on this install,
one line on stderr says that its kernels are compiling. ``SAMPLERGYM_COMPILE_NOTICE=0`` or
``set_compile_notice(False)`` silences it. ``python -m planners.compile`` fills the cache ahead.
See ``docs/compiling.md``.
"""

from __future__ import annotations

import atexit
import hashlib
import json
import math
import os
import shutil
import sys
import tempfile
from pathlib import Path

import numba

#: The environment variable that silences the compile notice when set to 0, "false", "no" or "off".
NOTICE_ENV = "SAMPLERGYM_COMPILE_NOTICE"

_PACKAGE = Path(__file__).resolve().parent.parent  # planners/
_state = {"dir": None, "notice": None, "user_dir": False}
_seen: set[tuple[str, str, str]] = set()
_known: set[tuple[Path, tuple[str, str, str]]] = set()  # (cache folder, key) stamps seen in this process

#: Compile seconds per planner and world kind ("RRT/2d": the planar worlds, "PRM/6dof": the rigid body among boxes,
#: "RRTConnect/mesh": the mesh worlds) as ``scripts/benchmark_first_call.py --save`` measured them, for the notice's
#: wording; a planner without a figure of its own is quoted as the range its kind's figures span.
FIGURES = Path(__file__).resolve().parent / "compile_seconds.json"
#: What the notice says when the figures file cannot be read (a planner without a row of its own is quoted
#: as the range its world kind's rows span).
UNMEASURED = "some seconds to a minute"


def source_hash(package: Path = _PACKAGE) -> str:
    """Hash of every source file under ``package`` (paths and contents) and numba's version: the cache folder's key."""
    h = hashlib.sha256(numba.__version__.encode())
    for p in sorted(package.rglob("*.py")):
        h.update(str(p.relative_to(package)).encode())
        h.update(b"\0")
        h.update(p.read_bytes())
        h.update(b"\0")
    return h.hexdigest()[:16]


def _writable(d: Path) -> bool:
    try:
        d.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=d):
            pass
        return True
    except OSError:
        return False


def choose_dir(key: str, package: Path = _PACKAGE) -> Path:
    """``package/__pycache__/numba/<key>`` if writable, else the user cache folder, else a temporary one.

    Each fallback is said in one line on stderr. A temporary folder lasts for this process only, so
    every process compiles the kernels again (seconds each): the line says to set ``NUMBA_CACHE_DIR``.

    Raises:
        OSError: Not even a temporary folder can be written (the message names the folders tried).
    """
    local = package / "__pycache__" / "numba" / key
    if _writable(local):
        return local
    try:
        base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    except RuntimeError:  # no home folder to be found
        base = None
    d = base / "samplergym" / "numba" / key if base is not None else None
    if d is not None and _writable(d):
        print(f"samplergym: {local.parent} is not writable; compiled kernels are cached in {d}", file=sys.stderr)
        return d
    try:
        tmp = Path(tempfile.mkdtemp(prefix="samplergym-numba-"))
    except OSError:
        raise OSError(f"no writable folder for compiled kernels: not {local}, {d} or the temporary folder "
                      f"({tempfile.gettempdir()}); set NUMBA_CACHE_DIR to a writable folder") from None
    atexit.register(shutil.rmtree, tmp, ignore_errors=True)
    print(f"samplergym: no writable cache for compiled kernels ({local.parent} and {d} are not writable); they are "
          f"compiled again in every process, into {tmp}. Set NUMBA_CACHE_DIR to a writable folder to keep them",
          file=sys.stderr)
    return tmp


def configure() -> Path | None:
    """Point numba's cache at the source-hash folder (once per process); the folder, or None if the user set one.

    Runs when ``planners.kernels`` is imported, before any kernel is defined.
    """
    if _state["dir"] is not None or _state["user_dir"]:
        return _state["dir"]
    if os.environ.get("NUMBA_CACHE_DIR"):
        _state["user_dir"] = True
        return None
    d = choose_dir(source_hash())
    numba.config.CACHE_DIR = str(d)
    _state["dir"] = d
    return d


def load_registries() -> None:
    """Load numba's typing and lowering registries now, as ``import planners`` does.

    numba loads them on a process's first compiled call, compiled or from the cache alike (about 0.4 s,
    SciPy's BLAS bindings among them); loaded at import, a first solve's time is the solve's own.
    """
    from numba.core.registry import cpu_target

    cpu_target.typing_context.refresh()
    cpu_target.target_context.refresh()


def cache_dir() -> Path:
    """The folder compiled kernels are cached in."""
    return _state["dir"] if _state["dir"] is not None else Path(os.environ["NUMBA_CACHE_DIR"])


def set_compile_notice(on: bool) -> None:
    """Show (True) or silence (False) the one-line stderr notice before a first compilation."""
    _state["notice"] = bool(on)


def _notice_on() -> bool:
    if _state["notice"] is not None:
        return _state["notice"]
    return os.environ.get(NOTICE_ENV, "1").strip().lower() not in ("0", "false", "no", "off")


def _stamp(key: tuple[str, str, str]) -> Path:
    return cache_dir() / "compiled" / "-".join(key)


def is_compiled(label: str, world, space) -> bool:
    """True if this install has compiled ``label``'s kernels for this world kind and space.

    A yes is remembered for the process (the cache folder only gains stamps), so a caller may ask once per query.
    """
    key = _key(label, world, space)
    known = (cache_dir(), key)
    if known in _known:
        return True
    if _stamp(key).exists():
        _known.add(known)
        return True
    return False


def mark_compiled(label: str, world, space) -> None:
    """Record that this install compiles ``label``'s kernels for this world kind and space.

    ``is_compiled`` is true from now on; the compilation itself follows at their first use. A folder that cannot be
    written keeps the mark for this process only.
    """
    key = _key(label, world, space)
    known = (cache_dir(), key)
    if known in _known:
        return
    _known.add(known)
    try:
        stamp = _stamp(key)
        stamp.parent.mkdir(parents=True, exist_ok=True)
        stamp.touch()
    except OSError:
        pass


def _key(label: str, world, space) -> tuple[str, str, str]:
    return (label, type(world).__name__, type(space).__name__)


def figure_kind(world, space) -> str:
    """The world kind ``compile_seconds.json`` keys its figures by: "mesh", "6dof" or "2d".

    "6dof" is the rigid body among boxes, "2d" the occupancy grids and the circle and rectangle worlds; ``world`` is a
    world's kernel, as ``announce`` takes it.
    """
    if type(world).__name__ == "MeshKernel":
        return "mesh"
    return "2d" if type(space).__name__.startswith("SpaceRn") else "6dof"


def expected_seconds(label: str, world, space, figures: Path = FIGURES) -> str:
    """How long compiling ``label``'s kernels for this world kind takes, in words.

    The figure measured for it, else the range its kind's figures span (any kind's, where the kind has none).
    """
    kind = figure_kind(world, space)
    try:
        data = json.loads(figures.read_text())
        measured, cpus = {k: float(v) for k, v in data["seconds"].items()}, int(data["cpus"])
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return UNMEASURED
    seconds = measured.get(f"{label}/{kind}")
    if seconds is None:  # no row for this one: the range its kind's rows span, else all rows'
        alike = [v for k, v in measured.items() if k.endswith(f"/{kind}")] or list(measured.values())
        if not alike:
            return UNMEASURED
        low, high = max(1, math.floor(min(alike))), max(1, math.ceil(max(alike)))
        span = f"{low}" if low == high else f"{low}-{high}"
        return f"about {span} s of CPU time (measured on a {cpus}-CPU machine)"
    return f"about {max(1, round(seconds))} s of CPU time (measured on a {cpus}-CPU machine)"


#: The world kinds a notice names, by their kernel's type.
_KINDS = {"GridKernel": "occupancy grids", "ShapesKernel": "circle and rectangle worlds",
          "RigidKernel": "the rigid body among boxes", "MeshKernel": "mesh worlds"}


def announce(label: str, world, space) -> None:
    """Before a planner's first run on a (world kind, space) this install has not compiled: say so on stderr.

    Called when a planner is made; costs one set lookup once the key has been seen in this process.
    The key is marked compiled at once (the compilation follows), so the notice shows once per install.
    """
    key = _key(label, world, space)
    if key in _seen:
        return
    _seen.add(key)
    stamp = _stamp(key)
    if stamp.exists():
        return
    if _notice_on():
        print(f"samplergym: compiling the {label} kernels for {_KINDS.get(type(world).__name__, 'this world')} once "
              f"for this install, {expected_seconds(label, world, space)}; other planners, worlds and samplers compile "
              f"at their own first use (python -m planners.compile does every planner ahead; docs/compiling.md "
              f"says where the time goes; {NOTICE_ENV}=0 silences this)", file=sys.stderr, flush=True)
    mark_compiled(label, world, space)  # where the folder cannot be written: a notice too many next time
