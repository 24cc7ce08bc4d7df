"""Compiled tree primitives shared by the RRT family: nearest vertex, steering, adding a vertex.

A tree reaches the kernels as ``(X, E, parent, cost, perm, split, box)``: states ``X``, their
nearest-neighbour embedding ``E`` (the same array as ``X`` for real-vector spaces), parent index,
cost-to-come and the k-d forest arrays of ``planners.datastructures.nn``. ``space`` is ``(kind, metric,
rot_weight)``, normally a typed ``planners.kernels.space.Space`` subclass: then ``space_nearest``,
``space_knn`` and ``space_within`` compile only the k-d traversal of its metric.
"""

from __future__ import annotations

import numba as nb
import numpy as np
from numba.extending import overload

from planners.datastructures import nn as nn_index
from planners.kernels.space import (
    METRIC_L1,
    METRIC_L2,
    METRIC_LINF,
    METRIC_SE3,
    OVERLOAD_JIT,
    SPACE_RN,
    compiled_only,
    kd_metric,
    space_distance,
    space_embedding,
    space_interpolate,
    static_code,
    uses_kd,
)


def space_nearest(P, perm, split, box, n, q, st, sb, space, X, x):
    """(index, reduced distance) of the nearest of the first ``n`` vertices to state ``x`` (compiled code only).

    ``P, perm, split, box``: the tree's k-d forest over its embedding ``E``; ``q``: ``x``'s embedding;
    ``st``, ``sb``: scratch stacks; ``X``: the tree's states, for the exact scan of a metric without a
    Euclidean embedding (SE3; its "reduced distance" is the distance itself). For a typed space the
    implementation is the k-d traversal of its metric itself (``planners.datastructures.nn``, which
    ignores the arguments after ``sb``), so no function between the kernel and the traversal is compiled.
    """
    raise NotImplementedError("space_nearest runs in compiled code only")


def _scan_nearest(P, perm, split, box, n, q, st, sb, space, X, x):
    best = np.inf
    bi = -1
    for i in range(n):
        d = space_distance(space, X[i], x)
        if d < best:
            best = d
            bi = i
    return bi, best


_scan_nearest_any = nb.njit(cache=True, no_cfunc_wrapper=True, no_cpython_wrapper=True)(_scan_nearest)


def _any_space_nearest(P, perm, split, box, n, q, st, sb, space, X, x):
    kind, metric, rot_weight = space
    if uses_kd(kind, metric):
        return nn_index.nearest_into(P, perm, split, box, n, q, kd_metric(metric), st, sb)
    return _scan_nearest_any(P, perm, split, box, n, q, st, sb, space, X, x)


@overload(space_nearest, jit_options=OVERLOAD_JIT)
def _space_nearest(P, perm, split, box, n, q, st, sb, space, X, x):
    metric = static_code(space, "METRIC")
    if metric is None:
        return _any_space_nearest  # kind and metric known at run time only: every branch
    if metric == METRIC_SE3:
        return _scan_nearest
    return nn_index.BY_METRIC[_kd_metric(metric)][0].py_func


def _kd_metric(metric):
    """``kd_metric`` at compile time: the k-d index's metric on the embedding (COSSIN embeds into L2)."""
    return metric if metric in (METRIC_L1, METRIC_LINF) else METRIC_L2


def space_within(tree, n, space, q, qe, radius, out):
    """All of the first ``n`` vertices within ``radius`` of ``q`` into ``out``; the count (compiled code only)."""
    raise NotImplementedError("space_within runs in compiled code only")


def _scan_within(tree, n, space, q, qe, radius, out):
    X = tree[0]
    cnt = 0
    for i in range(n):
        if space_distance(space, X[i], q) <= radius:
            out[cnt] = i
            cnt += 1
    return cnt


def _any_space_within(tree, n, space, q, qe, radius, out):
    X, E, parent, cost, perm, split, box = tree
    kind, metric, rot_weight = space
    if uses_kd(kind, metric):
        return nn_index.nearest_r(E, perm, split, box, n, qe, kd_metric(metric), radius, out)
    return _scan_within(tree, n, space, q, qe, radius, out)


@overload(space_within, jit_options=OVERLOAD_JIT)
def _space_within(tree, n, space, q, qe, radius, out):
    metric = static_code(space, "METRIC")
    if metric is None:
        return _any_space_within
    if metric == METRIC_SE3:
        return _scan_within
    kd = nn_index.BY_METRIC[_kd_metric(metric)][2]

    def impl(tree, n, space, q, qe, radius, out):
        X, E, parent, cost, perm, split, box = tree
        return kd(E, perm, split, box, n, qe, radius, out)

    return impl


