"""Compiled motion checks for a rigid body given as a triangle mesh among a triangle-mesh environment.

State ``q = (x, y, z, tx, ty, tz)`` as for ``planners.kernels.rigid``: a body vertex ``p`` sits at
``H p + (x, y, z)`` with ``H = Ry(ty) Rx(tx) Rz(tz)``. Along a motion no body point travels more than ``s`` when
the motion's parameter advances by ``s / L``, ``L`` the travel bound of ``motion_pieces``
(``|dt| + r (|dtx| + |dty| + |dtz|)``). Every checked pose must keep the body more than the world's band ``b``
(``params[P_BAND]``, ``delta / 8`` by default) from the environment, and a pose at travel ``s`` with clearance
``c`` covers the stretch ``(s - c, s + c)``: no pose there brings the body into contact (conservative
advancement, both ways). The far end is checked first and covers the end of the motion; the walk then covers
it from the start, placing each next pose just under ``c`` (the clearance just certified, times ``WALK_GUESS``)
beyond the covered stretch and at least ``2 b`` on, and where that pose's own clearance leaves a gap, checking
next the pose that the one-sided rule places (``max(2 b, c)`` after the last): two poses with clearances above
``b`` that far apart cover everything between them, so no obstacle, however thin, is stepped over. A band below
``delta / 2`` narrows each passage less and costs more poses only where the body passes within ``delta / 2``
of the environment.

Each pose's clearance comes first from a broad phase that can only certify: a Chebyshev distance grid of the
environment (``chebyshev_grid``), built once, gives every voxel a lower bound on the distance from any point in it to
any environment triangle. The bound of a pose is that of the body's bounding sphere, or else the smallest over the
body's cover points (points on its surface such that every surface point lies within ``cover`` of one) less
``cover``; a single state asks the sphere only, as the exact test costs about what the cover points do. Where the
bound does not clear the band, the exact test decides (``exact_clearance``): whether the body's triangles lie more
than a margin from the environment's (``planners.kernels.triangles``), at the margins ``CLEARANCE_LADDER`` times
``delta / 2`` that lie above the band and then at the band, the largest one cleared being the pose's clearance (all
of them in one walk of the two trees, ``sets_clearance``, which a motion's walk hands, pose to pose, the pair of
triangles that last set its margin). Before the walk, the same test with no margin at a few interior poses
(``PROBE_FRACTIONS``; those whose bounding sphere the grid clears left out) finds most blocked motions; a pose in
contact would make the walk fail as well. The far end, often in contact, tries the lowest margin first; the walk's
poses, rarely in contact, the largest. Every test runs in compiled code; the checks look at their planner's deadline
every ``DEADLINE_EVERY`` poses, counted across motions (far ends, probes and the walk's poses alike, so a run of short
motions looks as often as one long one), through numba's object mode, the world registered under an integer id that
``params`` carry; past it a check answers "blocked".

``params`` of a mesh world: ``[xlo, ylo, zlo, xhi, yhi, zhi, delta, radius, world id, gx, gy, gz,
h, nx, ny, nz, cover, c1, c2, c3, c4, band, ticks]``: the bounds of the body's origin, the motion resolution, the
body's radius (largest distance of a body vertex from its origin), the id, the grid's corner, voxel
side and shape, the cover radius of the body's cover points, where the parts of ``body`` end, the band, and the poses
checked since the deadline was last looked at (the one entry the checks write). The
grid travels as ``(nx, ny * nz)`` uint8 (``grid``), the cover points' clusters as ``geom``, and ``body``
holds, as rows of three, the cover points (to row ``c1``), the body's sphere tree (to ``c2``,
``triangles.sphere_nodes``), its triangles in that tree's order (to ``c3``), the environment's box tree
(to ``c4``, ``triangles.build_tree``) and its triangles.
"""

from __future__ import annotations

import itertools
import math
import weakref

import numba as nb
import numpy as np

from planners.kernels.rigid import motion_pieces, rotation_entries
from planners.kernels.space import SPACE_RIGID, interpolate
from planners.kernels.triangles import sets_apart, sets_clearance

P_ID = 8
P_GRID = 9
P_COVER = 16
P_PARTS = 17
P_BAND = 21
P_TICKS = 22
N_PARAMS = 23

#: The margins, in multiples of ``delta / 2``, at which ``exact_clearance`` tests a pose, largest first, those above
#: the world's band; then the band itself, raised by a relative ``BAND_RAISE`` so that a pose it clears has a
#: clearance above the value returned.
CLEARANCE_LADDER = np.array([16.0, 4.0, 1.0])
BAND_RAISE = 1.0 + 2.0 ** -30

