"""Compiled clearance tests between two triangle sets: "is every triangle of one more than ``m`` from the other?".

A mesh world's motion check asks at each pose it places whether the body keeps a clearance above a margin
(``planners.kernels.mesh``). FCL answers with a distance query, which searches for the closest pair; the
question needs less: a pair closer than ``m`` ends it with "no", and every pair whose boxes lie more than
``m`` apart is never looked at. This module answers it exactly, in compiled code, with no call out of it.

The environment's triangles sit in a tree of boxes and the body's in a tree of spheres (``build_tree``,
``sphere_nodes``; made once per world): a sphere turns with the body, so the body's tree serves every pose.
For a pose, the two trees are walked together, a pair of nodes set aside where the body node's sphere, or else
its box turned with the body (as the world box that holds it), lies more than ``m`` from the environment node's
box, and each pair of triangles in two leaves that is not set
aside by their boxes is compared exactly (``triangles_within``):

* Two triangles are more than ``m`` apart if the vertices of one lie more than ``m`` to one side of the
  other's plane.
* Otherwise, for triangles that do not meet, the distance is the least of the nine edge-to-edge
  distances and the six distances from a vertex of one to the other's face where the vertex's foot lies
  inside that face (a closest pair of points always has a vertex or two edges in it; the other
  vertex-to-triangle cases are edge cases).
* Triangles that meet, at distance 0, have an edge of one that crosses the other (or, in one plane, an
  edge that crosses an edge, or a vertex inside the other's face): six edge-against-face crossing tests.

Nothing is approximated: a test answers "more than ``m``" only when every pair's distance is (to the
rounding of float64 arithmetic on the coordinates). A degenerate triangle (no area) is its edges.

The tree travels as rows of three numbers, as the mesh kernels' ``body`` array carries everything
(``planners.kernels.mesh``): a node is three rows, its box ``(lo)``, ``(hi)``, and its links: ``(left, right, h)``,
its two children and its box's half diagonal ``h``, or for a leaf ``(-1, first, count)``, its triangles. A node of
the body's tree (``sphere_nodes``) is four rows: its box's centre, ``(radius, 0, 0)`` (its sphere about that
centre), its links, and its box's half sides. A triangle is three rows, its corners. Building the trees takes
about 1.5 s per 100,000 triangles.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

#: Most triangles in a leaf of the environment's tree.
LEAF_SIZE = 4

#: Rows of the walk's stack in ``sets_clearance``. Each pair taken off it puts back at most two pairs one level
#: deeper in one of the two trees, so it never holds more than the two trees' depths plus one; ``build_tree`` splits
#: at the median, so a tree over fewer than 2**31 triangles is at most 30 levels deep. A stack that grew inside the
#: walk would be a variable reassigned in its loop, which numba reference-counts at every step of the loop.
STACK_ROWS = 64


def build_tree(triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A bounding-box tree over ``triangles`` (``(T, 3, 3)``, corners by row).

    Returns ``(nodes, ordered)``: the nodes as ``(3 N, 3)`` rows (module docs; node 0 the root) and the
    triangles in the tree's order as ``(3 T, 3)`` rows, leaves holding consecutive triangles. Each node splits
    its triangles at the median of their centroids along the longest side of the centroids' box.
    """
    tris = np.ascontiguousarray(triangles, dtype=np.float64).reshape(-1, 3, 3)
    if len(tris) == 0:
        raise ValueError("build_tree needs at least one triangle")
    lo_t, hi_t = tris.min(axis=1), tris.max(axis=1)
    centroid = tris.mean(axis=1)
    order = np.arange(len(tris))
    rows: list[list[float]] = []
    stack = [(0, len(tris), 0)]  # (first, end, node index)
    nodes: list[tuple] = [None]
    while stack:
        first, end, node = stack.pop()
        idx = order[first:end]
        lo, hi = lo_t[idx].min(axis=0), hi_t[idx].max(axis=0)
        if end - first <= LEAF_SIZE:
            nodes[node] = (lo, hi, (-1.0, float(first), float(end - first)))
            continue
        c = centroid[idx]
        axis = int(np.argmax(c.max(axis=0) - c.min(axis=0)))
        mid = (end - first) // 2
        part = np.argsort(c[:, axis], kind="stable")
        order[first:end] = idx[part]
        left, right = len(nodes), len(nodes) + 1
        nodes.extend([None, None])
        nodes[node] = (lo, hi, (float(left), float(right), 0.5 * float(np.linalg.norm(hi - lo))))
        stack.append((first + mid, end, right))
        stack.append((first, first + mid, left))
    for lo, hi, link in nodes:
        rows.extend([list(lo), list(hi), list(link)])
    return np.array(rows, dtype=np.float64), np.ascontiguousarray(tris[order].reshape(-1, 3))


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def corners(t, i):
    """The corners of triangle ``t[i:i+3]`` (rows of 3) as three ``(x, y, z)`` tuples: values, not views of ``t``.

    The pair test below takes its triangles so: a variable naming either of two arrays, chosen in a loop, would be
    reference-counted at every choice, and an array handed to a compiled function at every call.
    """
    return ((t[i, 0], t[i, 1], t[i, 2]), (t[i + 1, 0], t[i + 1, 1], t[i + 1, 2]),
            (t[i + 2, 0], t[i + 2, 1], t[i + 2, 2]))


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _segments_d2(p0, p1, q0, q1):
    """Squared distance between segments ``p0 p1`` and ``q0 q1`` (``(x, y, z)`` tuples), degenerate ones included."""
    d1x, d1y, d1z = p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]
    d2x, d2y, d2z = q1[0] - q0[0], q1[1] - q0[1], q1[2] - q0[2]
    rx, ry, rz = p0[0] - q0[0], p0[1] - q0[1], p0[2] - q0[2]
    a = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    tiny = 1e-300
    if a <= tiny and e <= tiny:
        s = 0.0
        t = 0.0
    elif a <= tiny:
        s = 0.0
        t = min(max(f / e, 0.0), 1.0)
    else:
        c = d1x * rx + d1y * ry + d1z * rz
        if e <= tiny:
            t = 0.0
            s = min(max(-c / a, 0.0), 1.0)
        else:
            b = d1x * d2x + d1y * d2y + d1z * d2z
            denom = a * e - b * b
            s = min(max((b * f - c * e) / denom, 0.0), 1.0) if denom > 0.0 else 0.0
            t = (b * s + f) / e
            if t < 0.0:
                t = 0.0
                s = min(max(-c / a, 0.0), 1.0)
            elif t > 1.0:
                t = 1.0
                s = min(max((b - c) / a, 0.0), 1.0)
    x = rx + d1x * s - d2x * t
    y = ry + d1y * s - d2y * t
    z = rz + d1z * s - d2z * t
    return x * x + y * y + z * z


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _normal(t0, t1, t2):
    """The (unnormalised) normal of the triangle with corners ``t0, t1, t2``."""
    ux, uy, uz = t1[0] - t0[0], t1[1] - t0[1], t1[2] - t0[2]
    vx, vy, vz = t2[0] - t0[0], t2[1] - t0[1], t2[2] - t0[2]
    return uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _height(nx, ny, nz, b0, a):
    """``n . (a - b0)``: how far corner ``a`` lies above the plane through ``b0`` of normal ``n`` (times ``|n|``)."""
    return nx * (a[0] - b0[0]) + ny * (a[1] - b0[1]) + nz * (a[2] - b0[2])


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _in_face(t, nx, ny, nz, px, py, pz):
    """True if the point's foot on triangle ``t``'s plane (normal ``n``) lies in the face (edges included)."""
    for e in range(3):
        a = t[e]
        b = t[(e + 1) % 3]
        # the side of edge a -> b the point lies on, within the plane: n . ((b - a) x (p - a))
        ex, ey, ez = b[0] - a[0], b[1] - a[1], b[2] - a[2]
        wx, wy, wz = px - a[0], py - a[1], pz - a[2]
        if nx * (ey * wz - ez * wy) + ny * (ez * wx - ex * wz) + nz * (ex * wy - ey * wx) < 0.0:
            return False
    return True


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _beside_plane(a, b, m):
    """True if the corners of triangle ``a`` lie more than ``m`` to one side of triangle ``b``'s plane."""
    b0, b1, b2 = b
    nx, ny, nz = _normal(b0, b1, b2)
    length = math.sqrt(nx * nx + ny * ny + nz * nz)
    if length > 0.0:
        lo = math.inf
        hi = -math.inf
        for r in range(3):
            h = _height(nx, ny, nz, b0, a[r])
            lo = min(lo, h)
            hi = max(hi, h)
        if lo > m * length or -hi > m * length:
            return True
    return False


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _meets_face(a, b, m2):
    """True if a corner of triangle ``a`` within ``sqrt(m2)`` of triangle ``b``'s plane has its foot in that face, or
    an edge of ``a`` crosses the plane (not lying in it) inside the face, corner by corner (false where ``b`` has no
    area: it is its edges).
    """
    b0, b1, b2 = b
    nx, ny, nz = _normal(b0, b1, b2)
    n2 = nx * nx + ny * ny + nz * nz
    if n2 == 0.0:
        return False
    for r in range(3):
        c = a[r]
        # a corner of a whose foot lies in b's face, within m of it
        h = _height(nx, ny, nz, b0, c)
        if h * h <= m2 * n2 and _in_face(b, nx, ny, nz, c[0], c[1], c[2]):
            return True
        # an edge of a that crosses b's plane (not lying in it) inside b's face
        c2 = a[(r + 1) % 3]
        h2 = _height(nx, ny, nz, b0, c2)
        if (h > 0.0 and h2 > 0.0) or (h < 0.0 and h2 < 0.0) or h == h2:
            continue
        t = h / (h - h2)
        if _in_face(b, nx, ny, nz, c[0] + t * (c2[0] - c[0]), c[1] + t * (c2[1] - c[1]), c[2] + t * (c2[2] - c[2])):
            return True
    return False


