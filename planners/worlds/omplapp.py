"""OMPL.app's rigid-body problems: its ``.cfg`` problem files and ``.path`` solutions, as mesh-world problems.

OMPL.app (https://ompl.kavrakilab.org, ``resources/3D``) ships each problem as a ``.cfg`` file naming
an environment and a robot mesh (COLLADA), a start and a goal (a position and a rotation as an axis and
an angle), the box the robot's origin stays in, and benchmark settings. Its licence does not let us
ship the files: point ``--omplapp DIR`` or ``SAMPLERGYM_OMPLAPP_DIR`` at a copy (the repository's root
or its ``resources/3D`` folder).

The frame is OMPL.app's, so its solutions replay here: the meshes are read as assimp reads them
(every node's transform applied, the scene turned to +y up; ``planners.worlds.mesh.read_mesh``), and the
robot's origin is the mean of its vertices (OMPL.app's ``RigidBodyGeometry::getRobotCenter``), so a
state's translation is where that point goes.
"""

from __future__ import annotations

import configparser
import hashlib
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from planners.base.fileio import InputError
from planners.base.problem import Problem
from planners.worlds.mesh import DEFAULT_DELTA_FRACTION, MeshWorld, read_mesh
from planners.worlds.rigid3d import euler_from_matrix

#: The environment variable naming a copy of OMPL.app (its root or its ``resources/3D`` folder).
OMPLAPP_ENV = "SAMPLERGYM_OMPLAPP_DIR"
#: Default goal tolerance, as a fraction of the bounds' diagonal (OMPL.app's planners reach the goal
#: state itself; RRT-Connect does here too, the tolerance matters to one-tree planners).
DEFAULT_TOLERANCE_FRACTION = 1e-3


@dataclass(frozen=True)
class OMPLAppTask:
    """A ``.cfg`` file read: the problem and its benchmark settings.

    Attributes:
        problem: The planning problem on a ``MeshWorld``.
        time_limit: ``[benchmark] time_limit`` in seconds, None where absent.
        mem_limit: ``[benchmark] mem_limit`` in MB, None where absent.
        run_count: ``[benchmark] run_count``, None where absent.
        planners: The names in ``[planner]`` (e.g. ``("rrtconnect", "prm")``), settings left out.
        path: The ``.cfg`` file.
    """

    problem: Problem
    time_limit: float | None
    mem_limit: float | None
    run_count: int | None
    planners: tuple[str, ...]
    path: Path


def omplapp_dir(directory: str | os.PathLike | None = None, flag: str = "--omplapp") -> Path | None:
    """The folder of OMPL.app's 3-D problems: ``directory``, else ``$SAMPLERGYM_OMPLAPP_DIR``; None if neither is set.

    Either may name OMPL.app's root (``resources/3D`` is taken) or the folder of ``.cfg`` files itself. ``flag``:
    how the error names a ``directory`` given (the command line's flag).

    Raises:
        InputError: The folder given does not exist or holds no ``.cfg`` file.
    """
    given = directory if directory is not None else os.environ.get(OMPLAPP_ENV) or None
    if given is None:
        return None
    base = Path(given).expanduser()
    for candidate in (base / "resources" / "3D", base):
        if candidate.is_dir() and any(candidate.glob("*.cfg")):
            return candidate
    source = flag if directory is not None else OMPLAPP_ENV
    raise InputError(f"{source} {base}: no OMPL.app problems there (expected .cfg files in it or in its "
                     f"resources/3D folder)")