def space_knn(tree, n, space, q, qe, k, out, out_d):
    """The ``min(k, n)`` vertices nearest ``q``, nearest first, into ``out`` / ``out_d``; the count (compiled only)."""
    raise NotImplementedError("space_knn runs in compiled code only")


def _scan_knn(tree, n, space, q, qe, k, out, out_d):
    X = tree[0]
    dd = np.empty(n)  # exact scan for metrics without a Euclidean embedding
    for i in range(n):
        dd[i] = space_distance(space, X[i], q)
    order = np.argsort(dd)
    m = min(k, n)
    for j in range(m):
        out[j] = order[j]
        out_d[j] = dd[order[j]]
    return m


def _any_space_knn(tree, n, space, q, qe, k, out, out_d):
    X, E, parent, cost, perm, split, box = tree
    kind, metric, rot_weight = space
    if uses_kd(kind, metric):
        return nn_index.nearest_k(E, perm, split, box, n, qe, kd_metric(metric), k, out, out_d)
    return _scan_knn(tree, n, space, q, qe, k, out, out_d)


@overload(space_knn, jit_options=OVERLOAD_JIT)
def _space_knn(tree, n, space, q, qe, k, out, out_d):
    metric = static_code(space, "METRIC")
    if metric is None:
        return _any_space_knn
    if metric == METRIC_SE3:
        return _scan_knn
    kd = nn_index.BY_METRIC[_kd_metric(metric)][1]

    def impl(tree, n, space, q, qe, k, out, out_d):
        X, E, parent, cost, perm, split, box = tree
        return kd(E, perm, split, box, n, qe, k, out, out_d)

    return impl


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def nearest_vertex(tree, n, space, q, qe, st, sb):
    """Index of the vertex nearest ``q`` (``qe`` its embedding) among the first ``n``."""
    X, E, parent, cost, perm, split, box = tree
    i, _ = space_nearest(E, perm, split, box, n, qe, st, sb, space, X, q)
    return i


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def steer(space, a, b, step, out):
    """Write into ``out`` the state at most ``step`` from ``a`` towards ``b``; returns the distance a-b."""
    d = space_distance(space, a, b)
    if d <= step:
        for i in range(a.shape[0]):
            out[i] = b[i]
    else:
        space_interpolate(space, a, b, step / d, out)
    return d


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def add_vertex(tree, n, space, q, par, c):
    """Append state ``q`` with parent ``par`` and cost ``c``; returns the new vertex count."""
    X, E, parent, cost, perm, split, box = tree
    kind, metric, rot_weight = space
    for i in range(q.shape[0]):
        X[n, i] = q[i]
    if kind != SPACE_RN:  # else E is X
        space_embedding(space, q, E[n])
    parent[n] = par
    cost[n] = c
    if uses_kd(kind, metric):
        return nn_index.insert(E, perm, split, box, n)
    return n + 1


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def resolve_sample(space, raw, anchored, anchor, goal, low, high, out):
    """The sample a planner uses, by ``anchored`` code.

    0: ``raw`` itself. 1: ``anchor + raw`` (world frame). 2: ``anchor + R raw``, where ``R`` turns the
    first two coordinates into the frame whose x axis points from the anchor to the goal (y to its
    left), so an offset like "two steps ahead, slightly left" follows the tree wherever it goes.
    Anchored results are clipped to the bounds (rigid-body angles are wrapped first, not clipped).
    Only anchored samplers use codes 1 and 2: they are a call, not inlined into every kernel.
    """
    if anchored == 0:
        for i in range(raw.shape[0]):
            out[i] = raw[i]
    else:
        _resolve_anchored(space, raw, anchored, anchor, goal, low, high, out)


@compiled_only
def _resolve_anchored(space, raw, anchored, anchor, goal, low, high, out):
    kind, metric, rot_weight = space
    for i in range(raw.shape[0]):
        out[i] = anchor[i] + raw[i]
    if anchored == 2:
        ux = goal[0] - anchor[0]
        uy = goal[1] - anchor[1]
        norm = np.sqrt(ux * ux + uy * uy)
        if norm > 1e-12:
            ux /= norm
            uy /= norm
        else:
            ux, uy = 1.0, 0.0
        out[0] = anchor[0] + ux * raw[0] - uy * raw[1]
        out[1] = anchor[1] + uy * raw[0] + ux * raw[1]
    if kind != SPACE_RN:
        space_interpolate(space, out, out, 0.0, out)  # wraps the angles into [-pi, pi) (before clipping)
    for i in range(raw.shape[0]):
        if out[i] < low[i]:
            out[i] = low[i]
        elif out[i] >= high[i]:
            out[i] = np.nextafter(high[i], low[i])
