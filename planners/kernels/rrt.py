"""Compiled main loops of RRT and RRT-Connect.

Each kernel consumes a batch of samples (one sample = one iteration) and returns how many it used. It
stops early, before touching the next sample, when the problem is solved and ``stop_when_solved`` is
set or when the trees are too full to take another iteration; the Python side grows the arrays and
calls again, so results never depend on capacity or batch size.
"""

from __future__ import annotations

import numba as nb

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


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def scratch_rows(scratch, tree):
    """The sample, embedding and new-state buffers of a kernel, rows of the caller's ``scratch`` (three rows
    at least as wide as the tree's states and embedding; no array is allocated in the kernel).
    """
    return scratch[0, :tree.X.shape[1]], scratch[1, :tree.E.shape[1]], scratch[2, :tree.X.shape[1]]


@nb.njit(cache=True, no_cfunc_wrapper=True)
def rrt_run(samples, anchored, tree, istate, fstate, last, world, space, goal, step, tol, low, high,
            stop_when_solved, st, sb, scratch):
    """RRT (LaValle 1998) over a batch of samples."""
    X = tree.X
    q, qe_buf, new = scratch_rows(scratch, tree)
    used = samples.shape[0]
    for s in range(samples.shape[0]):
        if (stop_when_solved and istate[slots.I_SOLVED]) or istate[slots.I_N] >= X.shape[0]:
            used = s
            break
        rrt_iterate(samples[s], anchored[s], tree, istate, fstate, last, world, space, goal, step, tol, low, high,
                    st, sb, q, qe_buf, new)
    return used


@nb.njit(cache=True, no_cfunc_wrapper=True)
def connect_run(samples, anchored, ta, tb, istate, fstate, last, world, space, goal, step, low, high,
                max_connect, st, sb, scratch):
    """RRT-Connect (Kuffner & LaValle 2000): extend one tree, greedily connect the other, swap.

    The extension and the connecting steps are one loop, so the kernel holds one nearest-neighbour
    query, one steer, one collision check and one insertion (each compiled once).
    """
    Xa = ta.X
    Xb = tb.X
    q, qe_buf, new = scratch_rows(scratch, ta)
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
        # the first step extends the active tree t towards the sample; once it added vertex vt, the next
        # steps greedily connect the other tree o towards vt
        cur, ic, target = t, it, q
        connecting = False
        vt = -1
        while True:
            Xc = cur[0]
            n = istate[ic]
            near = nearest_vertex(cur, n, space, target, embed_query(space, target, qe_buf), st, sb)
            d = steer(space, Xc[near], target, step, new)
            if d <= 1e-12:
                if not connecting:
                    break
                v = near
            else:
                if n >= Xc.shape[0]:
                    # the tree is full: ``max_connect`` bounds a connect's steps where each step brings the target a
                    # step nearer, which a rigid body's metrics do not promise (a turn's chord shrinks by less than
                    # the step); the connect stops here, as if trapped, and the planner makes room before the next
                    # sample. Only a connect that would have run past the arrays stops this way.
                    break
                istate[slots.I_CHECKS] += 1
                if not motion_free(world, Xc[near], new):
                    break
                n = add_vertex(cur, n, space, new, near, cur[3][near] + space_distance(space, Xc[near], new))
                istate[ic] = n
                v = n - 1
                if connecting != from_start:  # cur is the start tree
                    if not connecting:
                        istate[slots.I_ADDED] = v
                    dg = space_distance(space, new, goal)
                    if dg < fstate[slots.F_BEST_D]:
                        fstate[slots.F_BEST_D] = dg
                        istate[slots.I_BEST_V] = v
                if not connecting:
                    vt = v
                    cur, ic, target = o, io, Xc[vt]
                    connecting = True
                    continue
                if d > step:
                    continue
            # the other tree reached vt: the trees are joined
            istate[slots.I_SOLVED] = 1
            istate[slots.I_FIRST] = istate[slots.I_ITER]
            if from_start:
                istate[slots.I_GOAL_V] = vt
                istate[slots.I_JOIN_B] = v
            else:
                istate[slots.I_GOAL_V] = v
                istate[slots.I_JOIN_B] = vt
            fstate[slots.F_BEST_COST] = t[3][vt] + o[3][v]
            break
    return samples.shape[0]

