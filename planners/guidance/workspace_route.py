"""The exact workspace route of a rigid body's centre, and the sampler that follows it with uniform orientations.

This is the no-learning ablation of a 6-DoF route sampler: it knows where the body's centre has to
go (a shortest route through the workspace) and nothing about how the body must turn.

* ``voxel_route(world, start, goal, cell)``: the workspace is cut into voxels of side ``cell``; a voxel
  is free when its centre lies farther than the body's inner radius (half its smallest side, for a box
  body; the largest ball about the centre inside the body's hull in general) from every box and from the
  workspace's walls, a necessary condition for any pose of the body centred there. A 26-connected
  Dijkstra search from the goal's voxel gives every free voxel its cost-to-go (edge lengths 1, sqrt 2,
  sqrt 3 voxels); the route descends it from the start's voxel. An end whose voxel is not free starts
  from the nearest free voxel.
* ``WorkspaceRouteSampler``: with probability ``route_fraction`` (0.75) a position drawn uniformly by arc
  length along the route, plus isotropic Gaussian noise of ``spread`` (default the inner radius),
  with uniform angles; otherwise a uniform state. Samples do not depend on the tree, so they come in
  batches.

Box worlds (``RigidBodyWorld``) only; numpy and numba.
"""

from __future__ import annotations

import heapq
import math

import numba as nb
import numpy as np

from planners.base.fileio import InputError, check_number
from planners.base.samplers import SamplerBase

#: Voxel side of the route search, in world units, unless told otherwise.
DEFAULT_CELL = 1.0
#: Most voxels a route search may use (about 40 bytes each).
MAX_VOXELS = 20_000_000


def inner_radius(body: np.ndarray) -> float:
    """Half the smallest side of the body points' bounding box about the body origin: the inner radius of a box."""
    half = np.minimum(np.abs(body.min(axis=0)), np.abs(body.max(axis=0)))
    return float(half.min())


def free_voxels(boxes: np.ndarray, low: np.ndarray, high: np.ndarray, cell: float, radius: float) -> np.ndarray:
    """``(nx, ny, nz)`` bool: voxel centres farther than ``radius`` from every box and from the walls."""
    shape = np.maximum(1, np.floor((high - low) / cell).astype(np.int64))
    if int(np.prod(shape)) > MAX_VOXELS:
        raise InputError(f"a route search at cell {cell:g} needs {int(np.prod(shape)):,} voxels, more than "
                         f"{MAX_VOXELS:,}; use a larger cell")
    axes = [low[k] + (np.arange(shape[k]) + 0.5) * cell for k in range(3)]
    free = np.ones(tuple(shape), dtype=np.bool_)
    for k in range(3):  # the walls
        near = (axes[k] - low[k] <= radius) | (high[k] - axes[k] <= radius)
        idx = [slice(None)] * 3
        idx[k] = near
        free[tuple(idx)] = False
    for b in boxes:
        sl, gaps = [], []
        for k in range(3):
            i0 = int(np.searchsorted(axes[k], b[k] - radius, side="left"))
            i1 = int(np.searchsorted(axes[k], b[3 + k] + radius, side="right"))
            sl.append(slice(i0, i1))
            c = axes[k][i0:i1]
            gaps.append(np.maximum(np.maximum(b[k] - c, c - b[3 + k]), 0.0))
        d2 = gaps[0][:, None, None] ** 2 + gaps[1][None, :, None] ** 2 + gaps[2][None, None, :] ** 2
        free[tuple(sl)] &= d2 > radius * radius
    return free


