"""A 6-DoF rigid body given as a triangle mesh among a triangle-mesh environment, checked exactly.

The state space is ``RigidBodyWorld``'s: ``q = (x, y, z, tx, ty, tz)``, a body vertex ``p`` (in the
body's own frame) sits at ``H p + (x, y, z)`` with ``H = Ry(ty) Rx(tx) Rz(tz)``; angles are sampled in
``[-pi, pi)`` and a motion turns along the shorter arc. The same metrics (``cossin``, ``se3``) and the
same bound on a body point's travel apply (``|dt| + r (|dtx| + |dty| + |dtz|)``, ``r`` the body
radius): every checked pose keeps the body more than the band ``b`` (``delta / 8`` by default) from the
environment and the next lies a travel of ``max(2 b, c)`` on, ``c`` the clearance just certified, so the
poses between stay free and no obstacle, however thin, is stepped over (``planners.kernels.mesh``).

A state is valid when the body's origin lies within the bounds and the body's triangles meet none of
the environment's (two meshes collide where their surfaces touch or cross, as in FCL and OMPL.app, so a
body wholly inside a closed obstacle is not seen; no motion from a valid state gets there, since it
would cross the surface).

The meshes are read with trimesh. The checks that planning makes run in compiled code
(``planners.kernels.mesh``, ``planners.kernels.triangles``: exact triangle-to-triangle tests behind
bounding-volume trees); FCL (python-fcl) gives the distance (``MeshWorld.clearance``) and the reference
test (``MeshWorld.pose_free_exact``) that the compiled one is tested against. Both libraries are
imported only when a mesh world is built (the ``mesh`` extra: ``pip install samplergym[mesh]``).
"""

from __future__ import annotations

import itertools
import math
import os
import threading
from pathlib import Path

import numpy as np

from planners.base.fileio import InputError
from planners.base.world import WorldBase
from planners.kernels import geometry
from planners.kernels import mesh as mesh_kernels
from planners.kernels import triangles as triangle_kernels
from planners.kernels.rigid import motion_pieces
from planners.kernels.rigid import rotation_matrix as _rotation_matrix
from planners.kernels.space import SPACE_RIGID, interpolate
from planners.worlds.rigid3d import (
    RigidBodyWorld,
    body_radius,
    check_resolution,
    monte_carlo_free_volume,
    positive_delta,
    rotation_weight,
    voxel_axes,
    workspace_bounds,
)

#: File types ``read_mesh`` reads (through trimesh; ``.dae`` through pycollada).
MESH_SUFFIXES = (".obj", ".stl", ".dae", ".ply", ".off")
#: Default motion resolution, as a fraction of the bounds' diagonal.
DEFAULT_DELTA_FRACTION = 1e-3
#: Default band (the clearance every checked pose keeps), as a fraction of ``delta``: chosen on the generated mesh
#: scenes' tuning part (``scripts/experiments/tune_mesh_delta.py --bands``; docs/rigid-body.md).
DEFAULT_BAND_FRACTION = 0.125
#: The RRT family's default step on a mesh world (``WorldBase.range_fraction``), as a fraction of the state box's
#: diagonal: a tenth of OMPL's default range, chosen for RRT-Connect on the generated mesh scenes' tuning part
#: (``scripts/experiments/tune_mesh_delta.py --steps``; docs/rigid-body.md).
MESH_RANGE_FRACTION = 0.02
#: Voxels along the longest side of the broad phase's grid (the grid covers the bounds grown by the
#: body radius).
DEFAULT_GRID_CELLS = 128
#: The default noise about the workspace route in a mesh world, in route cells (``MeshWorld.route_spread``).
ROUTE_SPREAD_CELLS = 1.0
#: States drawn for the free-volume estimate (RRT*'s and PRM*'s radius).
VOLUME_SAMPLES = 4096
#: Most triangles a mesh may have: FCL builds a bounding-volume tree over them, and the broad phase
#: tests each against the voxels its box covers.
MAX_TRIANGLES = 2_000_000

_INSTALL = 'pip install "samplergym[mesh]"  (trimesh, python-fcl, pycollada)'


def _trimesh():
    try:
        import trimesh
    except ImportError:
        raise ImportError(f"mesh worlds need trimesh: {_INSTALL}") from None
    return trimesh


def _fcl():
    try:
        import fcl
    except ImportError:
        raise ImportError(f"mesh worlds need python-fcl: {_INSTALL}") from None
    return fcl


#: COLLADA's up axes, as the rotation to Y up that assimp (and so OMPL.app) applies to a file's scene.
_UP_TO_Y = {
    "Y_UP": np.eye(3),
    "Z_UP": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]),
    "X_UP": np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
}


