"""Following a cost-to-go field: progress of a tree on it, targets down it, and costs of frontier cells.

Shared by the privileged expert (``learning.references.expert``, the grid search's exact field) and the learned
route sampler (``learning.samplers.route``, a predicted field); nothing here searches the map.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from planners import OccupancyGrid, Problem
from planners.guidance.frontier import frontier_shape
from planners.kernels.geometry import grid_segment_free

#: The length of a diagonal move, in cells.
SQRT2 = math.sqrt(2.0)
#: ``lowest_unvisited``'s visits when none are excluded.
NO_VISITS = np.empty(0, dtype=np.int64)


#: Walks whose buffer holds more cells than this look their visits up in a hash set (``walk_path``): a scan of
#: the cells walked so far costs as much as a set's lookup for a few dozen of them, and grows with the walk.
SCAN_VISITS = 64


@nb.njit(cache=True, inline="always")
def _hashed(table, u):
    """The slot of ``table`` (power-of-two long; -1: empty) holding cell ``u``, or the empty one where it would go."""
    mask = table.shape[0] - 1
    i = (u * 2654435761) & mask  # Knuth's multiplicative hash; open addressing, linear probing
    while table[i] != -1 and table[i] != u:
        i = (i + 1) & mask
    return i


@nb.njit(cache=True)
def _add_visit(table, filled, u):
    """``table`` with cell ``u`` added (doubled and rehashed when half full); returns the table and its count."""
    if 2 * (filled + 1) > table.shape[0]:
        bigger = np.full(2 * table.shape[0], -1, np.int64)
        for v in table:
            if v != -1:
                bigger[_hashed(bigger, v)] = v
        table = bigger
    i = _hashed(table, u)
    if table[i] == -1:
        table[i] = u
        filled += 1
    return table, filled


@nb.njit(cache=True, inline="always")
def octile_move(blocked, r, c, dr, dc):
    """The flat index of the free cell one move (dr, dc) from (r, c), or -1: off the map, blocked, no move, or a
    diagonal that cuts a blocked corner.
    """
    H, W = blocked.shape
    rr, cc = r + dr, c + dc
    if (dr == 0 and dc == 0) or rr < 0 or rr >= H or cc < 0 or cc >= W or blocked[rr, cc]:
        return -1
    if dr != 0 and dc != 0 and (blocked[r + dr, c] or blocked[r, c + dc]):
        return -1
    return rr * W + cc


@nb.njit(cache=True, inline="always")
def lowest_unvisited(field, blocked, r, c, visited, moves):
    """The lowest free neighbour of (r, c) not among ``visited[:moves]``, first in row-major order on ties.

    Octile moves with no corner cutting; -1 where there is none. It runs in RRT's loop at every walk: its neighbour
    test is written out here (through ``octile_move`` the same walks took twice as long).
    """
    H, W = field.shape
    best = np.inf
    out = -1
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            rr, cc = r + dr, c + dc
            if (dr == 0 and dc == 0) or rr < 0 or rr >= H or cc < 0 or cc >= W or blocked[rr, cc]:
                continue
            if dr != 0 and dc != 0 and (blocked[r + dr, c] or blocked[r, c + dc]):
                continue
            u = rr * W + cc
            seen = False
            for i in range(moves):
                if visited[i] == u:
                    seen = True
                    break
            if not seen and field[rr, cc] < best:
                best = field[rr, cc]
                out = u
    return out


@nb.njit(cache=True, inline="always")
def lowest_unhashed(field, blocked, r, c, table):
    """``lowest_unvisited`` with the visits in a hash set (``_add_visit``): each looked up in constant time."""
    W = field.shape[1]
    best = np.inf
    out = -1
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            u = octile_move(blocked, r, c, dr, dc)
            if u >= 0 and table[_hashed(table, u)] != u and field[u // W, u % W] < best:
                best = field[u // W, u % W]
                out = u
    return out


@nb.njit(cache=True, inline="always")
def next_cell(field, blocked, r, c):
    """The neighbour of cell (r, c) one octile step down ``field`` (flat index; -1 where none).

    The lowest free neighbour that is strictly lower, first in row-major order on ties, with no
    corner cutting; none from a cell whose cost is infinite.
    """
    if not np.isfinite(field[r, c]):
        return -1
    u = lowest_unvisited(field, blocked, r, c, NO_VISITS, 0)
    W = field.shape[1]
    return u if u >= 0 and field[u // W, u % W] < field[r, c] else -1


@nb.njit(cache=True)
def walk_field(field, blocked, cell, length, tolerance=0.0, growth=0.0):
    """Walk down ``field`` from ``cell`` for ``length`` cells of path; returns the cell reached.

    With ``tolerance`` 0 each move is ``next_cell``'s: to the lowest neighbour, while it is strictly lower.
    A learned field has shallow pits (ripples) where that walk stops short of the route; with a
    ``tolerance`` > 0 the walk moves to the lowest free neighbour it has not yet visited, and goes on
    while that neighbour is below ``low + tolerance + growth * max(low, 0)``, ``low`` the lowest value the
    walk has reached: it crosses ripples shallower than that and stops in deeper pits (a learned field's
    ripples deepen with the cost-to-go; ``growth`` lets the tolerance follow). On a field where every cell
    but the goal has a strictly lower neighbour (the grid search's) the two walks are the same.

    Each move is found when taken: a query walks a few moves at a time, far fewer than the map has cells.
    ``walk_path`` is the same walk with its cells kept in a buffer of the caller's.
    """
    visited = np.empty(int(length) + 2, np.int64)
    return visited[walk_path(field, blocked, cell, length, tolerance, growth, visited) - 1]


@nb.njit(cache=True)
def walk_path(field, blocked, cell, length, tolerance, growth, visited):
    """``walk_field``'s walk, its cells in order (``cell`` first) kept in ``visited``; the number of cells.

    ``visited`` should be at least ``int(length) + 2`` long (a shorter one ends the walk after
    ``len(visited) - 1`` moves). A walk with room for more than ``SCAN_VISITS`` cells keeps its visits in a hash
    set as well (``_walk_hashed``), so a walk over the whole map costs in proportion to its length, not its square;
    a shorter one (RRT's, each iteration) scans them, as this loop does.
    """
    W = field.shape[1]
    strict = tolerance <= 0.0 and growth <= 0.0
    acc = 0.0
    v = cell
    low = field[v // W, v % W]
    visited[0] = v
    moves = 1
    if not np.isfinite(low):
        return moves
    if not strict and visited.shape[0] > SCAN_VISITS:
        return _walk_hashed(field, blocked, low, length, tolerance, growth, visited)
    while acc < length and moves < visited.shape[0]:
        if strict:
            u = next_cell(field, blocked, v // W, v % W)
        else:
            u = lowest_unvisited(field, blocked, v // W, v % W, visited, moves)
            if u >= 0 and field[u // W, u % W] >= low + tolerance + growth * max(low, 0.0):
                u = -1
        if u < 0:
            break
        dr = u // W - v // W
        dc = u % W - v % W
        acc += math.sqrt(float(dr * dr + dc * dc))
        v = u
        visited[moves] = v  # each move covers at least one cell of path: int(length) + 2 entries suffice
        moves += 1
        low = min(low, field[v // W, v % W])
    return moves


@nb.njit(cache=True)
def _walk_hashed(field, blocked, low, length, tolerance, growth, visited):
    """``walk_path``'s tolerant walk on from ``visited[0]`` (its value ``low``), its visits also in a hash set
    (``_add_visit``), each looked up in constant time; the number of cells.
    """
    W = field.shape[1]
    acc = 0.0
    v = visited[0]
    moves = 1
    table, filled = _add_visit(np.full(256, -1, np.int64), 0, v)
    while acc < length and moves < visited.shape[0]:
        u = lowest_unhashed(field, blocked, v // W, v % W, table)
        if u < 0 or field[u // W, u % W] >= low + tolerance + growth * max(low, 0.0):
            break
        dr = u // W - v // W
        dc = u % W - v % W
        acc += math.sqrt(float(dr * dr + dc * dc))
        v = u
        visited[moves] = v
        moves += 1
        table, filled = _add_visit(table, filled, v)
        low = min(low, field[v // W, v % W])
    return moves


@nb.njit(cache=True)
def last_in_sight(blocked, path, moves):
    """The last cell of ``path[:moves]`` before the path first leaves the sight of its first cell's centre.

    The end itself where the straight segment between the two centres meets no blocked cell; otherwise
    the cell before the first one out of sight (``planners.kernels.geometry.grid_segment_free``).
    """
    W = blocked.shape[1]
    x0, y0 = path[0] % W + 0.5, path[0] // W + 0.5
    end = path[moves - 1]
    if grid_segment_free(blocked, 1.0, x0, y0, end % W + 0.5, end // W + 0.5):
        return end
    for i in range(1, moves):
        u = path[i]
        if not grid_segment_free(blocked, 1.0, x0, y0, u % W + 0.5, u // W + 0.5):
            return path[i - 1]
    return end


@nb.njit(cache=True)
def path_field(blocked, path, moves):
    """A cost to ``path[0]`` of every cell by way of ``path[:moves]`` (a walk: octile moves, no cell twice), in cells.

    On the path, the length of the path up to the cell; off it, that of the path cell a breadth-first search from
    all of the path's cells (octile moves, no corner cutting; a cell's straight neighbours before its diagonal ones)
    reaches it from, plus the lengths of the moves from there. It falls along the path towards its first cell and
    away from the path everywhere else, so a walk down it joins the path and follows it back. Infinite at blocked
    cells and cells the path's component does not hold. One pass over the map's cells: about 10 ns a cell.
    """
    H, W = blocked.shape
    wall = blocked.ravel()
    out = np.full(H * W, np.inf)
    queue = np.empty(H * W, np.int64)
    tail = 0
    s = 0.0
    for i in range(moves):
        u = path[i]
        if i:
            v = path[i - 1]
            dr, dc = u // W - v // W, u % W - v % W
            s += math.sqrt(float(dr * dr + dc * dc))
        if out[u] == np.inf:
            out[u] = s
            queue[tail] = u
            tail += 1
    head = 0
    # each neighbour written out: a loop over the eight moves takes three times as long
    while head < tail:
        v = queue[head]
        head += 1
        r = v // W
        c = v - r * W
        x = out[v]
        up = r > 0 and not wall[v - W]
        down = r < H - 1 and not wall[v + W]
        left = c > 0 and not wall[v - 1]
        right = c < W - 1 and not wall[v + 1]
        if up and out[v - W] == np.inf:
            out[v - W] = x + 1.0
            queue[tail] = v - W
            tail += 1
        if down and out[v + W] == np.inf:
            out[v + W] = x + 1.0
            queue[tail] = v + W
            tail += 1
        if left and out[v - 1] == np.inf:
            out[v - 1] = x + 1.0
            queue[tail] = v - 1
            tail += 1
        if right and out[v + 1] == np.inf:
            out[v + 1] = x + 1.0
            queue[tail] = v + 1
            tail += 1
        if up and left and not wall[v - W - 1] and out[v - W - 1] == np.inf:
            out[v - W - 1] = x + SQRT2
            queue[tail] = v - W - 1
            tail += 1
        if up and right and not wall[v - W + 1] and out[v - W + 1] == np.inf:
            out[v - W + 1] = x + SQRT2
            queue[tail] = v - W + 1
            tail += 1
        if down and left and not wall[v + W - 1] and out[v + W - 1] == np.inf:
            out[v + W - 1] = x + SQRT2
            queue[tail] = v + W - 1
            tail += 1
        if down and right and not wall[v + W + 1] and out[v + W + 1] == np.inf:
            out[v + W + 1] = x + SQRT2
            queue[tail] = v + W + 1
            tail += 1
    return out.reshape(H, W)


@nb.njit(cache=True)
def lowest_vertex_cell(field, vertices, res, origin, best, best_cell):
    """The lower of ``best`` and the field at the cells of ``vertices``, with its flat cell index."""
    W = field.shape[1]
    for i in range(vertices.shape[0]):
        r = int((vertices[i, 1] - origin[1]) / res)
        c = int((vertices[i, 0] - origin[0]) / res)
        d = field[r, c]
        if d < best:
            best = d
            best_cell = r * W + c
    return best, best_cell


class FieldFollower:
    """Tracks the tree's progress on a cost-to-go field and proposes targets ahead of it, down the field.

    Progress is the tree vertex in the cell of lowest cost; the target lies ``lookahead`` steps
    further along the field's steepest descent (octile moves, no corner cutting). The field may be
    exact (the expert's grid search, ``learning.references.expert``) or learned (``learning.samplers.route``).

    Args:
        problem: An ``OccupancyGrid`` problem.
        step_size: The planner's step.
        field: Cost-to-go per grid cell, inf where blocked.
        lookahead: How far ahead of the progress vertex the target lies, in steps.
    """

    def __init__(self, problem: Problem, step_size: float, field: np.ndarray, lookahead: float = 1.0) -> None:
        grid = problem.world
        if not isinstance(grid, OccupancyGrid):
            raise TypeError("following a cost-to-go field needs an OccupancyGrid problem")
        if np.shape(field) != grid.shape:
            raise ValueError(f"the field has shape {np.shape(field)}, the map {grid.shape}")
        self.problem, self.step, self.lookahead = problem, float(step_size), float(lookahead)
        self.res = grid.resolution
        self.origin = np.ascontiguousarray(grid.origin, dtype=np.float64)
        self.field = np.ascontiguousarray(field, dtype=np.float64)
        self.blocked = grid.kernel.grid
        self.W = grid.width
        self.seen = 0
        r, c = grid.cell_of(problem.start)
        self.best, self.best_cell = float(self.field[r, c]), r * self.W + c

    def update(self, vertices: np.ndarray, num_vertices: int) -> None:
        if num_vertices > self.seen:
            self.best, self.best_cell = lowest_vertex_cell(self.field,
                                                           np.ascontiguousarray(vertices[self.seen:num_vertices]),
                                                           self.res, self.origin, self.best, self.best_cell)
            self.seen = num_vertices

    def target(self, scale: float = 1.0) -> np.ndarray:
        """World point ``scale * lookahead`` steps ahead of the progress vertex along the shortest path."""
        v = walk_field(self.field, self.blocked, self.best_cell, self.lookahead * scale * self.step / self.res)
        return self.origin + np.array([(v % self.W + 0.5) * self.res, (v // self.W + 0.5) * self.res])


def frontier_costs(field: np.ndarray, grid: OccupancyGrid, cell: float, *, times: float = 1.0, over: float = 1.0,
                   blocked: np.ndarray | None = None) -> np.ndarray:
    """Cost-to-go of each frontier cell (flat, in frontier cells) read from a per-grid-cell ``field`` (in cells).

    ``cell`` is the frontier's cell width (``planners.guidance.frontier.Frontier``). A frontier cell's
    cost is the field at its centre cell (the frontier checks that it is free), or the block's best
    cell where the centre has none; 1e9 where neither has one. The field is read as ``field * times / over``, ``inf``
    where ``blocked`` (a grid-shaped mask; None: none): a field in other units, read without a converted copy.
    """
    H, W = frontier_shape(grid, cell)
    k = max(1, int(round(cell / grid.resolution)))  # grid cells per frontier cell
    out = np.empty(H * W)
    mask = np.zeros((0, 0), dtype=np.bool_) if blocked is None else np.ascontiguousarray(blocked, dtype=np.bool_)
    _frontier_costs(np.ascontiguousarray(field, dtype=np.float64), H, W, k, float(grid.resolution), float(cell), out,
                    float(times), float(over), mask)
    return out


@nb.njit(cache=True)
def _frontier_costs(field, H, W, k, res, cell, out, times, over, blocked):
    """``frontier_costs``' values: each frontier cell's centre, else its block's least (``inf`` off the field)."""
    h, w = field.shape
    masked = blocked.shape[0] > 0
    for R in range(H):
        for C in range(W):
            r, c = R * k + k // 2, C * k + k // 2
            v = np.inf
            if r < h and c < w and not (masked and blocked[r, c]):
                v = field[r, c] * times / over
            if not np.isfinite(v):
                v = np.inf
                for i in range(R * k, min(h, R * k + k)):
                    for j in range(C * k, min(w, C * k + k)):
                        if not (masked and blocked[i, j]):
                            v = min(v, field[i, j] * times / over)
            cost = v * res / cell
            out[R * W + C] = cost if np.isfinite(cost) else 1e9
