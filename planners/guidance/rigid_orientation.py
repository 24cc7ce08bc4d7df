"""What a learned 6-DoF orientation model sees along a workspace route, and its orientation classes (numpy only).

The box body (sides ``lx > ly > lz`` along its own x, y, z) passes the generated scenes' openings
turned to one of a few axis-aligned orientations. Up to the box's own symmetry (a half turn about any
of its axes maps it onto itself) an axis-aligned orientation is which world axis the long side lies
along and which the middle side does: six classes (``ORIENTATION_CLASSES``), each the same body
pose under four rotations (``class_rotations``).

* ``occupancy_grid(world, cell)``: the fraction of each voxel of side ``cell`` that the boxes cover,
  exact (boxes are axis-aligned), as float32.
* ``route_patches(grid, points, low, cell, half)``: the ``(2 half + 1)^3`` voxels about each point's
  voxel, voxels outside the workspace counting as covered.
* ``route_directions(route, reach)``: the route's unit direction at each of its points.
* ``path_points(path, spacing)``: a solution's or witness path's positions as dense as a route's points.
* ``route_observation(world, route)``: both, at every route point: the observation of the learned
  orientation model (``learning.models.rigid_orientation``), computed once per query. A mesh world's
  occupancy is its ``solid_share`` (surfaces and what they enclose, seen from the query's free space),
  computed over the boxes of runs of the route (``route_boxes``).
* ``body_axes(vertices)``: a body's long, middle and short axes, which carry the classes to a mesh body.
* ``permute_class`` / ``CLASS_PERMUTATIONS``: how the classes move when the world's axes are permuted
  (the training's augmentation).
* ``class_validity(world, points, classes, rng, jitter, k)``: the share of ``k`` poses of each class,
  jittered about each point, that keep the motion check's clearance (``check_motions`` of a pose to
  itself): the training label. A configuration-space query: training only, never at planning time.
* ``euler_from_matrices`` and ``small_rotations``: vectorised angle conversion and noise for drawing.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from planners.kernels.rigid import add_box_cover

#: (world axis of the body's long side, world axis of its middle side), the six axis-aligned classes.
ORIENTATION_CLASSES = tuple((a, b) for a in range(3) for b in range(3) if a != b)
N_CLASSES = len(ORIENTATION_CLASSES)
#: Half the side of an observation patch, in voxels: 13 voxels cover the body's long side (10) and more.
PATCH_HALF = 6
#: The long side of the box body the shipped orientation model learned on, in the model's voxels (1 unit): a
#: mesh body's observation takes voxels of its own long side over this, so the body spans the same voxels.
TRAINING_LONG_SIDE = 10.0
#: Route points on either side whose chord gives a route point's direction.
DIRECTION_REACH = 2


def class_rotations() -> np.ndarray:
    """``(6, 4, 3, 3)``: for each class, the four rotations that put the body in it (the box's symmetry)."""
    out = np.zeros((N_CLASSES, 4, 3, 3))
    for c, (a, b) in enumerate(ORIENTATION_CLASSES):
        for s, (sa, sb) in enumerate(itertools.product((1.0, -1.0), repeat=2)):
            ea, eb = np.zeros(3), np.zeros(3)
            ea[a], eb[b] = sa, sb
            out[c, s] = np.stack([ea, eb, np.cross(ea, eb)], axis=1)  # columns: the body's axes in the world
    return out


def permute_class(perm) -> np.ndarray:
    """``(6,)``: the class each class becomes when world axis ``perm[k]`` is renamed ``k``."""
    inv = np.argsort(np.asarray(perm))
    index = {ab: i for i, ab in enumerate(ORIENTATION_CLASSES)}
    return np.array([index[(int(inv[a]), int(inv[b]))] for a, b in ORIENTATION_CLASSES])


#: The six permutations of the world's axes.
AXIS_PERMUTATIONS = tuple(itertools.permutations(range(3)))
#: ``(6, 6)``: ``CLASS_PERMUTATIONS[p][c]`` is the class ``c`` becomes under ``AXIS_PERMUTATIONS[p]``.
CLASS_PERMUTATIONS = np.array([permute_class(p) for p in AXIS_PERMUTATIONS])


def _voxels(world, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """The workspace's low corner and its voxels of side ``cell`` along each axis (whole voxels, at least one)."""
    low = np.asarray(world.low3, dtype=np.float64)
    return low, np.maximum(1, np.floor((np.asarray(world.high3, dtype=np.float64) - low) / cell).astype(np.int64))


def occupancy_grid(world, cell: float = 1.0, seeds=None) -> np.ndarray:
    """``(nx, ny, nz)`` float32: the share of each voxel of side ``cell`` (from the workspace's low corner) in boxes.

    A mesh world (no boxes) gives its ``solid_share``: its surfaces and what they enclose, as seen from
    ``seeds`` (points in free space, such as the query's start and goal positions; required there).
    """
    low, shape = _voxels(world, cell)
    if not hasattr(world, "boxes"):
        if seeds is None:
            raise ValueError("occupancy_grid of a mesh world needs seeds: points in its free space")
        return world.solid_share_grid(low, cell, np.zeros(3, dtype=np.int64), shape, seeds)
    grid = np.zeros(tuple(shape), dtype=np.float64)
    add_box_cover(grid, np.ascontiguousarray(world.boxes, dtype=np.float64).reshape(-1, 6), low, float(cell))
    return np.minimum(grid, 1.0).astype(np.float32)


def voxel_index(points, low, cell: float, shape) -> np.ndarray:
    """``(n, 3)`` int: each point's voxel, clipped to the grid."""
    idx = np.floor((np.asarray(points, dtype=np.float64)[:, :3] - np.asarray(low)) / cell).astype(np.int64)
    return np.clip(idx, 0, np.asarray(shape) - 1)


def route_patches(grid: np.ndarray, points, low, cell: float = 1.0, half: int = PATCH_HALF) -> np.ndarray:
    """``(n, 2 half + 1, 2 half + 1, 2 half + 1)`` float32: the grid about each point's voxel, outside = 1."""
    padded = np.pad(grid, half, constant_values=1.0)
    side = 2 * half + 1
    windows = np.lib.stride_tricks.sliding_window_view(padded, (side, side, side))
    idx = voxel_index(points, low, cell, grid.shape)
    return np.ascontiguousarray(windows[idx[:, 0], idx[:, 1], idx[:, 2]])


def path_points(path, spacing: float = 1.0) -> np.ndarray:
    """``(n, 3)``: positions along a path's centres (its states' first three entries), about ``spacing`` apart,
    every vertex kept: where a solution or witness path is read at points as dense as a route's.
    """
    path = np.asarray(path, dtype=np.float64)
    pts = [path[0, :3]]
    for a, b in zip(path[:-1, :3], path[1:, :3], strict=True):
        k = max(1, int(np.ceil(np.linalg.norm(b - a) / spacing)))
        pts.extend(a + (b - a) * (np.arange(1, k + 1) / k)[:, None])
    return np.array(pts)


def route_directions(route, reach: int = DIRECTION_REACH) -> np.ndarray:
    """``(k, 3)``: the unit chord from ``reach`` points before each route point to ``reach`` after (0 if none)."""
    route = np.asarray(route, dtype=np.float64)[:, :3]
    k = len(route)
    i = np.arange(k)
    chord = route[np.minimum(i + reach, k - 1)] - route[np.maximum(i - reach, 0)]
    norm = np.linalg.norm(chord, axis=1, keepdims=True)
    return np.where(norm > 1e-12, chord / np.maximum(norm, 1e-12), 0.0)


def route_observation(world, route, cell: float = 1.0, half: int = PATCH_HALF,
                      seeds=None) -> tuple[np.ndarray, np.ndarray]:
    """The orientation model's observation at every route point: ``(patches, directions)`` (see the module doc).

    ``seeds``: points in free space, for a mesh world's ``occupancy_grid`` (default the route's ends).
    """
    directions = route_directions(route).astype(np.float32)
    if hasattr(world, "boxes"):
        return route_patches(occupancy_grid(world, cell), route, world.low3, cell, half), directions
    # a mesh world: the voxels of the box the patches span only (as route_patches over occupancy_grid would give)
    if seeds is None and len(route):
        seeds = np.asarray(route, dtype=np.float64)[[0, -1], :3]
    side = 2 * half + 1
    if not len(route):
        return np.ones((0, side, side, side), dtype=np.float32), directions
    low, shape = _voxels(world, cell)
    idx = voxel_index(route, low, cell, shape)
    patches = np.empty((len(idx), side, side, side), dtype=np.float32)
    for a, b in route_boxes(idx, half):  # runs of route points whose patches span a compact box
        lo, hi = np.maximum(idx[a:b].min(axis=0) - half, 0), np.minimum(idx[a:b].max(axis=0) + half + 1, shape)
        # outside the workspace counts as covered: the box's shares padded with ones, each patch a window of it
        padded = np.ones(tuple(int(n) for n in hi - lo + 2 * half), dtype=np.float32)
        padded[half:half + hi[0] - lo[0], half:half + hi[1] - lo[1], half:half + hi[2] - lo[2]] = \
            world.solid_share_grid(low, cell, lo, hi, seeds)  # the world's kept fill: no fill again per box
        windows = np.lib.stride_tricks.sliding_window_view(padded, (side, side, side))
        at = idx[a:b] - lo
        patches[a:b] = windows[at[:, 0], at[:, 1], at[:, 2]]
    return patches, directions


#: ``route_boxes``: a run's box holds at most this many times the voxels of its points' patches.
BOX_VOXELS_PER_PATCH = 4


def route_boxes(idx, half: int = PATCH_HALF) -> list[tuple[int, int]]:
    """Runs ``[a, b)`` of consecutive route voxels ``idx`` (``(n, 3)``) whose patches (``half`` about each) span a box.

    A run grows while its box holds at most ``BOX_VOXELS_PER_PATCH`` times its patches' voxels, so the occupancy
    computed over the boxes follows the route (a long diagonal route is many small boxes, not the workspace's cube).
    """
    idx = np.asarray(idx, dtype=np.int64).reshape(-1, 3)
    patch = (2 * half + 1) ** 3
    runs, a = [], 0
    lo = hi = idx[0] if len(idx) else None
    for i in range(1, len(idx)):
        lo_i, hi_i = np.minimum(lo, idx[i]), np.maximum(hi, idx[i])
        if np.prod(hi_i - lo_i + 2 * half + 1) > BOX_VOXELS_PER_PATCH * (i - a + 1) * patch:
            runs.append((a, i))
            a, lo, hi = i, idx[i], idx[i]
        else:
            lo, hi = lo_i, hi_i
    if len(idx):
        runs.append((a, len(idx)))
    return runs


def class_validity(world, points, rng: np.random.Generator, jitter: float, k: int, reduce: str = "mean") -> np.ndarray:
    """``(n, 6)``: per point and class, the share of ``k`` poses that keep the motion check's clearance.

    The first pose of each point is the point itself, the others Gaussian with deviation ``jitter``
    about it; each pose takes one of the class's four rotations at random. ``reduce="any"`` gives 1
    where any of the poses keeps it, else 0. A configuration-space query, for training labels only.
    """
    if reduce not in ("mean", "any"):
        raise ValueError(f"reduce = {reduce!r}, expected 'mean' or 'any'")
    points = np.asarray(points, dtype=np.float64)[:, :3]
    n = len(points)
    rots = class_rotations()
    pos = np.repeat(points[:, None], k, axis=1) + jitter * rng.standard_normal((n, k, 3)) * (np.arange(k) > 0)[:, None]
    pos = np.clip(pos, world.low3 + 1e-9, world.high3 - 1e-9)
    out = np.zeros((n, N_CLASSES))
    for c in range(N_CLASSES):
        angles = euler_from_matrices(rots[c, rng.integers(4, size=n * k)])
        q = np.concatenate([pos.reshape(-1, 3), angles], axis=1)
        ok = world.check_motions(q, q).reshape(n, k)
        out[:, c] = ok.mean(axis=1) if reduce == "mean" else ok.any(axis=1)
    return out


def nearest_class(rotations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(class, symmetry)`` indices of the axis-aligned rotation (``class_rotations``) nearest each of ``(n, 3, 3)``.

    Nearest in the angle between the rotations: the largest trace of ``C^T R`` over the 24.
    """
    rots = class_rotations().reshape(-1, 3, 3)
    k = np.einsum("kij,nij->nk", rots, np.asarray(rotations, dtype=np.float64).reshape(-1, 3, 3)).argmax(axis=1)
    return k // 4, k % 4


def nearer_end(points, start, goal) -> np.ndarray:
    """``(n,)`` int: 1 where a point lies nearer ``goal``'s position than ``start``'s, else 0 (an index into both)."""
    points = np.asarray(points, dtype=np.float64)[:, :3]
    return (((points - np.asarray(goal)[:3]) ** 2).sum(axis=1)
            < ((points - np.asarray(start)[:3]) ** 2).sum(axis=1)).astype(np.int64)


def solution_classes(points, states: np.ndarray) -> np.ndarray:
    """``(n, 6)`` one-hot: the class of the solution state nearest each point in position (``nearest_class``).

    ``states``: ``(m, 6)`` states of a solution (positions, then ``rotation_matrix``'s angles), dense along it. A
    label from a solution, for training only: the orientation a solution takes where the body passes each point.
    """
    from planners.worlds.mesh import rotation_matrices

    points = np.asarray(points, dtype=np.float64)[:, :3]
    states = np.asarray(states, dtype=np.float64)
    nearest = np.empty(len(points), dtype=np.int64)
    for i in range(0, len(points), 256):  # in chunks: points x states distances
        d = ((points[i:i + 256, None, :] - states[None, :, :3]) ** 2).sum(axis=2)
        nearest[i:i + 256] = d.argmin(axis=1)
    cls, _ = nearest_class(rotation_matrices(states[nearest, 3:]))
    out = np.zeros((len(points), N_CLASSES))
    out[np.arange(len(points)), cls] = 1.0
    return out


def body_axes(vertices) -> tuple[np.ndarray, np.ndarray]:
    """A body's own long, middle and short axes: ``(U, extents)``, the axes as the columns of a rotation.

    The principal axes of the body's vertices (about their mean), ordered by the body's extent along
    each (largest first), the third the cross product of the first two. A box body's axes are its
    sides. ``U`` maps the six classes from the box body the model learned on to another body: the
    class rotation ``C`` (columns: where the box's long, middle and short sides point) becomes
    ``C @ U.T`` (the body's long side along the class's long axis, and so on).
    """
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    centred = v - v.mean(axis=0)
    _, vecs = np.linalg.eigh(centred.T @ centred)
    extents = np.ptp(centred @ vecs, axis=0)
    order = np.argsort(-extents, kind="stable")
    u0, u1 = vecs[:, order[0]], vecs[:, order[1]]
    return np.stack([u0, u1, np.cross(u0, u1)], axis=1), extents[order]


def euler_from_matrices(R: np.ndarray) -> np.ndarray:
    """``(n, 3)`` angles ``(tx, ty, tz)`` with ``Ry(ty) Rx(tx) Rz(tz) = R`` for ``(n, 3, 3)`` rotations.

    ``tx`` lies in ``[-pi/2, pi/2]``; at ``tx = +-pi/2`` (gimbal lock) ``tz`` is 0, as
    ``planners.worlds.rigid3d.euler_from_matrix`` has it.
    """
    R = np.asarray(R, dtype=np.float64).reshape(-1, 3, 3)
    tx = np.arcsin(np.clip(-R[:, 1, 2], -1.0, 1.0))
    cx = np.sqrt(R[:, 1, 0] ** 2 + R[:, 1, 1] ** 2)
    lock = cx < 1e-9
    ty = np.where(lock, np.arctan2(np.where(R[:, 1, 2] < 0, 1.0, -1.0) * R[:, 0, 1], R[:, 0, 0]),
                  np.arctan2(R[:, 0, 2], R[:, 2, 2]))
    tz = np.where(lock, 0.0, np.arctan2(R[:, 1, 0], R[:, 1, 1]))
    return np.stack([tx, ty, tz], axis=1)


def small_rotations(omega: np.ndarray) -> np.ndarray:
    """``(n, 3, 3)``: the rotations ``exp([omega]x)`` of rotation vectors ``(n, 3)`` (Rodrigues)."""
    omega = np.asarray(omega, dtype=np.float64).reshape(-1, 3)
    theta = np.linalg.norm(omega, axis=1)
    safe = np.maximum(theta, 1e-12)
    k = omega / safe[:, None]
    K = np.zeros((len(omega), 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -k[:, 2], k[:, 1], -k[:, 0]
    K[:, 1, 0], K[:, 2, 0], K[:, 2, 1] = k[:, 2], -k[:, 1], k[:, 0]
    s, c = np.sin(theta)[:, None, None], (1.0 - np.cos(theta))[:, None, None]
    return np.eye(3)[None] + s * K + c * (K @ K)


def wrap_angles(a: np.ndarray) -> np.ndarray:
    """Angles wrapped to ``[-pi, pi)``."""
    return (np.asarray(a) + math.pi) % (2.0 * math.pi) - math.pi
