"""The exact workspace route of a rigid body's centre, and the sampler that follows it with uniform orientations.

This is the no-learning ablation of a 6-DoF route sampler: it knows where the body's centre has to
go (a shortest route through the workspace) and nothing about how the body must turn.

* ``voxel_route(world, start, goal, cell)``: the workspace is cut into voxels of side ``cell``; a voxel
  is free when its centre lies farther than the body's inner radius (the largest ball about the body's
  origin inside the body: half its smallest side, for a box body) from every obstacle (and, in a box
  world, from the workspace's walls), a necessary condition for any pose of the body centred there. The
  world decides which voxels are free (``centre_free_voxels``): a box world exactly, a mesh world from its
  broad phase's distance bounds. A 26-connected A* search from the goal's voxel (edge lengths 1, sqrt 2,
  sqrt 3 voxels; the heuristic the 26-connected distance to the start's voxel, scaled by ``HEURISTIC_SCALE``
  so that every voxel of every shortest route is settled before the start) gives the voxels it settles their
  exact cost-to-go; the route descends it from the start, to the neighbour of least cost plus step (the first
  of equals in a fixed order). An end whose voxel is not free starts from the nearest free voxel.
* ``WorkspaceRouteSampler``: with probability ``route_fraction`` (0.75) a position drawn uniformly by arc
  length along the route, plus isotropic Gaussian noise of ``spread`` (default the world's ``route_spread``:
  a box world's inner radius, a mesh world's ``ROUTE_SPREAD_CELLS`` route cells),
  with uniform angles; otherwise a uniform state. Samples do not depend on the tree, so they come in
  batches.

Box and mesh worlds (``RigidBodyWorld``, ``MeshWorld``); numpy and numba.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from planners.base.fileio import InputError, check_number
from planners.base.samplers import SamplerBase
from planners.kernels.heap import heap_lower, heap_pop
from planners.worlds.rigid3d import DEFAULT_CELL, MAX_VOXELS, free_voxels, inner_radius

__all__ = ["DEFAULT_CELL", "MAX_VOXELS", "WorkspaceRouteSampler", "box_muller", "centre_route", "cost_to_go",
           "free_voxels", "inner_radius", "route_world", "voxel_route"]


#: The A* heuristic's factor below 1 (``cost_to_go``): every voxel on a shortest route from the start then has a
#: key strictly below the start's, so it is settled first, with its exact cost, whatever the order among equal keys.
HEURISTIC_SCALE = 0.999


def _steps() -> tuple[np.ndarray, np.ndarray]:
    """The 26 neighbour steps in the descent's fixed order, and their lengths."""
    steps = np.array([(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1) if (a, b, c) != (0, 0, 0)],
                     dtype=np.int64)
    return steps, np.sqrt((steps * steps).sum(axis=1).astype(np.float64))


STEPS, STEP_LENGTHS = _steps()


@nb.njit(cache=True)
def _octile3(di, dj, dk):
    """The 26-connected distance of a voxel offset (edge lengths 1, sqrt 2, sqrt 3)."""
    a, b, c = abs(di), abs(dj), abs(dk)
    if a < b:
        a, b = b, a
    if b < c:
        b, c = c, b
    if a < b:
        a, b = b, a
    return c * math.sqrt(3.0) + (b - c) * math.sqrt(2.0) + (a - b)


