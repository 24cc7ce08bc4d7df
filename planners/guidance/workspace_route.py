"""The exact workspace route of a rigid body's centre, and the sampler that follows it with uniform orientations.

This is the no-learning ablation of a 6-DoF route sampler: it knows where the body's centre has to
go (a shortest route through the workspace) and nothing about how the body must turn.

* ``voxel_route(world, start, goal, cell)``: the workspace is cut into voxels of side ``cell``; a voxel
  is free when its centre lies farther than the body's inner radius (the largest ball about the body's
  origin inside the body: half its smallest side, for a box body) from every obstacle (and, in a box
  world, from the workspace's walls), a necessary condition for any pose of the body centred there. The
  world decides which voxels are free (``centre_free_voxels``): a box world exactly, a mesh world from its
  broad phase's distance bounds. A 26-connected Dijkstra search from the goal's voxel gives the free
  voxels their cost-to-go (edge lengths 1, sqrt 2, sqrt 3 voxels) until it settles the start's voxel; the
  route descends it from there. An end whose voxel is not free starts from the nearest free voxel.
* ``WorkspaceRouteSampler``: with probability ``route_fraction`` (0.75) a position drawn uniformly by arc
  length along the route, plus isotropic Gaussian noise of ``spread`` (default the world's ``route_spread``:
  a box world's inner radius, a mesh world's ``ROUTE_SPREAD_CELLS`` route cells),
  with uniform angles; otherwise a uniform state. Samples do not depend on the tree, so they come in
  batches.

Box and mesh worlds (``RigidBodyWorld``, ``MeshWorld``); numpy and numba.
"""

from __future__ import annotations

import heapq
import math

import numba as nb
import numpy as np

from planners.base.fileio import InputError, check_number
from planners.base.samplers import SamplerBase
from planners.worlds.rigid3d import DEFAULT_CELL, MAX_VOXELS, free_voxels, inner_radius

__all__ = ["DEFAULT_CELL", "MAX_VOXELS", "WorkspaceRouteSampler", "box_muller", "centre_route", "cost_to_go",
           "free_voxels", "inner_radius", "route_world", "voxel_route"]


@nb.njit(cache=True)
def cost_to_go(free, goal, stop=-1):
    """26-connected Dijkstra from voxel ``goal`` (a flat index) over ``free``: costs in voxel sides, inf unreached.

    With ``stop`` (a flat index), the search ends when that voxel is settled: every voxel cheaper than it
    holds its exact cost, every other one at least its cost (what a descent from ``stop`` needs).
    """
    nx, ny, nz = free.shape
    flat = free.ravel()
    cost = np.full(flat.shape[0], np.inf)
    cost[goal] = 0.0
    heap = [(0.0, goal)]
    while heap:
        c, v = heapq.heappop(heap)
        if c > cost[v]:
            continue
        if v == stop:
            break
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


def box_muller(u: np.ndarray) -> np.ndarray:
    """``(n, 2k)`` standard normals from ``(n, 2k)`` uniforms in [0, 1): ``k`` Box-Muller pairs.

    Radii from the first ``k`` columns, angles from the last ``k``; the cosines first, then the sines.
    """
    k = u.shape[1] // 2
    r = np.sqrt(-2.0 * np.log(1.0 - u[:, :k]))
    t = 2.0 * np.pi * u[:, k:2 * k]
    return np.concatenate([r * np.cos(t), r * np.sin(t)], axis=1)


def _nearest_free(free: np.ndarray, idx: np.ndarray) -> np.ndarray:
    if free[tuple(idx)]:
        return idx
    cells = np.argwhere(free)
    if len(cells) == 0:
        raise InputError("no voxel of the workspace is free for the body's centre")
    return cells[int(np.argmin(((cells - idx) ** 2).sum(axis=1)))]


def voxel_route(world, start, goal, cell: float | None = None) -> np.ndarray | None:
    """The workspace route of the body's centre from ``start`` to ``goal`` as ``(k, 3)`` points, or None if none.

    The route runs from the start's position through voxel centres to the goal's position (see the module doc);
    ``cell`` is the voxel side (None: the world's ``route_cell``).
    """
    world = route_world(world, "voxel_route")
    cell = float(world.route_cell if cell is None else check_number("voxel_route", "cell", cell, low=0,
                                                                     low_open=True))
    low = np.asarray(world.low3)
    free = world.centre_free_voxels(cell)
    shape = np.array(free.shape)

    def index(p):
        return np.clip(np.floor((np.asarray(p[:3]) - low) / cell).astype(np.int64), 0, shape - 1)

    s, g = _nearest_free(free, index(start)), _nearest_free(free, index(goal))
    # the search stops once the start is settled: the descent below meets only cheaper voxels, whose costs are exact
    cost = cost_to_go(free, int(np.ravel_multi_index(tuple(g), free.shape)),
                      int(np.ravel_multi_index(tuple(s), free.shape)))
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


