"""The attempt-pool loop of the compiled samplers that discard attempts: Gaussian, bridge test, OB-PRM.

Such a sampler makes each sample out of one or more *attempts*; an attempt reads a fixed slice of
``per`` uniforms from a pool the caller drew from its ``np.random.Generator``, so the samples depend
only on the generator's stream, never on how the caller splits it into pools. ``pooled_attempts``
runs the attempts and does the bookkeeping the samplers share: attempts not yet charged to a sample
(``S_PENDING``) and the position in the pool (``S_POS``) carry over between calls in ``state``, the
attempts behind each sample go to ``cand``, and validity checks accumulate in ``S_CHECKS``. The
sampler supplies the attempt itself, as ``planners.kernels.narrow`` and ``planners.kernels.obprm``
do, and wraps the loop in a cached entry of its own module::

    @numba.njit(cache=True)
    def my_samples(..., u, n, out, cand, state):
        return pooled_attempts(my_attempt, (...), u, per, n, out, cand, state)

(numba compiles the loop for ``my_attempt`` with a direct call to it, and caches it with the entry).
The Python side of the pool (its size, the generator) is ``planners.base.samplers.draw_pooled``.
"""

from __future__ import annotations

import math

import numba as nb

from planners.kernels.state import S_CHECKS, S_PENDING, S_POS


@nb.njit(inline="always")
def pooled_attempts(attempt, ctx, u, per, n, out, cand, state):
    """Write up to ``n`` samples into ``out`` from the uniforms in ``u``; return how many.

    Each attempt reads ``u[a:a + per]``; ``attempt(ctx, u, a, pending, state, row)`` returns
    ``(found, checks)``: whether it wrote a sample into ``row``, and the validity checks it made.
    ``pending`` counts the attempts spent on the sample sought, this one included. ``ctx`` is the
    sampler's arguments and scratch arrays; ``state`` (``planners.kernels.state``'s ``S_*`` slots) is
    the attempt's to read and write too (OB-PRM keeps ``S_SEEKING`` there).
    """
    pos = state[S_POS]
    pending = state[S_PENDING]
    checks = 0
    m = 0
    while m < n and pos + per <= u.shape[0]:
        a = pos
        pos += per
        pending += 1
        found, c = attempt(ctx, u, a, pending, state, out[m])
        checks += c
        if found:
            cand[m] = pending
            pending = 0
            m += 1
    state[S_POS] = pos
    state[S_PENDING] = pending
    state[S_CHECKS] += checks
    return m


@nb.njit(cache=True, no_cfunc_wrapper=True)
def normals(u, b, dim, out):
    """``dim`` standard normals into ``out`` from the pool's uniforms ``u[b:]``, a Box-Muller pair for two."""
    for k in range(0, dim, 2):
        r = math.sqrt(-2.0 * math.log(1.0 - u[b]))  # 1 - u lies in (0, 1]
        t = 2.0 * math.pi * u[b + 1]
        b += 2
        out[k] = r * math.cos(t)
        if k + 1 < dim:
            out[k + 1] = r * math.sin(t)
