"""The privileged expert: sample just ahead of the tree's progress along the shortest path.

It knows the map's geodesic distance field (a grid search), so it is a reference and a teacher,
never a competitor: at inference the learned policy sees only its observation.

Progress is the tree vertex with the smallest geodesic distance to the goal; the expert's target is
the point ``lookahead`` steps further along the shortest path from that vertex (found by steepest
descent of the distance field), and samples scatter around it with a spread of ``sigma`` steps.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from learning.ablation import ConstantGuidedSampler
from planners import OccupancyGrid, Problem, SamplerBase
from planners.maps.gridsearch import distance_field


@nb.njit(cache=True)
def _descent(field, blocked):
    """For every cell, the neighbour one octile step closer to the goal (-1 where none)."""
    H, W = field.shape
    nxt = np.full((H, W), -1, dtype=np.int64)
    for r in range(H):
        for c in range(W):
            best = field[r, c]
            if not np.isfinite(best):
                continue
            for dr in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    rr, cc = r + dr, c + dc
                    if (dr == 0 and dc == 0) or rr < 0 or rr >= H or cc < 0 or cc >= W or blocked[rr, cc]:
                        continue
                    if dr != 0 and dc != 0 and (blocked[r + dr, c] or blocked[r, c + dc]):
                        continue
                    if field[rr, cc] < best:
                        best = field[rr, cc]
                        nxt[r, c] = rr * W + cc
    return nxt


@nb.njit(cache=True)
def _walk(nxt, W, cell, length):
    """Follow the descent for ``length`` cells of path from ``cell``; returns the cell reached."""
    acc = 0.0
    v = cell
    while acc < length:
        u = nxt[v // W, v % W]
        if u < 0:
            break
        dr = u // W - v // W
        dc = u % W - v % W
        acc += math.sqrt(float(dr * dr + dc * dc))
        v = u
    return v


@nb.njit(cache=True)
def _best_cell(field, vertices, res, origin, best, best_cell):
    W = field.shape[1]
    for i in range(vertices.shape[0]):
        r = int((vertices[i, 1] - origin[1]) / res)
        c = int((vertices[i, 0] - origin[0]) / res)
        d = field[r, c]
        if d < best:
            best = d
            best_cell = r * W + c
    return best, best_cell


class GeodesicExpert:
    """Tracks the tree's geodesic progress and proposes targets ahead of it.

    Args:
        problem: An ``OccupancyGrid`` problem.
        step_size: The planner's step.
        lookahead: How far ahead of the progress vertex the target lies, in steps.
    """

    def __init__(self, problem: Problem, step_size: float, lookahead: float = 1.0) -> None:
        grid = problem.world
        if not isinstance(grid, OccupancyGrid):
            raise TypeError("the geodesic expert needs an OccupancyGrid problem")
        self.problem, self.step, self.lookahead = problem, float(step_size), float(lookahead)
        self.res = grid.resolution
        self.origin = np.ascontiguousarray(grid.origin, dtype=np.float64)
        self.field = distance_field(grid.obstacles, grid.cell_of(problem.goal))
        self.nxt = _descent(self.field, np.ascontiguousarray(grid.obstacles))
        self.W = grid.width
        self.seen = 0
        r, c = grid.cell_of(problem.start)
        self.best, self.best_cell = float(self.field[r, c]), r * self.W + c

    def update(self, vertices: np.ndarray, num_vertices: int) -> None:
        if num_vertices > self.seen:
            self.best, self.best_cell = _best_cell(self.field, np.ascontiguousarray(vertices[self.seen:num_vertices]),
                                                   self.res, self.origin, self.best, self.best_cell)
            self.seen = num_vertices

    def target(self, scale: float = 1.0) -> np.ndarray:
        """World point ``scale * lookahead`` steps ahead of the progress vertex along the shortest path."""
        v = _walk(self.nxt, self.W, self.best_cell, self.lookahead * scale * self.step / self.res)
        return self.origin + np.array([(v % self.W + 0.5) * self.res, (v // self.W + 0.5) * self.res])


class ExpertSampler(SamplerBase):
    """The privileged expert as a ``Sampler`` (reference only: it runs a grid search).

    Args:
        step_size: The planner's step.
        lookahead: Target distance ahead of the progress vertex, in steps (jittered by 0.5-1.5x).
        sigma: Spread around the target, in steps.
    """

    def __init__(self, step_size: float = 4.0, lookahead: float = 1.0, sigma: float = 0.5) -> None:
        self.step_size, self.lookahead, self.sigma = float(step_size), float(lookahead), float(sigma)

    def _setup(self) -> None:
        self._expert = GeodesicExpert(self.problem, self.step_size, self.lookahead)

    def draw(self, rng, n, view):
        self._expert.update(view.vertices, view.num_vertices)
        q = self._expert.target(rng.uniform(0.5, 1.5)) + rng.normal(0.0, self.sigma * self.step_size, 2)
        return np.clip(q, self.low, np.nextafter(self.high, self.low))[None, :]

    def __repr__(self) -> str:
        return f"ExpertSampler(lookahead={self.lookahead:g}, sigma={self.sigma:g})"


class GeodesicFrontierSampler(ConstantGuidedSampler):
    """The ablation with route knowledge in its frontier: a reference, not a competitor (it runs a grid search).

    It draws the constant ablation's classes (``learning.ablation``), but its frontier prefers cells
    by their geodesic distance to the goal instead of the straight-line one: what the frontier class
    could do if a network knew the cost-to-go of every cell exactly. ``scripts/imitation_ceiling.py``
    reports it beside the expert.

    Args:
        frontier: Probability of the frontier class; the rest goes to the cell straight ahead.
        step_size: The planner's step.
    """

    def __init__(self, frontier: float = 0.7, *, step_size: float = 4.0) -> None:
        super().__init__(frontier, step_size=step_size)

    def _setup(self) -> None:
        super()._setup()
        grid, f = self.problem.world, self.guide.frontier
        field = distance_field(grid.obstacles, grid.cell_of(self.problem.goal))
        k = max(1, int(round(f.cell / grid.resolution)))  # grid cells per frontier cell
        padded = np.full((f.H * k, f.W * k), np.inf)
        h, w = min(field.shape[0], f.H * k), min(field.shape[1], f.W * k)
        padded[:h, :w] = field[:h, :w]
        blocks = padded.reshape(f.H, k, f.W, k)
        centre = blocks[:, k // 2, :, k // 2]
        # a frontier cell's centre is free (the frontier checks it), so its grid cell has a distance
        # unless the goal cannot be reached from it; the block's best cell stands in then
        cost = np.where(np.isfinite(centre), centre, blocks.min((1, 3))) * grid.resolution / f.cell
        self._cost = np.where(np.isfinite(cost), cost, 1e9).reshape(-1)

    def draw(self, rng, n, view):
        f = self.guide.frontier
        f.update(view.vertices, view.num_vertices)
        cells = f.front[:len(f)]
        f.dist[cells] = self._cost[cells]  # the frontier draws by these weights from now on
        return super().draw(rng, n, view)

    def __repr__(self) -> str:
        return f"GeodesicFrontierSampler(frontier={self.frontier:g})"
