"""The tree's exploration frontier: free cells next to the tree that the tree does not cover yet.

A sample inside a frontier cell is nearest to a tree vertex that can see it, so its extension grows
the tree into unexplored free space instead of into a wall, which is where uniform sampling wastes
most of its iterations in mazes and rooms. The frontier is built only from the map and the tree
(the observation), never from a search towards the goal.

Cells are ``cell`` world units wide (one planner step by default). A cell is covered once it holds
a vertex; an uncovered cell whose centre is free joins the frontier when a vertex in a neighbouring
cell can reach its centre with a collision-free motion. Updates are incremental and compiled.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from planners import OccupancyGrid, Problem
from planners.kernels.geometry import GRID_EPS, grid_segment_free


@nb.njit(cache=True, inline="always")
def cdf_search(cdf, n, t):
    """Index of the first of ``cdf[:n]`` (non-decreasing) that is >= ``t`` (the last if none is)."""
    lo, hi = 0, n - 1
    while lo < hi:
        mid = (lo + hi) // 2
        if cdf[mid] < t:
            lo = mid + 1
        else:
            hi = mid
    return lo


@nb.njit(cache=True)
def column_counts(grid):
    """``out[r, c]``: blocked cells among rows ``0 .. r - 1`` of column ``c``, modulo 2**16.

    A box's blocked count is then a difference per column; modulo 2**16 it stays exact for any box
    under 65536 cells, and half the bytes of int32 keep the table in L1 next to the grid.
    """
    H, W = grid.shape
    out = np.empty((H + 1, W), dtype=np.uint16)
    out[0, :] = 0
    for r in range(H):
        for c in range(W):  # whole rows: vectorised
            out[r + 1, c] = out[r, c] + grid[r, c]  # wraps modulo 2**16
    return out


@nb.njit(cache=True, inline="always")
def _box_clear(grid, inv, counts, a, b):
    """True when no cell that ``grid_segment_free(grid, inv, ...)`` may read for the segment a-b is blocked.

    Those cells lie in the segment's bounding box as the traversal rounds it; one cell of margin
    covers rounding in its slab arithmetic. False also means "cannot tell" (the box leaves the grid).
    """
    H, W = grid.shape
    c_lo = int(math.ceil(min(a[0], b[0]) * inv - GRID_EPS)) - 1
    c_hi = int(math.floor(max(a[0], b[0]) * inv + GRID_EPS))
    r_lo = int(math.ceil(min(a[1], b[1]) * inv - GRID_EPS)) - 1
    r_hi = int(math.floor(max(a[1], b[1]) * inv + GRID_EPS))
    if c_lo < 0 or c_hi >= W or r_lo < 0 or r_hi >= H:
        return False
    c_lo = max(c_lo - 1, 0)
    c_hi = min(c_hi + 1, W - 1)
    r_lo = max(r_lo - 1, 0)
    r_hi = min(r_hi + 1, H - 1)
    blocked = 0
    for c in range(c_lo, c_hi + 1):
        blocked += (counts[r_hi + 1, c] - counts[r_lo, c]) & 0xFFFF
    return blocked == 0


# states of a cell centre in ``Frontier.free``: checked lazily, when a vertex first sees the cell
UNKNOWN, FREE, BLOCKED = 0, 1, 2
#: ``update_frontier``'s ``cost`` for ranking by the straight-line distance to the goal.
NO_COST = np.empty(0)


@nb.njit(cache=True)
def update_frontier(world, counts, vertices, cell, goal, free, cov, pos, front, dist, count, cost):
    """Mark new vertices' cells covered and add their visible uncovered neighbours; returns count.

    A cell's centre is checked, and its distance to the goal (in cells) computed, only when a vertex
    first looks at it: a solve that stays in one part of the map never pays for the rest. That
    distance is the straight line, or ``cost`` (per frontier cell, in cells) when it is not empty: a
    cost-to-go from elsewhere ranks the frontier instead. Vertices and
    goal are world points; cells are counted from the grid's corner (``world.params[1:3]``, a ROS map's
    origin), in whose frame the grid's collision checks work.
    """
    H, W = cov.shape
    grid = world.grid
    inv = world.params[0]
    ox, oy = world.params[1], world.params[2]
    gx, gy = goal[0] - ox, goal[1] - oy
    c_state = np.empty(2)
    v = np.empty(2)
    for n in range(vertices.shape[0]):
        v[0] = vertices[n, 0] - ox
        v[1] = vertices[n, 1] - oy
        r = int(v[1] / cell)
        c = int(v[0] / cell)
        if r < 0 or r >= H or c < 0 or c >= W:
            continue
        if not cov[r, c]:
            cov[r, c] = True
            p = pos[r, c]
            if p >= 0:  # swap-remove from the frontier list
                last = front[count - 1]
                front[p] = last
                pos[last // W, last % W] = p
                pos[r, c] = -1
                count -= 1
        for k in range(9):  # a loop, not tuples: numba unrolls tuple loops, nine copies of the checks
            rr = r + k // 3 - 1
            cc = c + k % 3 - 1
            if rr < 0 or rr >= H or cc < 0 or cc >= W:
                continue
            if cov[rr, cc] or pos[rr, cc] >= 0 or free[rr, cc] == BLOCKED:
                continue
            c_state[0] = (cc + 0.5) * cell
            c_state[1] = (rr + 0.5) * cell
            if free[rr, cc] == UNKNOWN:
                # the box test, else the traversal; spelled out here: behind a helper function (inlined
                # or not) the update ran 2x slower
                if not (_box_clear(grid, inv, counts, c_state, c_state)
                        or grid_segment_free(grid, inv, c_state[0], c_state[1], c_state[0], c_state[1])):
                    free[rr, cc] = BLOCKED
                    continue
                free[rr, cc] = FREE
                if cost.shape[0] > 0:
                    dist[rr * W + cc] = cost[rr * W + cc]
                else:
                    dx = c_state[0] - gx
                    dy = c_state[1] - gy
                    dist[rr * W + cc] = math.sqrt(dx * dx + dy * dy) / cell  # not ** 2: numba calls pow for that
            if (_box_clear(grid, inv, counts, v, c_state)
                    or grid_segment_free(grid, inv, v[0], v[1], c_state[0], c_state[1])):
                front[count] = rr * W + cc
                pos[rr, cc] = count
                count += 1
    return count


@nb.njit(cache=True, inline="always")
def frontier_dmin(front, count, dist):
    """The lowest distance ``d_min`` of the frontier's ``count`` cells, against which their weights are taken."""
    dmin = np.inf
    for i in range(count):
        d = dist[front[i]]
        if d < dmin:
            dmin = d
    return dmin