@nb.njit(cache=True)
def cost_to_go(free, goal):
    """26-connected Dijkstra from voxel ``goal`` (a flat index) over ``free``: costs in voxel sides, inf unreached."""
    nx, ny, nz = free.shape
    flat = free.ravel()
    cost = np.full(flat.shape[0], np.inf)
    cost[goal] = 0.0
    heap = [(0.0, goal)]
    while heap:
        c, v = heapq.heappop(heap)
        if c > cost[v]:
            continue
        i = v // (ny * nz)
        j = (v // nz) % ny
        k = v % nz
        for di in range(-1, 2):
            for dj in range(-1, 2):
                for dk in range(-1, 2):
                    if di == 0 and dj == 0 and dk == 0:
                        continue
                    a, b, e = i + di, j + dj, k + dk
                    if a < 0 or a >= nx or b < 0 or b >= ny or e < 0 or e >= nz:
                        continue
                    w = (a * ny + b) * nz + e
                    if not flat[w]:
                        continue
                    nc = c + math.sqrt(di * di + dj * dj + dk * dk)
                    if nc < cost[w]:
                        cost[w] = nc
                        heapq.heappush(heap, (nc, w))
    return cost.reshape(free.shape)


def _nearest_free(free: np.ndarray, idx: np.ndarray) -> np.ndarray:
    if free[tuple(idx)]:
        return idx
    cells = np.argwhere(free)
    if len(cells) == 0:
        raise InputError("no voxel of the workspace is free for the body's centre")
    return cells[int(np.argmin(((cells - idx) ** 2).sum(axis=1)))]


def voxel_route(world, start, goal, cell: float = DEFAULT_CELL) -> np.ndarray | None:
    """The workspace route of the body's centre from ``start`` to ``goal`` as ``(k, 3)`` points, or None if none.

    The route runs from the start's position through voxel centres to the goal's position (see the module doc).
    """
    cell = float(check_number("voxel_route", "cell", cell, low=0, low_open=True))
    low, high = np.asarray(world.low3), np.asarray(world.high3)
    free = free_voxels(np.asarray(world.boxes), low, high, cell, inner_radius(world.body))
    shape = np.array(free.shape)

    def index(p):
        return np.clip(np.floor((np.asarray(p[:3]) - low) / cell).astype(np.int64), 0, shape - 1)

    s, g = _nearest_free(free, index(start)), _nearest_free(free, index(goal))
    cost = cost_to_go(free, int(np.ravel_multi_index(tuple(g), free.shape)))
    if not np.isfinite(cost[tuple(s)]):
        return None
    steps = np.array([(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1) if (a, b, c) != (0, 0, 0)])
    path, v = [s], s
    while cost[tuple(v)] > 0:
        nb_ = v + steps
        ok = np.all((nb_ >= 0) & (nb_ < shape), axis=1)
        nb_, st = nb_[ok], steps[ok]
        total = cost[nb_[:, 0], nb_[:, 1], nb_[:, 2]] + np.linalg.norm(st, axis=1)
        v = nb_[int(np.argmin(total))]
        path.append(v)
    centres = low + (np.array(path) + 0.5) * cell
    return np.concatenate([np.asarray(start[:3])[None], centres, np.asarray(goal[:3])[None]])


def centre_route(world, route: np.ndarray, reach: int, cell: float = DEFAULT_CELL) -> np.ndarray:
    """``route`` with each interior point moved across the route to the clearest voxel centre within ``reach`` voxels.

    The candidates are the voxel centres within ``reach`` voxels of the point's voxel whose offset runs
    across the route (at most half a voxel along the route's local direction, the chord between the points
    two before and two after); the clearance of a point is its exact distance to the nearest box or
    workspace wall. The search's route keeps only the body's inner radius from every box, so it hugs the
    walls of a passage; this pulls it to the passage's middle. A point keeps its place unless a candidate
    clears more; the ends stay.
    """
    route = np.asarray(route, dtype=np.float64)
    if reach <= 0 or len(route) < 3:
        return route.copy()
    low, high = np.asarray(world.low3, dtype=np.float64), np.asarray(world.high3, dtype=np.float64)
    boxes = np.asarray(world.boxes, dtype=np.float64).reshape(-1, 6)
    shape = np.maximum(1, np.floor((high - low) / cell).astype(np.int64))
    r = np.arange(-reach, reach + 1)
    offsets = np.stack(np.meshgrid(r, r, r, indexing="ij"), axis=-1).reshape(-1, 3)

    def clearance(p: np.ndarray) -> np.ndarray:
        d = np.minimum(p - low, high - p).min(axis=1)
        if len(boxes):
            gap = np.maximum(np.maximum(boxes[None, :, :3] - p[:, None], p[:, None] - boxes[None, :, 3:]), 0.0)
            d = np.minimum(d, np.linalg.norm(gap, axis=2).min(axis=1))
        return d

    out = route.copy()
    k = len(route)
    for i in range(1, k - 1):
        chord = route[min(i + 2, k - 1)] - route[max(i - 2, 0)]
        along = np.abs(offsets @ (chord / max(float(np.linalg.norm(chord)), 1e-12)))
        v = np.clip(np.floor((route[i] - low) / cell).astype(np.int64), 0, shape - 1)
        cand = low + (np.clip(v + offsets[along <= 0.5], 0, shape - 1) + 0.5) * cell
        c = clearance(cand)
        best = int(np.argmax(c))
        if c[best] > clearance(route[i][None])[0]:
            out[i] = cand[best]
    return out


class WorkspaceRouteSampler(SamplerBase):
    """Positions along the exact workspace route of the body's centre, uniform angles (the module doc).

    Args:
        route_fraction: Probability in [0, 1] that a sample follows the route (else uniform); 0.75 is
            the share chosen on the tuning scenes (``scripts/experiments/tune_rigid_route.py``).
        spread: Standard deviation of the Gaussian noise about the route, world units; None: the
            body's inner radius.
        cell: Voxel side of the route search, world units.
    """

    def __init__(self, route_fraction: float = 0.75, spread: float | None = None, cell: float = DEFAULT_CELL) -> None:
        self.route_fraction = float(check_number("WorkspaceRouteSampler", "route_fraction", route_fraction,
                                                 low=0, high=1))
        self.spread = None if spread is None else float(check_number("WorkspaceRouteSampler", "spread", spread,
                                                                     low=0))
        self.cell = float(check_number("WorkspaceRouteSampler", "cell", cell, low=0, low_open=True))

    def _setup(self) -> None:
        world = self.problem.world
        if not (hasattr(world, "boxes") and hasattr(world, "body")):
            raise InputError(f"WorkspaceRouteSampler needs a box world (RigidBodyWorld), got {type(world).__name__}")
        route = voxel_route(world, self.problem.start, self.problem.goal, self.cell)
        self.route = np.zeros((0, 3)) if route is None else route
        seg = np.linalg.norm(np.diff(self.route, axis=0), axis=1) if len(self.route) > 1 else np.zeros(0)
        self._cum = np.concatenate([[0.0], np.cumsum(seg)])
        self._sd = inner_radius(world.body) if self.spread is None else self.spread

    def draw(self, rng, n, view):
        # one row of uniforms per sample (a coin, an arc length, a state, two Box-Muller pairs) keeps the
        # stream identical whatever the batch size
        d = self.problem.dim
        u = rng.random((n, 6 + d))
        r = np.sqrt(-2.0 * np.log(1.0 - u[:, 2 + d:4 + d]))
        t = 2.0 * np.pi * u[:, 4 + d:6 + d]
        z = np.concatenate([r * np.cos(t), r * np.sin(t)], axis=1)[:, :3]
        pts = self._uniform(u[:, 2:2 + d])
        if self._cum[-1] > 0:
            on = u[:, 0] < self.route_fraction
            s = u[on, 1] * self._cum[-1]
            i = np.clip(np.searchsorted(self._cum, s, side="right") - 1, 0, len(self.route) - 2)
            t = ((s - self._cum[i]) / np.maximum(self._cum[i + 1] - self._cum[i], 1e-300))[:, None]
            p = self.route[i] + t * (self.route[i + 1] - self.route[i]) + self._sd * z[on]
            pts[on, :3] = np.clip(p, self.low[:3], np.nextafter(self.high[:3], -np.inf))
        return pts

    def __repr__(self) -> str:
        sd = "inner radius" if self.spread is None else f"{self.spread:g}"
        return f"WorkspaceRouteSampler(route_fraction={self.route_fraction:g}, spread={sd}, cell={self.cell:g})"
