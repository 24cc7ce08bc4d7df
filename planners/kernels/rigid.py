"""Compiled collision checks for a rigid body, given as a set of points, among 3D boxes.

State ``q = (x, y, z, tx, ty, tz)``; a body point ``p`` sits at ``H p + (x, y, z)`` with
``H = Ry(ty) Rx(tx) Rz(tz)``.

How a motion check is bounded: along the motion (linear translation, shorter-arc angles) a body
point's path over a parameter interval has length at most ``|dt| + r * (|dtx| + |dty| + |dtz|)``,
where ``r`` is the largest distance of a body point from the body origin (the derivative of each
rotation factor has operator norm equal to its angular rate). The motion is cut into ``N`` pieces so
that this bound is at most ``delta`` per piece; every point of the continuous path then lies within
``delta / 2`` of a checked position. Each checked position must keep a clearance of more than
``delta / 2`` from every box and from the bounds, so no obstacle, however thin, is stepped over.

The spatial index: where ``params`` goes on past its first eight numbers, a uniform grid of cells
(``params[8:12]``: the grid's origin and cell side, ``params[12:15]``: cells along x, y, z) lists
for each cell the boxes that come within ``pad`` of it, ``pad`` at least the largest margin a check
asks (``delta / 2``). ``index[0]`` holds the cells' offsets (``ncells + 1`` of them) and then the
box numbers. A body point then tests only the boxes of its own cell: a box within the margin of the
point reaches into that cell, so the answer is the full scan's, at a cost that does not grow with
the boxes elsewhere in the scene (``box_index`` builds it).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from planners.kernels.space import SPACE_RIGID, interpolate, wrap_angle


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def rotation_entries(tx, ty, tz):
    """``rotation_matrix(tx, ty, tz)``'s nine entries, row by row, as values (no array to allocate).

    The products are written out: numba's matrix product needs scipy (not a core dependency), and
    a BLAS call costs more than these few multiplications.
    """
    cx, sx = math.cos(tx), math.sin(tx)
    cy, sy = math.cos(ty), math.sin(ty)
    cz, sz = math.cos(tz), math.sin(tz)
    # Ry @ Rx, rows (a, b, c); then (Ry @ Rx) @ Rz mixes the first two columns by tz
    a0, b0, c0 = cy, sy * sx, sy * cx
    a1, b1, c1 = 0.0, cx, -sx
    a2, b2, c2 = -sy, cy * sx, cy * cx
    return (a0 * cz + b0 * sz, b0 * cz - a0 * sz, c0,
            a1 * cz + b1 * sz, b1 * cz - a1 * sz, c1,
            a2 * cz + b2 * sz, b2 * cz - a2 * sz, c2)


@nb.njit(cache=True, no_cfunc_wrapper=True)
def rotation_matrix(tx, ty, tz):
    """H = Ry(ty) @ Rx(tx) @ Rz(tz) (``rotation_entries`` as a 3 x 3 array)."""
    e = rotation_entries(tx, ty, tz)
    H = np.empty((3, 3))
    H[0, 0], H[0, 1], H[0, 2] = e[0], e[1], e[2]
    H[1, 0], H[1, 1], H[1, 2] = e[3], e[4], e[5]
    H[2, 0], H[2, 1], H[2, 2] = e[6], e[7], e[8]
    return H


@nb.njit(cache=True, no_cfunc_wrapper=True)
def euler_angles(R, out):
    """Write ``(tx, ty, tz)`` with ``rotation_matrix(tx, ty, tz) = R`` into ``out``.

    ``tx`` lies in ``[-pi/2, pi/2]``; at ``tx = +-pi/2`` (gimbal lock) ``tz`` is 0.
    """
    out[0] = math.asin(max(-1.0, min(1.0, -R[1, 2])))
    if math.hypot(R[1, 0], R[1, 1]) > 1e-9:
        out[1] = math.atan2(R[0, 2], R[2, 2])
        out[2] = math.atan2(R[1, 0], R[1, 1])
    else:
        out[1] = math.atan2(-R[2, 0], R[0, 0])
        out[2] = 0.0


@nb.njit(cache=True, no_cfunc_wrapper=True)
def body_points_world(body, q):
    """(P, 3) world positions of the body points at state ``q``."""
    R = rotation_matrix(q[3], q[4], q[5])
    out = np.empty((body.shape[0], 3))
    for i in range(body.shape[0]):
        for j in range(3):
            out[i, j] = R[j, 0] * body[i, 0] + R[j, 1] * body[i, 1] + R[j, 2] * body[i, 2] + q[j]
    return out


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _point_box_gap2(x, y, z, box):
    """The squared distance from the point ``(x, y, z)`` to the box (0 inside it).

    Without branches: a point's gap to a box along an axis is ``max(lo - x, 0, x - hi)``, and the
    squared gaps are summed in axis order, as a test axis by axis would sum them (the same answers).
    """
    dx = max(box[0] - x, 0.0, x - box[3])
    dy = max(box[1] - y, 0.0, y - box[4])
    dz = max(box[2] - z, 0.0, z - box[5])
    return dx * dx + dy * dy + dz * dz


@nb.njit(cache=True, no_cfunc_wrapper=True)
def _point_box_near(x, y, z, box, m2):
    """True if the point ``(x, y, z)`` lies within squared distance ``m2`` of the box (closed).

    Among many boxes, where a pose tests several boxes before it is decided, a test with early exits
    costs about a third more than this one without branches (``scripts/experiments/box_index_cells.py``,
    docs/rigid-body.md).
    """
    return _point_box_gap2(x, y, z, box) <= m2


#: Parameters of a world without a spatial index (bounds, delta, radius); an indexed one has ``N_INDEXED``.
N_PLAIN = 8
N_INDEXED = 15


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _cell_of(x, origin, cell, n):
    """The cell along one axis that holds coordinate ``x``, clamped to ``[0, n - 1]``."""
    c = int(math.floor((x - origin) / cell))
    return min(max(c, 0), n - 1)


@nb.njit(cache=True, no_cfunc_wrapper=True)
def rigid_state_clear(geom, index, body, params, q, margin):
    """True if every body point is more than ``margin`` from every box and inside the bounds."""
    pts = body_points_world(body, q)
    m2 = margin * margin
    indexed = params.shape[0] >= N_INDEXED
    if indexed:
        cell = params[11]
        nx, ny, nz = int(params[12]), int(params[13]), int(params[14])
        base = nx * ny * nz + 1
    for i in range(pts.shape[0]):
        for j in range(3):
            if not (params[j] + margin < pts[i, j] < params[3 + j] - margin):
                return False
        if indexed:
            c = ((_cell_of(pts[i, 0], params[8], cell, nx) * ny + _cell_of(pts[i, 1], params[9], cell, ny)) * nz
                 + _cell_of(pts[i, 2], params[10], cell, nz))
            for t in range(index[0, c], index[0, c + 1]):
                if _point_box_near(pts[i, 0], pts[i, 1], pts[i, 2], geom[index[0, base + t]], m2):
                    return False
        else:
            for k in range(geom.shape[0]):
                if _point_box_near(pts[i, 0], pts[i, 1], pts[i, 2], geom[k], m2):
                    return False
    return True


@nb.njit(cache=True, no_cfunc_wrapper=True)
def states_clear(geom, index, body, params, qs, margin, out):
    """``rigid_state_clear`` over the rows of ``qs``, into ``out`` (benchmarks time the check with it)."""
    for i in range(qs.shape[0]):
        out[i] = rigid_state_clear(geom, index, body, params, qs[i], margin)


@nb.njit(cache=True, no_cfunc_wrapper=True)
def _box_cells(box, pad, origin, cell, shape, out):
    """The cell ranges ``[out[2j], out[2j + 1]]`` along each axis that the box grown by ``pad`` meets."""
    for j in range(3):
        out[2 * j] = _cell_of(box[j] - pad, origin[j], cell, shape[j])
        out[2 * j + 1] = _cell_of(box[3 + j] + pad, origin[j], cell, shape[j])


@nb.njit(cache=True, no_cfunc_wrapper=True)
def bin_boxes(geom, pad, origin, cell, shape):
    """``index[0]``: each cell's offset into the box numbers that follow, then the numbers (see the module doc)."""
    nx, ny, nz = shape[0], shape[1], shape[2]
    ncells = nx * ny * nz
    counts = np.zeros(ncells + 1, dtype=np.int64)
    r = np.empty(6, dtype=np.int64)
    for k in range(geom.shape[0]):
        _box_cells(geom[k], pad, origin, cell, shape, r)
        for a in range(r[0], r[1] + 1):
            for b in range(r[2], r[3] + 1):
                for c in range(r[4], r[5] + 1):
                    counts[(a * ny + b) * nz + c + 1] += 1
    for c in range(ncells):
        counts[c + 1] += counts[c]
    out = np.empty((1, ncells + 1 + counts[ncells]), dtype=np.int64)
    out[0, :ncells + 1] = counts
    fill = counts[:ncells].copy()
    for k in range(geom.shape[0]):
        _box_cells(geom[k], pad, origin, cell, shape, r)
        for a in range(r[0], r[1] + 1):
            for b in range(r[2], r[3] + 1):
                for c in range(r[4], r[5] + 1):
                    i = (a * ny + b) * nz + c
                    out[0, ncells + 1 + fill[i]] = k
                    fill[i] += 1
    return out