#: Cover points ``clearance_bound`` reads between its looks at whether the least bound so far settles the answer.
LEAST_RUN = 16

#: The motion checks look at their planner's deadline (``MeshWorld.set_deadline``) every this many poses, counted
#: across motions (``params[P_TICKS]``): a short motion's few poses count towards the next look too.
DEADLINE_EVERY = 16

#: The worlds' deadline keepers, by id: objects with ``past_deadline() -> bool`` (``MeshWorld.set_deadline``).
_CHECKS: weakref.WeakValueDictionary = weakref.WeakValueDictionary()
_IDS = itertools.count(1)


def register_check(check) -> int:
    """Register a world's deadline keeper (an object with ``past_deadline() -> bool``); returns its id.

    The registry holds it weakly: the world that owns it keeps it alive.
    """
    ident = next(_IDS)
    _CHECKS[ident] = check
    return ident


def past_deadline(ident) -> bool:
    """True once the deadline set on the check registered under ``ident`` has passed (object mode)."""
    check = _CHECKS.get(int(ident))
    return check is not None and bool(check.past_deadline())


@nb.njit(cache=True, no_cfunc_wrapper=True)
def _voxel(params, x, y, z):
    """Flat index ``(i, j * nz + k)`` of the voxel holding a point, ``(-1, -1)`` outside the grid."""
    gx, gy, gz, h = params[P_GRID], params[P_GRID + 1], params[P_GRID + 2], params[P_GRID + 3]
    nx, ny, nz = int(params[P_GRID + 4]), int(params[P_GRID + 5]), int(params[P_GRID + 6])
    i = int(math.floor((x - gx) / h))
    j = int(math.floor((y - gy) / h))
    k = int(math.floor((z - gz) / h))
    if i < 0 or j < 0 or k < 0 or i >= nx or j >= ny or k >= nz:
        return -1, -1
    return i, j * nz + k


@nb.njit(cache=True, no_cfunc_wrapper=True)
def sphere_free(grid, params, q, margin):
    """True if the broad phase's grid proves the body's bounding sphere at ``q`` more than ``margin`` clear."""
    i, jk = _voxel(params, q[0], q[1], q[2])
    return i >= 0 and (grid[i, jk] - 1.0) * params[P_GRID + 3] > params[7] + margin