@nb.njit(cache=True, inline="always")
def frontier_cdf(front, count, dist, tau, cdf):
    """Running sum into ``cdf`` of the frontier cells' weights exp(-(d - d_min) / tau); return the total."""
    dmin = frontier_dmin(front, count, dist)
    acc = 0.0
    for i in range(count):
        acc += math.exp(-(dist[front[i]] - dmin) / tau)
        cdf[i] = acc
    return acc


def frontier_memo(capacity: int) -> tuple:
    """What ``frontier_sample`` keeps between calls for a frontier of up to ``capacity`` cells.

    ``(weights, cells, cdf, meta)``: each list entry's weight and the cell it was computed for, the running sum,
    and (the distance the weights are taken from, entries valid). Allocated, not written: a page is touched only
    once the frontier reaches it.
    """
    return np.empty(capacity), np.empty(capacity, dtype=np.int64), np.empty(capacity), np.array([np.nan, 0.0])


#: How far the frontier's lowest distance may fall below (``BELOW``) or rise above (``ABOVE``) the distance its kept
#: weights are taken from, in units of ``tau``, before ``frontier_sample`` takes them all again from the lowest one:
#: a weight stays below e^600 (1e7 of them sum to under 1e268) and the best one above e^-64.
REBASE_BELOW, REBASE_ABOVE = 600.0, 64.0