def _collada_up_axis(path: Path) -> str:
    import collada

    try:
        doc = collada.Collada(str(path), ignore=[collada.common.DaeUnsupportedError,
                                                 collada.common.DaeBrokenRefError])
    except Exception as e:  # pycollada raises its own and lxml's errors for a bad file
        raise InputError(f"{path}: not a COLLADA file pycollada can read ({type(e).__name__}: {e})") from None
    return str(getattr(doc.assetInfo, "upaxis", "Y_UP") or "Y_UP")


def read_mesh(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    """A mesh file's triangles as ``(vertices (V, 3) float64, faces (F, 3) int32)``, in the file's world frame.

    OBJ, STL, PLY and OFF are read as they are. A COLLADA ``.dae`` scene is flattened with every node's
    transform applied, then turned so that its up axis is +y, as assimp does (OMPL.app reads its meshes
    with assimp: a ``Z_UP`` file's ``(x, y, z)`` becomes ``(x, z, -y)``). Vertices are kept as the file
    indexes them, not merged (OMPL.app's robot origin is their mean).

    Raises:
        InputError: The file is missing, of an unknown type, unreadable, or has no triangles.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"mesh file {path} does not exist")
    suffix = path.suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise InputError(f"{path}: unknown mesh type {suffix!r}; expected one of {MESH_SUFFIXES}")
    if path.stat().st_size == 0:  # e.g. a large file a partial copy or checkout left out
        raise InputError(f"mesh file {path} is empty (0 bytes): copy the file again")
    trimesh = _trimesh()
    try:
        scene = trimesh.load(str(path), force="scene")
    except Exception as e:  # trimesh raises many kinds of error for a bad file
        raise InputError(f"{path}: not a {suffix} mesh trimesh can read ({type(e).__name__}: {e})") from None
    meshes = [g for g in scene.dump() if hasattr(g, "faces") and len(g.faces)]
    if not meshes:
        raise InputError(f"{path}: the file holds no triangles")
    merged = trimesh.util.concatenate(meshes)
    V = np.asarray(merged.vertices, dtype=np.float64)
    F = np.asarray(merged.faces, dtype=np.int32)
    if suffix == ".dae":
        up = _collada_up_axis(path)
        if up not in _UP_TO_Y:
            raise InputError(f"{path}: unknown COLLADA up_axis {up!r}; expected one of {sorted(_UP_TO_Y)}")
        V = V @ _UP_TO_Y[up].T
    return _triangles(V, F, str(path))


def _triangles(vertices, faces, label: str) -> tuple[np.ndarray, np.ndarray]:
    try:
        V = np.ascontiguousarray(vertices, dtype=np.float64)
        F = np.ascontiguousarray(faces, dtype=np.int64)
    except (TypeError, ValueError):
        raise InputError(f"{label}: vertices must be (V, 3) numbers and faces (F, 3) integers") from None
    if V.ndim != 2 or V.shape[1] != 3 or len(V) == 0:
        raise InputError(f"{label}: vertices must have shape (V, 3) with V >= 1, got {V.shape}")
    if F.ndim != 2 or F.shape[1] != 3 or len(F) == 0:
        raise InputError(f"{label}: faces must have shape (F, 3) with F >= 1, got {F.shape}")
    if len(F) > MAX_TRIANGLES:
        raise InputError(f"{label}: {len(F):,} triangles, more than the limit of {MAX_TRIANGLES:,}")
    if not np.all(np.isfinite(V)):
        raise InputError(f"{label}: vertices must be finite")
    if F.min() < 0 or F.max() >= len(V):
        raise InputError(f"{label}: face indices must lie in [0, {len(V)}), got {F.min()} to {F.max()}")
    return V, F.astype(np.int32)


def _as_mesh(mesh, label: str) -> tuple[np.ndarray, np.ndarray]:
    """A path, a ``(vertices, faces)`` pair or a trimesh.Trimesh, as ``(vertices, faces)``."""
    if isinstance(mesh, (str, os.PathLike)):
        return read_mesh(mesh)
    if hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        return _triangles(mesh.vertices, mesh.faces, label)
    try:
        vertices, faces = mesh
    except (TypeError, ValueError):
        raise InputError(f"{label} must be a mesh file, a (vertices, faces) pair or a trimesh.Trimesh, "
                         f"got {type(mesh).__name__}") from None
    return _triangles(vertices, faces, label)


def cover_points(vertices: np.ndarray, faces: np.ndarray, spacing: float) -> np.ndarray:
    """Points on the mesh such that every point of every triangle lies within ``spacing`` of one.

    Each triangle is cut into ``k^2`` similar triangles whose sides are at most ``spacing``; their
    corners are the points (a point of a triangle lies within its longest side of each corner).
    """
    a, b, c = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    longest = np.max([np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1), np.linalg.norm(a - c, axis=1)],
                     axis=0)
    cuts = np.maximum(1, np.ceil(longest / spacing)).astype(np.int64)
    out = [vertices]
    for k in np.unique(cuts[cuts > 1]):  # triangles cut alike at once
        sel = cuts == k
        i, j = np.meshgrid(np.arange(k + 1), np.arange(k + 1), indexing="ij")
        keep = (i + j) <= k
        u, v = (i[keep] / k)[None, :, None], (j[keep] / k)[None, :, None]
        A, B, C = a[sel][:, None], b[sel][:, None], c[sel][:, None]
        out.append((A + u * (B - A) + v * (C - A)).reshape(-1, 3))
    return np.unique(np.concatenate(out), axis=0)


def solid_inner_radius(vertices: np.ndarray, faces: np.ndarray) -> float:
    """The radius of the largest ball about the origin inside the mesh's solid, or 0 if the origin is outside.

    Inside means an odd number of crossings of a ray from the origin with the triangles, for the most of
    three rays in fixed, unaligned directions (a mesh with holes may count differently along one ray);
    the radius is then the origin's distance to the nearest triangle.
    """
    a, b, c = (vertices[faces[:, i]].astype(np.float64) for i in range(3))
    inside = 0
    for d in ((0.5773, 0.5774, 0.5775), (-0.3119, 0.8377, 0.4482), (0.7071, -0.1234, -0.6963)):
        inside += int(_ray_crossings(np.asarray(d), a, b, c) % 2 == 1)
    if inside < 2:
        return 0.0
    return float(_origin_triangle_distance(a, b, c).min())


def _ray_crossings(d: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> int:
    """Triangles the ray from the origin along ``d`` crosses (Moller-Trumbore)."""
    e1, e2 = b - a, c - a
    p = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, p)
    ok = np.abs(det) > 1e-12
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    t0 = -a
    u = np.einsum("ij,ij->i", t0, p) * inv
    q = np.cross(t0, e1)
    v = (q @ d) * inv
    t = np.einsum("ij,ij->i", e2, q) * inv
    return int(np.sum(ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)))


def _origin_triangle_distance(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """``(F,)``: the origin's distance to each triangle (the closest point by its Voronoi region, Ericson 5.1.5)."""
    ab, ac, ap = b - a, c - a, -a
    d1, d2 = np.einsum("ij,ij->i", ab, ap), np.einsum("ij,ij->i", ac, ap)
    bp = -b
    d3, d4 = np.einsum("ij,ij->i", ab, bp), np.einsum("ij,ij->i", ac, bp)
    cp = -c
    d5, d6 = np.einsum("ij,ij->i", ab, cp), np.einsum("ij,ij->i", ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = va + vb + vc
        v = np.where(denom != 0, vb / denom, 0.0)
        w = np.where(denom != 0, vc / denom, 0.0)
        closest = a + ab * v[:, None] + ac * w[:, None]  # the face region
        # the edge and vertex regions, in the order the test ranks them (later cases override earlier ones)
        sbc = (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0)
        t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        closest = np.where(sbc[:, None], b + t[:, None] * (c - b), closest)
        sac = (vb <= 0) & (d2 >= 0) & (d6 <= 0)
        t = d2 / (d2 - d6)
        closest = np.where(sac[:, None], a + t[:, None] * ac, closest)
        sab = (vc <= 0) & (d1 >= 0) & (d3 <= 0)
        t = d1 / (d1 - d3)
        closest = np.where(sab[:, None], a + t[:, None] * ab, closest)
        closest = np.where(((d6 >= 0) & (d5 <= d6))[:, None], c, closest)
        closest = np.where(((d3 >= 0) & (d4 <= d3))[:, None], b, closest)
        closest = np.where(((d1 <= 0) & (d2 <= 0))[:, None], a, closest)
    return np.linalg.norm(closest, axis=1)


def rotation_matrices(angles: np.ndarray) -> np.ndarray:
    """``(n, 3, 3)``: ``Ry(ty) Rx(tx) Rz(tz)`` for each row ``(tx, ty, tz)``, vectorised (``rotation_matrix``'s)."""
    cx, sx = np.cos(angles[:, 0]), np.sin(angles[:, 0])
    cy, sy = np.cos(angles[:, 1]), np.sin(angles[:, 1])
    cz, sz = np.cos(angles[:, 2]), np.sin(angles[:, 2])
    a0, b0, c0 = cy, sy * sx, sy * cx
    b1, c1 = cx, -sx
    a2, b2, c2 = -sy, cy * sx, cy * cx
    R = np.empty((len(angles), 3, 3))
    R[:, 0, 0], R[:, 0, 1], R[:, 0, 2] = a0 * cz + b0 * sz, b0 * cz - a0 * sz, c0
    R[:, 1, 0], R[:, 1, 1], R[:, 1, 2] = b1 * sz, b1 * cz, c1
    R[:, 2, 0], R[:, 2, 1], R[:, 2, 2] = a2 * cz + b2 * sz, b2 * cz - a2 * sz, c2
    return R


class _Deadline(threading.local):
    at: float | None = None
    clock = None


def _positive_cell(cell) -> float:
    """``cell`` as a float, or an ``InputError`` unless it is a positive finite number."""
    cell = float(cell)
    if not (cell > 0 and math.isfinite(cell)):
        raise InputError(f"cell must be a positive number, got {cell!r}")
    return cell


class _FCLCheck:
    """FCL's bounding-volume trees of the body and the environment.

    For the distance (``MeshWorld.clearance``) and the reference test (``MeshWorld.pose_free_exact``); also this
    world's deadline (``MeshWorld.set_deadline``).
    """

    def __init__(self, body, env) -> None:
        self.deadline = _Deadline()  # per thread: a planner's time limit (set_deadline)
        self.cut = 0  # motion checks answered "blocked" because the deadline had passed
        fcl = _fcl()
        self._fcl = fcl
        self.body_model = self._model(*body)
        self.env_model = self._model(*env)
        self.body = fcl.CollisionObject(self.body_model, fcl.Transform())
        self.env = fcl.CollisionObject(self.env_model, fcl.Transform())
        self.collide_request = fcl.CollisionRequest()
        self.distance_request = fcl.DistanceRequest()

    def _model(self, vertices, faces):
        m = self._fcl.BVHModel()
        m.beginModel(len(vertices), len(faces))
        m.addSubModel(vertices, faces)
        m.endModel()
        return m

    def pose_free(self, R: np.ndarray, t: np.ndarray, margin: float) -> bool:
        """True if the body at rotation ``R`` and translation ``t`` is more than ``margin`` from the environment.

        With ``margin`` 0: its triangles meet none of the environment's.
        """
        fcl = self._fcl
        self.body.setTransform(fcl.Transform(R, t))
        result = fcl.CollisionResult()
        if fcl.collide(self.body, self.env, self.collide_request, result):
            return False
        if margin <= 0.0:
            return True
        return fcl.distance(self.body, self.env, self.distance_request, fcl.DistanceResult()) > margin

    def past_deadline(self) -> bool:
        """True once this thread's deadline has passed (counted in ``cut``); the compiled walk asks every few poses."""
        at = self.deadline.at
        if at is not None and self.deadline.clock() > at:
            self.cut += 1
            return True
        return False


class MeshWorld(WorldBase):
    """A rigid body (a triangle mesh) moving among a triangle-mesh environment; exact checks.

    Args:
        environment: The obstacles: a mesh file (``read_mesh``), a ``(vertices, faces)`` pair or a
            ``trimesh.Trimesh``, in world coordinates.
        robot: The body, in the same forms, in its own frame: the state's translation puts the
            body's origin there, its rotation turns the body about its origin.
        low: Corner of the box the body's origin stays in (OMPL.app's ``volume.min``).
        high: Opposite corner (``volume.max``).
        delta: Motion resolution (> 0): the clearance ladder's rungs are multiples of ``delta / 2``.
            Default ``DEFAULT_DELTA_FRACTION`` of the bounds' diagonal.
        band: The clearance every checked pose keeps (``0 < band <= delta / 2``; default
            ``DEFAULT_BAND_FRACTION`` of ``delta``): the poses checked from the start on lie a travel of at
            least ``2 band`` apart (more where the clearance allows), so a passage is narrowed by ``band`` on
            each side, and a smaller band costs more poses only where the body passes within ``delta / 2``
            of the environment.
        rot_weight: Weight of the rotation angle in the ``"se3"`` metric; default the body radius.
        grid_cells: Voxels along the longest side of the broad phase's grid (8 to 512).
        name: A label for ``repr``.
    """

    dim = RigidBodyWorld.dim
    space_kind = SPACE_RIGID
    metrics = RigidBodyWorld.metrics
    range_fraction = MESH_RANGE_FRACTION

    def __init__(self, environment, robot, *, low, high, delta: float | None = None, band: float | None = None,
                 rot_weight: float | None = None, grid_cells: int = DEFAULT_GRID_CELLS, name: str = "") -> None:
        lo, hi = workspace_bounds(low, high)
        self.env_vertices, self.env_faces = _as_mesh(environment, "environment")
        self.body_vertices, self.body_faces = _as_mesh(robot, "robot")
        self.radius = body_radius(self.body_vertices)
        if not math.isfinite(self.radius):
            raise InputError("the robot's vertices are too far from its origin to measure")
        diagonal = float(np.linalg.norm(hi - lo))
        self.delta = positive_delta(DEFAULT_DELTA_FRACTION * diagonal if delta is None else delta)
        check_resolution(self.delta, lo, hi, self.radius)
        self.band = motion_band(band, self.delta)
        check_resolution(self.band, lo, hi, self.radius, "band", apart=2.0)  # the walk's least step is twice the band
        self.rot_weight = rotation_weight(rot_weight, self.radius)
        if isinstance(grid_cells, bool) or not isinstance(grid_cells, (int, np.integer)) or not 8 <= grid_cells <= 512:
            raise InputError(f"grid_cells must be an integer from 8 to 512, got {grid_cells!r}")
        self.name = str(name)
        self.grid_cells = int(grid_cells)
        self.low3, self.high3 = lo, hi
        for a in (self.env_vertices, self.env_faces, self.body_vertices, self.body_faces, lo, hi):
            a.flags.writeable = False
        self._check = _FCLCheck((self.body_vertices, self.body_faces), (self.env_vertices, self.env_faces))
        ident = mesh_kernels.register_check(self._check)
        # the broad phase: a grid over every place a body point can reach, and the body's cover points
        pad = self.radius + self.delta
        origin = lo - pad
        side = float(np.max(hi - lo + 2 * pad)) / int(grid_cells)
        shape = np.maximum(1, np.ceil((hi - lo + 2 * pad) / side).astype(np.int64))
        self._grid_origin, self._grid_shape = origin, shape
        self.route_cell = side  # the workspace route's voxel (planners.guidance.workspace_route)
        self._inner_radius: float | None = None
        self._squared_distance: np.ndarray | None = None  # ``_distance_bound``'s Euclidean term, when first asked
        self._open_parts: list[np.ndarray] = []  # parts of the open voxels found so far (``reached_from``)
        self.grid = mesh_kernels.chebyshev_grid(self.env_vertices, self.env_faces.astype(np.int64), origin,
                                                side, int(shape[0]), int(shape[1]), int(shape[2]))
        self.cover, self.clusters = mesh_kernels.cover_clusters(cover_points(self.body_vertices, self.body_faces, side),
                                                                side)
        # the exact test's trees: the body's (spheres, they turn with it) and the environment's (boxes)
        body_nodes, body_triangles = triangle_kernels.build_tree(self.body_vertices[self.body_faces])
        env_nodes, env_triangles = triangle_kernels.build_tree(self.env_vertices[self.env_faces])
        parts = [self.cover, triangle_kernels.sphere_nodes(body_nodes, body_triangles), body_triangles, env_nodes,
                 env_triangles]
        params = np.zeros(mesh_kernels.N_PARAMS)
        params[:6] = np.concatenate([lo, hi])
        params[6], params[7], params[mesh_kernels.P_ID] = self.delta, self.radius, ident
        params[mesh_kernels.P_GRID:mesh_kernels.P_GRID + 4] = [*origin, side]
        params[mesh_kernels.P_GRID + 4:mesh_kernels.P_GRID + 7] = shape
        params[mesh_kernels.P_COVER] = side
        params[mesh_kernels.P_PARTS:mesh_kernels.P_PARTS + 4] = np.cumsum([len(p) for p in parts])[:4]
        params[mesh_kernels.P_BAND] = self.band
        self._kernel = geometry.world_kernel(geometry.WORLD_MESH, self.grid, self.clusters,
                                             np.ascontiguousarray(np.concatenate(parts)), params)
        self._low = np.concatenate([lo, [-math.pi] * 3])
        self._high = np.concatenate([hi, [math.pi] * 3])
        self._low.flags.writeable = False
        self._high.flags.writeable = False
        self._free_volume: float | None = None

    def __reduce__(self):
        # FCL's trees do not pickle: a copy (another process's) is built again from the triangles
        return _rebuild, ((self.env_vertices, self.env_faces), (self.body_vertices, self.body_faces),
                          {"low": self.low3, "high": self.high3, "delta": self.delta, "band": self.band,
                           "rot_weight": self.rot_weight,
                           "grid_cells": self.grid_cells, "name": self.name})

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``(low, high)``: the box of the body's origin, then ``[-pi, pi)`` for each angle."""
        return self._low, self._high

    def set_deadline(self, at: float | None, clock=None) -> None:
        """From now on, in this thread, motion checks still walking at ``clock() > at`` answer "blocked" (None: never).

        ``Planner.solve`` sets it under a time limit, so one long motion check cannot overrun the limit (the
        walk looks every ``DEADLINE_EVERY`` poses); answering "blocked" is conservative, the motion is left
        out, never wrongly accepted.
        """
        self._check.deadline.at = None if at is None else float(at)
        self._check.deadline.clock = clock

    def body_vertices_at(self, q) -> np.ndarray:
        """``(V, 3)`` world positions of the body's vertices at state ``q``."""
        q = self._state(q)
        return self.body_vertices @ np.asarray(_rotation_matrix(q[3], q[4], q[5])).T + q[:3]

    def motion_poses(self, a, b) -> np.ndarray:
        """Poses from ``a`` to ``b`` a travel of at most ``delta`` apart (``(n + 1, 6)``; one for ``a == b``).

        Where ``check_motion(a, b)`` is True every one of them is free, and every pose between: it certifies
        the whole motion, testing fewer poses where the clearance allows longer steps.
        """
        a = np.ascontiguousarray(self._state(a, "a"))
        b = np.ascontiguousarray(self._state(b, "b"))
        n, length = motion_pieces(self._kernel.params, a, b)
        if length == 0.0:
            return a[None].copy()
        out = np.empty((n + 1, 6))
        for k in range(n + 1):
            interpolate(SPACE_RIGID, a, b, k / n, out[k])
        return out

    def pose_free_exact(self, q, margin: float = 0.0) -> bool:
        """The exact check alone (FCL, no broad phase): the body at ``q`` is more than ``margin`` from the world."""
        q = self._state(q)
        return self._check.pose_free(np.asarray(_rotation_matrix(q[3], q[4], q[5])), q[:3].copy(), float(margin))

    def pose_free_broad(self, q, margin: float = 0.0) -> bool:
        """The broad phase alone: True only where it proves the pose free with ``margin`` (else undecided)."""
        q = np.ascontiguousarray(self._state(q))
        return bool(mesh_kernels.broad_phase_free(self.grid, self.cover, self.clusters, self._kernel.params, q,
                                                     float(margin)))

    def clearance(self, q) -> float:
        """Distance from the body at ``q`` to the environment (FCL; 0 or less where they meet)."""
        q = self._state(q)
        fcl = self._check._fcl
        self._check.body.setTransform(fcl.Transform(np.asarray(_rotation_matrix(q[3], q[4], q[5])), q[:3].copy()))
        if fcl.collide(self._check.body, self._check.env, self._check.collide_request, fcl.CollisionResult()):
            return 0.0
        return float(fcl.distance(self._check.body, self._check.env, self._check.distance_request,
                                  fcl.DistanceResult()))

    @property
    def inner_radius(self) -> float:
        """Radius of the largest ball about the body origin inside the body (``solid_inner_radius``).

        0 where the origin lies outside the body's solid.
        """
        if self._inner_radius is None:
            self._inner_radius = solid_inner_radius(self.body_vertices, self.body_faces)
        return self._inner_radius

    @property
    def route_spread(self) -> float:
        """The default noise about the workspace route: the inner radius or ``ROUTE_SPREAD_CELLS`` route cells.

        Whichever is larger.
        """
        return max(self.inner_radius, ROUTE_SPREAD_CELLS * self.route_cell)

    @property
    def grid_origin(self) -> np.ndarray:
        """The broad phase's grid (``grid``, ``(nx, ny * nz)`` voxels of side ``route_cell``): its low corner."""
        return self._grid_origin.copy()

    @property
    def grid_shape(self) -> tuple[int, int, int]:
        """The broad phase's grid: its voxels along each axis, ``(nx, ny, nz)``."""
        return tuple(int(n) for n in self._grid_shape)

    def workspace_clearance(self, points) -> np.ndarray:
        """``(n,)``: a lower bound on each point's distance to the environment's triangles.

        From the broad phase's grid (voxels of side ``route_cell``): the larger of a Chebyshev and a Euclidean bound
        (``_distance_bound``), which falls short of the distance by at most 2 sqrt(3) voxels where it is positive; the
        grid's edge, a body radius beyond the bounds, counts as an obstacle and outside the grid the bound is 0.
        """
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        x, y, z = (p - self._grid_origin).T
        return self._distance_bound(x, y, z)

    def _grid_cells(self, x, y, z):
        """The broad phase's voxel at offsets ``x, y, z`` from its origin (broadcastable arrays).

        ``(i, r, inside)``: the voxel's row and column in ``grid`` (``(nx, ny * nz)``), clipped to the grid,
        and whether the offset lies in the grid at all.
        """
        side, shape = self.route_cell, self._grid_shape
        idx = [np.floor(a / side).astype(np.int64) for a in (x, y, z)]
        inside = [(i >= 0) & (i < n) for i, n in zip(idx, shape, strict=True)]
        ix, iy, iz = (np.clip(i, 0, n - 1) for i, n in zip(idx, shape, strict=True))
        return ix, iy * int(shape[2]) + iz, inside[0] & inside[1] & inside[2]

    def _distance_bound(self, x, y, z) -> np.ndarray:
        """The grid's distance bound at offsets ``x, y, z`` from its origin (broadcastable arrays; 0 outside it).

        The larger of two lower bounds, in voxels: the Chebyshev one less one (``grid``), and the Euclidean distance
        between the voxel's centre and the nearest centre of a voxel that meets a triangle less sqrt(3) (a point of
        either voxel lies within half of that of its centre), which is the larger beside walls oblique to the grid.
        The Euclidean distances are computed once, at the first call (4 bytes a voxel).
        """
        if self._squared_distance is None:
            nx, ny, nz = self.grid_shape
            self._squared_distance = mesh_kernels.squared_distance_voxels(self.grid, nx, ny, nz)
        i, r, inside = self._grid_cells(x, y, z)
        chebyshev = self.grid[i, r].astype(np.float64) - 1.0
        euclidean = np.sqrt(self._squared_distance[i, r].astype(np.float64)) - math.sqrt(3.0)
        return np.maximum(np.maximum(chebyshev, euclidean), 0.0) * self.route_cell * inside

    def centre_free_voxels(self, cell: float) -> np.ndarray:
        """``(nx, ny, nz)`` bool over voxels of side ``cell`` from ``low3``: where the body's centre may be.

        Centres whose distance bound to the environment exceeds the inner radius and is positive (a closed
        obstacle's inside stays cut off by the band about its surface). The bound is a lower one, so a centre
        kept here has its inner ball clear; it falls short of the distance by up to 2 sqrt(3) voxels, so a passage
        less than about four voxels wider than the inner ball can be cut off although the ball passes it.
        """
        x, y, z = (a - o for a, o in zip(voxel_axes(self.low3, self.high3, cell), self._grid_origin, strict=True))
        # axis by axis, broadcast: no (n, 3) array of centres
        d = self._distance_bound(x[:, None, None], y[None, :, None], z[None, None, :])
        return (d > self.inner_radius) & (d > 0)

    #: The most parts of the open voxels a world keeps (``reached_from``): each is a bool over the broad phase's grid.
    OPEN_PARTS = 4

    def reached_from(self, seeds) -> np.ndarray:
        """``(nx, ny * nz)`` bool: the broad phase's voxels reached from ``seeds`` without crossing a triangle.

        The voxels of the points ``seeds`` and those about them start the fill (a seed beside a surface still starts
        it); a voxel that meets a triangle is never entered. The world keeps the parts it has filled (up to
        ``OPEN_PARTS``), so a later query whose seeds lie in them fills nothing again: the same voxels as one fill
        from every seed, which reaches the union of the seeds' parts. Read-only: it may be a kept part itself.
        """
        nx, ny, nz = (int(n) for n in self._grid_shape)
        around = self.route_cell * np.array(list(itertools.product((-1, 0, 1), repeat=3)))
        near = (np.asarray(seeds, dtype=np.float64).reshape(-1, 1, 3) - self._grid_origin + around).reshape(-1, 3)
        i, r, inside = self._grid_cells(*near.T)
        starts = np.unique((i * ny * nz + r)[inside])
        starts = starts[self.grid.reshape(-1)[starts] != 0]  # a voxel that meets a triangle starts nothing
        reached = None
        for v in starts:
            if reached is not None and reached.reshape(-1)[v]:
                continue
            part = next((q for q in self._open_parts if q.reshape(-1)[v]), None)
            if part is None:
                part = mesh_kernels.reach_open(self.grid, nx, ny, nz, np.array([v], dtype=np.int64))
                part.flags.writeable = False
                self._open_parts = [part, *self._open_parts][:self.OPEN_PARTS]
            reached = part if reached is None else reached | part
        if reached is None:  # no seed in open space: nothing reached
            return np.zeros((nx, ny * nz), dtype=bool)
        reached.flags.writeable = False
        return reached

    def solid_share_grid(self, low, cell: float, lo, hi, seeds, samples: int = 3) -> np.ndarray:
        """``solid_share`` of the cubes of side ``cell`` whose low corners are ``low + cell * k``, ``lo <= k < hi``.

        ``(hi - lo)`` float32 over the three axes: the same values as ``solid_share`` of those corners, bit for bit,
        from each axis's voxels of the broad phase looked up once per axis rather than once per point.
        """
        cell = _positive_cell(cell)
        low = np.asarray(low, dtype=np.float64)
        lo, hi = np.asarray(lo, dtype=np.int64), np.asarray(hi, dtype=np.int64)
        shape = self._grid_shape
        reached = self.reached_from(seeds).reshape(tuple(int(n) for n in shape))
        offsets = (np.arange(samples) + 0.5) / samples * cell
        index, inside = [], []
        for ax in range(3):  # each axis's broad-phase voxel at each sample offset, as _grid_cells gives it
            rel = (low[ax] + cell * np.arange(lo[ax], hi[ax])) - self._grid_origin[ax]
            at = [np.floor((rel + o) / self.route_cell).astype(np.int64) for o in offsets]
            index.append([np.clip(a, 0, int(shape[ax]) - 1) for a in at])
            inside.append([(a >= 0) & (a < int(shape[ax])) for a in at])
        share = np.zeros(tuple(int(n) for n in hi - lo))
        for a, b, c in itertools.product(range(samples), repeat=3):
            solid = ~(reached[index[0][a]][:, index[1][b]][:, :, index[2][c]]
                      & inside[0][a][:, None, None] & inside[1][b][None, :, None] & inside[2][c][None, None, :])
            share += solid
        return (share / samples ** 3).astype(np.float32)

    def solid_share(self, corners, cell: float, seeds, samples: int = 3) -> np.ndarray:
        """``(k,)`` float32: the share of each cube of side ``cell`` (low corners ``corners``, ``(k, 3)``) in solid.

        A point counts as solid where its broad-phase voxel (``route_cell``) meets a triangle or cannot be
        reached from the voxels of ``seeds`` (points, such as a query's start and goal positions, and the
        voxels about them) without crossing one: the environment's surfaces and what they enclose, as a box
        world's occupancy counts the boxes' volume; outside the broad phase's grid, solid. Each cube's share
        is measured at ``samples``^3 points spread evenly over it. For the learned orientation model's
        observation (``planners.guidance.rigid_orientation``).
        """
        cell = _positive_cell(cell)
        reached = self.reached_from(seeds)
        corners = np.asarray(corners, dtype=np.float64).reshape(-1, 3) - self._grid_origin
        offsets = (np.arange(samples) + 0.5) / samples * cell
        share = np.zeros(len(corners))
        for o in itertools.product(offsets, repeat=3):
            i, r, inside = self._grid_cells(*(corners + np.asarray(o)).T)
            share += ~(reached[i, r] & inside)
        return (share / samples ** 3).astype(np.float32)

    def free_volume(self) -> float:
        """Measure of the free states in ``(x, y, z, tx, ty, tz)`` coordinates (for RRT*/PRM* radii).

        Monte-Carlo estimate over ``VOLUME_SAMPLES`` states drawn with a fixed seed; computed once.
        """
        if self._free_volume is None:
            self._free_volume = monte_carlo_free_volume(self, VOLUME_SAMPLES)
        return self._free_volume

    def explain_invalid(self, q) -> str:
        """Why ``q`` is not a valid state ('' if it is)."""
        q = self._state(q)
        if not np.all(np.isfinite(q)):
            return "is not finite"
        if not np.all((self.low3 <= q[:3]) & (q[:3] <= self.high3)):
            return (f"puts the body's origin at {tuple(np.round(q[:3], 4).tolist())}, outside the bounds "
                    f"{tuple(self.low3.tolist())} - {tuple(self.high3.tolist())}")
        if not self.pose_free_exact(q):
            return "puts the body's triangles into the environment's"
        return ""

    def __repr__(self) -> str:
        label = f"{self.name!r}, " if self.name else ""
        band = "" if self.band == DEFAULT_BAND_FRACTION * self.delta else f", band={self.band:g}"
        return (f"MeshWorld({label}{len(self.env_faces)} environment triangles, {len(self.body_faces)} body "
                f"triangles, delta={self.delta:g}{band})")


def motion_band(band, delta: float) -> float:
    """The band a mesh world's checked poses keep clear: ``band``, or ``DEFAULT_BAND_FRACTION * delta`` where None."""
    if band is None:
        return DEFAULT_BAND_FRACTION * delta
    try:
        value = float(band)
    except (TypeError, ValueError):
        raise InputError(f"band must be a number in (0, delta / 2 = {0.5 * delta:g}], got {band!r}") from None
    if not (math.isfinite(value) and 0.0 < value <= 0.5 * delta):
        raise InputError(f"band must lie in (0, delta / 2 = {0.5 * delta:g}], got {band!r}")
    return value


def _rebuild(environment, robot, kwargs) -> MeshWorld:
    return MeshWorld(environment, robot, **kwargs)
