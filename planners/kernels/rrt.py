"""Compiled main loops of RRT and RRT-Connect.

Each kernel consumes a batch of samples (one sample = one iteration) and returns how many it used. It
stops early, before touching the next sample, when the problem is solved and ``stop_when_solved`` is
set or when the trees are too full to take another iteration; the Python side grows the arrays and
calls again, so results never depend on capacity or batch size.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from planners.kernels import state as slots
from planners.kernels.geometry import motion_free
from planners.kernels.space import copy_into, space_distance, space_embedding
from planners.kernels.tree import add_vertex, nearest_vertex, resolve_sample, steer


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def embed_query(space, q, qe):
    return space_embedding(space, q, qe)


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def extend(tree, n, space, q, qe_buf, step, new, world, istate, st, sb):
    """Nearest of the first ``n`` vertices to ``q``, steered at most ``step`` into ``new``.

    Returns that vertex, or -1 when the step is empty or its motion collides (a check is counted).
    """
    X = tree.X
    near = nearest_vertex(tree, n, space, q, embed_query(space, q, qe_buf), st, sb)
    if steer(space, X[near], q, step, new) <= 1e-12:
        return -1
    istate[slots.I_CHECKS] += 1
    if not motion_free(world, X[near], new):
        return -1
    return near


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def rrt_iterate(sample, anchored, tree, istate, fstate, last, world, space, goal, step, tol, low, high, st, sb,
                q, qe_buf, new):
    """One RRT iteration on one sample: resolve -> nearest -> steer -> check motion -> add.

    The building block of ``rrt_run`` and of samplers that fuse their draws into the RRT loop (see
    ``Sampler`` in ``planners.base.samplers``); the caller checks capacity and the stopping rule first.
    ``q``, ``qe_buf`` and ``new`` are scratch buffers.
    """
    X = tree.X
    cost = tree.cost
    istate[slots.I_ITER] += 1
    istate[slots.I_ADDED] = -1
    resolve_sample(space, sample, anchored, X[istate[slots.I_BEST_V]], goal, low, high, q)
    copy_into(last, q)
    n = istate[slots.I_N]
    near = extend(tree, n, space, q, qe_buf, step, new, world, istate, st, sb)
    if near < 0:
        return
    c = cost[near] + space_distance(space, X[near], new)
    n = add_vertex(tree, n, space, new, near, c)
    istate[slots.I_N] = n
    istate[slots.I_ADDED] = n - 1
    dg = space_distance(space, new, goal)
    if dg < fstate[slots.F_BEST_D]:
        fstate[slots.F_BEST_D] = dg
        istate[slots.I_BEST_V] = n - 1
    if dg <= tol and not istate[slots.I_SOLVED]:
        istate[slots.I_SOLVED] = 1
        istate[slots.I_GOAL_V] = n - 1
        istate[slots.I_FIRST] = istate[slots.I_ITER]
        fstate[slots.F_BEST_COST] = c


@nb.njit(cache=True, no_cfunc_wrapper=True)
def rrt_run(samples, anchored, tree, istate, fstate, last, world, space, goal, step, tol, low, high,
            stop_when_solved, st, sb):
    """RRT (LaValle 1998) over a batch of samples."""
    X = tree.X
    q = np.empty(X.shape[1])
    qe_buf = np.empty(tree.E.shape[1])
    new = np.empty(X.shape[1])
    for s in range(samples.shape[0]):
        if stop_when_solved and istate[slots.I_SOLVED]:
            return s
        if istate[slots.I_N] >= X.shape[0]:
            return s
        rrt_iterate(samples[s], anchored[s], tree, istate, fstate, last, world, space, goal, step, tol, low, high,
                    st, sb, q, qe_buf, new)
    return samples.shape[0]


@nb.njit(cache=True, no_cfunc_wrapper=True)
def connect_run(samples, anchored, ta, tb, istate, fstate, last, world, space, goal, step, low, high,
                max_connect, st, sb):
    """RRT-Connect (Kuffner & LaValle 2000): extend one tree, greedily connect the other, swap."""
    Xa = ta[0]
    Xb = tb[0]
    q = np.empty(Xa.shape[1])
    qe_buf = np.empty(ta[1].shape[1])
    new = np.empty(Xa.shape[1])
    nxt = np.empty(Xa.shape[1])
    for s in range(samples.shape[0]):
        if istate[slots.I_SOLVED]:
            return s
        if istate[slots.I_N] + max_connect >= Xa.shape[0] or istate[slots.I_N_B] + max_connect >= Xb.shape[0]:
            return s
        istate[slots.I_ITER] += 1
        istate[slots.I_ADDED] = -1
        resolve_sample(space, samples[s], anchored[s], Xa[istate[slots.I_BEST_V]], goal, low, high, q)
        copy_into(last, q)
        from_start = istate[slots.I_SWAP] == 0
        istate[slots.I_SWAP] = 1 - istate[slots.I_SWAP]
        if from_start:
            t, o, it, io = ta, tb, slots.I_N, slots.I_N_B
        else:
            t, o, it, io = tb, ta, slots.I_N_B, slots.I_N
        Xt, ct = t[0], t[3]
        Xo, co = o[0], o[3]
        # extend the active tree one step towards the sample
        n = istate[it]
        near = extend(t, n, space, q, qe_buf, step, new, world, istate, st, sb)
        if near < 0:
            continue
        n = add_vertex(t, n, space, new, near, ct[near] + space_distance(space, Xt[near], new))
        istate[it] = n
        vt = n - 1
        if from_start:
            istate[slots.I_ADDED] = vt
            dg = space_distance(space, new, goal)
            if dg < fstate[slots.F_BEST_D]:
                fstate[slots.F_BEST_D] = dg
                istate[slots.I_BEST_V] = vt
        # greedily connect the other tree towards the new vertex
        target = Xt[vt]
        while True:
            m = istate[io]
            near_o = nearest_vertex(o, m, space, target, embed_query(space, target, qe_buf), st, sb)
            d = steer(space, Xo[near_o], target, step, nxt)
            if d <= 1e-12:
                vo = near_o
                reached = True
            else:
                istate[slots.I_CHECKS] += 1
                if not motion_free(world, Xo[near_o], nxt):
                    break
                m = add_vertex(o, m, space, nxt, near_o, co[near_o] + space_distance(space, Xo[near_o],
                                                                               nxt))
                istate[io] = m
                vo = m - 1
                reached = d <= step
                if not from_start:
                    dg = space_distance(space, nxt, goal)
                    if dg < fstate[slots.F_BEST_D]:
                        fstate[slots.F_BEST_D] = dg
                        istate[slots.I_BEST_V] = vo
            if reached:
                istate[slots.I_SOLVED] = 1
                istate[slots.I_FIRST] = istate[slots.I_ITER]
                if from_start:
                    istate[slots.I_GOAL_V] = vt
                    istate[slots.I_JOIN_B] = vo
                else:
                    istate[slots.I_GOAL_V] = vo
                    istate[slots.I_JOIN_B] = vt
                fstate[slots.F_BEST_COST] = ct[vt] + co[vo]
                break
    return samples.shape[0]
