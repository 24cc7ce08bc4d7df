"""Compiled collision checks for every world kind, behind one dispatch used by all planners.

A world reaches the kernels as a ``planners.kernels.state.WorldKernel`` ``(kind, grid, geom, body,
params)`` (numba cannot cache kernels that take other jitted functions as arguments). Worlds hand out
the subclass of their kind (``GridKernel``, ``ShapesKernel``, ``RigidKernel``; see ``world_kernel``),
which numba types separately, so ``motion_free`` compiles only that kind's check into a kernel; a
plain ``WorldKernel`` is dispatched on ``kind`` at run time. Unused arrays are 1x1 placeholders. A
new kind needs a code and a class here and a branch in ``_any_motion_free`` and ``_world_motion_free``;
an unknown code raises.

* ``WORLD_GRID``: ``grid`` is the (H, W) uint8 obstacle grid, ``params = [1 / resolution, ox, oy]``
  with ``(ox, oy)`` the world coordinates of the corner of cell (0, 0).
* ``WORLD_SHAPES``: ``geom`` rows are ``(0, cx, cy, r, 0)`` circles and ``(1, x0, y0, x1, y1)``
  axis-aligned rectangles, ``params = [xlo, ylo, xhi, yhi]``.
* ``WORLD_RIGID``: ``geom`` rows are boxes ``(x0, y0, z0, x1, y1, z1)``, ``body`` the robot's points
  in its own frame, ``params = [xlo, ylo, zlo, xhi, yhi, zhi, delta, body_radius]``, followed in a
  scene of many boxes by the spatial index's grid, whose cell lists ``grid`` holds (int64; see
  ``planners.kernels.rigid``).
* ``WORLD_MESH``: a triangle-mesh body among a triangle-mesh environment; ``grid`` the broad phase's
  distance grid, ``body`` the body's cover points followed by the exact test's trees and triangles,
  ``geom`` the cover points' clusters (``cover_clusters``), ``params`` as ``planners.kernels.mesh`` lists
  them; the exact test is compiled too (``planners.kernels.triangles``).

Obstacles are closed sets and the free space is open: a motion is valid only if it meets no point of
any obstacle, its boundary included, and stays strictly inside the world's bounds.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numba.extending import overload

from planners.kernels.mesh import mesh_motion_free, mesh_state_free_py
from planners.kernels.rigid import rigid_motion_free
from planners.kernels.space import OVERLOAD_JIT, compiled_only, static_code
from planners.kernels.state import WorldKernel

WORLD_GRID = 0
WORLD_SHAPES = 1
WORLD_RIGID = 2
WORLD_MESH = 3

# Segments are inflated by this many cell widths, so floating-point rounding can only reject a
# motion that grazes an obstacle, never accept one that touches it.
GRID_EPS = 1e-9


@compiled_only
def grid_segment_free(grid, inv_res, ax, ay, bx, by):
    """True if the segment a-b meets no blocked cell and no cell outside the grid.

    Exact cell traversal over closed cells: for every column slab the segment crosses, the rows it
    spans inside that slab are enumerated, so corner touches and grid-line contacts are included.
    """
    H = grid.shape[0]
    W = grid.shape[1]
    ax *= inv_res
    ay *= inv_res
    bx *= inv_res
    by *= inv_res
    # min and max written out (as Python's builtins pick, the first of equals) and no int() around
    # ceil/floor (they return ints): each builtin would be one more compiled function
    xmin = bx if bx < ax else ax
    xmax = bx if bx > ax else ax
    dx = bx - ax
    dy = by - ay
    c_lo = math.ceil(xmin - GRID_EPS) - 1
    c_hi = math.floor(xmax + GRID_EPS)
    if c_lo < 0 or c_hi >= W:
        return False
    ymin_all = by if by < ay else ay
    ymax_all = by if by > ay else ay
    if math.ceil(ymin_all - GRID_EPS) - 1 < 0 or math.floor(ymax_all + GRID_EPS) >= H:
        return False
    flat = abs(dx) < 1e-15
    for c in range(c_lo, c_hi + 1):
        if flat:
            ylo = ymin_all
            yhi = ymax_all
        else:
            # parameter range of the segment inside the slab [c, c + 1]
            x0 = float(c)
            x0 = xmin if xmin > x0 else x0
            x0 = xmax if xmax < x0 else x0
            x1 = float(c + 1)
            x1 = xmin if xmin > x1 else x1
            x1 = xmax if xmax < x1 else x1
            t0 = (x0 - ax) / dx
            t0 = 0.0 if 0.0 > t0 else (1.0 if 1.0 < t0 else t0)
            t1 = (x1 - ax) / dx
            t1 = 0.0 if 0.0 > t1 else (1.0 if 1.0 < t1 else t1)
            y0 = ay + t0 * dy
            y1 = ay + t1 * dy
            ylo = y1 if y1 < y0 else y0
            yhi = y1 if y1 > y0 else y0
        r_lo = math.ceil(ylo - GRID_EPS) - 1
        r_hi = math.floor(yhi + GRID_EPS)
        for r in range(r_lo, r_hi + 1):
            if grid[r, c] != 0:
                return False
    return True


@nb.njit(cache=True, no_cfunc_wrapper=True)
def _segment_hits_circle(ax, ay, bx, by, cx, cy, r):
    dx = bx - ax
    dy = by - ay
    L2 = dx * dx + dy * dy
    t = 0.0
    if L2 > 0.0:
        t = ((cx - ax) * dx + (cy - ay) * dy) / L2
        t = min(max(t, 0.0), 1.0)
    px = ax + t * dx - cx
    py = ay + t * dy - cy
    return px * px + py * py <= r * r


@nb.njit(cache=True, no_cfunc_wrapper=True)
def _segment_hits_box(ax, ay, bx, by, x0, y0, x1, y1):
    # Liang-Barsky clipping against the closed box.
    t_enter = 0.0
    t_exit = 1.0
    d = (bx - ax, by - ay)
    p = (ax, ay)
    lo = (x0, y0)
    hi = (x1, y1)
    for i in range(2):
        if abs(d[i]) < 1e-300:
            if p[i] < lo[i] or p[i] > hi[i]:
                return False
        else:
            ta = (lo[i] - p[i]) / d[i]
            tb = (hi[i] - p[i]) / d[i]
            if ta > tb:
                ta, tb = tb, ta
            if ta > t_enter:
                t_enter = ta
            if tb < t_exit:
                t_exit = tb
            if t_enter > t_exit:
                return False
    return True


@nb.njit(cache=True, no_cfunc_wrapper=True)
def shapes_segment_free(geom, params, ax, ay, bx, by):
    """True if the segment stays strictly inside the bounds and meets no circle or rectangle."""
    for x in (ax, bx):
        if not (params[0] < x < params[2]):
            return False
    for y in (ay, by):
        if not (params[1] < y < params[3]):
            return False
    for i in range(geom.shape[0]):
        if geom[i, 0] == 0.0:
            if _segment_hits_circle(ax, ay, bx, by, geom[i, 1], geom[i, 2], geom[i, 3]):
                return False
        else:
            if _segment_hits_box(ax, ay, bx, by, geom[i, 1], geom[i, 2], geom[i, 3], geom[i, 4]):
                return False
    return True


def world_motion_free(world, a, b):
    """``motion_free`` (compiled code only): typed per ``WorldKernel`` class, see ``world_kernel``."""
    raise NotImplementedError("world_motion_free runs in compiled code only")


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _grid_motion_free(world, a, b):
    kind, grid, geom, body, params = world
    # x - 0.0 is x exactly, so maps at the origin check bit-identically to the frame-free kernel
    ox = params[1]
    oy = params[2]
    return grid_segment_free(grid, params[0], a[0] - ox, a[1] - oy, b[0] - ox, b[1] - oy)


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _shapes_motion_free(world, a, b):
    kind, grid, geom, body, params = world
    return shapes_segment_free(geom, params, a[0], a[1], b[0], b[1])


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _rigid_motion_free(world, a, b):
    kind, grid, geom, body, params = world
    return rigid_motion_free(geom, grid, body, params, a, b)


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _mesh_motion_free(world, a, b):
    kind, grid, geom, body, params = world
    return mesh_motion_free(grid, body, geom, params, a, b)


def _any_motion_free(world, a, b):
    kind = world[0]
    if kind == WORLD_GRID:
        return _grid_motion_free(world, a, b)
    elif kind == WORLD_SHAPES:
        return _shapes_motion_free(world, a, b)
    elif kind == WORLD_RIGID:
        return _rigid_motion_free(world, a, b)
    elif kind == WORLD_MESH:
        return _mesh_motion_free(world, a, b)
    raise ValueError("unknown world kind: add its check to planners.kernels.geometry.motion_free")


@overload(world_motion_free, jit_options=OVERLOAD_JIT, inline="always")
def _world_motion_free(world, a, b):
    kind = static_code(world, "KIND")
    if kind is None:
        return _any_motion_free  # a plain WorldKernel: the kind is known at run time only
    check = {WORLD_GRID: _grid_motion_free, WORLD_SHAPES: _shapes_motion_free, WORLD_RIGID: _rigid_motion_free,
             WORLD_MESH: _mesh_motion_free}[kind]
    return lambda world, a, b: check(world, a, b)


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def motion_free(world, a, b):
    """True if the straight motion from state ``a`` to state ``b`` is collision-free."""
    return world_motion_free(world, a, b)


@nb.njit(cache=True, no_cfunc_wrapper=True)
def state_free(world, q):
    """True if state ``q`` is collision-free (a zero-length motion)."""
    return motion_free(world, q, q)


def state_free_of(world, q) -> bool:
    """``state_free`` for Python callers (``World.is_valid``, a problem's start and goal).

    On a grid the check's own source runs in the interpreter (``grid_segment_free.py_func``: the same
    float64 arithmetic, so the same answer bit for bit), so validating a query compiles nothing a
    planner does not run; a mesh world's state check runs in the interpreter too (``mesh_state_free_py``:
    the bounds and the sphere's bound, then the compiled exact test, as the compiled check does), since
    compiling the whole check alone costs seconds that a planner's own compilation repeats. Other world
    kinds call the compiled ``state_free``.
    """
    if world[0] == WORLD_GRID:
        params = world[4]
        x = q[0] - params[1]
        y = q[1] - params[2]
        return bool(grid_segment_free.py_func(world[1], params[0], x, y, x, y))
    if world[0] == WORLD_MESH:
        return mesh_state_free_py(world[1], world[3], world[4], q)
    return bool(state_free(world, q))


@nb.njit(cache=True, no_cfunc_wrapper=True)
def motions_free(world, A, B, out):
    """Batched ``motion_free`` over rows of ``A`` and ``B``."""
    for i in range(A.shape[0]):
        out[i] = motion_free(world, A[i], B[i])


class GridKernel(WorldKernel):
    """A ``WorldKernel`` of kind ``WORLD_GRID``, typed as such: kernels compile only the grid check."""

    __slots__ = ()
    KIND = WORLD_GRID


class ShapesKernel(WorldKernel):
    """A ``WorldKernel`` of kind ``WORLD_SHAPES``, typed as such."""

    __slots__ = ()
    KIND = WORLD_SHAPES


class RigidKernel(WorldKernel):
    """A ``WorldKernel`` of kind ``WORLD_RIGID``, typed as such."""

    __slots__ = ()
    KIND = WORLD_RIGID


class MeshKernel(WorldKernel):
    """A ``WorldKernel`` of kind ``WORLD_MESH``, typed as such."""

    __slots__ = ()
    KIND = WORLD_MESH


def world_kernel(kind: int, grid: np.ndarray, geom: np.ndarray, body: np.ndarray, params: np.ndarray) -> WorldKernel:
    """The ``WorldKernel`` a world hands the planners, of its kind's class.

    Kernels compiled for it contain that kind's collision check only (a plain ``WorldKernel``
    dispatches at run time).
    """
    for cls in (GridKernel, ShapesKernel, RigidKernel, MeshKernel):
        if cls.KIND == kind:
            return cls(kind, grid, geom, body, params)
    return WorldKernel(kind, grid, geom, body, params)


def placeholder_arrays():
    """The 1x1 arrays that fill unused fields of a ``WorldKernel``."""
    return (
        np.zeros((1, 1), dtype=np.uint8),
        np.zeros((0, 5), dtype=np.float64),
        np.zeros((1, 3), dtype=np.float64),
    )