@nb.njit(cache=True)
def frontier_sample(front, count, W, cell, origin, dist, tau, u_pick, u_xy, out, memo):
    """Frontier cells drawn with weight exp(-(d - d_min) / tau), a uniform (world) point in each.

    ``memo`` (``frontier_memo``) keeps the weights and their running sum between calls. The weights are taken from a
    reference distance ``r`` rather than from ``d_min`` itself, exp(-(d - r) / tau): the same weights up to a common
    factor, so the same distribution. ``r`` is ``d_min`` when they are all taken, and stays while ``d_min`` moves
    less than ``REBASE_BELOW`` taus below it and ``REBASE_ABOVE`` above: a tree that gains on the goal lowers
    ``d_min`` at most of its steps, and taking every weight again at each would be most of a draw (a frontier of
    grid cells holds thousands). While ``r`` stands, the sum up to the first entry whose cell changed stands, and an
    entry whose cell is the one of the last call keeps its weight, so a call computes the exponentials of the
    entries that changed only; the sum adds the same values in the same order as a fresh memo with the same ``r``:
    the same samples, bit for bit. Against weights taken from ``d_min`` itself the running sums differ in their last
    bits, and a draw differs only where its uniform falls that close to the boundary between two cells. A
    frontier's cell keeps its distance once it has one.
    """
    if count == 0:
        return 0
    weights, cells, cdf, meta = memo
    dmin = frontier_dmin(front, count, dist)
    ref, valid = meta[0], min(int(meta[1]), count)
    if not (ref - REBASE_BELOW * tau <= dmin <= ref + REBASE_ABOVE * tau):  # (a fresh memo's reference is NaN)
        ref, valid = dmin, 0
    start = 0  # the running sum up to the first entry that changed stands
    while start < valid and cells[start] == front[start]:
        start += 1
    acc = cdf[start - 1] if start > 0 else 0.0
    for i in range(start, count):
        c = front[i]
        if i >= valid or cells[i] != c:
            weights[i] = math.exp(-(dist[c] - ref) / tau)
            cells[i] = c
        acc += weights[i]
        cdf[i] = acc
    meta[0], meta[1] = ref, count
    for k in range(u_pick.shape[0]):
        f = front[cdf_search(cdf, count, u_pick[k] * acc)]
        out[k, 0] = origin[0] + (f % W + u_xy[k, 0]) * cell
        out[k, 1] = origin[1] + (f // W + u_xy[k, 1]) * cell
    return u_pick.shape[0]


def frontier_shape(grid: OccupancyGrid, cell: float) -> tuple[int, int]:
    """Rows and columns of the frontier's cells of width ``cell`` over ``grid``."""
    lo, hi = grid.bounds
    return max(1, int(math.ceil((hi[1] - lo[1]) / cell))), max(1, int(math.ceil((hi[0] - lo[0]) / cell)))


@nb.njit(cache=True)
def frontier_arrays(obstacles, H, W):
    """A new frontier's state for ``H x W`` cells over the 0/1 grid ``obstacles``, in one compiled call.

    ``(counts, free, cov, pos, front, dist)``: the grid's ``column_counts`` (most visibility checks
    become a box sum), each cell's centre UNKNOWN / FREE / BLOCKED, covered flags, each cell's index
    in the frontier list (-1: not in it), the list, and goal distances (in cells, set when a cell is
    first checked).
    """
    pos = np.empty((H, W), dtype=np.int64)
    pos[:] = -1
    return (column_counts(obstacles), np.zeros((H, W), dtype=np.uint8), np.zeros((H, W), dtype=np.bool_), pos,
            np.empty(H * W, dtype=np.int64), np.empty(H * W))


class Frontier:
    """Incremental frontier of a tree on a 2-D grid map.

    Args:
        problem: An ``OccupancyGrid`` problem (its grid does the visibility checks).
        cell: Cell width in world units (e.g. the planner's step).
        tau: Temperature of the goal preference, in cells: frontier cells closer to the goal are
            drawn more often (``tau -> inf``: uniform over the frontier).
        cost: Cost-to-go of every frontier cell (flat, ``H * W``, in cells) to rank by instead of the
            straight-line distance to the goal.
    """

    def __init__(self, problem: Problem, cell: float, tau: float = 1.0, cost: np.ndarray | None = None) -> None:
        if not isinstance(problem.world, OccupancyGrid):
            raise TypeError("the frontier is defined on OccupancyGrid problems")
        if not (math.isfinite(cell) and cell > 0 and math.isfinite(tau) and tau > 0):
            raise ValueError(f"cell and tau must be positive, got {cell}, {tau}")
        self.cell, self.tau = float(cell), float(tau)
        self.H, self.W = frontier_shape(problem.world, self.cell)
        self.world = problem.world.kernel
        self.goal = np.ascontiguousarray(problem.goal[:2], dtype=np.float64)
        self.counts, self.free, self.cov, self.pos, self.front, self.dist = frontier_arrays(self.world.grid, self.H,
                                                                                          self.W)
        self.cost = NO_COST if cost is None else np.ascontiguousarray(cost, dtype=np.float64)
        if cost is not None and self.cost.shape != (self.H * self.W,):
            raise ValueError(f"cost must hold one value per frontier cell ({self.H * self.W}), got {self.cost.shape}")
        self.memo = frontier_memo(self.H * self.W)
        self.count = 0
        self.seen = 0

    def update(self, vertices: np.ndarray, num_vertices: int) -> None:
        if num_vertices > self.seen:
            self.count = update_frontier(self.world, self.counts, vertices[self.seen:num_vertices], self.cell,
                                         self.goal, self.free, self.cov, self.pos, self.front, self.dist, self.count,
                                         self.cost)
            self.seen = num_vertices

    def __len__(self) -> int:
        return int(self.count)

    def sample(self, rng: np.random.Generator, m: int) -> np.ndarray:
        """``m`` points in frontier cells (an empty array when the frontier is empty)."""
        u_pick = rng.random(m)
        u_xy = rng.random((m, 2))
        out = np.empty((m, 2))
        k = frontier_sample(self.front, self.count, self.W, self.cell, self.world.params[1:3], self.dist, self.tau,
                            u_pick, u_xy, out, self.memo)
        return out[:k]
