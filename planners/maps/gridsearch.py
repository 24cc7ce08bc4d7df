"""Exact grid searches: octile distance fields, shortest paths, fields over per-move costs, connected components.

Distances are on the 8-connected grid with straight steps of 1 and diagonal steps of sqrt(2), and no
corner cutting: a diagonal step from (r, c) to (r+dr, c+dc) is legal only if (r+dr, c) and (r, c+dc)
are both free. This is the definition behind the MovingAI benchmarks' ``optimal_length``, and it
matches the continuous collision model of ``OccupancyGrid`` (closed cells): two free cells are
mutually reachable in the plane iff they are 4-connected through free cells.

All kernels work on a copy of the map padded with one ring of blocked cells, so neighbour lookups
need no bounds checks and the map edge is a wall, as it is for ``OccupancyGrid``.
"""

from __future__ import annotations

import math
import operator

import numba as nb
import numpy as np

from planners.kernels.heap import heap_lower, heap_pop
from planners.worlds.grid import OccupancyGrid

SQRT2 = math.sqrt(2.0)

#: The 8 neighbour steps, (row, column) offsets: the first four straight, the last four diagonal.
MOVES = ((-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (-1, 1), (1, -1), (1, 1))
_DR = np.array([dr for dr, _ in MOVES], dtype=np.int64)
_DC = np.array([dc for _, dc in MOVES], dtype=np.int64)


# --- input checks -------------------------------------------------------------------------------


def _as_obstacles(obstacles) -> np.ndarray:
    """The map as a non-empty 2-D bool array, or a ValueError naming what was wrong."""
    arr = np.asarray(obstacles)
    if arr.ndim != 2 or arr.size == 0:
        raise ValueError(f"obstacles must be a non-empty 2-D (H, W) bool array, got shape {arr.shape}")
    if arr.dtype != np.bool_:
        raise ValueError(f"obstacles must be a bool array (True = obstacle), got dtype {arr.dtype}")
    return arr


def _as_cell(cell, obstacles: np.ndarray, label: str) -> tuple[int, int]:
    """``cell`` as an in-range, free (row, col) pair of ints, or a ValueError naming it."""
    try:
        r, c = (operator.index(v) for v in cell)
    except (TypeError, ValueError):
        raise ValueError(f"{label} cell must be a (row, col) pair of integers, got {cell!r}") from None
    H, W = obstacles.shape
    if not (0 <= r < H and 0 <= c < W):
        raise ValueError(f"{label} cell {(r, c)} lies outside the {H}x{W} grid")
    if obstacles[r, c]:
        raise ValueError(f"{label} cell {(r, c)} is blocked")
    return r, c


def _padded(obstacles: np.ndarray) -> np.ndarray:
    return np.pad(obstacles, 1, constant_values=True)


def _grid_cell(grid: OccupancyGrid, point, label: str) -> tuple[int, int]:
    if not isinstance(grid, OccupancyGrid):
        raise TypeError(f"grid must be an OccupancyGrid, got {type(grid).__name__}")
    try:
        cell = grid.cell_of(point)
    except ValueError as exc:
        raise ValueError(f"{label} {point!r}: {exc}") from None
    H, W = grid.shape
    if not (0 <= cell[0] < H and 0 <= cell[1] < W):
        raise ValueError(f"{label} {tuple(np.asarray(point, float).tolist())} lies outside the {H}x{W} grid")
    if grid.obstacles[cell]:
        raise ValueError(f"{label} {tuple(np.asarray(point, float).tolist())} lies in blocked cell {cell}")
    return cell


# --- compiled kernels ---------------------------------------------------------------------------


@nb.njit(cache=True)
def _dijkstra(padded, goal, stop, dr, dc):
    """Octile Dijkstra from flat padded index ``goal``; stops once ``stop`` is settled (-1: never).

    Returns the flat distance array and, per cell, the next cell on a shortest path to the goal.
    Uses an indexed binary heap with decrease-key (``planners.kernels.heap``), so the heap never holds more
    than H*W entries.
    """
    Wp = padded.shape[1]
    n = padded.size
    blocked = padded.ravel()
    dist = np.full(n, np.inf)
    toward = np.full(n, -1, dtype=np.int64)
    pos = np.full(n, -1, dtype=np.int64)  # heap slot; -1 never queued, -2 settled
    keys = np.empty(n)
    items = np.empty(n, dtype=np.int64)
    off = dr * Wp + dc
    dist[goal] = 0.0
    size = heap_lower(keys, items, pos, 0, 0.0, goal)
    while size > 0:
        dv, v = keys[0], items[0]
        size = heap_pop(keys, items, pos, size)
        if v == stop:
            break
        for k in range(8):
            u = v + off[k]
            if blocked[u] or pos[u] == -2:
                continue
            if k >= 4:
                # the step is symmetric, so the same test serves the reverse search from the goal
                if blocked[v + dr[k] * Wp] or blocked[v + dc[k]]:
                    continue
                nd = dv + SQRT2
            else:
                nd = dv + 1.0
            if nd < dist[u]:
                dist[u] = nd
                toward[u] = v
                size = heap_lower(keys, items, pos, size, nd, u)
    return dist, toward


@nb.njit(cache=True)
def _move_cost_dijkstra(costs, goal, walls, unreached, dr, dc, open_moves, most):
    """The least fixed point of ``V(b) = min over moves a of costs[a, b] + V(b + move a)``, ``V = 0`` at ``goal``.

    Dijkstra from the goal blocks over the reversed moves: settling a block relaxes each block that one
    move carries onto it. Sums are formed as ``costs[a, b] + V(n)`` in ``costs``' own precision, the very
    operation (and rounding) of value iteration, so the values are its fixed point bit for bit: every cost is
    positive, so each sum rounds to at least the value it adds to and the settling order holds in floating
    point. A block in ``walls`` is never relaxed; a sum at or above ``unreached`` leaves a block unreached.
    Where ``open_moves`` has the costs' shape, a move it does not hold is never taken, and a move priced above
    ``most[a]`` neither: the same values as those moves priced ``unreached`` (their sums never lower a value).
    The heap (one slot per block, with decrease-key) keeps each entry's key beside it, so sifting reads keys in
    order rather than looking each up by block.
    """
    A, h, w = costs.shape
    n = h * w
    gated = open_moves.shape == costs.shape
    dist = np.full(n, unreached, dtype=costs.dtype)
    pos = np.full(n, -1, dtype=np.int64)  # heap slot; -1 never queued, -2 settled
    keys = np.empty(n, dtype=costs.dtype)
    items = np.empty(n, dtype=np.int64)
    size = 0
    for i in range(n):
        if goal[i // w, i % w]:
            dist[i] = 0.0
            size = heap_lower(keys, items, pos, size, dist[i], i)
    while size > 0:
        dv, v = keys[0], items[0]
        size = heap_pop(keys, items, pos, size)
        r, c = v // w, v % w
        for a in range(A):
            br, bc = r - dr[a], c - dc[a]  # the block that move a carries onto v
            if br < 0 or br >= h or bc < 0 or bc >= w:
                continue
            b = br * w + bc
            if pos[b] == -2 or walls[br, bc]:
                continue
            if gated and (not open_moves[a, br, bc] or costs[a, br, bc] > most[a]):
                continue
            nd = costs[a, br, bc] + dv
            if nd < dist[b]:
                dist[b] = nd
                size = heap_lower(keys, items, pos, size, nd, b)
    return dist.reshape(h, w)


@nb.njit(cache=True)
def _incoming(costs, unreached, dr, dc, open_moves, most, inc):
    """Each block's incoming moves' prices into ``inc`` (h * w, 8): what move ``a`` costs from the block it comes
    from.

    ``unreached`` where that move cannot be taken (off the grid, not in ``open_moves``, priced above ``most[a]``
    or at ``unreached``). Also the least and the largest price of a move that can be taken.
    """
    A, h, w = costs.shape
    gated = open_moves.shape == costs.shape
    low, high = np.inf, 0.0
    for r in range(h):  # a row of blocks at a time, each move's prices read along a row of its plane
        for a in range(A):
            br = r - dr[a]
            for c in range(w):
                bc = c - dc[a]
                x = unreached
                if 0 <= br < h and 0 <= bc < w:
                    y = costs[a, br, bc]
                    if y < unreached and not (gated and (not open_moves[a, br, bc] or y > most[a])):
                        x = y
                        low = min(low, float(y))
                        high = max(high, float(y))
                inc[r * w + c, a] = x
    return low, high


@nb.njit(cache=True)
def _settle_buckets(inc, goal, walls, unreached, dr, dc, width, slots, dist, state, nxt, prv, where):
    """``_move_cost_dijkstra``'s values bit for bit, from ``_incoming``'s prices, with buckets ``width`` apart.

    Every move costs at least twice ``width`` and no sum below ``unreached`` rounds by as much as ``width`` (the
    caller checks both), so a block settled from bucket ``k`` puts its neighbours in bucket ``k + 1`` or later:
    every block of a bucket holds its final value when the bucket is taken, in whatever order its blocks come.
    Each value is then the least sum ``price + value`` over its neighbours' final values, the very sums (and
    rounding) of the heap's search. The buckets are a ring of ``slots`` doubly linked lists, enough for the
    dearest move; the blocks are kept on a grid padded with one settled block each side (no bounds to check),
    and a settling block reads its 8 incoming prices side by side. ``dist``, ``state`` (int8), ``nxt``, ``prv`` and
    ``where`` (int32) are working arrays of ``(h + 2) * (w + 2)``, whatever they hold.
    """
    h, w = goal.shape
    A = inc.shape[1]
    Wp = w + 2
    dist[:] = unreached
    state[:] = 2  # 0 never queued, 1 queued, 2 settled (the border and the walls)
    # nxt, prv: a queued block's neighbours in its bucket's list; where: its bucket
    head = np.full(slots, -1, dtype=np.int32)
    off = np.empty(A, dtype=np.int64)
    for a in range(A):
        off[a] = dr[a] * Wp + dc[a]
    for r in range(h):
        for c in range(w):
            if not walls[r, c]:
                state[(r + 1) * Wp + c + 1] = 0
    queued = 0
    for r in range(h):
        for c in range(w):
            if goal[r, c]:
                i = (r + 1) * Wp + c + 1
                dist[i] = 0.0
                state[i], where[i], prv[i], nxt[i] = 1, 0, -1, head[0]
                if head[0] >= 0:
                    prv[head[0]] = i
                head[0] = i
                queued += 1
    cur = 0
    while queued > 0:
        s = cur % slots
        p = head[s]
        if p < 0:
            cur += 1
            continue
        head[s] = nxt[p]
        if nxt[p] >= 0:
            prv[nxt[p]] = -1
        state[p] = 2
        queued -= 1
        dv = dist[p]
        v = (p // Wp - 1) * w + p % Wp - 1
        for a in range(A):
            b = p - off[a]  # the block that move a carries onto p
            if state[b] == 2:
                continue
            nd = inc[v, a] + dv
            if nd < dist[b]:
                dist[b] = nd
                k = int(nd / width)
                if state[b] == 1:
                    if where[b] == k:
                        continue
                    if prv[b] >= 0:  # out of its bucket
                        nxt[prv[b]] = nxt[b]
                    else:
                        head[where[b] % slots] = nxt[b]
                    if nxt[b] >= 0:
                        prv[nxt[b]] = prv[b]
                else:
                    state[b] = 1
                    queued += 1
                t = k % slots
                where[b], prv[b], nxt[b] = k, -1, head[t]
                if head[t] >= 0:
                    prv[head[t]] = b
                head[t] = b
    return dist.reshape(h + 2, Wp)[1:-1, 1:-1].copy()


def work_array(work: dict | None, name: str, shape: tuple[int, ...], dtype) -> np.ndarray:
    """The working array ``name`` kept in the dict ``work`` where it has this shape and dtype, else a new one kept
    there (the old one freed first); a new one each call where ``work`` is None. Its contents are whatever the last
    user left. The search's ``work`` (``move_cost_field``) and the route encoder's buffers keep theirs so.
    """
    kept = None if work is None else work.pop(name, None)
    if kept is None or kept.shape != shape or kept.dtype != dtype:
        del kept  # freed before the new one is made
        kept = np.empty(shape, dtype=dtype)
    if work is not None:
        work[name] = kept
    return kept


@nb.njit(cache=True)
def incoming_prices(costs, unreached, open_moves, most, inc):
    """Compiled (for compiled callers; ``move_cost_field`` checks what it hands on): each block's incoming moves'
    prices into ``inc`` (h * w, 8), ``unreached`` where that move cannot be taken; returns the least and the largest
    price of a move that can be taken (``inf`` and 0 where none can).

    ``costs`` (8, h, w); ``open_moves`` (8, h, w) bool with ``most`` (8,) the caps, or an empty ``open_moves`` for
    no gate and no cap, as ``move_cost_field`` takes them.
    """
    return _incoming(costs, unreached, _DR, _DC, open_moves, most, inc)


@nb.njit(cache=True)
def settle_prices(inc, low, high, costs, goal, walls, unreached, open_moves, most, dist, state, nxt, prv, where):
    """Compiled: ``move_cost_field``'s values from ``incoming_prices``' ``inc``, ``low`` and ``high`` (of the same
    ``costs``, ``open_moves`` and ``most``): by buckets where the prices allow it exactly, else by the heap.

    ``dist`` (of ``costs``' dtype), ``state`` (int8), ``nxt``, ``prv`` and ``where`` (int32): working arrays of
    ``(h + 2) * (w + 2)``, whatever they hold.
    """
    eps = 1.1920928955078125e-07 if costs.itemsize == 4 else 2.220446049250313e-16  # the dtype's machine epsilon
    width = low / 2
    # a sum below ``unreached`` rounds by at most unreached * eps / 2: the buckets need it well below ``width``
    if np.isfinite(low) and width > float(unreached) * eps and high / width < 1 << 22:
        return _settle_buckets(inc, goal, walls, unreached, _DR, _DC, float(width), int(high / width) + 3, dist, state,
                               nxt, prv, where)
    return _move_cost_dijkstra(costs, goal, walls, unreached, _DR, _DC, open_moves, most)


@nb.njit(cache=True)
def reaches_block(inc, goal, walls, unreached, row, col, seen):
    """Compiled: whether the search over ``incoming_prices``' ``inc`` reaches block (``row``, ``col``) from a
    ``goal`` block at all, by a breadth-first walk that stops there: the blocks the search would settle below
    ``unreached``, wherever no route's sum of prices comes near it. ``seen`` (h * w, uint8) marks each block walked
    (whatever it held before).
    """
    h, w = goal.shape
    A = inc.shape[1]
    seen[:] = 0
    queue = np.empty(h * w, dtype=np.int64)
    top = 0
    for r in range(h):
        for c in range(w):
            if goal[r, c]:
                seen[r * w + c] = 1
                queue[top] = r * w + c
                top += 1
    target = row * w + col
    at = 0
    while at < top:
        v = queue[at]
        at += 1
        if v == target:
            return True
        r, c = v // w, v % w
        for a in range(A):
            if not inc[v, a] < unreached:
                continue
            br, bc = r - _DR[a], c - _DC[a]  # the block that move a carries onto v (on the grid: its price is open)
            b = br * w + bc
            if seen[b] or walls[br, bc]:
                continue
            seen[b] = 1
            queue[top] = b
            top += 1
    return False


def _settle_moves(costs, goal, walls, unreached, open_moves, most, work=None):
    """``move_cost_field``'s search: by buckets where the prices allow it exactly, else by the heap."""
    A, h, w = costs.shape
    inc = work_array(work, "incoming", (h * w, A), costs.dtype)
    low, high = incoming_prices(costs, unreached, open_moves, most, inc)
    n = (h + 2) * (w + 2)
    scratch = [work_array(work, name, (n,), dtype) for name, dtype in
               (("dist", costs.dtype), ("state", np.int8), ("next", np.int32), ("previous", np.int32),
                ("where", np.int32))]
    return settle_prices(inc, low, high, costs, goal, walls, unreached, open_moves, most, *scratch)


@nb.njit(cache=True)
def _block_pairs(block, Wp, dr, dc):
    """Every (cell of a block, step) that leaves the block, grouped by the block move it makes.

    Returns ``(start, src, step, side_r, side_c)``: move ``a``'s pairs are ``start[a]:start[a + 1]``; ``src`` is the
    cell's offset from the block's window corner (one cell up and left of the block) in a map ``Wp`` cells wide,
    ``step`` the offset to the cell it steps to, and, for a diagonal step, ``side_r`` and ``side_c`` the offsets to
    the two cells beside it (0 otherwise): the step is allowed where all four are free.
    """
    A = len(dr)
    move = np.full((3, 3), -1, dtype=np.int64)  # (block row move + 1, block column move + 1) -> move index
    for a in range(A):
        move[dr[a] + 1, dc[a] + 1] = a
    count = np.zeros(A + 1, dtype=np.int64)
    for i in range(block):
        for j in range(block):
            for k in range(A):
                mr, mc = (i + dr[k]) // block, (j + dc[k]) // block
                if mr != 0 or mc != 0:
                    count[move[mr + 1, mc + 1] + 1] += 1
    start = np.cumsum(count)
    fill = start.copy()
    src = np.empty(start[A], dtype=np.int64)
    step = np.empty(start[A], dtype=np.int64)
    side_r = np.zeros(start[A], dtype=np.int64)
    side_c = np.zeros(start[A], dtype=np.int64)
    for i in range(block):
        for j in range(block):
            for k in range(A):
                mr, mc = (i + dr[k]) // block, (j + dc[k]) // block
                if mr != 0 or mc != 0:
                    a = move[mr + 1, mc + 1]
                    t = fill[a]
                    fill[a] += 1
                    src[t] = (i + 1) * Wp + j + 1
                    step[t] = dr[k] * Wp + dc[k]
                    if k >= 4:  # no corner cutting
                        side_r[t], side_c[t] = dr[k] * Wp, dc[k]
    return start, src, step, side_r, side_c


@nb.njit(cache=True)
def _window_table(block, dr, dc):
    """The block moves each window of cells allows: ``table[bits]``, bit ``a`` set where move ``a`` is open.

    A window is a block and the cells around it, ``side = block + 2`` cells a side, its cell at (row, column) the
    bit ``column * side + row`` of ``bits`` (set where the cell is free).
    """
    side = block + 2
    start, src, step, side_r, side_c = _block_pairs(block, side, dr, dc)
    A = len(dr)
    pattern = np.zeros(start[A], dtype=np.int64)
    for t in range(start[A]):
        for off in (src[t], src[t] + step[t], src[t] + side_r[t], src[t] + side_c[t]):
            row = off // side
            pattern[t] |= np.int64(1) << np.int64((off - row * side) * side + row)
    table = np.zeros(1 << (side * side), dtype=np.uint8)
    for bits in range(1 << (side * side)):
        for a in range(A):
            for t in range(start[a], start[a + 1]):
                if (bits & pattern[t]) == pattern[t]:
                    table[bits] |= np.uint8(1 << a)
                    break
    return table


@nb.njit(cache=True)
def _block_steps(p, block, dr, dc, table):
    """(8, h, w) bool: whether some free cell of each block steps into its neighbour block by each move.

    ``p``: the map's free cells (nonzero) padded with one blocked cell on every side. ``table``:
    ``_window_table(block, ...)`` (blocks of up to ``WINDOW_TABLE_BLOCK`` cells): each block's window is read once,
    along a row of blocks by the columns the last window does not hold, and its moves looked up. ``table`` empty:
    each block move is tried by the (cell of the block, step) pairs that make it (``_block_pairs``), the first that
    the map allows deciding it. The same answers either way.
    """
    H, W = p.shape[0] - 2, p.shape[1] - 2
    Wp = W + 2
    h, w = H // block, W // block
    A = len(dr)
    flat = p.ravel()
    out = np.zeros((A, h, w), dtype=np.uint8)
    if table.shape[0]:
        side = block + 2
        row = np.empty(w, dtype=np.uint8)  # a row of blocks' moves, written out plane by plane
        for r in range(h):
            top = r * block * Wp
            bits = 0
            for c in range(w):
                first = 0  # the window's first column not held from the last window
                if c > 0:
                    bits >>= block * side
                    first = side - block
                for j in range(first, side):
                    at = top + c * block + j
                    for i in range(side):
                        bits |= np.int64(flat[at + i * Wp] != 0) << (j * side + i)
                row[c] = table[bits]
            for a in range(A):
                for c in range(w):
                    out[a, r, c] = (row[c] >> a) & 1
        return out.view(np.bool_)
    start, src, step, side_r, side_c = _block_pairs(block, Wp, dr, dc)
    for r in range(h):
        for c in range(w):
            corner = r * block * Wp + c * block
            for a in range(A):
                for t in range(start[a], start[a + 1]):
                    s = corner + src[t]
                    if flat[s] != 0 and flat[s + step[t]] != 0 and flat[s + side_r[t]] != 0 \
                            and flat[s + side_c[t]] != 0:
                        out[a, r, c] = 1
                        break
    return out.view(np.bool_)


#: Blocks of up to this many cells a side look their moves up in a table of every window (``_window_table``:
#: 2 ** 16 bytes for blocks of 2 cells, made once per process).
WINDOW_TABLE_BLOCK = 2
_WINDOW_TABLES: dict[int, np.ndarray] = {}


def _steps(p: np.ndarray, block: int, lookup: bool) -> np.ndarray:
    """``_block_steps`` of padded map ``p``, with the window table of ``block`` where one is kept and ``lookup``."""
    table = _WINDOW_TABLES.get(block)
    if table is None:
        table = _window_table(block, _DR, _DC) if block <= WINDOW_TABLE_BLOCK else np.zeros(0, dtype=np.uint8)
        _WINDOW_TABLES[block] = table
    return _block_steps(p, block, _DR, _DC, table if lookup else table[:0])


@nb.njit(cache=True)
def _flood(padded, seed, label, value, stop):
    """4-connected flood fill of free cells from flat padded index ``seed``; True if ``stop`` was reached."""
    Wp = padded.shape[1]
    blocked = padded.ravel()
    stack = np.empty(padded.size, dtype=np.int64)
    label[seed] = value
    stack[0] = seed
    sp = 1
    while sp > 0:
        sp -= 1
        v = stack[sp]
        if v == stop:
            return True
        for u in (v - Wp, v + Wp, v - 1, v + 1):
            if not blocked[u] and label[u] < 0:
                label[u] = value
                stack[sp] = u
                sp += 1
    return False


@nb.njit(cache=True)
def _components(padded):
    label = np.full(padded.size, -1, dtype=np.int32)
    blocked = padded.ravel()
    count = 0
    for v in range(padded.size):
        if not blocked[v] and label[v] < 0:
            _flood(padded, v, label, count, -1)
            count += 1
    return label


# --- public API ---------------------------------------------------------------------------------


def distance_field(obstacles: np.ndarray, goal_cell: tuple[int, int]) -> np.ndarray:
    """Octile shortest-path distance (in cells) from every cell to ``goal_cell``.

    Args:
        obstacles: (H, W) bool array, True = obstacle.
        goal_cell: Free (row, col) the distances are measured to.

    Returns:
        (H, W) float64 array; blocked and unreachable cells hold +inf.
    """
    obstacles = _as_obstacles(obstacles)
    r, c = _as_cell(goal_cell, obstacles, "goal")
    padded = _padded(obstacles)
    dist, _ = _dijkstra(padded, (r + 1) * padded.shape[1] + c + 1, -1, _DR, _DC)
    return dist.reshape(padded.shape)[1:-1, 1:-1].copy()


#: ``move_cost_field``'s sentinels for no gate on the moves: no mask of the costs' shape, no cap.
_NO_GATE = np.ones((0, 0, 0), dtype=bool)
_NO_CAP = np.zeros(0, dtype=np.float64)


def move_cost_field(costs: np.ndarray, goal: np.ndarray, walls: np.ndarray, unreached: float, *,
                    open_moves: np.ndarray | None = None, most: np.ndarray | None = None,
                    work: dict | None = None) -> np.ndarray:
    """Every cell's least total cost to reach a ``goal`` cell, moving with per-cell, per-move ``costs``.

    The fixed point that value iteration reaches (``V = min over moves of cost + V of the cell reached``),
    computed exactly by a compiled Dijkstra instead of one sweep of the grid per iteration.

    Args:
        costs: (8, h, w) float array, positive: ``costs[a, r, c]`` is what leaving cell (r, c) by move ``a``
            costs, the moves in ``MOVES`` order ((-1, 0), (1, 0), (0, -1), (0, 1), then the diagonals
            (-1, -1), (-1, 1), (1, -1), (1, 1)); a move off the grid is never taken.
        goal: (h, w) bool, the cells whose value is 0.
        walls: (h, w) bool, cells never entered (their value stays ``unreached``, unless they are goals).
        unreached: The value of a cell no goal reaches; a total at or above it counts as unreached.
        open_moves: (8, h, w) bool, the moves that may be taken (default: every one); a move it does not hold is
            a wall, as one priced ``unreached`` would be, without a copy of ``costs``.
        most: (8,) the most each move may cost (in ``costs``' dtype, compared as value iteration's callers compare
            it); a move priced above it is a wall likewise. Default: no cap.
        work: A dict in which the search keeps its working arrays (about 50 bytes a cell for float32 costs) for
            the next call on a grid of the same shape, which reuses them rather than mapping new memory (a large
            map's repeated searches); the values do not depend on it. Default: new arrays each call.

    Returns:
        (h, w) array of ``costs``' dtype. The sums are formed in that dtype as value iteration forms them, so
        the result equals value iteration's converged values bit for bit.
    """
    costs = np.ascontiguousarray(costs)
    if costs.ndim != 3 or costs.shape[0] != len(MOVES):
        raise ValueError(f"costs must be an (8, h, w) array, got shape {costs.shape}")
    if costs.dtype not in (np.float32, np.float64):
        raise ValueError(f"costs must be float32 or float64, got dtype {costs.dtype}")
    shape = costs.shape[1:]
    goal, walls = np.ascontiguousarray(goal, dtype=bool), np.ascontiguousarray(walls, dtype=bool)
    if goal.shape != shape or walls.shape != shape:
        raise ValueError(f"goal {goal.shape} and walls {walls.shape} must have the costs' grid shape {shape}")
    if open_moves is None and most is None:
        return _settle_moves(costs, goal, walls, costs.dtype.type(unreached), _NO_GATE, _NO_CAP, work)
    open_moves = np.ones(costs.shape, dtype=bool) if open_moves is None else np.ascontiguousarray(open_moves, bool)
    if open_moves.shape != costs.shape:
        raise ValueError(f"open_moves must have the costs' shape {costs.shape}, got {open_moves.shape}")
    cap = np.full(len(MOVES), np.inf, dtype=costs.dtype) if most is None else np.asarray(most, dtype=costs.dtype)
    if cap.shape != (len(MOVES),):
        raise ValueError(f"most must hold one cap per move ({len(MOVES)}), got shape {cap.shape}")
    return _settle_moves(costs, goal, walls, costs.dtype.type(unreached), open_moves, np.ascontiguousarray(cap),
                         work)


def block_steps(free: np.ndarray, block: int, *, lookup: bool = True) -> np.ndarray:
    """Whether any free cell of each ``block`` x ``block`` block can step into its neighbour block, per move.

    A step goes from a free cell to one of its 8 neighbours that is free, a diagonal one only if both cells
    beside it are free (the grid's own rule); cells off the map are blocked.

    Args:
        free: (H, W) bool, True where a cell is free; H and W whole multiples of ``block``.
        block: Cells per block side.
        lookup: Blocks of up to ``WINDOW_TABLE_BLOCK`` cells: read each block's window of cells once and look its
            moves up in a table of every window (made once per process); False: test each move's cell pairs in
            turn. The same answers; the lookup is the faster.

    Returns:
        (8, H // block, W // block) bool, the moves in ``MOVES`` order.
    """
    free = np.asarray(free, dtype=bool)
    if free.ndim != 2 or free.shape[0] % block or free.shape[1] % block:
        raise ValueError(f"free must be an (H, W) map of whole {block}-cell blocks, got shape {free.shape}")
    p = np.zeros((free.shape[0] + 2, free.shape[1] + 2), dtype=np.uint8)
    p[1:-1, 1:-1] = free
    return _steps(p, int(block), bool(lookup))


def padded_block_steps(padded: np.ndarray, block: int, *, lookup: bool = True) -> np.ndarray:
    """``block_steps`` of a map already padded with one blocked cell on every side (``lookup`` as there).

    ``padded``: (H + 2, W + 2) uint8, nonzero where a cell is free (H and W whole multiples of ``block``).
    """
    padded = np.ascontiguousarray(padded, dtype=np.uint8)
    if padded.ndim != 2 or (padded.shape[0] - 2) % block or (padded.shape[1] - 2) % block:
        raise ValueError(f"padded must be an (H + 2, W + 2) map of whole {block}-cell blocks, got {padded.shape}")
    return _steps(padded, int(block), bool(lookup))


def _search(grid: OccupancyGrid, start, goal):
    """Dijkstra from goal's cell until start's cell is settled: (padded map, distances, pointers, start index)."""
    s = _grid_cell(grid, start, "start")
    g = _grid_cell(grid, goal, "goal")
    padded = _padded(np.asarray(grid.obstacles))
    Wp = padded.shape[1]
    si = (s[0] + 1) * Wp + s[1] + 1
    dist, toward = _dijkstra(padded, (g[0] + 1) * Wp + g[1] + 1, si, _DR, _DC)
    return padded, dist, toward, si


def shortest_path_length(grid: OccupancyGrid, start, goal) -> float:
    """Octile shortest-path length (world units) between the cells containing ``start`` and ``goal``.

    Returns inf if the cells are not connected. Raises ValueError if either point lies outside the
    grid or in a blocked cell.
    """
    _, dist, _, si = _search(grid, start, goal)
    return float(dist[si]) * grid.resolution


def shortest_path(grid: OccupancyGrid, start, goal) -> np.ndarray:
    """One shortest octile path from the cell containing ``start`` to the cell containing ``goal``.

    Returns:
        (k, 2) world coordinates (the grid's origin included) of the centres of the path's cells,
        start's cell first.

    Raises:
        ValueError: If there is no path, or either point lies outside the grid or in a blocked cell.
    """
    padded, dist, toward, si = _search(grid, start, goal)
    if not np.isfinite(dist[si]):
        raise ValueError(
            f"no path: start cell {grid.cell_of(start)} and goal cell {grid.cell_of(goal)} are not connected"
        )
    cells = [si]
    while toward[cells[-1]] >= 0:
        cells.append(int(toward[cells[-1]]))
    rows, cols = np.divmod(np.array(cells), padded.shape[1])
    # -1 for the padding, +0.5 to centre; adding a zero origin leaves the coordinates bit-identical
    return np.stack([cols - 0.5, rows - 0.5], axis=1) * grid.resolution + grid.origin


def free_components(obstacles: np.ndarray) -> np.ndarray:
    """(H, W) int32 label of each free cell's 4-connected component (0, 1, ... in scan order); -1 if blocked."""
    padded = _padded(_as_obstacles(obstacles))
    return _components(padded).reshape(padded.shape)[1:-1, 1:-1].copy()


def connected(obstacles: np.ndarray, a_cell: tuple[int, int], b_cell: tuple[int, int]) -> bool:
    """True if free cells ``a_cell`` and ``b_cell`` are 4-connected through free cells."""
    obstacles = _as_obstacles(obstacles)
    a = _as_cell(a_cell, obstacles, "a")
    b = _as_cell(b_cell, obstacles, "b")
    padded = _padded(obstacles)
    Wp = padded.shape[1]
    label = np.full(padded.size, -1, dtype=np.int32)
    return bool(_flood(padded, (a[0] + 1) * Wp + a[1] + 1, label, 0, (b[0] + 1) * Wp + b[1] + 1))
