"""Compiled main loops of RRT and RRT-Connect.

Each kernel consumes a batch of samples (one sample = one iteration) and returns how many it used. It
stops early, before touching the next sample, when the problem is solved and ``stop_when_solved`` is
set or when the trees are too full to take another iteration; the Python side grows the arrays and
calls again, so results never depend on capacity or batch size.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from planners.kernels.geometry import motion_free
from planners.kernels.space import SPACE_RN, distance, embed
from planners.kernels.tree import add_vertex, nearest_vertex, resolve_sample, steer

# integer state slots shared by all tree planners
I_N = 0  # vertices in the (start) tree
I_ITER = 1  # iterations (samples consumed)
I_CHECKS = 2  # collision checks (one per motion or state validated)
I_SOLVED = 3  # 1 once a solution exists
I_GOAL_V = 4  # vertex that reached the goal region (RRT) / start-tree side of the join (Connect)
I_BEST_V = 5  # start-tree vertex nearest the goal: the progress anchor
I_ADDED = 6  # vertex added by the last iteration, -1 if none
I_N_B = 7  # vertices in the goal tree (Connect)
I_SWAP = 8  # which tree extends next (Connect)
I_JOIN_B = 9  # goal-tree side of the join (Connect)
I_FIRST = 10  # iteration at which the first solution was found
N_ISTATE = 16

F_BEST_D = 0  # distance from the anchor vertex to the goal
F_BEST_COST = 1  # cost of the best solution so far
N_FSTATE = 4


@nb.njit(cache=True, inline="always")
def _embed_query(space, q, qe):
    kind, metric, rw = space
    if kind == SPACE_RN:
        return q
    embed(kind, metric, q, qe)
    return qe


@nb.njit(cache=True, inline="always")
def extend(tree, n, space, q, qe_buf, step, new, world, istate, st, sb):
    """Nearest of the first ``n`` vertices to ``q``, steered at most ``step`` into ``new``.

    Returns that vertex, or -1 when the step is empty or its motion collides (a check is counted).
    """
    X = tree[0]
    near = nearest_vertex(tree, n, space, q, _embed_query(space, q, qe_buf), st, sb)
    if steer(space, X[near], q, step, new) <= 1e-12:
        return -1
    istate[I_CHECKS] += 1
    if not motion_free(world, X[near], new):
        return -1
    return near


@nb.njit(cache=True, inline="always")
def rrt_iterate(sample, anchored, tree, istate, fstate, last, world, space, goal, step, tol, low, high, st, sb,
                q, qe_buf, new):
    """One RRT iteration on one sample: resolve -> nearest -> steer -> check motion -> add.

    The building block of ``rrt_run`` and of samplers that fuse their draws into the RRT loop (see
    ``Sampler`` in ``planners.base.samplers``); the caller checks capacity and the stopping rule first.
    ``q``, ``qe_buf`` and ``new`` are scratch buffers.
    """
    X, E, parent, cost, perm, split, box = tree
    kind, metric, rw = space
    istate[I_ITER] += 1
    istate[I_ADDED] = -1
    resolve_sample(space, sample, anchored, X[istate[I_BEST_V]], goal, low, high, q)
    last[:] = q
    n = istate[I_N]
    near = extend(tree, n, space, q, qe_buf, step, new, world, istate, st, sb)
    if near < 0:
        return
    c = cost[near] + distance(kind, metric, rw, X[near], new)
    n = add_vertex(tree, n, space, new, near, c)
    istate[I_N] = n
    istate[I_ADDED] = n - 1
    dg = distance(kind, metric, rw, new, goal)
    if dg < fstate[F_BEST_D]:
        fstate[F_BEST_D] = dg
        istate[I_BEST_V] = n - 1
    if dg <= tol and not istate[I_SOLVED]:
        istate[I_SOLVED] = 1
        istate[I_GOAL_V] = n - 1
        istate[I_FIRST] = istate[I_ITER]
        fstate[F_BEST_COST] = c


@nb.njit(cache=True)
def rrt_run(samples, anchored, tree, istate, fstate, last, world, space, goal, step, tol, low, high,
            stop_when_solved, st, sb):
    """RRT (LaValle 1998) over a batch of samples."""
    X = tree[0]
    q = np.empty(X.shape[1])
    qe_buf = np.empty(tree[1].shape[1])
    new = np.empty(X.shape[1])
    for s in range(samples.shape[0]):
        if stop_when_solved and istate[I_SOLVED]:
            return s
        if istate[I_N] >= X.shape[0]:
            return s
        rrt_iterate(samples[s], anchored[s], tree, istate, fstate, last, world, space, goal, step, tol, low, high,
                    st, sb, q, qe_buf, new)
    return samples.shape[0]


@nb.njit(cache=True)
def connect_run(samples, anchored, ta, tb, istate, fstate, last, world, space, goal, step, low, high,
                max_connect, st, sb):
    """RRT-Connect (Kuffner & LaValle 2000): extend one tree, greedily connect the other, swap."""
    Xa = ta[0]
    Xb = tb[0]
    kind, metric, rw = space
    q = np.empty(Xa.shape[1])
    qe_buf = np.empty(ta[1].shape[1])
    new = np.empty(Xa.shape[1])
    nxt = np.empty(Xa.shape[1])
    for s in range(samples.shape[0]):
        if istate[I_SOLVED]:
            return s
        if istate[I_N] + max_connect >= Xa.shape[0] or istate[I_N_B] + max_connect >= Xb.shape[0]:
            return s
        istate[I_ITER] += 1
        istate[I_ADDED] = -1
        resolve_sample(space, samples[s], anchored[s], Xa[istate[I_BEST_V]], goal, low, high, q)
        last[:] = q
        from_start = istate[I_SWAP] == 0
        istate[I_SWAP] = 1 - istate[I_SWAP]
        if from_start:
            t, o, it, io = ta, tb, I_N, I_N_B
        else:
            t, o, it, io = tb, ta, I_N_B, I_N
        Xt, ct = t[0], t[3]
        Xo, co = o[0], o[3]
        # extend the active tree one step towards the sample
        n = istate[it]
        near = extend(t, n, space, q, qe_buf, step, new, world, istate, st, sb)
        if near < 0:
            continue
        n = add_vertex(t, n, space, new, near, ct[near] + distance(kind, metric, rw, Xt[near], new))
        istate[it] = n
        vt = n - 1
        if from_start:
            istate[I_ADDED] = vt
            dg = distance(kind, metric, rw, new, goal)
            if dg < fstate[F_BEST_D]:
                fstate[F_BEST_D] = dg
                istate[I_BEST_V] = vt
        # greedily connect the other tree towards the new vertex
        target = Xt[vt]
        while True:
            m = istate[io]
            near_o = nearest_vertex(o, m, space, target, _embed_query(space, target, qe_buf), st, sb)
            d = steer(space, Xo[near_o], target, step, nxt)
            if d <= 1e-12:
                vo = near_o
                reached = True
            else:
                istate[I_CHECKS] += 1
                if not motion_free(world, Xo[near_o], nxt):
                    break
                m = add_vertex(o, m, space, nxt, near_o, co[near_o] + distance(kind, metric, rw, Xo[near_o], nxt))
                istate[io] = m
                vo = m - 1
                reached = d <= step
                if not from_start:
                    dg = distance(kind, metric, rw, nxt, goal)
                    if dg < fstate[F_BEST_D]:
                        fstate[F_BEST_D] = dg
                        istate[I_BEST_V] = vo
            if reached:
                istate[I_SOLVED] = 1
                istate[I_FIRST] = istate[I_ITER]
                if from_start:
                    istate[I_GOAL_V] = vt
                    istate[I_JOIN_B] = vo
                else:
                    istate[I_GOAL_V] = vo
                    istate[I_JOIN_B] = vt
                fstate[F_BEST_COST] = ct[vt] + co[vo]
                break
    return samples.shape[0]


@nb.njit(cache=True)
def path_to_root(parent, v):
    """Vertex indices from the root to ``v``."""
    k = 0
    u = v
    while u >= 0:
        k += 1
        u = parent[u]
    out = np.empty(k, dtype=np.int64)
    u = v
    for i in range(k - 1, -1, -1):
        out[i] = u
        u = parent[u]
    return out
