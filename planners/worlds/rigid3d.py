"""A 6-DoF rigid body among 3-D boxes: the world, box-shaped bodies, scene files and scene generators.

State ``q = (x, y, z, tx, ty, tz)``: a body point ``p`` (in the body's own frame) sits at
``H p + (x, y, z)`` with ``H = Ry(ty) Rx(tx) Rz(tz)``; angles are radians, sampled in ``[-pi, pi)``
and periodic (a motion turns along the shorter arc).

The robot is its point set (e.g. the 16 corner and edge points of ``box_body``): a state is valid when
every body point lies strictly inside the workspace and outside every closed box. A motion is checked
so that no obstacle, however thin, is stepped over: it is cut into pieces along which no body point
travels more than ``delta`` (the travel of a point is bounded by ``|dt| + r (|dtx| + |dty| + |dtz|)``,
``r`` the body's radius), and every checked position must keep a clearance of more than ``delta / 2``;
every point of the continuous motion then lies within ``delta / 2`` of a checked position, so it
touches no obstacle (see ``planners.kernels.rigid``). Motions passing closer than ``delta / 2`` to an
obstacle are rejected (conservative). What the point model cannot see is an obstacle slipping between
two body points; use a denser body (``box_body(..., spacing=...)``) where that matters. A ``delta``
that would cut the world's longest motion into more than ``MAX_MOTION_POSES`` poses is refused: it
bounds the work of one check, and so how late a planner notices its time limit.

Distances (``Problem.metric``): ``"cossin"`` (default) is the Euclidean distance on
``(x, y, z, cos tx, sin tx, cos ty, sin ty, cos tz, sin tz)``; ``"se3"`` is the translation distance
plus ``rot_weight`` times the geodesic angle between the two rotations.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from planners.base.fileio import InputError, atomic_write_text, check_int, env_limit
from planners.base.problem import Problem
from planners.base.world import WorldBase
from planners.kernels import geometry
from planners.kernels import rigid as rigid_kernels
from planners.kernels.rigid import body_points_world
from planners.kernels.space import SPACE_RIGID, interpolate

#: The scene shipped with the package (see ``load_scene`` for the format).
EXAMPLE_SCENE = Path(__file__).resolve().parents[1] / "scenes" / "example.scene"
#: The seed project's kind of scene: a box flies from one room to the other through a window; both
#: ``SETUPS`` solve it (``tests/test_rigid3d.py`` checks seeds 0 to 4).
WINDOW_SCENE = Path(__file__).resolve().parents[1] / "scenes" / "window.scene"

#: The seed project's two planning set-ups, for ``setup_planner`` and ``scripts/plan3d.py``.
SETUPS = ("prm", "rrt")
#: PRM set-up: samples in the roadmap, nearest neighbours per sample, roadmap search.
PRM_SETUP = {"samples": 5000, "k": 3, "search": "dijkstra"}
#: RRT set-up: step as a fraction of the workspace's longest side, goal distance, goal bias, iteration cap.
RRT_SETUP = {"step_fraction": 0.01, "goal_distance": 1.0, "goal_bias": 0.05, "max_iterations": 20000}

#: Default resolution of motion checks (world units a body point may travel per checked piece).
DEFAULT_DELTA = 0.05

#: The most poses one motion check may test: a world whose ``delta`` would cut its longest possible
#: motion (the workspace diagonal plus a half turn about each axis, ``diagonal + 3 pi r``) into more
#: pieces is refused. This bounds the work of one check (0.4 us per pose for a 16-point body among six
#: boxes: about 40 ms at the limit), and so how late a planner can notice its time limit.
MAX_MOTION_POSES = 100_000
#: Largest coordinate of a workspace corner: beyond it distances and volumes lose their precision.
MAX_COORDINATE = 1e12
#: Most boxes a world accepts unless raised. A scene of more than ``INDEX_MIN_BOXES`` boxes gets a spatial
#: index (a uniform grid of at most ``INDEX_MAX_CELLS`` cells, each listing the boxes near it), so a body
#: point tests the boxes of its own cell only and a pose's cost does not grow with every box in the scene.
DEFAULT_MAX_BOXES = 100_000
#: Fewer boxes than this are scanned in full: there the scan is as cheap as the index's look-up.
INDEX_MIN_BOXES = 16
#: Most cells of the spatial index (int64 offsets: 8 bytes each); the grid aims at about 4 cells per box.
INDEX_MAX_CELLS = 1 << 18
#: The environment variable that raises (or lowers) ``DEFAULT_MAX_BOXES``.
MAX_BOXES_ENV = "SAMPLERGYM_MAX_BOXES"


#: Voxel side of a box world's workspace route of the body's centre (``planners.guidance.workspace_route``),
#: in world units, unless told otherwise.
DEFAULT_CELL = 1.0
#: Most voxels a workspace route search may use (about 40 bytes each).
MAX_VOXELS = 20_000_000


def max_boxes_limit() -> int:
    """The box limit in force: ``$SAMPLERGYM_MAX_BOXES`` if set, else ``DEFAULT_MAX_BOXES``."""
    return env_limit(MAX_BOXES_ENV, DEFAULT_MAX_BOXES, low=0)


#: Point-box tests the free-volume estimate (PRM's and RRT*'s radius) may spend: about 0.1 s. Scenes of
#: up to ~80 boxes with the default 16-point body keep the full 16,384 samples.
MAX_VOLUME_TESTS = 20_000_000


def rotation_matrix(tx: float, ty: float, tz: float) -> np.ndarray:
    """``H = Ry(ty) @ Rx(tx) @ Rz(tz)`` as a (3, 3) array (the compiled checks' own matrix)."""
    return rigid_kernels.rotation_matrix(float(tx), float(ty), float(tz))


@dataclass(frozen=True)
class Box3D:
    """Closed axis-aligned box ``[x0, x1] x [y0, y1] x [z0, z1]``."""

    x0: float
    y0: float
    z0: float
    x1: float
    y1: float
    z1: float

    def as_row(self) -> tuple[float, float, float, float, float, float]:
        """``(x0, y0, z0, x1, y1, z1)``."""
        return (self.x0, self.y0, self.z0, self.x1, self.y1, self.z1)


def box_body(lx: float, ly: float, lz: float, points: int = 16, spacing: float | None = None) -> np.ndarray:
    """Points of a box-shaped body of side lengths ``(lx, ly, lz)``, centred on the body origin.

    Args:
        lx: Side length along the body's x axis (> 0).
        ly: Side length along y (> 0).
        lz: Side length along z (> 0).
        points: ``8``: the corners. ``16``: the corners plus the points at 1/3 and 2/3 of the four
            edges parallel to the longest side (x on ties). ``20``: the corners plus the midpoints of
            all 12 edges.
        spacing: If given, overrides ``points``: points along all 12 edges, at most ``spacing`` apart
            (corners included).

    Returns:
        ``(P, 3)`` float array, corners first.
    """
    sides = np.array([lx, ly, lz], dtype=np.float64)
    if sides.shape != (3,) or not np.all(np.isfinite(sides)) or np.any(sides <= 0):
        raise InputError(f"box_body side lengths must be positive finite numbers, got {(lx, ly, lz)}")
    h = 0.5 * sides
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=np.float64) * h
    # the 12 edges: pairs of corners differing in one coordinate, grouped by the axis they run along
    edges = {axis: [(i, j) for i in range(8) for j in range(i + 1, 8)
                    if np.count_nonzero(corners[i] != corners[j]) == 1 and corners[i][axis] != corners[j][axis]]
             for axis in range(3)}
    if spacing is not None:
        spacing = float(spacing)
        if not (math.isfinite(spacing) and spacing > 0):
            raise InputError(f"spacing must be a positive finite number, got {spacing}")
        fracs_by_axis = {a: np.arange(1, max(1, math.ceil(sides[a] / spacing))) / max(1, math.ceil(sides[a] / spacing))
                         for a in range(3)}
        chosen = [(a, e, fracs_by_axis[a]) for a in range(3) for e in edges[a]]
    elif points == 8:
        chosen = []
    elif points == 16:
        a = int(np.argmax(sides))
        chosen = [(a, e, np.array([1.0 / 3.0, 2.0 / 3.0])) for e in edges[a]]
    elif points == 20:
        chosen = [(a, e, np.array([0.5])) for a in range(3) for e in edges[a]]
    else:
        raise InputError(f"points must be 8, 16 or 20 (or give spacing=), got {points!r}")
    extra = [corners[i] + t * (corners[j] - corners[i]) for _, (i, j), fr in chosen for t in fr]
    return np.concatenate([corners, np.array(extra).reshape(-1, 3)])