@nb.njit(cache=True, no_cfunc_wrapper=True)
def clearance_bound(grid, cover, clusters, params, q, need):
    """A lower bound on the distance from the body at ``q`` to the environment, from the grid alone.

    The sphere's bound first; where it is not above ``need``, the cover points' (stopping as soon as
    the points read show the bound cannot exceed ``need``). A result at or below ``need`` says nothing.

    The cover points come in clusters (``cover_clusters``): the cluster with the lowest floor is read
    first, then each other cluster only where its floor could undercut the lowest point found so far,
    which gives the smallest bound over all points, exactly as reading every point would. A cluster's
    floor is a lower bound, in voxel values, on ``grid`` at each of its points: they lie within its radius
    of its centre, so their voxels lie within ``slack`` voxels of the centre's (Chebyshev index distance),
    and the grid's values change by at most 1 per voxel; near the grid's edge, where a point may lie
    outside it, the floor is unknown (``-inf``) and each point's voxel is checked. A cluster is read for its
    least voxel value (the bound grows with the value, so its least bound is that value's), ``LEAST_RUN``
    points at a time in loops without an exit (``_least_voxel``): the bound returned above ``need`` is the
    same, bit for bit, as a point-by-point reading's, and at or below ``need`` both say "undecided".
    """
    h = params[P_GRID + 3]
    i, jk = _voxel(params, q[0], q[1], q[2])
    if i < 0:
        return -1.0
    bound = (grid[i, jk] - 1.0) * h - params[7]
    if bound > need:
        return bound
    gx, gy, gz = params[P_GRID], params[P_GRID + 1], params[P_GRID + 2]
    nx, ny, nz = int(params[P_GRID + 4]), int(params[P_GRID + 5]), int(params[P_GRID + 6])
    # the rotation and the grid's constants read once for every point: read from their arrays point by point, each
    # point's voxel through ``_voxel``, they cost four times as much (the same arithmetic, term for term)
    rot = rotation_entries(q[3], q[4], q[5])
    t = (q[0], q[1], q[2])
    g = (gx, gy, gz)
    n = clusters.shape[0]
    floors = np.empty(n)
    first = 0
    for c in range(n):
        i, j, k = _posed_voxel(clusters[c, 0], clusters[c, 1], clusters[c, 2], rot, t, g, h)
        slack = clusters[c, 3]
        if i < slack or j < slack or k < slack or i + slack >= nx or j + slack >= ny or k + slack >= nz:
            floors[c] = -np.inf  # at or near the grid's edge: a point may lie outside it
        else:
            floors[c] = grid[i, j * nz + k] - slack
        if floors[c] < floors[first]:
            first = c
    cover_radius = params[P_COVER]
    lowest = np.inf
    for m in range(n + 1):
        c = first if m == 0 else m - 1
        if m > 0 and (c == first or (floors[c] - 1.0) * h - cover_radius >= lowest):
            continue
        if floors[c] == -np.inf:  # a point may lie outside the grid: each one checked
            least = 255
            for p in range(int(clusters[c, 4]), int(clusters[c + 1, 4]) if c + 1 < n else cover.shape[0]):
                i, j, k = _posed_voxel(cover[p, 0], cover[p, 1], cover[p, 2], rot, t, g, h)
                if i < 0 or j < 0 or k < 0 or i >= nx or j >= ny or k >= nz:
                    return bound
                least = min(least, grid[i, j * nz + k])
        else:  # every point's voxel lies within ``slack`` of the centre's: inside the grid
            least = _least_voxel(grid, cover, int(clusters[c, 4]), int(clusters[c + 1, 4]) if c + 1 < n else
                                 cover.shape[0], rot, t, g, h, nz, cover_radius, need)
        # the cluster's least voxel value gives its least bound: the bound grows with the value
        d = (least - 1.0) * h - cover_radius
        if d < lowest:
            lowest = d
            if lowest <= need:
                return max(bound, lowest)
    return max(bound, lowest)


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _posed_voxel(x, y, z, rot, t, g, h):
    """The grid voxel ``(i, j, k)`` of the body-frame point ``(x, y, z)`` turned by ``rot`` (``rotation_entries``'),
    moved by ``t``, in the grid of origin ``g`` and voxel side ``h`` (unchecked against the grid's shape).
    """
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = rot
    return (int(math.floor((r00 * x + r01 * y + r02 * z + t[0] - g[0]) / h)),
            int(math.floor((r10 * x + r11 * y + r12 * z + t[1] - g[1]) / h)),
            int(math.floor((r20 * x + r21 * y + r22 * z + t[2] - g[2]) / h)))


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _least_voxel(grid, cover, first, end, rot, t, g, h, nz, cover_radius, need):
    """The least ``grid`` value at the cover points ``first:end`` posed (``_posed_voxel``), each in the grid; or, as
    soon as the least so far bounds the clearance at or below ``need``, that value. ``LEAST_RUN`` points at a time, in
    loops with no exit that the compiler runs several points at a time.
    """
    least = 255
    p = first
    while p < end:
        stop = min(p + LEAST_RUN, end)
        for r in range(p, stop):
            i, j, k = _posed_voxel(cover[r, 0], cover[r, 1], cover[r, 2], rot, t, g, h)
            least = min(least, grid[i, j * nz + k])
        if (least - 1.0) * h - cover_radius <= need:
            return least
        p = stop
    return least


@nb.njit(cache=True, no_cfunc_wrapper=True)
def broad_phase_free(grid, cover, clusters, params, q, margin):
    """True if the broad phase proves the pose ``q`` keeps the body more than ``margin`` from the environment.

    False means undecided, never "in collision". ``clearance_bound``'s verdict.
    """
    return clearance_bound(grid, cover, clusters, params, q, margin) > margin


