"""Compiled main loop of RRT* (choose-parent and rewire with cost propagation).

Beyond the tree tuple, RRT* keeps per vertex the length of its parent edge (``elen``) and a doubly
linked list of children (``first_child``, ``next_sib``, ``prev_sib``) so a rewired vertex can be
moved in O(1) and its subtree's costs updated exactly: ``cost[c] = cost[parent[c]] + elen[c]``.
Costs only ever decrease, and the set of goal-region vertices only grows, so the best solution cost
never increases.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from planners.kernels import state as slots
from planners.kernels.geometry import motion_free
from planners.kernels.rrt import embed_query, extend
from planners.kernels.space import copy_into, space_distance
from planners.kernels.tree import add_vertex, resolve_sample, space_within


@nb.njit(cache=True, no_cfunc_wrapper=True)
def near_vertices(tree, n, space, q, qe, radius, out):
    """All of the first ``n`` vertices within ``radius`` of ``q``; returns the count."""
    return space_within(tree, n, space, q, qe, radius, out)


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _link(v, p, first_child, next_sib, prev_sib):
    next_sib[v] = first_child[p]
    prev_sib[v] = -1
    if first_child[p] >= 0:
        prev_sib[first_child[p]] = v
    first_child[p] = v


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _unlink(v, p, first_child, next_sib, prev_sib):
    if prev_sib[v] >= 0:
        next_sib[prev_sib[v]] = next_sib[v]
    else:
        first_child[p] = next_sib[v]
    if next_sib[v] >= 0:
        prev_sib[next_sib[v]] = prev_sib[v]


#: Below this many entries ``argsort_into`` sorts by insertion (numba's quicksort's SMALL_QUICKSORT).
SMALL_SORT = 15
#: Pending ranges ``argsort_into`` can hold (numba's quicksort's MAX_STACK).
SORT_STACK = 100


@nb.njit(cache=True, no_cfunc_wrapper=True)
def argsort_into(A, m, R, stack):
    """``R[:m]`` = the order numba's ``np.argsort(A[:m])`` gives, for ``A`` without NaN; ``stack`` holds
    ``2 * SORT_STACK`` ints.

    The same algorithm step for step (numba's quicksort: median-of-three partitions down to ranges of
    ``SMALL_SORT``, then insertion sort), so equal entries come out in the same order, as one function:
    numba's generic version compiles several functions and a list, seconds of a first RRT*.
    """
    for i in range(m):
        R[i] = i
    if m < 2:
        return
    stack[0] = 0
    stack[1] = m - 1
    n = 1
    while n > 0:
        n -= 1
        low = stack[2 * n]
        high = stack[2 * n + 1]
        while high - low >= SMALL_SORT:
            # partition R[low:high + 1] around the median of three
            mid = (low + high) >> 1
            if A[R[mid]] < A[R[low]]:
                R[low], R[mid] = R[mid], R[low]
            if A[R[high]] < A[R[mid]]:
                R[high], R[mid] = R[mid], R[high]
            if A[R[mid]] < A[R[low]]:
                R[low], R[mid] = R[mid], R[low]
            pivot = A[R[mid]]
            R[high], R[mid] = R[mid], R[high]
            i = low
            j = high - 1
            while True:
                while i < high and A[R[i]] < pivot:
                    i += 1
                while j >= low and pivot < A[R[j]]:
                    j -= 1
                if i >= j:
                    break
                R[i], R[j] = R[j], R[i]
                i += 1
                j -= 1
            R[i], R[high] = R[high], R[i]
            # push the larger side, go on with the smaller
            if high - i > i - low:
                if high > i:
                    stack[2 * n] = i + 1
                    stack[2 * n + 1] = high
                    n += 1
                high = i - 1
            else:
                if i > low:
                    stack[2 * n] = low
                    stack[2 * n + 1] = i - 1
                    n += 1
                low = i + 1
        for i in range(low + 1, high + 1):  # insertion sort of R[low:high + 1]
            k = R[i]
            v = A[k]
            j = i
            while j > low and v < A[R[j - 1]]:
                R[j] = R[j - 1]
                j -= 1
            R[j] = k


@nb.njit(cache=True, no_cfunc_wrapper=True)
def propagate_costs(v, cost, elen, parent, first_child, next_sib, stack):
    """Set ``cost[c] = cost[parent[c]] + elen[c]`` for every descendant of ``v``, top-down."""
    sp = 0
    c = first_child[v]
    while c >= 0:
        stack[sp] = c
        sp += 1
        c = next_sib[c]
    while sp > 0:
        sp -= 1
        u = stack[sp]
        cost[u] = cost[parent[u]] + elen[u]
        c = first_child[u]
        while c >= 0:
            stack[sp] = c
            sp += 1
            c = next_sib[c]


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def rrtstar_iterate(sample, anchored, tree, aux, istate, fstate, last, world, space, goal, step, tol, low, high,
                    gamma, dim, nbr, nbr_cost, nbr_ok, stack, st, sb, q, qe_buf, new, order, sort_stack):
    """One RRT* iteration on ``sample`` (room for one more vertex is the caller's to check).

    ``q``, ``qe_buf``, ``new``, ``order`` and ``sort_stack`` are scratch buffers (``rrtstar_scratch``), allocated
    once per call of the caller rather than once per iteration.
    """
    X, E, parent, cost, perm, split, box = tree
    elen, first_child, next_sib, prev_sib, goal_nodes = aux
    n = istate[slots.I_N]
    istate[slots.I_ITER] += 1
    istate[slots.I_ADDED] = -1
    resolve_sample(space, sample, anchored, X[istate[slots.I_BEST_V]], goal, low, high, q)
    copy_into(last, q)
    near = extend(tree, n, space, q, qe_buf, step, new, world, istate, st, sb)
    if near < 0:
        return
    # near set of the new state
    card = n + 1.0
    radius = min(gamma * (math.log(card) / card) ** (1.0 / dim), step)
    ne = embed_query(space, new, qe_buf)
    k = near_vertices(tree, n, space, new, ne, radius, nbr)
    # choose parent: cheapest neighbour with a valid motion, checked lazily in cost order
    best_p = near
    best_len = space_distance(space, X[near], new)
    best_c = cost[near] + best_len
    for j in range(k):
        u = nbr[j]
        nbr_ok[j] = -1
        if u == near:
            nbr_ok[j] = 1
            nbr_cost[j] = np.inf
            continue
        nbr_cost[j] = cost[u] + space_distance(space, X[u], new)
    argsort_into(nbr_cost, k, order, sort_stack)  # np.argsort(nbr_cost[:k])'s order
    for jj in range(k):
        j = order[jj]
        if nbr_cost[j] >= best_c:
            break
        u = nbr[j]
        istate[slots.I_CHECKS] += 1
        ok = motion_free(world, X[u], new)
        nbr_ok[j] = 1 if ok else 0
        if ok:
            best_p = u
            best_len = space_distance(space, X[u], new)
            best_c = cost[u] + best_len
            break
    n = add_vertex(tree, n, space, new, best_p, best_c)
    v = n - 1
    istate[slots.I_N] = n
    istate[slots.I_ADDED] = v
    elen[v] = best_len
    first_child[v] = -1
    _link(v, best_p, first_child, next_sib, prev_sib)
    # rewire: route neighbours through the new vertex when that is cheaper
    rewired = False
    for j in range(k):
        u = nbr[j]
        if u == best_p:
            continue
        el = space_distance(space, new, X[u])
        c_new = best_c + el
        if c_new >= cost[u]:
            continue
        if nbr_ok[j] == -1:
            istate[slots.I_CHECKS] += 1
            nbr_ok[j] = 1 if motion_free(world, new, X[u]) else 0
        if nbr_ok[j] == 0:
            continue
        _unlink(u, parent[u], first_child, next_sib, prev_sib)
        parent[u] = v
        elen[u] = el
        cost[u] = c_new
        _link(u, v, first_child, next_sib, prev_sib)
        propagate_costs(u, cost, elen, parent, first_child, next_sib, stack)
        rewired = True
    # goal region bookkeeping
    dg = space_distance(space, new, goal)
    if dg < fstate[slots.F_BEST_D]:
        fstate[slots.F_BEST_D] = dg
        istate[slots.I_BEST_V] = v
    if dg <= tol:
        goal_nodes[istate[slots.I_N_GOAL]] = v
        istate[slots.I_N_GOAL] += 1
        if not istate[slots.I_SOLVED]:
            istate[slots.I_SOLVED] = 1
            istate[slots.I_FIRST] = istate[slots.I_ITER]
        rewired = True
    if rewired and istate[slots.I_SOLVED]:
        for i in range(istate[slots.I_N_GOAL]):
            g = goal_nodes[i]
            if cost[g] < fstate[slots.F_BEST_COST]:
                fstate[slots.F_BEST_COST] = cost[g]
                istate[slots.I_GOAL_V] = g


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def rrtstar_scratch(tree, nbr):
    """``rrtstar_iterate``'s scratch buffers for ``tree`` and a neighbour array ``nbr`` of the tree's capacity."""
    return (np.empty(tree.X.shape[1]), np.empty(tree.E.shape[1]), np.empty(tree.X.shape[1]),
            np.empty(nbr.shape[0], dtype=np.int64), np.empty(2 * SORT_STACK, dtype=np.int64))


@nb.njit(cache=True, no_cfunc_wrapper=True)
def rrtstar_run(samples, anchored, tree, aux, istate, fstate, last, world, space, goal, step, tol, low, high,
                gamma, dim, nbr, nbr_cost, nbr_ok, stack, st, sb):
    """RRT* (Karaman & Frazzoli 2011) with radius ``min(gamma * (log n / n)^(1/dim), step)``."""
    q, qe_buf, new, order, sort_stack = rrtstar_scratch(tree, nbr)
    for s in range(samples.shape[0]):
        if istate[slots.I_N] >= tree.X.shape[0]:
            return s
        rrtstar_iterate(samples[s], anchored[s], tree, aux, istate, fstate, last, world, space, goal, step, tol, low,
                        high, gamma, dim, nbr, nbr_cost, nbr_ok, stack, st, sb, q, qe_buf, new, order, sort_stack)
    return samples.shape[0]
