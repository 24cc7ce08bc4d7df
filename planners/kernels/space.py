"""Compiled state-space primitives: distance, interpolation and the nearest-neighbour embedding.

A state space is described to the kernels by two small integers, ``(kind, metric)``:

* ``SPACE_RN`` -- real vectors; ``metric`` is one of ``METRIC_L2``, ``METRIC_L1``, ``METRIC_LINF``.
  The nearest-neighbour embedding is the identity.
* ``SPACE_RIGID`` -- 6-DoF rigid body ``(x, y, z, tx, ty, tz)`` with Euler angles in ``[-pi, pi)``.
  ``METRIC_COSSIN``: Euclidean distance on ``(x, y, z, cos tx, sin tx, ..., cos tz, sin tz)``, so the
  embedding is 9-D and the k-d index applies. ``METRIC_SE3``: translation distance plus
  ``rot_weight`` times the geodesic rotation angle; no Euclidean embedding exists, so nearest-neighbour
  queries fall back to a compiled exact scan.

Angles are interpolated along the shorter arc, so a motion from 3.1 to -3.1 rad turns 0.08 rad.
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numba as nb
import numpy as np
from numba.extending import overload

SPACE_RN = 0
SPACE_RIGID = 1

METRIC_L2 = 0
METRIC_L1 = 1
METRIC_LINF = 2
METRIC_COSSIN = 3
METRIC_SE3 = 4

METRIC_NAMES = {
    "euclidean": METRIC_L2,
    "manhattan": METRIC_L1,
    "chebyshev": METRIC_LINF,
    "cossin": METRIC_COSSIN,
    "se3": METRIC_SE3,
}

TWO_PI = 2.0 * math.pi

#: numba options of the overloads' implementations (``space_distance`` and the like): only compiled code
#: calls them, so they are compiled without numba's Python entry wrapper and its C-callable one (less to
#: compile). A function compiled without the Python wrapper must never be called from Python.
OVERLOAD_JIT = {"cache": True, "no_cfunc_wrapper": True, "no_cpython_wrapper": True}


def compiled_only(f):
    """``f`` for compiled callers only: compiled without numba's Python entry wrapper (``OVERLOAD_JIT``).

    Returns a stand-in of ``f``'s name and signature. Compiled code calling it compiles ``f`` itself (the
    implementation of an ``overload`` of the stand-in), so nothing lies between the caller and ``f``;
    Python calling it gets an error instead of the crash a wrapper-less function gives. The stand-in's
    ``py_func`` is ``f``, to run its source in the interpreter.
    """

    @functools.wraps(f)
    def stand_in(*args):
        raise NotImplementedError(f"{f.__qualname__} runs in compiled code only (its py_func runs in Python)")

    @functools.wraps(f)
    def typer(*args):
        return f

    overload(stand_in, jit_options=OVERLOAD_JIT)(typer)
    stand_in.py_func = f
    return stand_in


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def wrap_angle(a):
    """Map an angle to [-pi, pi)."""
    return (a + math.pi) % TWO_PI - math.pi


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def embed_dim(kind, metric, dim):
    if kind == SPACE_RIGID and metric == METRIC_COSSIN:
        return 9
    return dim


@nb.njit(cache=True, no_cfunc_wrapper=True)
def embed(kind, metric, q, out):
    """Write the nearest-neighbour embedding of ``q`` into ``out``."""
    if kind == SPACE_RIGID and metric == METRIC_COSSIN:
        out[0] = q[0]
        out[1] = q[1]
        out[2] = q[2]
        for i in range(3):
            out[3 + 2 * i] = math.cos(q[3 + i])
            out[4 + 2 * i] = math.sin(q[3 + i])
    else:
        for i in range(q.shape[0]):
            out[i] = q[i]


@nb.njit(cache=True, no_cfunc_wrapper=True)
def _euler_to_quat(tx, ty, tz, out):
    # H = Ry @ Rx @ Rz, so the quaternion is qy * qx * qz.
    cx, sx = math.cos(0.5 * tx), math.sin(0.5 * tx)
    cy, sy = math.cos(0.5 * ty), math.sin(0.5 * ty)
    cz, sz = math.cos(0.5 * tz), math.sin(0.5 * tz)
    # qy * qx
    w1 = cy * cx
    x1 = cy * sx
    y1 = sy * cx
    z1 = -sy * sx
    # (qy * qx) * qz
    out[0] = w1 * cz - z1 * sz
    out[1] = x1 * cz + y1 * sz
    out[2] = y1 * cz - x1 * sz
    out[3] = z1 * cz + w1 * sz


@nb.njit(cache=True, no_cfunc_wrapper=True)
def rotation_angle_between(a, b):
    """Geodesic angle (radians, in [0, pi]) between the rotations of two rigid-body states."""
    qa = np.empty(4)
    qb = np.empty(4)
    _euler_to_quat(a[3], a[4], a[5], qa)
    _euler_to_quat(b[3], b[4], b[5], qb)
    dot = abs(qa[0] * qb[0] + qa[1] * qb[1] + qa[2] * qb[2] + qa[3] * qb[3])
    if dot > 1.0:
        dot = 1.0
    return 2.0 * math.acos(dot)


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _l2(a, b):
    s = 0.0
    for i in range(a.shape[0]):
        d = a[i] - b[i]
        s += d * d
    return math.sqrt(s)


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _l1(a, b):
    s = 0.0
    for i in range(a.shape[0]):
        s += abs(a[i] - b[i])
    return s


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _linf(a, b):
    s = 0.0
    for i in range(a.shape[0]):
        d = abs(a[i] - b[i])
        if d > s:
            s = d
    return s


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _cossin(a, b):
    t = 0.0
    for i in range(3):
        d = a[i] - b[i]
        t += d * d
    # |(cos a, sin a) - (cos b, sin b)|^2 = 4 sin^2((a - b) / 2)
    for i in range(3, 6):
        s = math.sin(0.5 * (a[i] - b[i]))
        t += 4.0 * s * s
    return math.sqrt(t)


@nb.njit(cache=True, no_cfunc_wrapper=True)
def distance(kind, metric, rot_weight, a, b):
    """Distance between two states under ``(kind, metric)``."""
    if kind == SPACE_RN:
        if metric == METRIC_L2:
            return _l2(a, b)
        elif metric == METRIC_L1:
            return _l1(a, b)
        return _linf(a, b)
    if metric == METRIC_COSSIN:
        return _cossin(a, b)
    # rigid body, SE3
    t = 0.0
    for i in range(3):
        d = a[i] - b[i]
        t += d * d
    return math.sqrt(t) + rot_weight * rotation_angle_between(a, b)


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _interpolate_rn(a, b, t, out):
    for i in range(a.shape[0]):
        out[i] = a[i] + t * (b[i] - a[i])


@nb.njit(**OVERLOAD_JIT)
def _interpolate_rigid(a, b, t, out):
    for i in range(3):
        out[i] = a[i] + t * (b[i] - a[i])
    for i in range(3, 6):
        out[i] = wrap_angle(a[i] + t * wrap_angle(b[i] - a[i]))


@nb.njit(cache=True, no_cfunc_wrapper=True)
def interpolate(kind, a, b, t, out):
    """State at fraction ``t`` of the motion from ``a`` to ``b`` (shorter arc for angles)."""
    if kind == SPACE_RN:
        _interpolate_rn(a, b, t, out)
    else:
        _interpolate_rigid(a, b, t, out)


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def kd_metric(metric):
    """Lp metric code the k-d index uses on the embedding (COSSIN embeds into L2)."""
    if metric == METRIC_L1 or metric == METRIC_LINF:
        return metric
    return METRIC_L2


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def uses_kd(kind, metric):
    return metric != METRIC_SE3


# --- spaces whose kind and metric are part of the type ----------------------------------------------
# ``Problem.space`` hands the kernels one of the classes below. They are ``Space`` tuples like any
# other, but numba types each class separately, so the helpers that take ``space`` whole
# (``space_distance``, ``space_nearest`` in ``planners.kernels.tree``) compile only the branch of
# that kind and metric: a 2-D Euclidean run never compiles the rigid-body or L1 code. A plain
# ``(kind, metric, rot_weight)`` tuple still works everywhere, dispatched at run time.


class Space(NamedTuple):
    """``(kind, metric, rot_weight)`` as the kernels take it (see the module docstring)."""

    kind: int
    metric: int
    rot_weight: float


class SpaceRnL2(Space):
    """R^n with the Euclidean metric."""

    __slots__ = ()
    KIND, METRIC = SPACE_RN, METRIC_L2


class SpaceRnL1(Space):
    """R^n with the L1 metric."""

    __slots__ = ()
    KIND, METRIC = SPACE_RN, METRIC_L1


class SpaceRnLinf(Space):
    """R^n with the L-infinity metric."""

    __slots__ = ()
    KIND, METRIC = SPACE_RN, METRIC_LINF


class SpaceRigidCossin(Space):
    """The rigid body's states with the ``cossin`` metric."""

    __slots__ = ()
    KIND, METRIC = SPACE_RIGID, METRIC_COSSIN