@nb.njit(cache=True, no_cfunc_wrapper=True)
def motion_pieces(params, a, b):
    """Number of pieces a motion is cut into so no body point moves more than delta per piece."""
    delta = params[6]
    radius = params[7]
    dt = 0.0
    for j in range(3):
        d = b[j] - a[j]
        dt += d * d
    dang = 0.0
    for j in range(3, 6):
        dang += abs(wrap_angle(b[j] - a[j]))
    length = math.sqrt(dt) + radius * dang
    return max(1, int(math.ceil(length / delta))), length


@nb.njit(cache=True, no_cfunc_wrapper=True)
def rigid_motion_free(geom, index, body, params, a, b):
    """True if the motion a -> b keeps every body point clear of every box (see module doc)."""
    n, length = motion_pieces(params, a, b)
    if length == 0.0:
        return rigid_state_clear(geom, index, body, params, a, 0.0)
    margin = 0.5 * params[6]
    q = np.empty(6)
    for k in range(n + 1):
        interpolate(SPACE_RIGID, a, b, k / n, q)
        if not rigid_state_clear(geom, index, body, params, q, margin):
            return False
    return True


@nb.njit(cache=True)
def box_clearance(points, boxes, low, high):
    """``(n,)``: each point's distance to the nearest of ``boxes`` (``(m, 6)``: low corner, high corner) or wall of
    the workspace ``[low, high]``: 0 inside a box, negative outside the workspace.
    """
    n = points.shape[0]
    out = np.empty(n)
    for i in range(n):
        x, y, z = points[i, 0], points[i, 1], points[i, 2]
        d = min(min(x - low[0], high[0] - x), min(y - low[1], high[1] - y))
        d = min(d, min(z - low[2], high[2] - z))
        for b in range(boxes.shape[0]):
            g = math.sqrt(_point_box_gap2(x, y, z, boxes[b]))
            if g < d:
                d = g
        out[i] = d
    return out


