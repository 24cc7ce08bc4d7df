"""RRT's, RRT-Connect's and RRT*'s loops with a sampler's compiled draws inside, the refill schedule, the floor.

Internal: ``planners.fused`` is the public way in (it documents the draw function's contract).
Each loop (``rrt_loop``, ``connect_loop``, ``rrtstar_loop``) takes the sampler's ``draw`` as an argument, so numba
compiles one loop per draw function with the draw called directly, as if the loop had been written for it. A
loop specialised on a function argument cannot be cached on its own, so the sampler wraps it in a small cached entry
in its own module (``planners.fused`` shows how): that entry's cache then holds the whole loop, and
an edit to the sampler's file recompiles it. Each loop is inlined into that entry (numba's
``inline="always"``): a call that passed the draw function across a call boundary would carry the
function object's address in the machine code, which numba cannot cache.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from planners.kernels.rrt import connect_run, rrt_iterate
from planners.kernels.rrtstar import rrtstar_iterate, rrtstar_scratch
from planners.kernels.state import F_BEST_D, I_BEST_V, I_ITER, I_N, I_N_B, I_SOLVED, I_SWAP

#: Samples handed to a compiled kernel per call; bounds how late a time limit is noticed.
CHUNK = 1024
#: Size of the first sample refill; refills double up to CHUNK, so short solves draw few samples.
FIRST_REFILL = 64

# slots of the fused loop's buffer counters (``FusedRRT.counters``; ``FusedConnect`` adds the goal tree's vertices
# seen; RRT's loop ends its call after a refill whose draw set ``B_STOP``)
B_POS, B_COUNT, B_REFILLS, B_SEEN_B, B_STOP = range(5)


def refill_size(refills: int) -> int:
    """Samples the planner asks for at its ``refills``-th refill (0-based): 64, 128, ... doubling up to ``CHUNK``.

    When refills happen, and so what a tree-dependent sampler sees, must not depend on how a caller
    splits its budget; this schedule is the planner's, and the fused loop follows it exactly.
    """
    return min(CHUNK, FIRST_REFILL << min(refills, 16))  # 64 << 16 > CHUNK: no overflow however many refills


refill_size_compiled = nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")(refill_size)


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def growing_floor(floor0, max_floor, patience, stalled):
    """The uniform share after ``stalled`` iterations without coming closer to the goal.

    ``floor0`` until ``patience`` iterations have passed, then growing in proportion to the time
    stalled, up to ``max_floor``: a tree pinned by its own biased samples gets RRT's Voronoi bias back.
    """
    if stalled < patience:
        return floor0
    return max(floor0, min(max_floor, floor0 * stalled / patience))


@nb.njit(cache=True)
def nearest_distance(X, lo, hi, q):
    """The least Euclidean distance from ``q`` to the rows ``X[lo:hi]`` (``inf`` where there are none).

    As ``np.sqrt(((X[lo:hi] - q) ** 2).sum(axis=1)).min()`` computes it, value for value.
    """
    d = np.inf
    for v in range(lo, hi):
        acc = 0.0
        for j in range(X.shape[1]):
            acc += (X[v, j] - q[j]) ** 2
        d = min(d, np.sqrt(acc))
    return d


@nb.njit(inline="always")
def refill(draw, state, X, n, best_vertex, best_distance, iteration, rng, counters, pts, anch, batch):
    """The next ``min(batch, refill_size(refills))`` samples from ``draw`` into the buffer, its counters reset."""
    m = min(batch, refill_size_compiled(counters[B_REFILLS]))
    draw(state, X, n, best_vertex, best_distance, iteration, rng, pts[:m], anch[:m])
    counters[B_REFILLS] += 1
    counters[B_COUNT] = m
    counters[B_POS] = 0


@nb.njit(inline="always")
def rrt_loop(budget, draw, state, buffers, rng, loop):
    """Up to ``budget`` RRT iterations with samples from ``draw``, never leaving compiled code.

    ``buffers`` is (counters, points, anchor codes) (``planners.fused.FusedRRT``); ``loop`` is the
    planner's ``loop_args()``. Batches are drawn when the buffer runs dry, at ``min(batch,
    refill_size(refills))`` samples, so the run matches a planner calling the sampler's ``draw``
    sample for sample. A draw that sets the counters' ``B_STOP`` (its state holds them) ends the call
    right after its refill, its samples unused in the buffer.
    """
    counters, pts, anch = buffers
    tree, istate, fstate, last, world, space, goal, step, tol, low, high, st, sb = loop
    X = tree.X
    q = np.empty(X.shape[1])
    qe_buf = np.empty(tree.E.shape[1])
    new = np.empty(X.shape[1])
    batch = pts.shape[0]
    for s in range(budget):
        if istate[I_SOLVED] or istate[I_N] >= X.shape[0]:
            return s
        if counters[B_POS] >= counters[B_COUNT]:
            refill(draw, state, X, istate[I_N], istate[I_BEST_V], fstate[F_BEST_D], istate[I_ITER], rng, counters, pts,
                   anch, batch)
            if counters[B_STOP]:  # the draw ends this call before its samples are used (``planners.fused``)
                return s
        p = counters[B_POS]
        rrt_iterate(pts[p], anch[p], tree, istate, fstate, last, world, space, goal, step, tol, low, high, st, sb, q,
                    qe_buf, new)
        counters[B_POS] = p + 1
    return budget


@nb.njit(inline="always")
def connect_loop(budget, draw, state_a, state_b, buffers, rng, loop):
    """Up to ``budget`` RRT-Connect iterations with samples from ``draw``, never leaving compiled code.

    ``buffers`` is (counters, points, anchor codes, the goal tree's closest distance to the start (1,), the two
    trees' batch sizes (2,)) (``planners.fused.FusedConnect``); ``loop`` is the planner's ``loop_args()``. When the
    buffer runs dry the loop draws ``min(batch, refill_size(refills))`` samples for the tree whose turn it is: the
    start tree as ``draw(state_a, ...)`` sees it, the goal tree as ``draw(state_b, ...)`` (its vertices, its closest
    distance to the start, Euclidean over the state's coordinates, tracked here over the vertices added since its
    last draw), each with its own count of draws (``iteration // 2``), so the run matches a planner calling a
    bidirectional sampler's ``draw``.
    """
    counters, pts, anch, closest_b, batches = buffers
    ta, tb, istate, fstate, last, world, space, goal, step, low, high, max_connect, st, sb, scratch = loop
    start = ta.X[0].copy()  # the start tree's root: the start state
    done = 0
    while done < budget:
        Xa, Xb = ta.X, tb.X
        if istate[I_SOLVED] or istate[I_N] + max_connect >= Xa.shape[0] or istate[I_N_B] + max_connect >= Xb.shape[0]:
            return done
        if counters[B_POS] >= counters[B_COUNT]:
            if istate[I_SWAP] == 1:  # the goal tree's turn
                nb_ = istate[I_N_B]
                closest_b[0] = min(closest_b[0], nearest_distance(Xb, counters[B_SEEN_B], nb_, start))
                counters[B_SEEN_B] = nb_
                refill(draw, state_b, Xb, nb_, 0, closest_b[0], istate[I_ITER] // 2, rng, counters, pts, anch,
                       batches[1])
            else:
                refill(draw, state_a, Xa, istate[I_N], istate[I_BEST_V], fstate[F_BEST_D], istate[I_ITER] // 2, rng,
                       counters, pts, anch, batches[0])
        # the buffer's samples in one call (a batch's samples serve both trees in turn, as the planner's own do)
        p = counters[B_POS]
        k = min(counters[B_COUNT] - p, budget - done)
        used = connect_run(pts[p:p + k], anch[p:p + k], ta, tb, istate, fstate, last, world, space, goal, step, low,
                           high, max_connect, st, sb, scratch)
        counters[B_POS] = p + used
        done += used
        if used < k:  # solved, or a tree is full
            return done
    return budget


#: What ``rrtstar_loop`` returns when it hands the draws back to the planner (``planners.fused``).
HAND_BACK = -1


@nb.njit(inline="always")
def rrtstar_loop(budget, draw, state, buffers, rng, loop):
    """Up to ``budget`` RRT* iterations with samples from ``draw`` until the first solution, in compiled code.

    As ``rrt_loop``, with RRT*'s iteration (``rrtstar_run``; ``loop`` is the planner's ``loop_args()``). Once the
    planner has a solution, the loop draws no more: at the first refill after it, it returns the iterations it ran,
    or ``HAND_BACK`` where it ran none, and the planner draws through the sampler's ``draw`` from then on.
    """
    counters, pts, anch = buffers
    tree, aux, istate, fstate, last, world, space, goal, step, tol, low, high, gamma, dim, nbr, nbr_cost, nbr_ok, \
        dfs, st, sb = loop
    X = tree.X
    batch = pts.shape[0]
    q, qe_buf, new, order, sort_stack = rrtstar_scratch(tree, nbr)
    for s in range(budget):
        if istate[I_N] >= X.shape[0]:
            return s
        if counters[B_POS] >= counters[B_COUNT]:
            if istate[I_SOLVED]:
                return s if s > 0 else HAND_BACK
            refill(draw, state, X, istate[I_N], istate[I_BEST_V], fstate[F_BEST_D], istate[I_ITER], rng, counters, pts,
                   anch, batch)
        p = counters[B_POS]
        rrtstar_iterate(pts[p], anch[p], tree, aux, istate, fstate, last, world, space, goal, step, tol, low, high,
                        gamma, dim, nbr, nbr_cost, nbr_ok, dfs, st, sb, q, qe_buf, new, order, sort_stack)
        counters[B_POS] = p + 1
    return budget