class RigidBodyWorld(WorldBase):
    """A rigid body (a set of points) moving among closed axis-aligned boxes in a 3-D workspace.

    Args:
        boxes: Obstacles, as an ``(n, 6)`` array of rows ``(x0, y0, z0, x1, y1, z1)`` or ``Box3D``
            instances.
        body: ``(P, 3)`` body points in the body frame; default ``box_body(1.0, 0.5, 0.25)``.
        low: Workspace corner ``(x, y, z)``; the workspace is the open box ``(low, high)``.
        high: Opposite workspace corner.
        delta: Motion-check resolution (> 0): the largest travel of a body point between checked
            positions; motions must keep a clearance of ``delta / 2`` (see the module docs). A state
            closer than that to an obstacle is valid (``is_valid``) but no motion out of it passes.
            At least ``(diagonal + 3 pi r) / MAX_MOTION_POSES`` (``r`` the body radius).
        rot_weight: Weight of the rotation angle in the ``"se3"`` metric; default the body radius
            (the farthest a body point moves per radian).
    """

    dim = 6
    space_kind = SPACE_RIGID
    metrics = ("cossin", "se3")

    def __init__(self, boxes=(), body=None, *, low: Sequence[float] = (0.0, 0.0, 0.0),
                 high: Sequence[float] = (10.0, 10.0, 10.0), delta: float = DEFAULT_DELTA,
                 rot_weight: float | None = None) -> None:
        lo, hi = workspace_bounds(low, high)
        extent = hi - lo
        self.boxes = _boxes(boxes)
        limit = max_boxes_limit()
        if len(self.boxes) > limit:
            raise InputError(f"the scene has {len(self.boxes):,} boxes, more than the limit of {limit:,} (the "
                             f"spatial index holds every box, and the free-volume estimate scans them); if that "
                             f"is intended, set {MAX_BOXES_ENV}={len(self.boxes)}")
        self.body = box_body(1.0, 0.5, 0.25) if body is None else _body(body)
        delta = positive_delta(delta)
        if delta >= float(extent.min()):
            raise InputError(f"delta {delta:g} leaves no valid state: every checked position needs a clearance of "
                             f"delta / 2 = {delta / 2:g}, and no point is that far from the walls of a workspace "
                             f"whose smallest side is {float(extent.min()):g}; use delta < {float(extent.min()):g}")
        self.radius = body_radius(self.body)
        check_resolution(delta, lo, hi, self.radius)
        self.delta = delta
        self.rot_weight = rotation_weight(rot_weight, self.radius)
        self.low3, self.high3 = lo, hi
        for a in (self.boxes, self.body, self.low3, self.high3):
            a.flags.writeable = False
        index, grid_params = box_index(self.boxes, lo, hi, 0.5 * delta)
        params = np.concatenate([lo, hi, [delta, self.radius], grid_params])
        self._kernel = geometry.world_kernel(geometry.WORLD_RIGID, index, np.ascontiguousarray(self.boxes),
                                             np.ascontiguousarray(self.body), params)
        self._low = np.concatenate([lo, [-math.pi] * 3])
        self._high = np.concatenate([hi, [math.pi] * 3])
        self._low.flags.writeable = False
        self._high.flags.writeable = False
        self._free_volume: float | None = None

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``(low, high)``: the workspace corners, then ``[-pi, pi)`` for each angle."""
        return self._low, self._high

    def body_points(self, q) -> np.ndarray:
        """``(P, 3)`` world positions of the body points at state ``q``."""
        q = self._state(q)
        return self.body @ rotation_matrix(q[3], q[4], q[5]).T + q[:3]

    def clearance(self, q) -> float:
        """Smallest distance from a body point to a box or to the workspace boundary (<= 0: invalid)."""
        return float(self.workspace_clearance(self.body_points(q)).min())

    # The workspace as the route of the body's centre sees it (``planners.guidance.workspace_route``); a mesh
    # world offers the same five members.
    route_cell = DEFAULT_CELL

    @property
    def inner_radius(self) -> float:
        """Radius of a ball about the body origin inside the body at every pose (``inner_radius``)."""
        return inner_radius(self.body)

    @property
    def route_spread(self) -> float:
        """The default noise about the workspace route: the inner radius (chosen on the tuning scenes)."""
        return self.inner_radius

    def centre_free_voxels(self, cell: float) -> np.ndarray:
        """``(nx, ny, nz)`` bool over voxels of side ``cell`` from ``low3``: where the body's centre may be.

        Centres farther than the inner radius from every box and wall (a necessary condition for a valid
        pose centred there).
        """
        return free_voxels(self.boxes, self.low3, self.high3, cell, self.inner_radius)

    def workspace_clearance(self, points) -> np.ndarray:
        """``(n,)``: each point's distance to the nearest box or workspace wall (exact).

        0 inside a box, negative outside the workspace.
        """
        p = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
        boxes = np.ascontiguousarray(self.boxes, dtype=np.float64).reshape(-1, 6)
        return rigid_kernels.box_clearance(p, boxes, np.asarray(self.low3, dtype=np.float64),
                                           np.asarray(self.high3, dtype=np.float64))

    def free_volume(self) -> float:
        """Measure of the free states in ``(x, y, z, tx, ty, tz)`` coordinates (for RRT*/PRM* radii).

        Monte-Carlo estimate over 16,384 states drawn with a fixed seed (fewer, down to 256, where
        the scene is so large that 16,384 checks would exceed ``MAX_VOLUME_TESTS`` point-box tests):
        the free fraction times the workspace volume times ``(2 pi)^3``; computed once.
        """
        if self._free_volume is None:
            n = int(min(16384, max(256, MAX_VOLUME_TESTS // max(1, len(self.boxes) * len(self.body)))))
            self._free_volume = monte_carlo_free_volume(self, n)
        return self._free_volume

    def explain_invalid(self, q) -> str:
        """Why ``q`` is not a valid state ('' if it is): which body point is outside or in which box."""
        q = self._state(q)
        if not np.all(np.isfinite(q)):
            return "is not finite"
        pts = np.asarray(body_points_world(self._kernel.body, np.ascontiguousarray(q)))
        for i, p in enumerate(pts):
            if not np.all((self.low3 < p) & (p < self.high3)):
                return (f"puts body point {i} at {tuple(np.round(p, 4).tolist())} outside the workspace interior "
                        f"{tuple(self.low3.tolist())} - {tuple(self.high3.tolist())}")
        if len(self.boxes):
            inside = np.all((self.boxes[None, :, :3] <= pts[:, None]) & (pts[:, None] <= self.boxes[None, :, 3:]),
                            axis=2)  # (points, boxes)
            hits = np.argwhere(inside)
            if len(hits):
                i, k = (int(v) for v in hits[0])  # the first point, then its first box
                return (f"puts body point {i} at {tuple(np.round(pts[i], 4).tolist())} in box {k} "
                        f"{tuple(self.boxes[k].tolist())}")
        return ""

    def __repr__(self) -> str:
        ext = "x".join(f"{v:g}" for v in self.high3 - self.low3)
        return f"RigidBodyWorld({ext}, {len(self.boxes)} boxes, {len(self.body)} body points, delta={self.delta:g})"


def inner_radius(body: np.ndarray) -> float:
    """Half the smallest side of the body points' bounding box about the body origin: the inner radius of a box."""
    half = np.minimum(np.abs(body.min(axis=0)), np.abs(body.max(axis=0)))
    return float(half.min())