@nb.njit(cache=True, no_cfunc_wrapper=True)
def corners_within(p, q, m):
    """True if the triangles with corners ``p`` and ``q`` (``corners``' tuples) lie at most ``m`` apart (``m >= 0``).

    Each check runs for both orders of the two triangles (the one whose corners or edges are tried, and the one
    whose plane and face they are tried against), each through one function called twice: the corners are values,
    so choosing the order costs nothing (a variable that names either of two arrays would be reference-counted at
    every choice).
    """
    # apart if the corners of one lie more than m to one side of the other's plane
    if _beside_plane(p, q, m) or _beside_plane(q, p, m):
        return False
    m2 = m * m
    for e in range(3):  # the nine pairs of edges
        for f in range(3):
            if _segments_d2(p[e], p[(e + 1) % 3], q[f], q[(f + 1) % 3]) <= m2:
                return True
    return _meets_face(p, q, m2) or _meets_face(q, p, m2)


@nb.njit(cache=True, no_cfunc_wrapper=True)
def triangles_within(p, i, q, j, m):
    """True if triangles ``p[i:i+3]`` and ``q[j:j+3]`` (corners by row) lie at most ``m`` apart (``m >= 0``).

    ``corners_within`` of their ``corners``.
    """
    return corners_within(corners(p, i), corners(q, j), m)