def centre_route(world, route: np.ndarray, reach: int, cell: float | None = None) -> np.ndarray:
    """``route`` with each interior point moved across the route to the clearest voxel centre within ``reach`` voxels.

    The candidates are the voxel centres within ``reach`` voxels of the point's voxel whose offset runs
    across the route (at most half a voxel along the route's local direction, the chord between the points
    two before and two after); the clearance of a point is the world's ``workspace_clearance`` (a box
    world's exact distance to the nearest box or wall). The search's route keeps only the body's inner
    radius from every box, so it hugs the walls of a passage; this pulls it to the passage's middle. A
    point keeps its place unless a candidate clears more; the ends stay.
    """
    route = np.asarray(route, dtype=np.float64)
    if reach <= 0 or len(route) < 3:
        return route.copy()
    world = route_world(world, "centre_route")
    cell = float(world.route_cell if cell is None else cell)
    low, high = np.asarray(world.low3, dtype=np.float64), np.asarray(world.high3, dtype=np.float64)
    shape = np.maximum(1, np.floor((high - low) / cell).astype(np.int64))
    r = np.arange(-reach, reach + 1)
    offsets = np.stack(np.meshgrid(r, r, r, indexing="ij"), axis=-1).reshape(-1, 3)

    clearance = world.workspace_clearance
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


def route_world(world, who: str):
    """``world`` if it offers what the workspace route needs (a box or mesh world), else a clear error."""
    if not all(hasattr(world, m) for m in ("centre_free_voxels", "workspace_clearance", "inner_radius", "route_cell",
                                         "route_spread")):
        raise InputError(f"{who} needs a 6-DoF body world (RigidBodyWorld or MeshWorld), got {type(world).__name__}")
    return world


class WorkspaceRouteSampler(SamplerBase):
    """Positions along the exact workspace route of the body's centre, uniform angles (the module doc).

    Args:
        route_fraction: Probability in [0, 1] that a sample follows the route (else uniform); 0.75 is
            the share chosen on the tuning scenes (``scripts/experiments/tune_rigid_route.py``).
        spread: Standard deviation of the Gaussian noise about the route, world units; None: the world's
            ``route_spread`` (a box world's inner radius).
        cell: Voxel side of the route search, world units; None: the world's ``route_cell`` (``DEFAULT_CELL``
            in a box world, the broad phase's voxel in a mesh world).
    """

    def __init__(self, route_fraction: float = 0.75, spread: float | None = None, cell: float | None = None) -> None:
        self.route_fraction = float(check_number("WorkspaceRouteSampler", "route_fraction", route_fraction,
                                                 low=0, high=1))
        self.spread = None if spread is None else float(check_number("WorkspaceRouteSampler", "spread", spread,
                                                                     low=0))
        self.cell = None if cell is None else float(check_number("WorkspaceRouteSampler", "cell", cell, low=0,
                                                                 low_open=True))

    def _setup(self) -> None:
        world = route_world(self.problem.world, "WorkspaceRouteSampler")
        route = voxel_route(world, self.problem.start, self.problem.goal, self.cell)
        self.route = np.zeros((0, 3)) if route is None else route
        seg = np.linalg.norm(np.diff(self.route, axis=0), axis=1) if len(self.route) > 1 else np.zeros(0)
        self._cum = np.concatenate([[0.0], np.cumsum(seg)])
        self._sd = world.route_spread if self.spread is None else self.spread

    def draw(self, rng, n, view):
        # one row of uniforms per sample (a coin, an arc length, a state, two Box-Muller pairs) keeps the
        # stream identical whatever the batch size
        d = self.problem.dim
        u = rng.random((n, 6 + d))
        z = box_muller(u[:, 2 + d:6 + d])[:, :3]
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
        sd = "the world's" if self.spread is None else f"{self.spread:g}"
        cell = "the world's" if self.cell is None else f"{self.cell:g}"
        return f"WorkspaceRouteSampler(route_fraction={self.route_fraction:g}, spread={sd}, cell={cell})"