def voxel_axes(low: np.ndarray, high: np.ndarray, cell: float) -> list[np.ndarray]:
    """The voxel centres along each axis of a route search over ``[low, high]`` at side ``cell``.

    Raises:
        InputError: More than ``MAX_VOXELS`` voxels.
    """
    shape = np.maximum(1, np.floor((high - low) / cell).astype(np.int64))
    if int(np.prod(shape)) > MAX_VOXELS:
        raise InputError(f"a route search at cell {cell:g} needs {int(np.prod(shape)):,} voxels, more than "
                         f"{MAX_VOXELS:,}; use a larger cell")
    return [low[k] + (np.arange(shape[k]) + 0.5) * cell for k in range(3)]


def free_voxels(boxes: np.ndarray, low: np.ndarray, high: np.ndarray, cell: float, radius: float) -> np.ndarray:
    """``(nx, ny, nz)`` bool: voxel centres farther than ``radius`` from every box and from the walls."""
    axes = voxel_axes(low, high, cell)
    free = np.ones(tuple(len(a) for a in axes), dtype=np.bool_)
    for k in range(3):  # the walls
        near = (axes[k] - low[k] <= radius) | (high[k] - axes[k] <= radius)
        idx = [slice(None)] * 3
        idx[k] = near
        free[tuple(idx)] = False
    if len(boxes):  # compiled: a scene of thousands of boxes costs milliseconds
        rigid_kernels.clear_box_voxels(free, np.ascontiguousarray(boxes, dtype=np.float64).reshape(-1, 6),
                                       *(np.ascontiguousarray(a, dtype=np.float64) for a in axes), float(radius))
    return free