def sphere_nodes(nodes: np.ndarray, ordered: np.ndarray) -> np.ndarray:
    """The tree ``nodes`` over the triangles ``ordered`` (``build_tree``'s pair) with a bounding sphere per node.

    Rows of four per node: the sphere's centre (the box's), ``(radius, 0, 0)``, the node's links as in
    ``build_tree``, and the box's half sides. Spheres and boxes turn with the body, so the body's tree is
    checked in this form. Both are grown by a relative 1e-9 (the box also by 1e-9 of the radius), so that the
    rounding of a turned corner cannot take it out of them.
    """
    n = len(nodes) // 3
    out = np.zeros((4 * n, 3))
    corners = ordered.reshape(-1, 3, 3)
    # each node's triangles: the leaves' ranges, gathered bottom up (children come after their parent)
    spans = [(0, 0)] * n
    for k in range(n - 1, -1, -1):
        link = nodes[3 * k + 2]
        if link[0] < 0:
            spans[k] = (int(link[1]), int(link[1]) + int(link[2]))
        else:
            a, b = spans[int(link[0])], spans[int(link[1])]
            spans[k] = (min(a[0], b[0]), max(a[1], b[1]))
    for k in range(n):
        centre = 0.5 * (nodes[3 * k] + nodes[3 * k + 1])
        points = corners[spans[k][0]:spans[k][1]].reshape(-1, 3)
        radius = float(np.sqrt(((points - centre) ** 2).sum(axis=1)).max()) * (1.0 + 1e-9)
        out[4 * k] = centre
        out[4 * k + 1, 0] = radius
        out[4 * k + 2] = nodes[3 * k + 2]
        out[4 * k + 3] = np.abs(points - centre).max(axis=0) * (1.0 + 1e-9) + 1e-9 * radius
    return out


