"""Exact grid searches: octile distance fields, shortest paths and connected components.

Distances are on the 8-connected grid with straight steps of 1 and diagonal steps of sqrt(2), and no
corner cutting: a diagonal step is legal only if both orthogonal neighbours are free. This is the
definition of the MovingAI benchmarks' ``optimal_length``, and matches the continuous collision
model (closed cells): two free cells are mutually reachable in the plane iff they are 4-connected.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from planners.grid import OccupancyGrid

SQRT2 = math.sqrt(2.0)


def _check(obstacles: np.ndarray, cell, label: str) -> tuple[np.ndarray, tuple[int, int]]:
    obstacles = np.asarray(obstacles)
    if obstacles.ndim != 2 or obstacles.size == 0:
        raise ValueError(f"obstacles must be a non-empty 2-D array, got shape {obstacles.shape}")
    r, c = (int(v) for v in cell)
    H, W = obstacles.shape
    if not (0 <= r < H and 0 <= c < W):
        raise ValueError(f"{label} cell {(r, c)} lies outside the {H}x{W} grid")
    if obstacles[r, c]:
        raise ValueError(f"{label} cell {(r, c)} is blocked")
    return np.ascontiguousarray(obstacles, dtype=np.bool_), (r, c)


@nb.njit(cache=True)
def _dijkstra(blocked, gr, gc):
    H, W = blocked.shape
    dist = np.full((H, W), np.inf)
    done = np.zeros((H, W), dtype=np.bool_)
    cap = 8 * H * W + 1
    hd = np.empty(cap)
    hi = np.empty(cap, dtype=np.int64)
    dist[gr, gc] = 0.0
    hd[0] = 0.0
    hi[0] = gr * W + gc
    n = 1
    drs = np.array([-1, 1, 0, 0, -1, -1, 1, 1])
    dcs = np.array([0, 0, -1, 1, -1, 1, -1, 1])
    while n > 0:
        d = hd[0]
        v = hi[0]
        n -= 1
        ld = hd[n]
        lv = hi[n]
        i = 0
        while True:  # sift the last entry down from the root
            c = 2 * i + 1
            if c >= n:
                break
            if c + 1 < n and hd[c + 1] < hd[c]:
                c += 1
            if hd[c] >= ld:
                break
            hd[i] = hd[c]
            hi[i] = hi[c]
            i = c
        if n > 0:
            hd[i] = ld
            hi[i] = lv
        r = v // W
        c0 = v % W
        if done[r, c0]:
            continue
        done[r, c0] = True
        for k in range(8):
            rr = r + drs[k]
            cc = c0 + dcs[k]
            if rr < 0 or rr >= H or cc < 0 or cc >= W or blocked[rr, cc]:
                continue
            if k >= 4:
                if blocked[r + drs[k], c0] or blocked[r, c0 + dcs[k]]:
                    continue  # no corner cutting
                nd = d + SQRT2
            else:
                nd = d + 1.0
            if nd < dist[rr, cc]:
                dist[rr, cc] = nd
                j = n
                n += 1
                while j > 0:
                    p = (j - 1) // 2
                    if hd[p] <= nd:
                        break
                    hd[j] = hd[p]
                    hi[j] = hi[p]
                    j = p
                hd[j] = nd
                hi[j] = rr * W + cc
    return dist


def distance_field(obstacles: np.ndarray, goal_cell: tuple[int, int]) -> np.ndarray:
    """(H, W) octile shortest-path distance (in cells) from every cell to ``goal_cell``.

    Blocked and unreachable cells hold +inf.
    """
    blocked, (r, c) = _check(obstacles, goal_cell, "goal")
    return _dijkstra(blocked, r, c)


def shortest_path_length(grid: OccupancyGrid, start, goal) -> float:
    """Octile length (world units) between the cells containing ``start`` and ``goal``; inf if disconnected."""
    s = grid.cell_of(start)
    field = distance_field(grid.obstacles, grid.cell_of(goal))
    _check(grid.obstacles, s, "start")
    return float(field[s]) * grid.resolution


@nb.njit(cache=True)
def _descend(field, blocked, r, c):
    H, W = field.shape
    out = np.empty((H * W, 2), dtype=np.int64)
    k = 0
    out[k, 0] = r
    out[k, 1] = c
    k += 1
    while field[r, c] > 0.0:
        best = field[r, c]
        br, bc = -1, -1
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                rr, cc = r + dr, c + dc
                if (dr == 0 and dc == 0) or rr < 0 or rr >= H or cc < 0 or cc >= W or blocked[rr, cc]:
                    continue
                if dr != 0 and dc != 0 and (blocked[r + dr, c] or blocked[r, c + dc]):
                    continue
                step = SQRT2 if dr != 0 and dc != 0 else 1.0
                # a neighbour on a shortest path satisfies field[n] + step == field[here]
                if field[rr, cc] + step <= field[r, c] + 1e-9 and field[rr, cc] < best:
                    best = field[rr, cc]
                    br, bc = rr, cc
        r, c = br, bc
        out[k, 0] = r
        out[k, 1] = c
        k += 1
    return out[:k]


def shortest_path(grid: OccupancyGrid, start, goal) -> np.ndarray:
    """(k, 2) world waypoints (cell centres) of one shortest octile path from start's cell to goal's."""
    field = distance_field(grid.obstacles, grid.cell_of(goal))
    _, (r, c) = _check(grid.obstacles, grid.cell_of(start), "start")
    if not np.isfinite(field[r, c]):
        raise ValueError(f"no path: start cell {(r, c)} and goal cell {grid.cell_of(goal)} are not connected")
    cells = _descend(field, np.ascontiguousarray(grid.obstacles), r, c)
    return np.stack([(cells[:, 1] + 0.5) * grid.resolution, (cells[:, 0] + 0.5) * grid.resolution], axis=1)


@nb.njit(cache=True)
def _label(blocked):
    H, W = blocked.shape
    lab = np.full((H, W), -1, dtype=np.int32)
    stack = np.empty(H * W, dtype=np.int64)
    cur = 0
    for r0 in range(H):
        for c0 in range(W):
            if blocked[r0, c0] or lab[r0, c0] >= 0:
                continue
            lab[r0, c0] = cur
            sp = 0
            stack[sp] = r0 * W + c0
            sp += 1
            while sp > 0:
                sp -= 1
                v = stack[sp]
                r = v // W
                c = v % W
                for dr, dc in ((1, 0), (-1, 0), (0, 1), (0, -1)):
                    rr, cc = r + dr, c + dc
                    if 0 <= rr < H and 0 <= cc < W and not blocked[rr, cc] and lab[rr, cc] < 0:
                        lab[rr, cc] = cur
                        stack[sp] = rr * W + cc
                        sp += 1
            cur += 1
    return lab


def free_components(obstacles: np.ndarray) -> np.ndarray:
    """int32 label of each free cell's 4-connected component; -1 for blocked cells."""
    obstacles = np.asarray(obstacles)
    if obstacles.ndim != 2 or obstacles.size == 0:
        raise ValueError(f"obstacles must be a non-empty 2-D array, got shape {obstacles.shape}")
    return _label(np.ascontiguousarray(obstacles, dtype=np.bool_))


def connected(obstacles: np.ndarray, a_cell: tuple[int, int], b_cell: tuple[int, int]) -> bool:
    """True if free cells ``a_cell`` and ``b_cell`` are 4-connected through free cells."""
    blocked, a = _check(obstacles, a_cell, "a")
    _, b = _check(obstacles, b_cell, "b")
    lab = _label(blocked)
    return bool(lab[a] == lab[b])
