"""Compiled tree primitives shared by the RRT family: nearest vertex, steering, adding a vertex.

A tree reaches the kernels as ``(X, E, parent, cost, perm, split, box)``: states ``X``, their
nearest-neighbour embedding ``E`` (the same array as ``X`` for real-vector spaces), parent index,
cost-to-come and the k-d forest arrays of ``planners.datastructures.nn``. ``space`` is ``(kind, metric,
rot_weight)``.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from planners.datastructures import nn as nn_index
from planners.kernels.space import SPACE_RN, distance, embed, interpolate, kd_metric, uses_kd


@nb.njit(cache=True, inline="always")
def nearest_vertex(tree, n, space, q, qe, st, sb):
    """Index of the vertex nearest ``q`` (``qe`` its embedding) among the first ``n``."""
    X, E, parent, cost, perm, split, box = tree
    kind, metric, rot_weight = space
    if uses_kd(kind, metric):
        i, _ = nn_index.nearest_into(E, perm, split, box, n, qe, kd_metric(metric), st, sb)
        return i
    best = np.inf
    bi = -1
    for i in range(n):
        d = distance(kind, metric, rot_weight, X[i], q)
        if d < best:
            best = d
            bi = i
    return bi


@nb.njit(cache=True, inline="always")
def steer(space, a, b, step, out):
    """Write into ``out`` the state at most ``step`` from ``a`` towards ``b``; returns the distance a-b."""
    kind, metric, rot_weight = space
    d = distance(kind, metric, rot_weight, a, b)
    if d <= step:
        for i in range(a.shape[0]):
            out[i] = b[i]
    else:
        interpolate(kind, a, b, step / d, out)
    return d


@nb.njit(cache=True, inline="always")
def add_vertex(tree, n, space, q, par, c):
    """Append state ``q`` with parent ``par`` and cost ``c``; returns the new vertex count."""
    X, E, parent, cost, perm, split, box = tree
    kind, metric, rot_weight = space
    for i in range(q.shape[0]):
        X[n, i] = q[i]
    if kind != SPACE_RN:
        embed(kind, metric, q, E[n])
    parent[n] = par
    cost[n] = c
    if uses_kd(kind, metric):
        return nn_index.insert(E, perm, split, box, n)
    return n + 1


@nb.njit(cache=True, inline="always")
def resolve_sample(space, raw, anchored, anchor, goal, low, high, out):
    """The sample a planner uses, by ``anchored`` code.

    0: ``raw`` itself. 1: ``anchor + raw`` (world frame). 2: ``anchor + R raw``, where ``R`` turns the
    first two coordinates into the frame whose x axis points from the anchor to the goal (y to its
    left), so an offset like "two steps ahead, slightly left" follows the tree wherever it goes.
    Anchored results are clipped to the bounds (rigid-body angles are wrapped first, not clipped).
    """
    kind, metric, rot_weight = space
    if anchored == 0:
        for i in range(raw.shape[0]):
            out[i] = raw[i]
        return
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
        interpolate(kind, out, out, 0.0, out)  # wraps the angles into [-pi, pi) (before clipping)
    for i in range(raw.shape[0]):
        if out[i] < low[i]:
            out[i] = low[i]
        elif out[i] >= high[i]:
            out[i] = np.nextafter(high[i], low[i])