def box_index(boxes: np.ndarray, low: np.ndarray, high: np.ndarray, margin: float) -> tuple[np.ndarray, np.ndarray]:
    """The spatial index of ``boxes`` for checks with margins up to ``margin``: ``(index, grid parameters)``.

    Scenes of at most ``INDEX_MIN_BOXES`` boxes get none (a ``(1, 1)`` placeholder and no parameters).
    Otherwise a grid of cubic cells over the workspace, about four cells per box and at most
    ``INDEX_MAX_CELLS``, lists in each cell the boxes that come within ``margin`` of it
    (``planners.kernels.rigid``); the grid parameters are its origin, cell side and cells per axis.
    """
    if len(boxes) <= INDEX_MIN_BOXES:
        return np.zeros((1, 1), dtype=np.int64), np.zeros(0)
    extent = high - low
    cells = min(INDEX_MAX_CELLS, max(4096, 4 * len(boxes)))
    side = float(np.prod(extent) / cells) ** (1.0 / 3.0)
    shape = np.maximum(1, np.ceil(extent / side)).astype(np.int64)
    while int(np.prod(shape)) > INDEX_MAX_CELLS:  # flat workspaces: ceil can overshoot the budget
        side *= 1.1
        shape = np.maximum(1, np.ceil(extent / side)).astype(np.int64)
    # a little more than the margin: a point within it of a box, by rounded arithmetic, is surely in its cells
    pad = margin * (1.0 + 1e-9) + 1e-12 * float(np.max(np.abs(np.concatenate([low, high]))) + 1.0)
    index = rigid_kernels.bin_boxes(np.ascontiguousarray(boxes), pad, np.ascontiguousarray(low), side, shape)
    return index, np.concatenate([low, [side], shape.astype(np.float64)])