@nb.njit(cache=True)
def clear_box_voxels(free, boxes, ax, ay, az, radius):
    """Mark ``False`` the voxels of ``free`` (centres ``ax``, ``ay``, ``az`` along each axis, ascending) whose centre
    lies within ``radius`` of any of ``boxes`` (``(m, 6)``: low corner, high corner); in place.
    """
    r2 = radius * radius
    for b in range(boxes.shape[0]):
        i0 = np.searchsorted(ax, boxes[b, 0] - radius, side="left")
        i1 = np.searchsorted(ax, boxes[b, 3] + radius, side="right")
        j0 = np.searchsorted(ay, boxes[b, 1] - radius, side="left")
        j1 = np.searchsorted(ay, boxes[b, 4] + radius, side="right")
        k0 = np.searchsorted(az, boxes[b, 2] - radius, side="left")
        k1 = np.searchsorted(az, boxes[b, 5] + radius, side="right")
        for i in range(i0, i1):
            gx = max(max(boxes[b, 0] - ax[i], ax[i] - boxes[b, 3]), 0.0)
            for j in range(j0, j1):
                gy = max(max(boxes[b, 1] - ay[j], ay[j] - boxes[b, 4]), 0.0)
                for k in range(k0, k1):
                    gz = max(max(boxes[b, 2] - az[k], az[k] - boxes[b, 5]), 0.0)
                    if not gx * gx + gy * gy + gz * gz > r2:
                        free[i, j, k] = False


@nb.njit(cache=True)
def add_box_cover(grid, boxes, low, cell):
    """Add to each voxel of ``grid`` (side ``cell`` from ``low``) the share of it that each of ``boxes`` covers
    (the product of the box's cover along each axis), box by box; in place.
    """
    shape = grid.shape
    lo_i = np.empty(3, dtype=np.int64)
    hi_i = np.empty(3, dtype=np.int64)
    for b in range(boxes.shape[0]):
        empty = False
        for k in range(3):
            lo_i[k] = max(0, int(math.floor((boxes[b, k] - low[k]) / cell)))
            hi_i[k] = min(shape[k], int(math.ceil((boxes[b, 3 + k] - low[k]) / cell)))
            if hi_i[k] <= lo_i[k]:
                empty = True
                break
        if empty:
            continue
        for i in range(lo_i[0], hi_i[0]):
            cx = _cover(low[0] + i * cell, low[0] + (i + 1) * cell, boxes[b, 0], boxes[b, 3], cell)
            for j in range(lo_i[1], hi_i[1]):
                cy = _cover(low[1] + j * cell, low[1] + (j + 1) * cell, boxes[b, 1], boxes[b, 4], cell)
                for m in range(lo_i[2], hi_i[2]):
                    cz = _cover(low[2] + m * cell, low[2] + (m + 1) * cell, boxes[b, 2], boxes[b, 5], cell)
                    grid[i, j, m] += cx * cy * cz


@nb.njit(cache=True)
def _cover(lo, hi, blo, bhi, cell):
    """The share of the interval ``[lo, hi]`` (length about ``cell``) inside ``[blo, bhi]``."""
    return min(max(min(hi, bhi) - max(lo, blo), 0.0), cell) / cell