@nb.njit(cache=True, no_cfunc_wrapper=True)
def _gap(v, lo, hi):
    """Distance from ``v`` to the interval ``[lo, hi]`` (0 inside it)."""
    return lo - v if v < lo else (v - hi if v > hi else 0.0)


@nb.njit(cache=True, no_cfunc_wrapper=True)
def _box_gap2(nodes, r, x, y, z):
    """Squared distance from point ``(x, y, z)`` to the box of the node at row ``r`` (0 inside it)."""
    gx = _gap(x, nodes[r, 0], nodes[r + 1, 0])
    gy = _gap(y, nodes[r, 1], nodes[r + 1, 1])
    gz = _gap(z, nodes[r, 2], nodes[r + 1, 2])
    return gx * gx + gy * gy + gz * gz


@nb.njit(cache=True, no_cfunc_wrapper=True)
def _box_of(c):
    """The box of the triangle with corners ``c`` (``corners``'): ``(lo_x, lo_y, lo_z, hi_x, hi_y, hi_z)``."""
    c0, c1, c2 = c
    return (min(c0[0], min(c1[0], c2[0])), min(c0[1], min(c1[1], c2[1])), min(c0[2], min(c1[2], c2[2])),
            max(c0[0], max(c1[0], c2[0])), max(c0[1], max(c1[1], c2[1])), max(c0[2], max(c1[2], c2[2])))


@nb.njit(cache=True, no_cfunc_wrapper=True)
def _boxes_apart(a, b):
    """True if boxes ``a`` and ``b`` (``_box_of``'s) lie apart along an axis."""
    return (b[0] > a[3] or b[3] < a[0] or b[1] > a[4] or b[4] < a[1] or b[2] > a[5] or b[5] < a[2])


@nb.njit(cache=True, no_cfunc_wrapper=True)
def sets_apart(spheres, body, rot, t, nodes, tris, m, hint):
    """True if every triangle of the body lies more than ``m`` from every triangle of the environment (``m >= 0``).

    ``spheres``: the body's tree (``sphere_nodes``, body frame); ``body``: its triangles in the tree's order, in
    world coordinates at the pose ``(rot, t)`` (``(3 B, 3)``): ``rot`` the rotation's nine entries row by row and
    ``t`` the translation, as tuples (``planners.kernels.rigid.rotation_entries``: values, where arrays would be
    allocated and reference-counted at every pose); ``nodes`` and ``tris``: the environment's tree (``build_tree``).
    ``sets_clearance`` with the one margin; ``hint`` is its (``np.full(2, -1)`` for none).
    """
    margins = np.empty(1)
    margins[0] = m
    return sets_clearance(spheres, body, rot, t, nodes, tris, margins, hint) == 0


