"""Compiled obstacle-based sampling (OB-PRM): step out of a colliding configuration to the free space.

Every attempt reads a fixed slice of ``per_attempt(dim)`` uniforms from a pool drawn by the caller
from its ``np.random.Generator``, so the samples depend only on the generator's stream, never on
how the caller splits it into pools.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from planners.kernels.geometry import state_free
from planners.kernels.pool import normals
from planners.kernels.space import copy_into
from planners.kernels.state import S_CHECKS, S_PENDING, S_POS, S_SEEKING


@nb.njit(cache=True, no_cfunc_wrapper=True)
def per_attempt(dim):
    """Uniforms one attempt reads: a mixing coin, a candidate, and Box-Muller pairs for a direction."""
    return 1 + dim + 2 * ((dim + 1) // 2)


@nb.njit(cache=True, no_cfunc_wrapper=True)
def ob_samples(world, low, high, u, n, uniform_fraction, walk_step, refine, max_walk, out, cand, state):
    """Write up to ``n`` samples into ``out`` from the uniforms in ``u``; return how many.

    Per sample, the coin of its first attempt decides: with probability ``uniform_fraction`` that
    attempt's uniform candidate is the sample; otherwise attempts go on until one succeeds. A free
    candidate is discarded; from a colliding one the state walks in a random direction in steps of
    ``walk_step`` (at most ``max_walk`` steps, discarded when it leaves the box ``[low, high)``) to
    the first free state, and ``refine`` bisections between that state and the last colliding one
    shrink their gap to ``walk_step / 2**refine``. The free end is the sample, so it lies within
    that gap of a colliding state. ``cand[i]`` receives the attempts spent on sample ``i``;
    attempts that produced nothing are carried in ``state`` to the next sample.
    """
    d = low.shape[0]
    per = per_attempt(d)
    pos = state[S_POS]
    pending = state[S_PENDING]
    seeking = state[S_SEEKING] != 0
    checks = 0
    q = np.empty(d)
    p = np.empty(d)
    lo = np.empty(d)
    hi = np.empty(d)
    mid = np.empty(d)
    direction = np.empty(d)
    m = 0
    while m < n and pos + per <= u.shape[0]:
        a = pos
        pos += per
        pending += 1
        for k in range(d):
            q[k] = low[k] + (high[k] - low[k]) * u[a + 1 + k]
        if not seeking:
            if u[a] < uniform_fraction:
                out[m, :] = q
                cand[m] = pending
                pending = 0
                m += 1
                continue
            seeking = True
        # a colliding candidate is required
        checks += 1
        if state_free(world, q):
            continue
        # random direction: Box-Muller normals, normalised
        normals(u, a + 1 + d, d, direction)
        norm2 = 0.0
        for k in range(d):
            norm2 += direction[k] * direction[k]
        if norm2 <= 1e-300:
            continue
        inv = 1.0 / math.sqrt(norm2)
        for k in range(d):
            direction[k] *= inv
        # walk out of the obstacle to the first free state
        copy_into(lo, q)
        found = False
        for j in range(1, max_walk + 1):
            inside = True
            for k in range(d):
                p[k] = q[k] + j * walk_step * direction[k]
                if not (low[k] <= p[k] < high[k]):
                    inside = False
            if not inside:
                break
            checks += 1
            if state_free(world, p):
                found = True
                break
            copy_into(lo, p)
        if not found:
            continue
        # bisect the last colliding / first free pair: hi stays free, lo colliding
        copy_into(hi, p)
        for _ in range(refine):
            for k in range(d):
                mid[k] = 0.5 * (lo[k] + hi[k])
            checks += 1
            if state_free(world, mid):
                copy_into(hi, mid)
            else:
                copy_into(lo, mid)
        out[m, :] = hi
        cand[m] = pending
        pending = 0
        seeking = False
        m += 1
    state[S_POS] = pos
    state[S_PENDING] = pending
    state[S_CHECKS] += checks
    state[S_SEEKING] = 1 if seeking else 0
    return m
