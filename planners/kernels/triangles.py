"""Compiled clearance tests between two triangle sets: "is every triangle of one more than ``m`` from the other?".

A mesh world's motion check asks at each pose it places whether the body keeps a clearance above a margin
(``planners.kernels.mesh``). FCL answers with a distance query, which searches for the closest pair; the
question needs less: a pair closer than ``m`` ends it with "no", and every pair whose boxes lie more than
``m`` apart is never looked at. This module answers it exactly, in compiled code, with no call out of it.

The environment's triangles sit in a tree of boxes and the body's in a tree of spheres (``build_tree``,
``sphere_nodes``; made once per world): a sphere turns with the body, so the body's tree serves every pose.
For a pose, the two trees are walked together, a pair of nodes set aside where the body node's sphere lies
more than ``m`` from the environment node's box, and each pair of triangles in two leaves that is not set
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
(``planners.kernels.mesh``): a node is three rows, its box ``(lo)``, ``(hi)`` (a sphere's node: its centre and
``(radius, 0, 0)``), and its links: ``(left, right, 0)``, its two children, or for a leaf ``(-1, first, count)``,
its triangles. A triangle is three rows, its corners. Building the trees takes about 1.5 s per 100,000 triangles.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

#: Most triangles in a leaf of the environment's tree.
LEAF_SIZE = 4


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
        nodes[node] = (lo, hi, (float(left), float(right), 0.0))
        stack.append((first + mid, end, right))
        stack.append((first, first + mid, left))
    for lo, hi, link in nodes:
        rows.extend([list(lo), list(hi), list(link)])
    return np.array(rows, dtype=np.float64), np.ascontiguousarray(tris[order].reshape(-1, 3))


@nb.njit(cache=True, inline="always")
def _segments_d2(p0, p1, q0, q1):
    """Squared distance between segments ``p0 p1`` and ``q0 q1`` (rows of 3), degenerate segments included."""
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


@nb.njit(cache=True, inline="always")
def _normal(t, k):
    """The (unnormalised) normal of the triangle in rows ``k, k + 1, k + 2`` of ``t``."""
    ux, uy, uz = t[k + 1, 0] - t[k, 0], t[k + 1, 1] - t[k, 1], t[k + 1, 2] - t[k, 2]
    vx, vy, vz = t[k + 2, 0] - t[k, 0], t[k + 2, 1] - t[k, 1], t[k + 2, 2] - t[k, 2]
    return uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx


@nb.njit(cache=True)
def _side_apart(p, i, q, j, m):
    """True if the corners of triangle ``p[i:i+3]`` lie more than ``m`` to one side of triangle ``q[j:j+3]``'s plane."""
    nx, ny, nz = _normal(q, j)
    length = math.sqrt(nx * nx + ny * ny + nz * nz)
    if length == 0.0:
        return False
    lo = math.inf
    hi = -math.inf
    for r in range(3):
        s = (nx * (p[i + r, 0] - q[j, 0]) + ny * (p[i + r, 1] - q[j, 1]) + nz * (p[i + r, 2] - q[j, 2])) / length
        lo = min(lo, s)
        hi = max(hi, s)
    return lo > m or hi < -m


@nb.njit(cache=True, inline="always")
def _in_face(q, j, nx, ny, nz, px, py, pz):
    """True if the point's foot on triangle ``q[j:j+3]``'s plane (normal ``n``) lies in the face (edges included)."""
    for e in range(3):
        a = j + e
        b = j + (e + 1) % 3
        # the side of edge a -> b the point lies on, within the plane: n . ((b - a) x (p - a))
        ex, ey, ez = q[b, 0] - q[a, 0], q[b, 1] - q[a, 1], q[b, 2] - q[a, 2]
        wx, wy, wz = px - q[a, 0], py - q[a, 1], pz - q[a, 2]
        if nx * (ey * wz - ez * wy) + ny * (ez * wx - ex * wz) + nz * (ex * wy - ey * wx) < 0.0:
            return False
    return True