@nb.njit(cache=True, no_cfunc_wrapper=True)
def sets_clearance(spheres, body, rot, t, nodes, tris, margins, hint):
    """The first ``k`` such that every body triangle lies more than ``margins[k]`` from every environment triangle.

    ``margins`` decrease (all ``>= 0``); ``len(margins)`` where the last is not cleared either. The arguments are
    ``sets_apart``'s. The two trees are walked together once, a pair of nodes set aside where the body node's
    sphere, or else the world box that holds its turned box, lies more than the margin asked so far from the
    environment node's box; a pair of triangles within it moves the margin asked to the next one that pair
    clears (a pair set aside, or cleared, at one margin is so at every smaller one). The answer is the first margin
    at which testing each margin in turn with its own walk would succeed, in one walk.

    ``hint``: a pair of triangles ``(body, environment)`` to test before the walk (``-1``: none), where the last
    pair that moved the margin is written back. A nearby pose's pair (the walk of a motion poses the body again a
    little further on) is often the closest again, so the walk starts at the margin that pair leaves and sets aside
    more; a pair within a margin is one the walk would reach, so the answer is the same with any hint.
    """
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = rot
    a00, a01, a02, a10, a11, a12, a20, a21, a22 = (abs(r00), abs(r01), abs(r02), abs(r10), abs(r11), abs(r12),
                                                   abs(r20), abs(r21), abs(r22))
    t0, t1, t2 = t
    stack = np.empty((STACK_ROWS, 2), dtype=np.int64)
    stack[0, 0] = 0
    stack[0, 1] = 0
    top = 1
    k = 0
    m = margins[0]
    # a node's turned centre and its triangles' turned corners are rounded apart by a few units in the last place of
    # the coordinates: a pair is set aside only where its bound clears the margin by far more than that
    rounding = 1e-12 * (abs(t0) + abs(t1) + abs(t2) + spheres[1, 0])
    far = m + rounding
    if hint[0] >= 0:
        b, e = hint[0], hint[1]
        P = corners(body, 3 * b)
        Q = corners(tris, 3 * e)
        lo0, lo1, lo2, hi0, hi1, hi2 = _box_of(P)
        box = _box_of(Q)
        while not _boxes_apart((lo0 - m, lo1 - m, lo2 - m, hi0 + m, hi1 + m, hi2 + m), box) and \
                corners_within(P, Q, m):
            k += 1
            if k == margins.shape[0]:
                return k
            m = margins[k]
            far = m + rounding
    while top > 0:
        top -= 1
        sb = 4 * stack[top, 0]
        se = 3 * stack[top, 1]
        cx = r00 * spheres[sb, 0] + r01 * spheres[sb, 1] + r02 * spheres[sb, 2] + t0
        cy = r10 * spheres[sb, 0] + r11 * spheres[sb, 1] + r12 * spheres[sb, 2] + t1
        cz = r20 * spheres[sb, 0] + r21 * spheres[sb, 1] + r22 * spheres[sb, 2] + t2
        reach = spheres[sb + 1, 0] + far
        if _box_gap2(nodes, se, cx, cy, cz) > reach * reach:
            continue
        # the node's box turned with the body lies in the world box of half sides w about the centre
        ex, ey, ez = spheres[sb + 3, 0], spheres[sb + 3, 1], spheres[sb + 3, 2]
        wx = a00 * ex + a01 * ey + a02 * ez
        wy = a10 * ex + a11 * ey + a12 * ez
        wz = a20 * ex + a21 * ey + a22 * ez
        gx = max(nodes[se, 0] - (cx + wx), (cx - wx) - nodes[se + 1, 0], 0.0)
        gy = max(nodes[se, 1] - (cy + wy), (cy - wy) - nodes[se + 1, 1], 0.0)
        gz = max(nodes[se, 2] - (cz + wz), (cz - wz) - nodes[se + 1, 2], 0.0)
        if gx * gx + gy * gy + gz * gz > far * far:
            continue
        body_leaf = spheres[sb + 2, 0] < 0.0
        env_leaf = nodes[se + 2, 0] < 0.0
        if body_leaf and env_leaf:
            for b in range(int(spheres[sb + 2, 1]), int(spheres[sb + 2, 1] + spheres[sb + 2, 2])):
                P = corners(body, 3 * b)
                lo0, lo1, lo2, hi0, hi1, hi2 = _box_of(P)
                for e in range(int(nodes[se + 2, 1]), int(nodes[se + 2, 1] + nodes[se + 2, 2])):
                    Q = corners(tris, 3 * e)
                    box = _box_of(Q)
                    while not _boxes_apart((lo0 - m, lo1 - m, lo2 - m, hi0 + m, hi1 + m, hi2 + m), box) and \
                            corners_within(P, Q, m):
                        hint[0] = b
                        hint[1] = e
                        k += 1
                        if k == margins.shape[0]:
                            return k
                        m = margins[k]
                        far = m + rounding
            continue
        # open the body's node where the environment's is a leaf or the smaller of the two
        if not body_leaf and (env_leaf or spheres[sb + 1, 0] >= nodes[se + 2, 2]):  # the box's half diagonal
            for c in range(2):
                stack[top + c, 0] = int(spheres[sb + 2, 1 - c])
                stack[top + c, 1] = se // 3
        else:
            for c in range(2):
                stack[top + c, 0] = sb // 4
                stack[top + c, 1] = int(nodes[se + 2, 1 - c])
        top += 2
    return k