def cover_clusters(cover: np.ndarray, h: float, side: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """The cover points ordered by cluster, and the clusters as rows ``(x, y, z, slack, first point)``.

    A cluster holds the points of one cube of ``side`` voxels in the body's frame; its centre is their mean,
    its slack the voxels (Chebyshev index distance) a point's voxel can lie from the centre's: one more
    than its radius over the voxel side, rounded up.
    """
    key = np.floor(cover / (side * h)).astype(np.int64)
    _, label = np.unique(key, axis=0, return_inverse=True)
    label = label.reshape(-1)
    order = np.argsort(label, kind="stable")
    points = np.ascontiguousarray(cover[order])
    label = label[order]
    starts = np.flatnonzero(np.r_[True, label[1:] != label[:-1]])
    rows = np.empty((len(starts), 5))
    for r, (a, b) in enumerate(zip(starts, np.r_[starts[1:], len(points)], strict=True)):
        centre = points[a:b].mean(axis=0)
        radius = float(np.sqrt(((points[a:b] - centre) ** 2).sum(axis=1)).max())
        rows[r, :3] = centre
        rows[r, 3] = math.ceil(radius / h + 1e-6) + 1
        rows[r, 4] = a
    return points, rows


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _parts(body, params):
    """The parts of a mesh world's ``body`` array: cover points, the body's tree and triangles, the environment's."""
    first = params[P_PARTS:P_PARTS + 4]
    return (body[:int(first[0])], body[int(first[0]):int(first[1])], body[int(first[1]):int(first[2])],
            body[int(first[2]):int(first[3])], body[int(first[3]):])


@nb.njit(cache=True, no_cfunc_wrapper=True)
def _posed(triangles, q):
    """The rotation of pose ``q`` (``rotation_entries``') and the body's triangles (rows, body frame) placed at it."""
    rot = rotation_entries(q[3], q[4], q[5])
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = rot
    x, y, z = q[0], q[1], q[2]
    out = np.empty_like(triangles)
    for r in range(triangles.shape[0]):
        out[r, 0] = r00 * triangles[r, 0] + r01 * triangles[r, 1] + r02 * triangles[r, 2] + x
        out[r, 1] = r10 * triangles[r, 0] + r11 * triangles[r, 1] + r12 * triangles[r, 2] + y
        out[r, 2] = r20 * triangles[r, 0] + r21 * triangles[r, 1] + r22 * triangles[r, 2] + z
    return rot, out


@nb.njit(cache=True, no_cfunc_wrapper=True)
def exact_apart(body, params, q, margin, hint):
    """True if the body's triangles at pose ``q`` lie more than ``margin`` from the environment's (exact, compiled).

    ``margin`` 0: no triangle of the body meets one of the environment's (touching counts as meeting). ``hint``:
    ``sets_clearance``'s (the same answer with any; ``np.full(2, -1)`` for none).
    """
    cover, spheres, triangles, nodes, env = _parts(body, params)
    rot, placed = _posed(triangles, q)
    return sets_apart(spheres, placed, rot, (q[0], q[1], q[2]), nodes, env, margin, hint)


@nb.njit(cache=True, no_cfunc_wrapper=True)
def exact_clearance(body, params, q, need, low_first, hint):
    """A lower bound above ``need`` on the body's clearance at pose ``q``, or 0 where it is ``need`` or less.

    The largest of the margins ``CLEARANCE_LADDER`` times ``delta / 2`` above ``need``, and ``need`` itself (raised
    by ``BAND_RAISE``), that the pose clears: the exact test (``planners.kernels.triangles.sets_clearance``) asks
    them all in one walk of the two trees, largest first. ``low_first``: test ``need`` alone first (a pose likely to
    fail, where that one test settles it). ``hint``: ``sets_clearance``'s (the same answer with any; ``np.full(2,
    -1)`` for none); the walk of a motion passes one from pose to pose.
    """
    cover, spheres, triangles, nodes, env = _parts(body, params)
    rot, placed = _posed(triangles, q)
    t = (q[0], q[1], q[2])
    lowest = need * BAND_RAISE
    if low_first and not sets_apart(spheres, placed, rot, t, nodes, env, lowest, hint):
        return 0.0
    half = 0.5 * params[6]
    rungs = 0
    while rungs < CLEARANCE_LADDER.shape[0] and half * CLEARANCE_LADDER[rungs] > lowest:
        rungs += 1
    if low_first and rungs == 0:
        return lowest
    margins = np.empty(rungs + (0 if low_first else 1))
    for k in range(rungs):
        margins[k] = half * CLEARANCE_LADDER[k]
    if not low_first:
        margins[rungs] = lowest
    k = sets_clearance(spheres, placed, rot, t, nodes, env, margins, hint)
    if k < rungs:
        return margins[k]
    if k == rungs:  # the band cleared (low first: tested before)
        return lowest
    return 0.0


@nb.njit(cache=True, no_cfunc_wrapper=True)
def _pose_clearance(grid, body, clusters, params, q, need, low_first, hint):
    """The grid's bound where it exceeds ``need``, else ``exact_clearance``'s (0 where not ``need`` clear)."""
    c = clearance_bound(grid, _parts(body, params)[0], clusters, params, q, need)
    if c > need:
        return c
    return exact_clearance(body, params, q, need, low_first, hint)


@nb.njit(cache=True, no_cfunc_wrapper=True)
def _in_bounds(params, q):
    for j in range(3):
        if not (params[j] <= q[j] <= params[3 + j]):
            return False
    return True


def mesh_state_free_py(grid, body, params, q) -> bool:
    """``mesh_motion_free(q, q)`` for Python callers (the same answer), compiling only the exact test.

    The bounds, then the bounding sphere's grid bound (``sphere_free``'s source, run by the interpreter), else
    the compiled ``exact_apart`` with no margin.
    """
    if not _in_bounds.py_func(params, q):
        return False
    if sphere_free.py_func(grid, params, q, 0.0):
        return True
    none = np.full(2, -1, dtype=np.int64)  # no hint
    return bool(exact_apart(body, params, np.ascontiguousarray(q, dtype=np.float64), 0.0, none))


#: Where a motion is blocked inside, the contact test (``exact_apart`` with no margin) at a few of its poses
#: finds it before the walk certifies clearances pose by pose: the poses at these fractions (a bisection to
#: depth 3), on motions at least ``PROBE_MIN_PIECES`` resolution steps long. A pose in contact makes the walk
#: fail too, so the verdict is the same; a free motion pays up to 7 contact tests.
PROBE_FRACTIONS = np.array([0.5, 0.25, 0.75, 0.125, 0.375, 0.625, 0.875])
PROBE_MIN_PIECES = 8

#: The walk places its next pose this many times the last clearance beyond the stretch already covered
#: (two-sided conservative advancement: the pose covers as much behind it as ahead of it when its
#: clearance is at least that). Just under 1: the exact test's clearances are the ladder's rungs, so the next
#: pose's often equals the last one's, and a pose placed a whole clearance on would only touch the covered end
#: (the stretches are open), a gap that costs another pose.
WALK_GUESS = 0.99


@nb.njit(cache=True, no_cfunc_wrapper=True)
def _past_deadline(params):
    """True once the deadline of the world's planner has passed (``MeshWorld.set_deadline``; object mode)."""
    ident = params[P_ID]
    past = False
    with nb.objmode(past="boolean"):
        past = past_deadline(ident)
    return past


@nb.njit(cache=True, no_cfunc_wrapper=True)
def _tick_past_deadline(params, poses):
    """Count ``poses`` more checked poses; at every ``DEADLINE_EVERY``-th, whether the deadline has passed."""
    ticks = params[P_TICKS] + poses
    if ticks < DEADLINE_EVERY:
        params[P_TICKS] = ticks
        return False
    params[P_TICKS] = 0.0
    return _past_deadline(params)


@nb.njit(cache=True, no_cfunc_wrapper=True)
def mesh_motion_free(grid, body, clusters, params, a, b):
    """True if the motion a -> b keeps the body clear of the environment (see the module docs).

    The origin must stay within the bounds (checked at both ends: the bounds are a box and translation
    is linear). A zero-length motion is a state check: no contact, no clearance asked.
    """
    if not (_in_bounds(params, a) and _in_bounds(params, b)):
        return False
    n, length = motion_pieces(params, a, b)
    if length == 0.0:
        # a single state: the sphere only (the exact test costs about what the cover points do)
        return sphere_free(grid, params, a, 0.0) or exact_apart(body, params, a, 0.0, np.full(2, -1, dtype=np.int64))
    margin = params[P_BAND]
    least = 2.0 * margin  # the least step from the last pose: two poses clear by more than ``margin`` cover it
    # the far end first (a blocked extension is usually blocked there): its clearance covers the travel
    # (length - cb, length]; then the interior probes; then the walk from the start (see the module docs)
    # the low-first choice as np.bool_, a value: a constant True or False would compile _pose_clearance once each;
    # the exact test's hint passes from pose to pose (``sets_clearance``)
    hint = np.full(2, -1, dtype=np.int64)
    if _tick_past_deadline(params, 1.0):  # past the deadline a check answers "blocked" (module docs)
        return False
    cb = _pose_clearance(grid, body, clusters, params, b, margin, np.bool_(True), hint)
    if not cb > margin:
        return False
    q = np.empty(6)
    if n >= PROBE_MIN_PIECES:
        if _tick_past_deadline(params, float(PROBE_FRACTIONS.shape[0])):
            return False
        # the probes: the contact test at the poses PROBE_FRACTIONS places, those whose bounding sphere the grid
        # proves free left out (the cover points' bound costs a free pose more than the contact test does)
        for f in PROBE_FRACTIONS:
            interpolate(SPACE_RIGID, a, b, f, q)
            if not sphere_free(grid, params, q, 0.0) and not exact_apart(body, params, q, 0.0, hint):
                return False
    end = length - cb  # (end, length] is covered
    covered = -1.0  # [0, covered) is covered; nothing yet
    island_lo = island_hi = -1.0  # a stretch covered by a pose whose guess left a gap
    last = 0.0  # the travel of the last pose that extended the covered stretch
    s = 0.0
    while True:
        interpolate(SPACE_RIGID, a, b, s / length, q)
        c = _pose_clearance(grid, body, clusters, params, q, margin, np.bool_(False), hint)
        if not c > margin:
            return False
        if _tick_past_deadline(params, 1.0):
            return False
        if covered < 0.0 or s - c < covered:
            covered = s + c
            last = s
            if island_lo >= 0.0 and island_lo < covered:
                covered = max(covered, island_hi)
            if covered > end:
                return True
            # guess that the next pose's clearance is about this one's: place it that far beyond the
            # covered stretch, at least ``least`` on, and no farther than halfway to the covered end
            s = max(last + least, min(covered + WALK_GUESS * c, 0.5 * (covered + end)))
        else:
            # the guess left a gap: keep what this pose covers and place the next as the one-sided rule does
            if s + c > end:
                end = s - c
            else:
                island_lo, island_hi = s - c, s + c
            s = max(covered, last + least)
        if s >= end:
            # less than the band is left between the covered stretches: a pose halfway closes it
            s = 0.5 * (covered + end)


# --- building the broad phase --------------------------------------------------------------------------


@nb.njit(cache=True)
def _separated(ax, ay, az, x0, y0, z0, x1, y1, z1, x2, y2, z2, hx, hy, hz):
    """True if the axis ``(ax, ay, az)`` separates the triangle (corners relative to the box's centre) from the box."""
    p0 = x0 * ax + y0 * ay + z0 * az
    p1 = x1 * ax + y1 * ay + z1 * az
    p2 = x2 * ax + y2 * ay + z2 * az
    lo = min(p0, min(p1, p2))
    hi = max(p0, max(p1, p2))
    r = hx * abs(ax) + hy * abs(ay) + hz * abs(az)
    return lo > r or hi < -r


@nb.njit(cache=True)
def triangle_box_overlap(c, half, t0, t1, t2):
    """True if the closed triangle meets the closed box of centre ``c`` and half sides ``half``.

    The separating-axis test (the box's three axes, the triangle's normal and the nine edge cross
    products; T. Akenine-Moeller, "Fast 3D triangle-box overlap testing", 2001), in scalars. Callers
    enlarge ``half`` slightly so that rounding can only report an overlap, never miss one.
    """
    hx, hy, hz = half[0], half[1], half[2]
    x0, y0, z0 = t0[0] - c[0], t0[1] - c[1], t0[2] - c[2]
    x1, y1, z1 = t1[0] - c[0], t1[1] - c[1], t1[2] - c[2]
    x2, y2, z2 = t2[0] - c[0], t2[1] - c[1], t2[2] - c[2]
    if min(x0, min(x1, x2)) > hx or max(x0, max(x1, x2)) < -hx:
        return False
    if min(y0, min(y1, y2)) > hy or max(y0, max(y1, y2)) < -hy:
        return False
    if min(z0, min(z1, z2)) > hz or max(z0, max(z1, z2)) < -hz:
        return False
    # the edges e0 = v1 - v0, e1 = v2 - v1, e2 = v0 - v2 and the normal e0 x e1
    ex0, ey0, ez0 = x1 - x0, y1 - y0, z1 - z0
    ex1, ey1, ez1 = x2 - x1, y2 - y1, z2 - z1
    ex2, ey2, ez2 = x0 - x2, y0 - y2, z0 - z2
    nx = ey0 * ez1 - ez0 * ey1
    ny = ez0 * ex1 - ex0 * ez1
    nz = ex0 * ey1 - ey0 * ex1
    if _separated(nx, ny, nz, x0, y0, z0, x1, y1, z1, x2, y2, z2, hx, hy, hz):
        return False
    # each box axis crossed with each edge: x cross e = (0, -ez, ey), y cross e = (ez, 0, -ex), z cross e = (-ey, ex, 0)
    for k in range(3):
        if k == 0:
            ex, ey, ez = ex0, ey0, ez0
        elif k == 1:
            ex, ey, ez = ex1, ey1, ez1
        else:
            ex, ey, ez = ex2, ey2, ez2
        if _separated(0.0, -ez, ey, x0, y0, z0, x1, y1, z1, x2, y2, z2, hx, hy, hz):
            return False
        if _separated(ez, 0.0, -ex, x0, y0, z0, x1, y1, z1, x2, y2, z2, hx, hy, hz):
            return False
        if _separated(-ey, ex, 0.0, x0, y0, z0, x1, y1, z1, x2, y2, z2, hx, hy, hz):
            return False
    return True


@nb.njit(cache=True)
def chebyshev_grid(vertices, faces, origin, h, nx, ny, nz):
    """Voxel bounds of the distance to the environment's triangles, as ``(nx, ny * nz)`` uint8.

    A voxel's value ``c`` says: no triangle meets the voxels within Chebyshev index distance ``c - 1``
    of it, so every point of the voxel lies at least ``(c - 1) h`` from every triangle. Triangles
    outside the grid are accounted for by counting a layer of occupied voxels around it; values stop at
    255.
    """
    # one flat array indexed by hand, scalar loops and conditional expressions instead of array
    # ufuncs, np.full, min and max: this builds once per world, and each of those is more compiled
    # machinery (more to type and lower) than the loops take to run
    nyz = ny * nz
    total = nx * nyz
    dist = np.empty(total, dtype=np.uint8)
    for v in range(total):
        dist[v] = 255
    half = np.empty(3)
    for d in range(3):
        half[d] = 0.5 * h * (1.0 + 1e-6)
    c = np.empty(3)
    lo = np.empty(3, dtype=np.int64)
    hi = np.empty(3, dtype=np.int64)
    for f in range(faces.shape[0]):
        t0 = vertices[faces[f, 0]]
        t1 = vertices[faces[f, 1]]
        t2 = vertices[faces[f, 2]]
        # the voxels of the triangle's bounding box, one more on every side
        for d in range(3):
            a, b, e = t0[d], t1[d], t2[d]
            least = a if a < b else b
            least = least if least < e else e
            most = a if a > b else b
            most = most if most > e else e
            first = math.floor((least - origin[d]) / h) - 1
            last = math.floor((most - origin[d]) / h) + 1
            top = (nx if d == 0 else ny if d == 1 else nz) - 1
            lo[d] = first if first > 0 else 0
            hi[d] = last if last < top else top
        for i in range(lo[0], hi[0] + 1):
            c[0] = origin[0] + (i + 0.5) * h
            for j in range(lo[1], hi[1] + 1):
                c[1] = origin[1] + (j + 0.5) * h
                for k in range(lo[2], hi[2] + 1):
                    v = i * nyz + j * nz + k
                    if dist[v] == 0:
                        continue
                    c[2] = origin[2] + (k + 0.5) * h
                    if triangle_box_overlap(c, half, t0, t1, t2):
                        dist[v] = 0
    # level-by-level breadth-first search over the 26 neighbours: the Chebyshev index distance
    cur = np.empty(total, dtype=np.int64)
    nxt = np.empty(total, dtype=np.int64)
    nc = 0
    for v in range(total):
        if dist[v] == 0:
            cur[nc] = v
            nc += 1
    level = 0
    while level < 255:
        nn = 0
        for s in range(nc):
            v = cur[s]
            i = v // nyz
            j = (v // nz) % ny
            k = v % nz
            # constant bounds, so the 27 steps unroll (a third faster than clamped bounds)
            for di in range(-1, 2):
                for dj in range(-1, 2):
                    for dk in range(-1, 2):
                        a = i + di
                        b = j + dj
                        d = k + dk
                        if a < 0 or b < 0 or d < 0 or a >= nx or b >= ny or d >= nz:
                            continue
                        w = a * nyz + b * nz + d
                        if dist[w] > level + 1:
                            dist[w] = level + 1
                            nxt[nn] = w
                            nn += 1
        if level == 0:
            # the layer around the grid counts as occupied: the voxels on the grid's faces are at most 1
            for i in range(nx):
                for j in range(ny):
                    for k in range(nz):
                        if i == 0 or j == 0 or k == 0 or i == nx - 1 or j == ny - 1 or k == nz - 1:
                            w = i * nyz + j * nz + k
                            if dist[w] > 1:
                                dist[w] = 1
                                nxt[nn] = w
                                nn += 1
        if nn == 0:
            break
        cur, nxt = nxt, cur
        nc = nn
        level += 1
    return dist.reshape((nx, nyz))


@nb.njit(cache=True)
def reach_open(grid, nx, ny, nz, seeds):
    """``(nx, ny * nz)`` bool: the voxels reached from ``seeds`` (flat indices) through voxels that meet no triangle.

    ``grid`` is ``chebyshev_grid``'s: a voxel of value 0 meets a triangle. Six-connected breadth-first
    search; a seed that meets a triangle is not entered.
    """
    nyz = ny * nz
    seen = np.zeros((nx, nyz), dtype=np.bool_)
    queue = np.empty(nx * nyz, dtype=np.int64)
    n = 0
    for s in range(seeds.shape[0]):
        v = seeds[s]
        i, r = v // nyz, v % nyz
        if grid[i, r] != 0 and not seen[i, r]:
            seen[i, r] = True
            queue[n] = v
            n += 1
    head = 0
    while head < n:
        v = queue[head]
        head += 1
        i = v // nyz
        j = (v // nz) % ny
        k = v % nz
        for d in range(6):  # the face neighbours: -x, +x, -y, +y, -z, +z
            step = 2 * (d % 2) - 1
            a = i + step * (d // 2 == 0)
            b = j + step * (d // 2 == 1)
            c = k + step * (d // 2 == 2)
            if a < 0 or b < 0 or c < 0 or a >= nx or b >= ny or c >= nz:
                continue
            r = b * nz + c
            if grid[a, r] != 0 and not seen[a, r]:
                seen[a, r] = True
                queue[n] = a * nyz + r
                n += 1
    return seen


@nb.njit(cache=True)
def _lower_envelope(f, n, sites, bounds, out):
    """One line of the squared distance transform (Felzenszwalb and Huttenlocher's lower envelope of parabolas).

    ``out[q] = min over p of (q - p) ** 2 + f[p]`` for ``q`` in ``0 .. n - 1``, ``p`` over ``-1 .. n``, where ``f``
    holds the line's values at index ``p + 1`` and the two ends ``f[0]``, ``f[n + 1]`` (the layer around the grid).
    ``sites`` (``n + 2`` ints) and ``bounds`` (``n + 3``) are work space.
    """
    k = 0
    sites[0] = -1
    bounds[0] = -np.inf
    bounds[1] = np.inf
    for q in range(0, n + 1):
        fq = f[q + 1] + q * q
        while True:
            p = sites[k]
            s = (fq - (f[p + 1] + p * p)) / (2.0 * (q - p))
            if s <= bounds[k] and k > 0:
                k -= 1
            else:
                break
        k += 1
        sites[k] = q
        bounds[k] = s
        bounds[k + 1] = np.inf
    k = 0
    for q in range(n):
        while bounds[k + 1] < q:
            k += 1
        p = sites[k]
        out[q] = (q - p) * (q - p) + f[p + 1]


@nb.njit(cache=True)
def squared_distance_voxels(grid, nx, ny, nz):
    """``(nx, ny * nz)`` float32: each voxel's squared distance, in voxels, to the nearest voxel that meets a triangle.

    Centre to centre; a voxel meets a triangle where ``grid`` (``chebyshev_grid``'s) is 0, and the layer of voxels
    around the grid counts as such, as ``chebyshev_grid`` counts it. Exact (separable: along z, then y, then x); the
    values are integers.
    """
    nyz = ny * nz
    out = np.empty((nx, nyz), dtype=np.float32)
    # along z: the distance to the nearest such voxel on the line (the layer at -1 and nz included)
    for i in range(nx):
        for j in range(ny):
            base = j * nz
            last = -1
            for k in range(nz):
                if grid[i, base + k] == 0:
                    last = k
                out[i, base + k] = k - last
            after = nz
            for k in range(nz - 1, -1, -1):
                if grid[i, base + k] == 0:
                    after = k
                d = out[i, base + k]
                d = d if d < after - k else after - k
                out[i, base + k] = d * d
    most = nx if nx > ny else ny
    f = np.zeros(most + 2)
    line = np.empty(most)
    sites = np.empty(most + 2, dtype=np.int64)
    bounds = np.empty(most + 3)
    for i in range(nx):  # along y
        for k in range(nz):
            for j in range(ny):
                f[j + 1] = out[i, j * nz + k]
            f[0] = 0.0
            f[ny + 1] = 0.0
            _lower_envelope(f, ny, sites, bounds, line)
            for j in range(ny):
                out[i, j * nz + k] = line[j]
    for r in range(nyz):  # along x
        for i in range(nx):
            f[i + 1] = out[i, r]
        f[0] = 0.0
        f[nx + 1] = 0.0
        _lower_envelope(f, nx, sites, bounds, line)
        for i in range(nx):
            out[i, r] = line[i]
    return out