@nb.njit(cache=True)
def _face_d2(p, r, q, j):
    """Squared distance from point ``p[r]`` to triangle ``q[j:j+3]`` where its foot lies in the face, else inf."""
    nx, ny, nz = _normal(q, j)
    n2 = nx * nx + ny * ny + nz * nz
    if n2 == 0.0 or not _in_face(q, j, nx, ny, nz, p[r, 0], p[r, 1], p[r, 2]):
        return math.inf
    s = nx * (p[r, 0] - q[j, 0]) + ny * (p[r, 1] - q[j, 1]) + nz * (p[r, 2] - q[j, 2])
    return s * s / n2


@nb.njit(cache=True)
def _edge_crosses(p, a, b, q, j):
    """True if segment ``p[a] p[b]`` crosses or touches triangle ``q[j:j+3]`` through its plane (not lying in it)."""
    nx, ny, nz = _normal(q, j)
    da = nx * (p[a, 0] - q[j, 0]) + ny * (p[a, 1] - q[j, 1]) + nz * (p[a, 2] - q[j, 2])
    db = nx * (p[b, 0] - q[j, 0]) + ny * (p[b, 1] - q[j, 1]) + nz * (p[b, 2] - q[j, 2])
    if (da > 0.0 and db > 0.0) or (da < 0.0 and db < 0.0) or da == db:
        return False
    t = da / (da - db)
    return _in_face(q, j, nx, ny, nz, p[a, 0] + t * (p[b, 0] - p[a, 0]), p[a, 1] + t * (p[b, 1] - p[a, 1]),
                    p[a, 2] + t * (p[b, 2] - p[a, 2]))


@nb.njit(cache=True)
def triangles_within(p, i, q, j, m):
    """True if triangles ``p[i:i+3]`` and ``q[j:j+3]`` (corners by row) lie at most ``m`` apart (``m >= 0``)."""
    if _side_apart(p, i, q, j, m) or _side_apart(q, j, p, i, m):
        return False
    m2 = m * m
    for e in range(3):
        for f in range(3):
            if _segments_d2(p[i + e], p[i + (e + 1) % 3], q[j + f], q[j + (f + 1) % 3]) <= m2:
                return True
    for r in range(3):
        if _face_d2(p, i + r, q, j) <= m2 or _face_d2(q, j + r, p, i) <= m2:
            return True
    for e in range(3):
        if _edge_crosses(p, i + e, i + (e + 1) % 3, q, j) or _edge_crosses(q, j + e, j + (e + 1) % 3, p, i):
            return True
    return False


def sphere_nodes(nodes: np.ndarray, ordered: np.ndarray) -> np.ndarray:
    """The tree ``nodes`` over the triangles ``ordered`` (``build_tree``'s pair) with a bounding sphere per node.

    Rows of three per node: the sphere's centre (the box's), ``(radius, 0, 0)``, and the node's links as in
    ``build_tree``. A sphere turns with the body, so the body's tree is checked in this form.
    """
    n = len(nodes) // 3
    out = np.zeros((3 * n, 3))
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
        out[3 * k] = centre
        out[3 * k + 1, 0] = float(np.sqrt(((points - centre) ** 2).sum(axis=1)).max()) * (1.0 + 1e-12)
        out[3 * k + 2] = nodes[3 * k + 2]
    return out


@nb.njit(cache=True)
def _box_gap2(nodes, r, x, y, z):
    """Squared distance from point ``(x, y, z)`` to the box of the node at row ``r`` (0 inside it)."""
    g = 0.0
    for d, v in ((0, x), (1, y), (2, z)):
        if v < nodes[r, d]:
            g += (nodes[r, d] - v) ** 2
        elif v > nodes[r + 1, d]:
            g += (v - nodes[r + 1, d]) ** 2
    return g


