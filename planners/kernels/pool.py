"""What the compiled samplers that draw attempts from a pool of uniforms share: Gaussian, bridge test, OB-PRM.

Such a sampler makes each sample out of one or more *attempts*; an attempt reads a fixed slice of
uniforms from a pool the caller drew from its ``np.random.Generator`` (``planners.base.samplers.draw_pooled``
sizes the pools and carries the state between them), so the samples depend only on the generator's
stream, never on how the caller splits it into pools. ``normals`` turns a slice of an attempt's uniforms
into standard normals.

The attempt loops themselves stay one per kernel module (``planners.kernels.narrow``,
``planners.kernels.obprm``): a loop shared through a compiled attempt function passed to it ran the
bridge test's cheap attempts three times slower (numba passes the world and scratch arrays to every
attempt, or reference-counts them where the attempt is inlined), for the same samples.
"""

from __future__ import annotations

import math

import numba as nb


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
