"""Compiled narrow-passage sampling: OMPL's Gaussian and bridge-test valid state samplers.

Both follow OMPL's ``GaussianValidStateSampler`` and ``BridgeTestValidStateSampler``:

* Gaussian (Boor, Overmars, van der Stappen 1999): draw a uniform state ``s1`` and a Gaussian state
  ``s2`` around it; when exactly one of the two is valid, that one is the sample.
* Bridge test (Hsu et al. 2003): draw a uniform state ``s1``; if it is invalid, draw a Gaussian
  state ``s2`` around it; if that is invalid too, the midpoint of ``s1`` and ``s2`` (the space's
  interpolation) is the sample when it is valid.

An attempt that makes no sample is repeated, at most ``attempts`` times per sample; then the
sample is the last attempt's uniform state (OMPL reports failure there; our planners take every
sample they are given and check it themselves).

The Gaussian state follows OMPL's ``sampleGaussian`` of the space: each position coordinate is
``N(mean, pos_sd)`` clamped to the bounds; on the rigid body's angles the rotation is perturbed by
``exp(v)`` with ``v ~ N(0, rot_sd^2 I_3)`` in the body frame (OMPL's ``SO3StateSampler``), or drawn
uniformly when ``rot_sd`` exceeds ``ROT_UNIFORM`` (OMPL does the same: the tails wrap around).

Every attempt reads a fixed slice of ``per_attempt(dim)`` uniforms from a pool drawn by the caller
from its ``np.random.Generator``, so samples do not depend on how the caller splits its pools.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from planners.kernels.geometry import state_free
from planners.kernels.pool import normals
from planners.kernels.rigid import euler_angles, rotation_matrix
from planners.kernels.space import SPACE_RN, interpolate
from planners.kernels.state import S_CHECKS, S_PENDING, S_POS

#: Above this rotational deviation OMPL's SO(3) Gaussian draws a uniform rotation instead.
ROT_UNIFORM = 1.17

GAUSSIAN = 0
BRIDGE = 1


@nb.njit(cache=True, no_cfunc_wrapper=True)
def per_attempt(dim):
    """Uniforms one attempt reads: a state, Box-Muller pairs for ``dim`` normals, and three spare uniforms."""
    return dim + 2 * ((dim + 1) // 2) + 3


@nb.njit(cache=True, no_cfunc_wrapper=True)
def gaussian_state(kind, low, high, mean, u, a, pos_sd, rot_sd, out):
    """A Gaussian state around ``mean`` from the attempt's uniforms ``u[a:]`` (see the module doc)."""
    d = low.shape[0]
    z = np.empty(d)
    normals(u, a + d, d, z)
    npos = d if kind == SPACE_RN else 3
    for k in range(npos):
        v = mean[k] + pos_sd * z[k]
        out[k] = min(max(v, low[k]), high[k])
    if kind == SPACE_RN:
        return
    spare = a + d + 2 * ((d + 1) // 2)
    if rot_sd > ROT_UNIFORM:
        for k in range(3, 6):
            out[k] = low[k] + (high[k] - low[k]) * u[spare + k - 3]
        return
    vx, vy, vz = rot_sd * z[3], rot_sd * z[4], rot_sd * z[5]
    theta = math.sqrt(vx * vx + vy * vy + vz * vz)
    if theta < 1e-300:
        for k in range(3, 6):
            out[k] = mean[k]
        return
    # Rodrigues: the rotation by theta about v / theta, applied in the body frame (R = R_mean @ P)
    kx, ky, kz = vx / theta, vy / theta, vz / theta
    c, s = math.cos(theta), math.sin(theta)
    C = 1.0 - c
    P = np.empty((3, 3))
    P[0, 0] = c + kx * kx * C
    P[0, 1] = kx * ky * C - kz * s
    P[0, 2] = kx * kz * C + ky * s
    P[1, 0] = ky * kx * C + kz * s
    P[1, 1] = c + ky * ky * C
    P[1, 2] = ky * kz * C - kx * s
    P[2, 0] = kz * kx * C - ky * s
    P[2, 1] = kz * ky * C + kx * s
    P[2, 2] = c + kz * kz * C
    M = rotation_matrix(mean[3], mean[4], mean[5])
    R = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            for k in range(3):
                R[i, j] += M[i, k] * P[k, j]
    ang = np.empty(3)
    euler_angles(R, ang)
    for k in range(3):
        out[3 + k] = ang[k]


@nb.njit(cache=True, no_cfunc_wrapper=True)
def narrow_samples(world, kind, mode, low, high, u, n, attempts, pos_sd, rot_sd, out, cand, state):
    """Write up to ``n`` samples into ``out`` from the uniforms in ``u``; return how many.

    ``mode`` is ``GAUSSIAN`` or ``BRIDGE``. ``cand[i]`` receives the attempts spent on sample ``i``;
    the attempts of a sample still being sought when ``u`` runs out are carried in ``state``.
    """
    d = low.shape[0]
    per = per_attempt(d)
    pos = state[S_POS]
    pending = state[S_PENDING]
    checks = 0
    s1 = np.empty(d)
    s2 = np.empty(d)
    mid = np.empty(d)
    m = 0
    while m < n and pos + per <= u.shape[0]:
        a = pos
        pos += per
        pending += 1
        for k in range(d):
            s1[k] = low[k] + (high[k] - low[k]) * u[a + k]
        found = False
        if mode == GAUSSIAN:
            v1 = state_free(world, s1)
            gaussian_state(kind, low, high, s1, u, a, pos_sd, rot_sd, s2)
            v2 = state_free(world, s2)
            checks += 2
            if v1 != v2:
                found = True
                out[m, :] = s2 if v2 else s1
        else:
            checks += 1
            if not state_free(world, s1):
                gaussian_state(kind, low, high, s1, u, a, pos_sd, rot_sd, s2)
                checks += 1
                if not state_free(world, s2):
                    interpolate(kind, s2, s1, 0.5, mid)
                    checks += 1
                    if state_free(world, mid):
                        found = True
                        out[m, :] = mid
        if not found and pending >= attempts:
            out[m, :] = s1  # OMPL gives up here; the planner checks the uniform state itself
            found = True
        if found:
            cand[m] = pending
            pending = 0
            m += 1
    state[S_POS] = pos
    state[S_PENDING] = pending
    state[S_CHECKS] += checks
    return m