class SpaceRigidSE3(Space):
    """The rigid body's states with the ``se3`` metric."""

    __slots__ = ()
    KIND, METRIC = SPACE_RIGID, METRIC_SE3


SPACE_CLASSES = (SpaceRnL2, SpaceRnL1, SpaceRnLinf, SpaceRigidCossin, SpaceRigidSE3)


def make_space(kind: int, metric: int, rot_weight: float) -> Space:
    """The ``Space`` of that kind and metric, typed so the kernels compile only its branch."""
    for cls in SPACE_CLASSES:
        if cls.KIND == kind and cls.METRIC == metric:
            return cls(int(kind), int(metric), float(rot_weight))
    return Space(int(kind), int(metric), float(rot_weight))


def static_code(tup, name):
    """The class constant ``name`` (``KIND``, ``METRIC``) of a typed tuple's class, or None (known at run time only)."""
    return getattr(getattr(tup, "instance_class", None), name, None)


def space_distance(space, a, b):
    """Distance between two states in ``space`` (compiled code only; see ``distance``)."""
    raise NotImplementedError("space_distance runs in compiled code only")


@overload(space_distance, jit_options=OVERLOAD_JIT)
def _space_distance(space, a, b):
    kind, metric = static_code(space, "KIND"), static_code(space, "METRIC")
    if kind == SPACE_RN:
        impl = {METRIC_L2: _l2, METRIC_L1: _l1, METRIC_LINF: _linf}[metric]
        return lambda space, a, b: impl(a, b)
    if kind == SPACE_RIGID and metric == METRIC_COSSIN:
        return lambda space, a, b: _cossin(a, b)
    return lambda space, a, b: distance(space[0], space[1], space[2], a, b)