def axis_angle_matrix(axis, theta: float) -> np.ndarray:
    """Rotation by ``theta`` radians about ``axis`` (any length > 0; ignored when ``theta`` is 0)."""
    axis = np.asarray(axis, dtype=np.float64)
    n = float(np.linalg.norm(axis))
    if theta == 0.0:
        return np.eye(3)
    if not n > 0:
        raise ValueError(f"a rotation of {theta:g} rad needs a non-zero axis, got {tuple(axis.tolist())}")
    x, y, z = axis / n
    c, s, C = math.cos(theta), math.sin(theta), 1.0 - math.cos(theta)
    return np.array([[c + x * x * C, x * y * C - z * s, x * z * C + y * s],
                     [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
                     [z * x * C - y * s, z * y * C + x * s, c + z * z * C]])


def quaternion_matrix(x: float, y: float, z: float, w: float) -> np.ndarray:
    """Rotation of the unit quaternion ``w + x i + y j + z k`` (normalised here)."""
    q = np.array([w, x, y, z], dtype=np.float64)
    n = float(np.linalg.norm(q))
    if not n > 0:
        raise ValueError("a quaternion of norm 0 is no rotation")
    w, x, y, z = q / n
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _number(path: Path, section: str, key: str, raw: str | None, *, integer: bool = False):
    if raw is None:
        raise InputError(f"{path}: [{section}] {key} is missing")
    try:
        value = int(raw) if integer else float(raw)
    except ValueError:
        kind = "an integer" if integer else "a number"
        raise InputError(f"{path}: [{section}] {key} = {raw!r} is not {kind}") from None
    if not math.isfinite(value):
        raise InputError(f"{path}: [{section}] {key} = {raw!r} must be finite")
    return value


def _pose(path: Path, problem: configparser.SectionProxy, which: str) -> np.ndarray:
    get = {k: problem.get(f"{which}.{k}") for k in ("x", "y", "z", "theta", "axis.x", "axis.y", "axis.z")}
    vals = {k: _number(path, "problem", f"{which}.{k}", v) for k, v in get.items()}
    try:
        R = axis_angle_matrix([vals["axis.x"], vals["axis.y"], vals["axis.z"]], vals["theta"])
    except ValueError as e:
        raise InputError(f"{path}: [problem] {which}: {e}") from None
    return np.concatenate([[vals["x"], vals["y"], vals["z"]], euler_from_matrix(R)])


def read_omplapp_path(path: str | os.PathLike) -> np.ndarray:
    """An OMPL.app ``.path`` solution (rows ``x y z qx qy qz qw``) as ``(k, 6)`` states of this project."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"path file {path} does not exist")
    rows = []
    for lineno, line in enumerate(path.read_text().splitlines(), start=1):
        if not line.strip():
            continue
        try:
            vals = [float(v) for v in line.split()]
        except ValueError:
            raise InputError(f"{path}, line {lineno}: expected 7 numbers (x y z qx qy qz qw), got {line!r}") from None
        if len(vals) != 7 or not all(math.isfinite(v) for v in vals):
            raise InputError(f"{path}, line {lineno}: expected 7 finite numbers (x y z qx qy qz qw), got {line!r}")
        try:
            R = quaternion_matrix(*vals[3:])
        except ValueError as e:
            raise InputError(f"{path}, line {lineno}: {e}") from None
        rows.append(np.concatenate([vals[:3], euler_from_matrix(R)]))
    if not rows:
        raise InputError(f"{path}: no states in the file")
    return np.array(rows)


def centred_robot(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The robot mesh moved so that the mean of its vertices is the origin (OMPL.app's robot frame)."""
    return vertices - vertices.mean(axis=0), faces


def _read_cfg(path: Path) -> configparser.ConfigParser:
    if not path.is_file():
        raise InputError(f"problem file {path} does not exist")
    cfg = configparser.ConfigParser(strict=False, interpolation=None, inline_comment_prefixes=("#",))
    try:
        cfg.read_string(path.read_text(encoding="utf-8"), source=str(path))
    except (configparser.Error, UnicodeDecodeError) as e:
        raise InputError(f"{path}: not an OMPL.app problem file ({type(e).__name__}: {e})") from None
    if "problem" not in cfg:
        raise InputError(f"{path}: no [problem] section")
    return cfg


def problem_files(path: str | os.PathLike) -> dict[str, Path]:
    """The files an OMPL.app problem is read from: ``{"cfg": ..., "world": ..., "robot": ...}`` (the meshes that its
    ``[problem]`` section names, beside it); an ``InputError`` names a missing one. Nothing is parsed but the ``.cfg``.
    """
    path = Path(path)
    return {"cfg": path, **_mesh_paths(path, _read_cfg(path)["problem"])}


def _mesh_paths(path: Path, prob: configparser.SectionProxy) -> dict[str, Path]:
    """The world's and the robot's mesh files that the ``[problem]`` section ``prob`` of ``path`` names."""
    out = {}
    for key in ("world", "robot"):
        name = prob.get(key)
        if not name:
            raise InputError(f"{path}: [problem] {key} is missing (the {key}'s mesh file)")
        out[key] = path.parent / name.strip()
        if not out[key].is_file():
            raise InputError(f"{path}: [problem] {key} = {name.strip()} not found beside it ({out[key]})")
    return out


def problem_digests(path: str | os.PathLike) -> dict[str, str]:
    """SHA-256 of each of ``problem_files(path)`` (name and digest by role): what a run's record keeps, so two runs
    on OMPL.app's problems can tell whether they read the same files (OMPL.app's snapshots differ).
    """
    return {role: f"{file.name} sha256:{hashlib.sha256(file.read_bytes()).hexdigest()}"
            for role, file in problem_files(path).items()}


def mesh_library_versions() -> dict[str, str | None]:
    """The installed versions of the libraries a mesh world reads and checks with (None: not installed), without
    importing them.
    """
    from importlib import metadata

    out = {}
    for dist in ("trimesh", "pycollada", "python-fcl"):
        try:
            out[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            out[dist] = None
    return out


def _world(path: Path, prob: configparser.SectionProxy, delta: float | None, grid_cells: int | None,
           band: float | None = None) -> MeshWorld:
    meshes = {key: read_mesh(file) for key, file in _mesh_paths(path, prob).items()}
    env = meshes["world"]
    robot = centred_robot(*meshes["robot"])
    if any(f"volume.{e}.{a}" in prob for e in ("min", "max") for a in "xyz"):
        low = [_number(path, "problem", f"volume.min.{a}", prob.get(f"volume.min.{a}")) for a in "xyz"]
        high = [_number(path, "problem", f"volume.max.{a}", prob.get(f"volume.max.{a}")) for a in "xyz"]
    else:
        low, high = env[0].min(axis=0), env[0].max(axis=0)
    diagonal = float(np.linalg.norm(np.asarray(high, float) - np.asarray(low, float)))
    name = prob.get("name", path.stem).strip() or path.stem
    try:
        return MeshWorld(env, robot, low=low, high=high, name=name,
                         delta=DEFAULT_DELTA_FRACTION * diagonal if delta is None else delta, band=band,
                         **({} if grid_cells is None else {"grid_cells": grid_cells}))
    except InputError as e:
        raise InputError(f"{path}: {e}") from None


def load_omplapp_world(path: str | os.PathLike, *, delta: float | None = None,
                       grid_cells: int | None = None, band: float | None = None) -> MeshWorld:
    """The world of an OMPL.app ``.cfg`` file alone: its meshes in OMPL.app's frame and its bounds, no query.

    For other queries in OMPL.app's environments, and for replaying a shipped solution whose problem does
    not load here (``escape.cfg``'s goal itself meets the environment). The arguments are ``load_omplapp``'s.

    Raises:
        InputError: A missing or malformed key or a missing mesh.
    """
    path = Path(path)
    return _world(path, _read_cfg(path)["problem"], delta, grid_cells, band)


def load_omplapp(path: str | os.PathLike, *, delta: float | None = None, goal_tolerance: float | None = None,
                 grid_cells: int | None = None, band: float | None = None) -> OMPLAppTask:
    """Read an OMPL.app ``.cfg`` problem file and its meshes (found beside it).

    Args:
        path: The ``.cfg`` file.
        delta: Motion resolution of the world (``MeshWorld``); default ``DEFAULT_DELTA_FRACTION`` of
            the bounds' diagonal.
        goal_tolerance: Goal tolerance of the problem; default ``DEFAULT_TOLERANCE_FRACTION`` of the
            bounds' diagonal.
        grid_cells: The broad phase's grid resolution (``MeshWorld``'s default where None).
        band: The clearance every checked pose keeps (``MeshWorld``); default ``delta / 8``.

    Returns:
        An ``OMPLAppTask``: the problem (start and goal as ``(x, y, z, tx, ty, tz)``, bounds from
        ``volume.*``, else the environment's bounding box as OMPL.app infers it) and the benchmark's
        time limit, memory limit, run count and planners.

    Raises:
        InputError: A missing or malformed key, a missing mesh, or a start or goal in collision.
    """
    path = Path(path)
    cfg = _read_cfg(path)
    prob = cfg["problem"]
    start, goal = _pose(path, prob, "start"), _pose(path, prob, "goal")
    world = _world(path, prob, delta, grid_cells, band)
    diagonal = float(np.linalg.norm(world.high3 - world.low3))
    try:
        tol = DEFAULT_TOLERANCE_FRACTION * diagonal if goal_tolerance is None else goal_tolerance
        problem = Problem(world, start, goal, goal_tolerance=tol, name=world.name)
    except InputError as e:
        raise InputError(f"{path}: {e}") from None
    bench = cfg["benchmark"] if "benchmark" in cfg else {}
    time_limit = _number(path, "benchmark", "time_limit", bench["time_limit"]) if "time_limit" in bench else None
    mem_limit = _number(path, "benchmark", "mem_limit", bench["mem_limit"]) if "mem_limit" in bench else None
    runs = _number(path, "benchmark", "run_count", bench["run_count"], integer=True) if "run_count" in bench else None
    names = tuple(k for k in cfg["planner"] if "." not in k) if "planner" in cfg else ()
    return OMPLAppTask(problem, time_limit, mem_limit, runs, names, path)


def load_omplapp_cfg(path: str | os.PathLike, **kwargs) -> Problem:
    """The problem of an OMPL.app ``.cfg`` file (``load_omplapp(path, **kwargs).problem``)."""
    return load_omplapp(path, **kwargs).problem
