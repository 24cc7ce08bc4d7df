"""Compiled roadmap kernels: PRM and Lazy-PRM growth, union-find, A* over the roadmap.

A roadmap reaches the kernels as the vertex tuple of ``planners.kernels.tree`` (its ``parent`` and
``cost`` slots unused) plus edge arrays ``(eu, ev, ew, es)``: endpoints, length and status
(``EDGE_VALID`` / ``EDGE_UNKNOWN`` / ``EDGE_INVALID``; PRM only ever stores valid edges). Vertex
status lives in ``vstat``. ``uf = (parent, rank, cbest, cbest_d)`` is a union-find forest whose roots
also carry their component's vertex nearest the goal (the progress anchor). For Lazy-PRM the forest
is optimistic (unchecked edges count) and is rebuilt when checks remove edges.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np
from numba.extending import overload

from planners.kernels import state as slots
from planners.kernels.geometry import motion_free, state_free
from planners.kernels.rrt import embed_query
from planners.kernels.rrtstar import near_vertices
from planners.kernels.space import OVERLOAD_JIT, copy_into, space_distance, static_code
from planners.kernels.tree import add_vertex, resolve_sample, space_knn


@nb.njit(cache=True, no_cfunc_wrapper=True)
def uf_find(uf, v):
    p = uf[0]
    r = v
    while p[r] != r:
        r = p[r]
    while p[v] != r:  # path compression
        nxt = p[v]
        p[v] = r
        v = nxt
    return r


@nb.njit(cache=True, no_cfunc_wrapper=True)
def uf_union(uf, a, b):
    """Merge the components of a and b; the root keeps the closer-to-goal anchor."""
    p, rank, cbest, cbest_d = uf
    ra = uf_find(uf, a)
    rb = uf_find(uf, b)
    if ra == rb:
        return
    if rank[ra] < rank[rb]:
        ra, rb = rb, ra
    p[rb] = ra
    if rank[ra] == rank[rb]:
        rank[ra] += 1
    if cbest_d[rb] < cbest_d[ra]:
        cbest_d[ra] = cbest_d[rb]
        cbest[ra] = cbest[rb]


@nb.njit(cache=True, no_cfunc_wrapper=True)
def uf_make(uf, v, dgoal):
    p, rank, cbest, cbest_d = uf
    p[v] = v
    rank[v] = 0
    cbest[v] = v
    cbest_d[v] = dgoal


class Neighbourhood(NamedTuple):
    """The vertices a new roadmap vertex tries to connect to: its ``k`` nearest (``k > 0``) or all within the
    connection radius (``k == 0``). ``neighbourhood`` makes the subclass of its kind, which numba types
    separately, so a roadmap kernel compiled for it contains only that query's k-d traversal.
    """

    k: int


class KNearest(Neighbourhood):
    """The ``k`` nearest nodes."""

    __slots__ = ()
    KNN = True


class WithinRadius(Neighbourhood):
    """Every node within a radius."""

    __slots__ = ()
    KNN = False


def neighbourhood(k: int) -> Neighbourhood:
    """The typed ``Neighbourhood`` of ``k`` nearest neighbours (0: all within the connection radius)."""
    return KNearest(int(k)) if k > 0 else WithinRadius(0)


def neighbours(store, n, space, q, qe, nbhd, radius, out, out_d):
    """The ``nbhd.k`` nearest (``k > 0``) or all within ``radius`` (``k == 0``) of the first n vertices (compiled
    code only).
    """
    raise NotImplementedError("neighbours runs in compiled code only")


def _any_neighbours(store, n, space, q, qe, nbhd, radius, out, out_d):
    if nbhd[0] > 0:
        return space_knn(store, n, space, q, qe, nbhd[0], out, out_d)
    return near_vertices(store, n, space, q, qe, radius, out)


@overload(neighbours, jit_options=OVERLOAD_JIT)
def _neighbours(store, n, space, q, qe, nbhd, radius, out, out_d):
    knn = static_code(nbhd, "KNN")
    if knn is None:  # a plain Neighbourhood: known at run time only, both traversals
        return _any_neighbours
    if knn:
        return lambda store, n, space, q, qe, nbhd, radius, out, out_d: space_knn(store, n, space, q, qe, nbhd[0],
                                                                                   out, out_d)
    return lambda store, n, space, q, qe, nbhd, radius, out, out_d: near_vertices(store, n, space, q, qe, radius, out)


@nb.njit(cache=True, no_cfunc_wrapper=True)
def refresh_anchor(uf, istate, fstate):
    """Make the query's progress anchor the start component's vertex nearest the goal (union-find root data)."""
    root = uf_find(uf, istate[slots.I_QS])
    istate[slots.I_BEST_V] = uf[2][root]
    fstate[slots.F_BEST_D] = uf[3][root]


@nb.njit(cache=True, no_cfunc_wrapper=True)
def insert_vertex(q, store, edges, uf, vstat, istate, world, space, goal, nbhd, radius, max_edge, lazy, valid,
                  nbr, nbr_d, qe_buf):
    """Add state ``q`` and connect it to its neighbours (``nbhd``, a ``Neighbourhood``); returns the new vertex index.

    ``valid``: the caller already knows ``q`` is collision-free (query states).
    """
    X = store.X
    eu, ev, ew, es = edges
    kind, metric, rot_weight = space
    n = istate[slots.I_N]
    qe = embed_query(space, q, qe_buf)
    m = neighbours(store, n, space, q, qe, nbhd, radius, nbr, nbr_d)
    v = n
    istate[slots.I_N] = add_vertex(store, n, space, q, -1, 0.0)
    vstat[v] = slots.V_VALID if (valid or not lazy) else slots.V_UNKNOWN
    uf_make(uf, v, space_distance(space, q, goal))
    for j in range(m):
        u = nbr[j]
        if vstat[u] == slots.V_INVALID:
            continue
        du = space_distance(space, X[u], q)
        if max_edge > 0.0 and du > max_edge:
            continue
        if not lazy:
            istate[slots.I_CHECKS] += 1
            if not motion_free(world, X[u], q):
                continue
        e = istate[slots.I_E]
        eu[e] = u
        ev[e] = v
        ew[e] = du
        es[e] = slots.EDGE_UNKNOWN if lazy else slots.EDGE_VALID
        istate[slots.I_E] = e + 1
        uf_union(uf, u, v)
    return v


@nb.njit(cache=True, no_cfunc_wrapper=True)
def roadmap_run(samples, anchored, store, edges, uf, vstat, istate, fstate, last, world, space, goal, low, high,
                nbhd, radius_gamma, fixed_radius, max_edge, dim, lazy, until_joined, nbr, nbr_d):
    """Grow a PRM (``lazy=False``) or a Lazy-PRM roadmap (``lazy=True``), one sample per iteration.

    PRM checks each sample and each connection to its neighbours (``nbhd``: k nearest, or within a radius:
    ``fixed_radius`` if > 0, else the PRM* radius ``radius_gamma (log n / n)^(1/dim)``) and keeps only
    valid edges. Lazy-PRM stores samples and connections unchecked. With ``until_joined`` it returns
    before the next sample once the query's start and goal share a component (PRM: solved;
    Lazy-PRM: time to search); without it, it grows the roadmap regardless.
    """
    X = store.X
    k = nbhd[0]
    cap = X.shape[0]
    ecap = edges[0].shape[0]
    q = np.empty(X.shape[1])
    qe_buf = np.empty(store.E.shape[1])
    for s in range(samples.shape[0]):
        if until_joined and uf_find(uf, istate[slots.I_QS]) == uf_find(uf, istate[slots.I_QG]):
            return s
        n = istate[slots.I_N]
        if n >= cap or istate[slots.I_E] + (k if k > 0 else n) > ecap:
            return s
        istate[slots.I_ITER] += 1
        istate[slots.I_ADDED] = -1
        resolve_sample(space, samples[s], anchored[s], X[istate[slots.I_BEST_V]], goal, low, high, q)
        copy_into(last, q)
        if not lazy:
            istate[slots.I_CHECKS] += 1
            if not state_free(world, q):
                continue
        radius = 0.0
        if k == 0:
            if fixed_radius > 0.0:
                radius = fixed_radius
            else:
                radius = radius_gamma * (math.log(n + 1.0) / (n + 1.0)) ** (1.0 / dim)
            if max_edge > 0.0 and radius > max_edge:
                radius = max_edge
        # valid = not lazy: the same vertex status as False (a plain bool, not a literal False, so this call and the
        # query states' call from Python share one compilation of insert_vertex)
        istate[slots.I_ADDED] = insert_vertex(q, store, edges, uf, vstat, istate, world, space, goal, nbhd, radius,
                                              max_edge, lazy, not lazy, nbr, nbr_d, qe_buf)
        refresh_anchor(uf, istate, fstate)
        if not lazy and uf_find(uf, istate[slots.I_QS]) == uf_find(uf, istate[slots.I_QG]):
            istate[slots.I_SOLVED] = 1
            if istate[slots.I_FIRST] < 0:
                istate[slots.I_FIRST] = istate[slots.I_ITER]
    return samples.shape[0]


@nb.njit(cache=True, no_cfunc_wrapper=True)
def rebuild_components(store, edges, uf, vstat, istate, goal, space):
    """Recompute the union-find from edges that are not known invalid between live vertices."""
    X = store.X
    eu, ev, ew, es = edges
    kind, metric, rot_weight = space
    for v in range(istate[slots.I_N]):
        uf_make(uf, v, space_distance(space, X[v], goal) if vstat[v] != slots.V_INVALID else np.inf)
    for e in range(istate[slots.I_E]):
        if es[e] != slots.EDGE_INVALID and vstat[eu[e]] != slots.V_INVALID and vstat[ev[e]] != slots.V_INVALID:
            uf_union(uf, eu[e], ev[e])


@nb.njit(cache=True, no_cfunc_wrapper=True)
def build_csr(edges, n, ne):
    """Adjacency of the first ``ne`` edges over ``n`` vertices: (offsets, neighbour, edge index)."""
    eu, ev = edges[0], edges[1]
    deg = np.zeros(n + 1, dtype=np.int64)
    for e in range(ne):
        deg[eu[e] + 1] += 1
        deg[ev[e] + 1] += 1
    for v in range(n):
        deg[v + 1] += deg[v]
    adj_v = np.empty(deg[n], dtype=np.int64)
    adj_e = np.empty(deg[n], dtype=np.int64)
    fill = deg[:n].copy()
    for e in range(ne):
        a, b = eu[e], ev[e]
        adj_v[fill[a]] = b
        adj_e[fill[a]] = e
        fill[a] += 1
        adj_v[fill[b]] = a
        adj_e[fill[b]] = e
        fill[b] += 1
    return deg, adj_v, adj_e


@nb.njit(cache=True, no_cfunc_wrapper=True)
def astar_csr(X, csr, ew, es, vstat, src, dst, space, only_valid, heuristic, h):
    """Shortest path src -> dst as (vertex indices, edge indices); empty arrays if none.

    Follows edges that are valid (``only_valid``) or not known invalid, between vertices not known
    invalid, reading the statuses live so one adjacency serves a whole lazy search. The heuristic
    is ``h`` (one entry per vertex; below 0: not known yet, then the metric distance to ``dst``, which is
    admissible as edges are straight, written there when first needed); ``heuristic=False`` makes
    the search Dijkstra's (same path length, more vertices expanded; ``h`` unread).

    Adaptive A* (S. Koenig, M. Likhachev, "Adaptive A*", AAMAS 2005): after a search that reaches ``dst``
    at cost g*, every vertex it expanded gets ``h = g* - g``, a larger heuristic that stays consistent as
    long as no edge gets shorter (edges dropped as invalid only lengthen routes). So Lazy-PRM's searches
    of one roadmap, between which checks only drop edges and vertices, pass the same ``h`` on and each
    expands fewer vertices than the one before would from scratch; it finds a shortest path all the same.
    """
    deg, adj_v, adj_e = csr
    kind, metric, rot_weight = space
    n = deg.shape[0] - 1
    expanded = np.empty(n, dtype=np.int64)
    ne = 0
    g = np.full(n, np.inf)
    via_v = np.full(n, -1, dtype=np.int64)
    via_e = np.full(n, -1, dtype=np.int64)
    closed = np.zeros(n, dtype=np.bool_)
    hf = np.empty(deg[n] + 1)
    hv = np.empty(deg[n] + 1, dtype=np.int64)
    g[src] = 0.0
    if heuristic and h[src] < 0.0:
        h[src] = space_distance(space, X[src], X[dst])
    hf[0] = h[src] if heuristic else 0.0
    hv[0] = src
    hn = 1
    while hn > 0:
        v = hv[0]
        hn -= 1
        lf = hf[hn]
        lv = hv[hn]
        i = 0
        while True:  # sift the last entry down from the root
            c = 2 * i + 1
            if c >= hn:
                break
            if c + 1 < hn and hf[c + 1] < hf[c]:
                c += 1
            if hf[c] >= lf:
                break
            hf[i] = hf[c]
            hv[i] = hv[c]
            i = c
        if hn > 0:
            hf[i] = lf
            hv[i] = lv
        if closed[v]:
            continue
        closed[v] = True
        expanded[ne] = v
        ne += 1
        if v == dst:
            break
        for j in range(deg[v], deg[v + 1]):
            u = adj_v[j]
            e = adj_e[j]
            if closed[u] or vstat[u] == slots.V_INVALID:
                continue
            if es[e] == slots.EDGE_INVALID or (only_valid and es[e] != slots.EDGE_VALID):
                continue
            nd = g[v] + ew[e]
            if nd < g[u]:
                g[u] = nd
                via_v[u] = v
                via_e[u] = e
                f = nd
                if heuristic:
                    if h[u] < 0.0:
                        h[u] = space_distance(space, X[u], X[dst])
                    f += h[u]
                i = hn
                hn += 1
                while i > 0:
                    p = (i - 1) // 2
                    if hf[p] <= f:
                        break
                    hf[i] = hf[p]
                    hv[i] = hv[p]
                    i = p
                hf[i] = f
                hv[i] = u
    if not closed[dst] or vstat[src] == slots.V_INVALID:
        return np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64)
    if heuristic:  # Adaptive A*'s update: what the next search of this roadmap starts from
        for i in range(ne):
            h[expanded[i]] = g[dst] - g[expanded[i]]
    k = 1
    v = dst
    while v != src:
        v = via_v[v]
        k += 1
    verts = np.empty(k, dtype=np.int64)
    eds = np.empty(k - 1, dtype=np.int64)
    v = dst
    for i in range(k - 1, 0, -1):
        verts[i] = v
        eds[i - 1] = via_e[v]
        v = via_v[v]
    verts[0] = src
    return verts, eds


@nb.njit(cache=True, no_cfunc_wrapper=True)
def lazy_resolve(store, edges, csr, uf, vstat, istate, fstate, world, space, goal, max_rounds):
    """Lazy-PRM query: search the optimistic roadmap, check the path, drop what fails, repeat.

    Every vertex of a candidate path is checked, then every edge between two valid ones, before the next search
    (as Bohlin and Kavraki check a path), so a search drops all that fails along its path rather than the first
    failure only: one search of the whole roadmap per failed vertex or edge made Lazy-PRM on the 512-cell MovingAI
    maze and room maps take 2 to 3 minutes a run. Whether a valid path exists does not depend on the order; the
    iteration a solve ends at can (``LAZY_ROUNDS`` searches a call), and on 270 runs compared (generated, shifted
    and MovingAI maps, three samplers) it did not move: the same iterations, successes and path costs, the checks
    within 3%.

    ``csr`` is the roadmap's adjacency (``build_csr`` of its vertices and edges), which the caller keeps while
    the roadmap does not grow: statuses are read live, so one adjacency serves every search. The searches of one
    call share their heuristic (``astar_csr``'s Adaptive A*): between them checks only drop edges and vertices, so
    each search starts from what the ones before learned of the distances to the goal and finds a shortest path
    all the same (the same path wherever the shortest is unique).

    Returns the valid path's vertex indices (and marks the planner solved), or an empty array after
    rebuilding the components when start and goal turn out to be disconnected, or an empty array
    after ``max_rounds`` searches (the checks done so far are kept; the next call goes on), so the
    caller's time limit is looked at between bounded pieces of work.
    """
    X = store.X
    eu, ev, ew, es = edges
    h = np.full(csr[0].shape[0] - 1, -1.0)  # the searches' heuristic, carried from one to the next (Adaptive A*)
    rounds = 0
    while True:
        if rounds >= max_rounds:
            return np.empty(0, dtype=np.int64)
        rounds += 1
        # the flags as np.bool_ values, as PRM passes them from Python: a constant would compile astar_csr a
        # second time
        verts, eds = astar_csr(X, csr, ew, es, vstat, istate[slots.I_QS], istate[slots.I_QG], space, np.bool_(False),
                               np.bool_(True), h)
        if verts.shape[0] == 0:
            rebuild_components(store, edges, uf, vstat, istate, goal, space)
            refresh_anchor(uf, istate, fstate)
            return verts
        ok = True
        for v in verts:  # every vertex of the path, then every edge between valid ones, before the next search
            if vstat[v] == slots.V_UNKNOWN:
                istate[slots.I_CHECKS] += 1
                vstat[v] = slots.V_VALID if state_free(world, X[v]) else slots.V_INVALID
            if vstat[v] == slots.V_INVALID:
                ok = False
        for e in eds:
            if vstat[eu[e]] == slots.V_INVALID or vstat[ev[e]] == slots.V_INVALID:
                continue
            if es[e] == slots.EDGE_UNKNOWN:
                istate[slots.I_CHECKS] += 1
                es[e] = slots.EDGE_VALID if motion_free(world, X[eu[e]], X[ev[e]]) else slots.EDGE_INVALID
            if es[e] == slots.EDGE_INVALID:
                ok = False
        if ok:
            istate[slots.I_SOLVED] = 1
            if istate[slots.I_FIRST] < 0:
                istate[slots.I_FIRST] = istate[slots.I_ITER]
            c = 0.0
            for e in eds:
                c += ew[e]
            fstate[slots.F_BEST_COST] = c
            return verts