def space_interpolate(space, a, b, t, out):
    """``interpolate`` in ``space`` (compiled code only): a typed space compiles only its kind's branch."""
    raise NotImplementedError("space_interpolate runs in compiled code only")


@overload(space_interpolate, jit_options=OVERLOAD_JIT)
def _space_interpolate(space, a, b, t, out):
    kind = static_code(space, "KIND")
    if kind is None:
        return lambda space, a, b, t, out: interpolate(space[0], a, b, t, out)
    impl = _interpolate_rn if kind == SPACE_RN else _interpolate_rigid
    return lambda space, a, b, t, out: impl(a, b, t, out)


def space_embedding(space, q, out):
    """The nearest-neighbour embedding of ``q`` (compiled code only): ``q`` itself in a real-vector space,
    else written into ``out`` and ``out`` returned. A typed space compiles only its kind's branch.
    """
    raise NotImplementedError("space_embedding runs in compiled code only")


def _embedding_any(space, q, out):
    if space[0] == SPACE_RN:
        return q
    embed(space[0], space[1], q, out)
    return out


@overload(space_embedding, jit_options=OVERLOAD_JIT)
def _space_embedding(space, q, out):
    kind = static_code(space, "KIND")
    if kind is None:
        return _embedding_any
    if kind == SPACE_RN:
        return lambda space, q, out: q

    def impl(space, q, out):
        embed(space[0], space[1], q, out)
        return out

    return impl


@nb.njit(cache=True, no_cfunc_wrapper=True)
def space_distance_of(space, a, b):
    """``space_distance`` compiled for Python callers: compiles only ``space``'s branch (see ``distance_of``)."""
    return space_distance(space, a, b)


#: The metrics whose distance is one small function of the two states, by ``(kind, metric)``.
_LEAF_DISTANCES = {
    (SPACE_RN, METRIC_L2): _l2,
    (SPACE_RN, METRIC_L1): _l1,
    (SPACE_RN, METRIC_LINF): _linf,
    (SPACE_RIGID, METRIC_COSSIN): _cossin,
}


def distance_of(space, a: np.ndarray, b: np.ndarray) -> float:
    """``space_distance`` for Python callers (``Problem.distance``), on float64 vectors.

    The real-vector metrics and cossin run their compiled function's own source in the interpreter
    (``py_func``: the same float64 operations in the same order, so the same value bit for bit), so a
    distance asked from Python compiles nothing; SE3 calls the compiled ``space_distance_of``.
    """
    leaf = _LEAF_DISTANCES.get((space[0], space[1]))
    if leaf is not None:
        return float(leaf.py_func(a, b))
    return float(space_distance_of(space, a, b))


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def copy_into(out, q):
    """``out[:] = q`` for two vectors of one length.

    (The slice assignment compiles numba's shape-mismatch message formatting, seconds of compilation per kernel
    that uses it.)
    """
    for i in range(q.shape[0]):
        out[i] = q[i]