@nb.njit(cache=True)
def _search(free, goal, stop, steps, lengths, scale):
    nx, ny, nz = free.shape
    n = nx * ny * nz
    flat = free.ravel()
    cost = np.full(n, np.inf)
    pos = np.full(n, -1, dtype=np.int64)  # heap slot; -1 never queued, -2 settled
    keys = np.empty(n)
    items = np.empty(n, dtype=np.int64)
    si, sj, sk = 0, 0, 0
    if stop >= 0:
        si, sj, sk = stop // (ny * nz), (stop // nz) % ny, stop % nz
    cost[goal] = 0.0
    size = heap_lower(keys, items, pos, 0, 0.0, goal)
    while size > 0:
        v = items[0]
        size = heap_pop(keys, items, pos, size)
        if v == stop:
            break
        c = cost[v]
        i = v // (ny * nz)
        j = (v // nz) % ny
        k = v % nz
        for m in range(steps.shape[0]):
            a, b, e = i + steps[m, 0], j + steps[m, 1], k + steps[m, 2]
            if a < 0 or a >= nx or b < 0 or b >= ny or e < 0 or e >= nz:
                continue
            w = (a * ny + b) * nz + e
            if not flat[w] or pos[w] == -2:
                continue
            nc = c + lengths[m]
            if nc < cost[w]:
                cost[w] = nc
                h = scale * _octile3(a - si, b - sj, e - sk) if stop >= 0 else 0.0
                size = heap_lower(keys, items, pos, size, nc + h, w)
    return cost.reshape(free.shape)


def cost_to_go(free: np.ndarray, goal: int, stop: int = -1) -> np.ndarray:
    """26-connected costs to voxel ``goal`` (a flat index) over ``free``, in voxel sides; inf where not reached.

    Without ``stop``: a Dijkstra search, every free voxel's exact cost. With ``stop`` (a flat index): an A* search
    toward it that ends once it is settled (see the module doc): ``stop`` and every voxel of every shortest route
    from it hold their exact costs, every other voxel at least its cost (what a descent from ``stop`` needs).
    """
    free = np.ascontiguousarray(free, dtype=np.bool_)
    return _search(free, int(goal), int(stop), STEPS, STEP_LENGTHS, HEURISTIC_SCALE)


@nb.njit(cache=True)
def _descend(cost, s, steps, lengths):
    """``(k, 3)`` voxel indices from ``s`` down ``cost`` to a voxel of cost 0: each step to the neighbour of least
    cost plus step length, the first of equals in ``steps``' order.
    """
    nx, ny, nz = cost.shape
    i, j, k = s[0], s[1], s[2]
    out = np.empty((int(cost[i, j, k]) + 2, 3), dtype=np.int64)  # each step lowers the cost by at least 1
    out[0, 0], out[0, 1], out[0, 2] = i, j, k
    n = 1
    while cost[i, j, k] > 0:
        best, bi, bj, bk = np.inf, -1, -1, -1
        for m in range(steps.shape[0]):
            a, b, e = i + steps[m, 0], j + steps[m, 1], k + steps[m, 2]
            if a < 0 or a >= nx or b < 0 or b >= ny or e < 0 or e >= nz:
                continue
            t = cost[a, b, e] + lengths[m]
            if t < best:
                best, bi, bj, bk = t, a, b, e
        if n == out.shape[0]:
            raise RuntimeError("the route's descent did not fall by a voxel side a step")
        i, j, k = bi, bj, bk
        out[n, 0], out[n, 1], out[n, 2] = i, j, k
        n += 1
    return out[:n]


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
    path = _descend(cost, np.asarray(s, dtype=np.int64), STEPS, STEP_LENGTHS)
    centres = low + (path + 0.5) * cell
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

    # every interior point at once: its candidates in ``offsets``' order, those along the route masked out
    k = len(route)
    inner = np.arange(1, k - 1)
    chords = route[np.minimum(inner + 2, k - 1)] - route[np.maximum(inner - 2, 0)]
    across = np.stack([np.abs(offsets @ (ch / max(float(np.linalg.norm(ch)), 1e-12))) <= 0.5 for ch in chords])
    v = np.clip(np.floor((route[inner] - low) / cell).astype(np.int64), 0, shape - 1)
    cand = low + (np.clip(v[:, None, :] + offsets[None], 0, shape - 1) + 0.5) * cell
    c = np.full(across.shape, -np.inf)
    c[across] = world.workspace_clearance(cand[across])
    best = np.argmax(c, axis=1)  # the first of equals, as over the masked candidates alone
    gain = c[np.arange(len(inner)), best] > world.workspace_clearance(route[inner])
    out = route.copy()
    out[inner[gain]] = cand[np.flatnonzero(gain), best[gain]]
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