@nb.njit(cache=True)
def sets_apart(spheres, body, R, t, nodes, tris, m):
    """True if every triangle of the body lies more than ``m`` from every triangle of the environment (``m >= 0``).

    ``spheres``: the body's tree (``sphere_nodes``, body frame); ``body``: its triangles in the tree's order, in
    world coordinates at the pose ``(R, t)`` (``(3 B, 3)``); ``nodes`` and ``tris``: the environment's tree
    (``build_tree``). The two trees are walked together, a pair of nodes set aside where the body node's sphere
    lies more than ``m`` from the environment node's box; stops at the first pair of triangles within ``m``.
    """
    stack = np.empty((64, 2), dtype=np.int64)
    stack[0, 0] = 0
    stack[0, 1] = 0
    top = 1
    while top > 0:
        top -= 1
        sb = 3 * stack[top, 0]
        se = 3 * stack[top, 1]
        cx = R[0, 0] * spheres[sb, 0] + R[0, 1] * spheres[sb, 1] + R[0, 2] * spheres[sb, 2] + t[0]
        cy = R[1, 0] * spheres[sb, 0] + R[1, 1] * spheres[sb, 1] + R[1, 2] * spheres[sb, 2] + t[1]
        cz = R[2, 0] * spheres[sb, 0] + R[2, 1] * spheres[sb, 1] + R[2, 2] * spheres[sb, 2] + t[2]
        reach = spheres[sb + 1, 0] + m
        if _box_gap2(nodes, se, cx, cy, cz) > reach * reach:
            continue
        body_leaf = spheres[sb + 2, 0] < 0.0
        env_leaf = nodes[se + 2, 0] < 0.0
        if body_leaf and env_leaf:
            for b in range(int(spheres[sb + 2, 1]), int(spheres[sb + 2, 1] + spheres[sb + 2, 2])):
                k = 3 * b
                blo0 = min(body[k, 0], body[k + 1, 0], body[k + 2, 0]) - m
                blo1 = min(body[k, 1], body[k + 1, 1], body[k + 2, 1]) - m
                blo2 = min(body[k, 2], body[k + 1, 2], body[k + 2, 2]) - m
                bhi0 = max(body[k, 0], body[k + 1, 0], body[k + 2, 0]) + m
                bhi1 = max(body[k, 1], body[k + 1, 1], body[k + 2, 1]) + m
                bhi2 = max(body[k, 2], body[k + 1, 2], body[k + 2, 2]) + m
                for e in range(int(nodes[se + 2, 1]), int(nodes[se + 2, 1] + nodes[se + 2, 2])):
                    j = 3 * e
                    if (min(tris[j, 0], tris[j + 1, 0], tris[j + 2, 0]) > bhi0
                            or max(tris[j, 0], tris[j + 1, 0], tris[j + 2, 0]) < blo0
                            or min(tris[j, 1], tris[j + 1, 1], tris[j + 2, 1]) > bhi1
                            or max(tris[j, 1], tris[j + 1, 1], tris[j + 2, 1]) < blo1
                            or min(tris[j, 2], tris[j + 1, 2], tris[j + 2, 2]) > bhi2
                            or max(tris[j, 2], tris[j + 1, 2], tris[j + 2, 2]) < blo2):
                        continue
                    if triangles_within(body, k, tris, j, m):
                        return False
            continue
        if top + 2 > stack.shape[0]:
            grown = np.empty((2 * stack.shape[0], 2), dtype=np.int64)
            grown[:top] = stack[:top]
            stack = grown
        # open the body's node where the environment's is a leaf or the smaller of the two
        half = 0.5 * math.sqrt((nodes[se + 1, 0] - nodes[se, 0]) ** 2 + (nodes[se + 1, 1] - nodes[se, 1]) ** 2
                               + (nodes[se + 1, 2] - nodes[se, 2]) ** 2)
        if not body_leaf and (env_leaf or spheres[sb + 1, 0] >= half):
            for c in range(2):
                stack[top + c, 0] = int(spheres[sb + 2, 1 - c])
                stack[top + c, 1] = se // 3
        else:
            for c in range(2):
                stack[top + c, 0] = sb // 3
                stack[top + c, 1] = int(nodes[se + 2, 1 - c])
        top += 2
    return True