def _vector(v, n: int, label: str) -> np.ndarray:
    try:
        a = np.array(v, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{label} must be {n} numbers, got {v!r}") from None
    if a.shape != (n,) or not np.all(np.isfinite(a)):
        raise InputError(f"{label} must be {n} finite numbers, got {v!r}")
    return a


def _boxes(boxes) -> np.ndarray:
    rows = []
    for i, b in enumerate(boxes):
        row = b.as_row() if isinstance(b, Box3D) else b
        try:
            r = np.array(row, dtype=np.float64)
        except (TypeError, ValueError):
            raise InputError(f"box {i} must be 6 numbers (x0, y0, z0, x1, y1, z1), got {b!r}") from None
        if r.shape != (6,) or not np.all(np.isfinite(r)):
            raise InputError(f"box {i} must be 6 finite numbers (x0, y0, z0, x1, y1, z1), got {b!r}")
        for j, ax in enumerate("xyz"):
            if r[3 + j] < r[j]:
                raise InputError(f"box {i}: {ax}1 ({r[3 + j]:g}) < {ax}0 ({r[j]:g}) in {tuple(r.tolist())}")
        rows.append(r)
    return np.array(rows, dtype=np.float64).reshape(-1, 6)


def _body(body) -> np.ndarray:
    try:
        b = np.array(body, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"body must be a (P, 3) array of points, got {body!r}") from None
    if b.ndim != 2 or b.shape[1] != 3 or len(b) == 0:
        raise InputError(f"body must be a (P, 3) array of points with P >= 1, got shape {b.shape}")
    if not np.all(np.isfinite(b)):
        raise InputError("body points must be finite")
    return np.ascontiguousarray(b)


# --- the rigid-body state space, shared by every 6-DoF world (RigidBodyWorld, MeshWorld) ----------------


def workspace_bounds(low, high) -> tuple[np.ndarray, np.ndarray]:
    """Validated workspace corners ``(low, high)``: finite, ``low < high`` on every axis, within ``MAX_COORDINATE``."""
    lo = _vector(low, 3, "low")
    hi = _vector(high, 3, "high")
    for j, ax in enumerate("xyz"):
        if not lo[j] < hi[j]:
            raise InputError(f"workspace bounds need low < high on every axis; "
                             f"on {ax}: low {lo[j]:g}, high {hi[j]:g}")
    with np.errstate(over="ignore"):
        extent = hi - lo
        diagonal = float(np.linalg.norm(extent))
    if not (np.all(np.isfinite(extent)) and math.isfinite(diagonal)) or np.abs(np.concatenate([lo, hi])).max() > \
            MAX_COORDINATE:
        raise InputError(f"workspace bounds {tuple(lo.tolist())} - {tuple(hi.tolist())} are too large: "
                         f"coordinates must lie within +-{MAX_COORDINATE:g}")
    return lo, hi


def positive_delta(delta) -> float:
    """``delta`` as a positive finite float, else an InputError."""
    try:
        delta = float(delta)
    except (TypeError, ValueError):
        raise InputError(f"delta must be a positive number, got {delta!r}") from None
    if not (math.isfinite(delta) and delta > 0):
        raise InputError(f"delta must be a positive finite number, got {delta}")
    return delta


def body_radius(points: np.ndarray) -> float:
    """Largest distance of a body point from the body's origin (inf where it overflows)."""
    with np.errstate(over="ignore"):
        return float(np.linalg.norm(points, axis=1).max())


def check_resolution(delta: float, lo: np.ndarray, hi: np.ndarray, radius: float, name: str = "delta",
                     apart: float = 1.0) -> None:
    """Refuse a ``delta`` that would cut the longest motion into more than ``MAX_MOTION_POSES`` poses.

    The longest motion is the workspace diagonal plus a half turn about each axis (``3 pi radius``):
    the bound on a body point's travel that ``planners.kernels.rigid.motion_pieces`` cuts by. ``name``: the
    setting the message names; ``apart``: the poses lie ``apart`` times it apart (a mesh world's band: 2).
    """
    step = apart * delta
    with np.errstate(over="ignore"):  # a huge workspace or body gives inf here, refused just below
        longest = float(np.linalg.norm(hi - lo)) + 3.0 * math.pi * radius
    if not longest / step <= MAX_MOTION_POSES:
        raise InputError(f"{name} {delta:g} is too fine for this world: its longest motion ({longest:.4g}: the "
                         f"workspace diagonal plus a half turn about each axis) would be checked at "
                         f"{longest / step:.3g} poses, more than MAX_MOTION_POSES = {MAX_MOTION_POSES:,}; "
                         f"use {name} >= {longest / (apart * MAX_MOTION_POSES):.3g}")


def rotation_weight(rot_weight, radius: float) -> float:
    """The ``se3`` metric's rotation weight: ``rot_weight``, or the body radius where it is None."""
    if rot_weight is None:
        rot_weight = radius if radius > 0 else 1.0
    try:
        rot_weight = float(rot_weight)
    except (TypeError, ValueError):
        raise InputError(f"rot_weight must be a non-negative number, got {rot_weight!r}") from None
    if not (math.isfinite(rot_weight) and rot_weight >= 0):
        raise InputError(f"rot_weight must be a non-negative finite number, got {rot_weight}")
    return rot_weight


def monte_carlo_free_volume(world, n: int) -> float:
    """Free fraction of ``n`` states drawn with seed 0, times the state box's measure (at least 1 / n of it)."""
    low, high = world.bounds
    rng = np.random.default_rng(0)
    Q = low + (high - low) * rng.random((n, 6))
    frac = max(float(world.check_motions(Q, Q).mean()), 1.0 / n)
    return frac * float(np.prod(high[:3] - low[:3])) * (2.0 * math.pi) ** 3


def euler_from_matrix(R) -> np.ndarray:
    """Angles ``(tx, ty, tz)`` with ``Ry(ty) Rx(tx) Rz(tz) = R`` (``rotation_matrix``'s convention).

    ``tx`` lies in ``[-pi/2, pi/2]``; at ``tx = +-pi/2`` (gimbal lock) ``tz`` is 0.
    """
    out = np.empty(3)
    # the kernel's own source, run in the interpreter: Python calls this a few times per problem (a .cfg's
    # start and goal, a .path's states), where compiling it would cost a first call about a quarter second
    rigid_kernels.euler_angles.py_func(np.ascontiguousarray(R, dtype=np.float64), out)
    return out


# --- the seed project's planning set-ups -----------------------------------------------------------


def seed_step(world) -> float:
    """The seed set-up's RRT step on a 6-DoF world (a box or mesh world): ``RRT_SETUP["step_fraction"]`` of the
    workspace's longest side.
    """
    return RRT_SETUP["step_fraction"] * float(np.max(world.high3 - world.low3))


def setup_planner(problem: Problem, setup: str, *, seed: int = 0):
    """The seed project's planner for a rigid-body problem, and its iteration budget.

    Both plan on the ``cossin`` metric (Euclidean on ``(x, y, z, cos, sin of each angle)``), whatever
    the problem's own metric.

    * ``"prm"``: PRM with ``k = 3`` nearest neighbours, Dijkstra on the roadmap, 5,000 samples.
    * ``"rrt"``: RRT with a step of 0.01 times the workspace's longest side, goal distance 1.0 (the
      problem's goal tolerance is replaced), 5% goal bias, at most 20,000 iterations.

    Args:
        problem: A 6-DoF problem: a ``RigidBodyWorld``'s (boxes) or a ``MeshWorld``'s (meshes, an OMPL.app ``.cfg``).
        setup: ``"prm"`` or ``"rrt"`` (``SETUPS``).
        seed: Seed of the planner's generator.

    Returns:
        ``(planner, max_iterations)``; ``planner.solve(max_iterations=...)`` runs the set-up.
    """
    from planners.algorithms.prm import PRM
    from planners.algorithms.rrt import RRT
    from planners.base.samplers import GoalBiasedSampler

    # a box world or a mesh world (planners.worlds.mesh imports this module: its class is not named here)
    if not isinstance(problem, Problem) or problem.dim != 6 or getattr(problem.world, "high3", None) is None:
        raise TypeError(f"setup_planner needs a 6-DoF rigid-body problem (a box or mesh world), got {problem!r}")
    if setup not in SETUPS:
        raise InputError(f"setup must be one of {SETUPS}, got {setup!r}")
    if setup == "prm":
        p = problem.with_query(problem.start, problem.goal, metric="cossin")
        return PRM(p, k=PRM_SETUP["k"], search=PRM_SETUP["search"], seed=seed), PRM_SETUP["samples"]
    world = problem.world
    p = problem.with_query(problem.start, problem.goal, metric="cossin", goal_tolerance=RRT_SETUP["goal_distance"])
    planner = RRT(p, step_size=seed_step(world), sampler=GoalBiasedSampler(RRT_SETUP["goal_bias"]), seed=seed)
    return planner, RRT_SETUP["max_iterations"]


# --- dense interpolation -----------------------------------------------------------------------


def densify(path, problem: Problem, spacing: float) -> np.ndarray:
    """States along ``path`` at most ``spacing`` apart in the problem's metric (shorter-arc angles).

    Every vertex of ``path`` is kept.
    """
    path = np.asarray(path, dtype=np.float64).reshape(-1, problem.dim)
    if not (math.isfinite(spacing) and spacing > 0):
        raise InputError(f"spacing must be a positive finite number, got {spacing}")
    kind = problem.space[0]
    out = [path[0]]
    q = np.empty(problem.dim)
    for a, b in zip(path[:-1], path[1:], strict=True):
        n = max(1, math.ceil(problem.distance(a, b) / spacing))
        for k in range(1, n + 1):
            interpolate(kind, a, b, k / n, q)
            out.append(q.copy())
    return np.array(out)


# --- scenes --------------------------------------------------------------------------------------


#: Plain decimal numbers only: Python's ``float`` also takes ``0_3`` (as 3.0), non-ASCII digits, ``nan``
#: and ``inf``, none of which a scene file should mean.
_NUMBER = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_INTEGER = re.compile(r"[+-]?[0-9]+")


def _scene_lines(path: Path) -> list[tuple[int, str]]:
    """``(line number, text)`` of every line; a line that is not UTF-8 is an InputError naming it."""
    out = []
    for lineno, raw in enumerate(path.read_bytes().split(b"\n"), start=1):
        try:
            out.append((lineno, raw.decode("utf-8")))
        except UnicodeDecodeError as e:
            raise InputError(f"{path}, line {lineno}: not UTF-8 text (byte 0x{raw[e.start]:02x} at column "
                             f"{e.start + 1}); scene files are plain text") from None
    return out


def load_scene(path: str | os.PathLike) -> Problem:
    """Load a rigid-body planning problem from a text scene file.

    One statement per line; ``#`` starts a comment; numbers are plain decimals (``1``, ``-0.5``,
    ``2.5e-3``) separated by spaces; angles are in radians::

        bounds x0 y0 z0 x1 y1 z1        # workspace (required, once)
        body box lx ly lz [points]      # a box body (box_body; points 8, 16 or 20, default 16), or
        point x y z                     # one body point per line (body frame), instead of "body"
        box x0 y0 z0 x1 y1 z1           # an obstacle (any number)
        start x y z tx ty tz            # required, once
        goal x y z tx ty tz             # required, once
        tolerance t                     # goal tolerance (optional, default 0.5)
        delta d                         # motion-check resolution (optional, default 0.05; see
                                        # MAX_MOTION_POSES for the finest allowed)
        rot_weight w                    # se3 rotation weight (optional, default the body radius)
        metric cossin|se3               # optional, default cossin

    The file is UTF-8 text. Every error is an ``InputError`` naming the file and the line. The
    problem's name is the file's stem.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"scene file {path} does not exist")
    spec: dict = {"boxes": [], "points": []}
    counts = {"bounds": 6, "box": 6, "point": 3, "start": 6, "goal": 6, "tolerance": 1, "delta": 1, "rot_weight": 1}
    once = ("bounds", "start", "goal", "tolerance", "delta", "rot_weight", "metric", "body")
    where = {}
    for lineno, raw in _scene_lines(path):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        key, *args = line.split()

        def fail(msg: str, lineno=lineno) -> None:
            raise InputError(f"{path}, line {lineno}: {msg}")

        if key in once and key in where:
            fail(f"{key!r} given twice (first on line {where[key]})")
        where.setdefault(key, lineno)
        if key == "metric":
            if len(args) != 1 or args[0] not in RigidBodyWorld.metrics:
                fail(f"metric must be one of {RigidBodyWorld.metrics}, got {' '.join(args)!r}")
            spec["metric"] = args[0]
            continue
        if key == "body":
            if not args or args[0] != "box" or len(args) not in (4, 5):
                fail(f"expected 'body box lx ly lz [points]', got {line!r}")
            bad = [v for v in args[1:4] if not _NUMBER.fullmatch(v)]
            if bad or (len(args) == 5 and not _INTEGER.fullmatch(args[4])):
                fail(f"'body box' takes three plain decimal numbers and an optional integer, got {line!r}")
            try:
                dims = [float(v) for v in args[1:4]]
                npts = int(args[4]) if len(args) == 5 else 16
                spec["body"] = box_body(*dims, points=npts)
            except ValueError as e:
                fail(str(e))
            continue
        if key not in counts:
            fail(f"unknown statement {key!r}; expected one of {sorted(set(counts) | {'metric', 'body'})}")
        if len(args) != counts[key]:
            fail(f"{key!r} takes {counts[key]} numbers, got {len(args)}: {line!r}")
        bad = [v for v in args if not _NUMBER.fullmatch(v)]
        if bad:
            fail(f"non-numeric value {bad[0]!r} in {line!r} (expected a plain decimal number such as 0.3 or 1e-2)")
        vals = [float(v) for v in args]
        if not all(math.isfinite(v) for v in vals):
            fail(f"non-finite value in {line!r}")
        if key == "box":
            spec["boxes"].append((lineno, vals))
        elif key == "point":
            spec["points"].append(vals)
        else:
            spec[key] = vals if counts[key] > 1 else vals[0]
    for key in ("bounds", "start", "goal"):
        if key not in spec:
            raise InputError(f"{path}: missing required {key!r} line")
    for key in ("start", "goal"):
        angles = spec[key][3:]
        if max(abs(a) for a in angles) > 2 * math.pi:
            raise InputError(f"{path}, line {where[key]}: {key} angles {angles} must lie within +-2 pi (radians)")
    if "body" in spec and spec["points"]:
        raise InputError(f"{path}, line {where['point']}: give either a 'body box' line or 'point' lines, not both")
    body = spec.get("body", np.array(spec["points"]) if spec["points"] else None)
    for lineno, b in spec["boxes"]:
        try:
            _boxes([b])
        except ValueError as e:
            raise InputError(f"{path}, line {lineno}: {e}") from None
    try:
        world = RigidBodyWorld([b for _, b in spec["boxes"]], body, low=spec["bounds"][:3], high=spec["bounds"][3:],
                               delta=spec.get("delta", DEFAULT_DELTA), rot_weight=spec.get("rot_weight"))
    except ValueError as e:
        label = next((k for k in ("delta", "rot_weight", "point") if str(e).startswith(k)), "bounds")
        raise InputError(f"{path}, line {where.get(label, where.get('bounds'))}: {e}") from None
    try:
        return Problem(world, spec["start"], spec["goal"], goal_tolerance=spec.get("tolerance", 0.5),
                       metric=spec.get("metric"), name=path.stem)
    except ValueError as e:
        label = "start" if str(e).startswith("start") else "goal" if str(e).startswith("goal") else "tolerance"
        raise InputError(f"{path}, line {where.get(label, where.get('start'))}: {e}") from None


def save_scene(problem: Problem, path: str | os.PathLike) -> Path:
    """Write a rigid-body problem as a scene file (``load_scene`` reads it back exactly)."""
    world = problem.world
    if not isinstance(world, RigidBodyWorld):
        raise TypeError(f"save_scene needs a RigidBodyWorld problem, got {type(world).__name__}")

    def nums(a) -> str:
        return " ".join(repr(float(v)) for v in a)

    out = [f"# SamplerGym rigid-body scene: {problem.name or 'unnamed'}",
           f"bounds {nums(world.low3)} {nums(world.high3)}"]
    out += [f"point {nums(p)}" for p in world.body]
    out += [f"box {nums(b)}" for b in world.boxes]
    out += [f"start {nums(problem.start)}", f"goal {nums(problem.goal)}",
            f"tolerance {problem.goal_tolerance!r}", f"delta {world.delta!r}", f"rot_weight {world.rot_weight!r}",
            f"metric {problem.metric}"]
    path = Path(path)
    atomic_write_text(path, "\n".join(out) + "\n")
    return path


def _random_state(rng: np.random.Generator, world: RigidBodyWorld, xlo: float, xhi: float, margin: float,
                  tries: int = 2000) -> np.ndarray:
    lo, hi = world.low3, world.high3
    for _ in range(tries):
        pos = np.array([rng.uniform(xlo, xhi), rng.uniform(lo[1], hi[1]), rng.uniform(lo[2], hi[2])])
        q = np.concatenate([pos, rng.uniform(-math.pi, math.pi, 3)])
        if world.clearance(q) > margin:
            return q
    raise RuntimeError(f"no state with clearance {margin:g} found in {tries} tries")


def random_scene(seed: int, n_boxes: int = 30, *, size: float = 10.0, body=None,
                 box_size: tuple[float, float] = (0.5, 2.5), goal_tolerance: float = 0.5,
                 delta: float = DEFAULT_DELTA, metric: str | None = None) -> Problem:
    """A seeded random scene: ``n_boxes`` boxes in the middle of a cube, start and goal on opposite sides.

    Boxes have side lengths uniform in ``box_size`` and lie in the slab ``0.25 size < x < 0.75 size``;
    the start (``x < 0.25 size``) and goal (``x > 0.75 size``) have random orientations and a
    clearance of at least ``2 delta``. Scenes are not guaranteed to be solvable (dense settings can
    wall the slab off). Everything is drawn from ``np.random.default_rng(seed)``.

    Args:
        seed: Generator seed.
        n_boxes: Number of boxes (>= 0).
        size: Side of the cubic workspace ``(0, size)^3``.
        body: Body points; default ``box_body(0.1 size, 0.05 size, 0.025 size)``.
        box_size: Range of box side lengths, scaled by ``size / 10``.
        goal_tolerance: Goal tolerance of the problem.
        delta: Motion-check resolution, scaled by ``size / 10``.
        metric: ``"cossin"`` (default) or ``"se3"``.
    """
    check_int(n_boxes, "n_boxes", low=0)
    size = float(size)
    if not (math.isfinite(size) and size > 0):
        raise InputError(f"size must be a positive finite number, got {size}")
    s = size / 10.0
    rng = np.random.default_rng(seed)
    body = box_body(1.0 * s, 0.5 * s, 0.25 * s) if body is None else body
    lo_side, hi_side = (float(v) * s for v in box_size)
    if not (0 < lo_side <= hi_side):
        raise InputError(f"box_size must be (low, high) with 0 < low <= high, got {box_size}")
    boxes = []
    for _ in range(int(n_boxes)):
        side = rng.uniform(lo_side, hi_side, 3)
        c = np.array([rng.uniform(0.25 * size + side[0] / 2, 0.75 * size - side[0] / 2),
                      rng.uniform(0, size), rng.uniform(0, size)])
        boxes.append(np.concatenate([np.clip(c - side / 2, 0, size), np.clip(c + side / 2, 0, size)]))
    world = RigidBodyWorld(boxes, body, low=(0, 0, 0), high=(size, size, size), delta=delta * s)
    start = _random_state(rng, world, 0.0, 0.25 * size, 2 * world.delta)
    goal = _random_state(rng, world, 0.75 * size, size, 2 * world.delta)
    return Problem(world, start, goal, goal_tolerance=goal_tolerance, metric=metric, name=f"rigid-random-{seed}")


def thin_wall_scene(thickness: float = 0.01, hole: float = 1.6, *, size: float = 10.0, body=None,
                    goal_tolerance: float = 0.5, delta: float = DEFAULT_DELTA, metric: str | None = None) -> Problem:
    """A wall of ``thickness`` across the middle of a cube (``x = size / 2``) with a square hole.

    The hole (side ``hole``) is centred on the wall; start and goal, on either side of the wall,
    face each other through solid wall (``y = z = size / 4``), so the straight motion between them
    crosses the wall. The wall is far thinner than a typical coarse check step: a check that only
    samples states every few tenths of a unit passes straight through it; ``check_motion`` does not
    (see the module docs). Planners must find the hole.
    """
    thickness, hole, size = float(thickness), float(hole), float(size)
    if not (math.isfinite(thickness) and thickness > 0):
        raise InputError(f"thickness must be a positive finite number, got {thickness}")
    if not (math.isfinite(size) and size > 0):
        raise InputError(f"size must be a positive finite number, got {size}")
    if not (math.isfinite(hole) and 0 < hole < size):
        raise InputError(f"hole must lie in (0, size={size:g}), got {hole}")
    m = size / 2
    x0, x1 = m - thickness / 2, m + thickness / 2
    h0, h1 = m - hole / 2, m + hole / 2
    boxes = [
        (x0, 0.0, 0.0, x1, h0, size),  # below the hole in y
        (x0, h1, 0.0, x1, size, size),  # above the hole in y
        (x0, h0, 0.0, x1, h1, h0),  # beside the hole in z
        (x0, h0, h1, x1, h1, size),
    ]
    world = RigidBodyWorld(boxes, body, low=(0, 0, 0), high=(size, size, size), delta=delta)
    # 0.205 / 0.805: with the default body, sampling states every 0.25 units from start to goal puts no
    # body point inside the wall, so a sampled check passes the straight motion (tests/test_rigid3d.py)
    start = (0.205 * size, 0.25 * size, 0.25 * size, 0.0, 0.0, 0.0)
    goal = (0.805 * size, 0.25 * size, 0.25 * size, 0.0, 0.0, 0.0)
    return Problem(world, start, goal, goal_tolerance=goal_tolerance, metric=metric, name="rigid-thin-wall")
