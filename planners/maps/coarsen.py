"""A map read at a coarser resolution, and whether that keeps its passages.

``block_any`` reads a map on cells ``k`` times as wide, a cell blocked where any of its cells is (what
``planners.worlds.grid.resample_obstacles`` gives at a whole factor, which it calls). That never opens a wall but can
close a gap narrower than a coarse cell, and a closed gap changes the routes. ``keeps_passages`` says whether it closed
none: the obstacles keep their number of 8-connected pieces (the map's outside counted as one obstacle), so no gap
between two of them closed, no 4-connected free region falls apart into two (a gap between an obstacle and itself),
and none with as many cells as a coarse cell vanishes. Smaller pockets may vanish; a query's start and goal must
stay in free coarse cells (``free_at``).
"""

from __future__ import annotations

from collections import OrderedDict

import numba as nb
import numpy as np


@nb.njit(cache=True)
def block_any(obstacles, k):
    """(ceil(H / k), ceil(W / k)) bool: cell (i, j) blocked where any cell of ``obstacles`` in rows ``[i k, (i + 1) k)``
    and the columns alike is (the part beyond the map counts as free).
    """
    H, W = obstacles.shape
    h, w = (H + k - 1) // k, (W + k - 1) // k
    out = np.zeros((h, w), dtype=np.bool_)
    for r in range(H):
        i = r // k
        for c in range(W):
            if obstacles[r, c]:
                out[i, c // k] = True
    return out


@nb.njit(cache=True)
def _root(parent, v):
    while parent[v] != v:
        parent[v] = parent[parent[v]]  # path halving
        v = parent[v]
    return v


@nb.njit(cache=True)
def _join(parent, a, b):
    a, b = _root(parent, a), _root(parent, b)
    if a != b:
        if a < b:
            parent[b] = a
        else:
            parent[a] = b


@nb.njit(cache=True)
def _runs(blocked):
    """The rows of ``blocked`` as runs of equal cells: ``(first, start, stop, value)``, row r's runs
    ``first[r]:first[r + 1]``, each covering columns ``start:stop``.
    """
    H, W = blocked.shape
    n = 0
    for r in range(H):  # counted first: a map's runs are usually far fewer than its cells
        n += 1
        for c in range(1, W):
            if blocked[r, c] != blocked[r, c - 1]:
                n += 1
    first = np.empty(H + 1, dtype=np.int64)
    start = np.empty(n, dtype=np.int32)
    stop = np.empty(n, dtype=np.int32)
    value = np.empty(n, dtype=np.bool_)
    n = 0
    for r in range(H):
        first[r] = n
        c = 0
        while c < W:
            b = blocked[r, c]
            e = c + 1
            while e < W and blocked[r, e] == b:
                e += 1
            start[n], stop[n], value[n] = c, e, b
            n += 1
            c = e
    first[H] = n
    return first, start, stop, value


@nb.njit(cache=True)
def _pieces(blocked):
    """Union-find over the runs of ``blocked`` (``_runs``): free runs joined 4-connected, blocked ones 8-connected,
    and every blocked run on the map's edge joined to the outside (index ``len(start)``).

    Returns ``(first, start, parent, obstacle pieces, stop, value)``: the runs, their forest (roots by ``_root``)
    and the number of obstacle pieces, the outside one included.
    """
    H, W = blocked.shape
    first, start, stop, value = _runs(blocked)
    n = len(start)
    parent = np.empty(n + 1, dtype=np.int32)
    for v in range(n + 1):
        parent[v] = v
    for r in range(H):
        a, a_end = first[r], first[r + 1]
        for v in range(a, a_end):
            if value[v] and (r == 0 or r == H - 1 or start[v] == 0 or stop[v] == W):
                _join(parent, v, n)
        if r == 0:
            continue
        u, u_end = first[r - 1], first[r]
        for v in range(a, a_end):  # the runs above that meet run v: they overlap it, or touch its ends diagonally
            while u < u_end and stop[u] < start[v]:
                u += 1
            w = u
            while w < u_end and start[w] <= stop[v]:
                if value[w] == value[v]:
                    if value[v] or (start[w] < stop[v] and start[v] < stop[w]):
                        _join(parent, v, w)
                w += 1
    pieces = 1  # the outside
    top = _root(parent, n)
    for v in range(n):
        if value[v] and _root(parent, v) == v and v != top:
            pieces += 1
    return first, start, parent, pieces, stop, value


@nb.njit(cache=True)
def _keeps(obstacles, fine, coarse, k):
    first, start, parent, pieces = fine[0], fine[1], fine[2], fine[3]
    cfirst, cstart, cparent, cpieces = _pieces(coarse)[:4]
    if cpieces != pieces:
        return False
    H, W = obstacles.shape
    h, w = coarse.shape
    region = np.full(len(start), -1, dtype=np.int32)  # per fine free root: the coarse free root its cells fall in
    for i in range(h):
        r = min(i * k, H - 1)
        u, u_last = first[r], first[r + 1] - 1  # the fine run under column j * k, walked along the row
        v, v_last = cfirst[i], cfirst[i + 1] - 1  # the coarse run of column j
        for j in range(w):
            while v < v_last and cstart[v + 1] <= j:
                v += 1
            if coarse[i, j]:
                continue
            c = min(j * k, W - 1)
            while u < u_last and start[u + 1] <= c:
                u += 1
            mine, root = _root(cparent, v), _root(parent, u)
            if region[root] < 0:
                region[root] = mine
            elif region[root] != mine:
                return False
    size = np.zeros(len(start), dtype=np.int64)  # the free regions that vanish: none as large as a coarse cell
    stop, value = fine[4], fine[5]
    for v in range(len(start)):
        if not value[v]:
            size[_root(parent, v)] += stop[v] - start[v]
    for v in range(len(start)):
        if not value[v] and region[v] < 0 and size[v] >= k * k:
            return False
    return True


def keeps_passages(obstacles: np.ndarray, coarse: np.ndarray, k: int) -> bool:
    """Whether ``coarse`` (``block_any(obstacles, k)``) closed no gap of ``obstacles`` (the module's rule)."""
    obstacles = np.ascontiguousarray(obstacles, dtype=np.bool_)
    return bool(_keeps(obstacles, _pieces(obstacles), np.ascontiguousarray(coarse, dtype=np.bool_), int(k)))


@nb.njit(cache=True)
def _coarsest(obstacles, most):
    fine = _pieces(obstacles)
    best = 1
    k = 2
    coarse = obstacles
    while k <= most:
        coarse = block_any(coarse, 2)  # the map at k from the map at k / 2: the same cells
        if not _keeps(obstacles, fine, coarse, k):
            break
        best = k
        k *= 2
    return best


#: The last maps' answers (``coarsest_keeping``): a map queried again is not scanned again.
_KEPT: OrderedDict = OrderedDict()
KEPT_MAPS = 8


def coarsest_keeping(obstacles: np.ndarray, most: int) -> int:
    """The largest power of two ``k <= most`` such that ``block_any(obstacles, j)`` keeps the passages
    (``keeps_passages``) for every power of two ``j <= k``; 1 where none does.

    One scan of the map for its pieces, then one of each coarse map tried; the answers for the last ``KEPT_MAPS``
    maps (by their cells) are kept, so a later query on a map costs a hash of its cells.
    """
    if int(most) < 2:
        return 1
    obstacles = np.ascontiguousarray(obstacles, dtype=np.bool_)
    key = (obstacles.shape, int(most), np.packbits(obstacles).tobytes())
    k = _KEPT.get(key)
    if k is None:
        k = int(_coarsest(obstacles, int(most)))
        _KEPT[key] = k
        while len(_KEPT) > KEPT_MAPS:
            _KEPT.popitem(last=False)
    else:
        _KEPT.move_to_end(key)
    return k


def forget_kept() -> None:
    """Forget the kept answers (``coarsest_keeping``): the next query on any map scans it again, as a first one does."""
    _KEPT.clear()


def free_at(obstacles: np.ndarray, k: int, cells) -> int:
    """The largest power of two ``j <= k`` at which every cell of ``cells`` ((row, col) pairs) lies in a free cell of
    ``block_any(obstacles, j)`` (1 at the least: a free cell of ``obstacles`` itself).
    """
    while k > 1 and any(obstacles[r // k * k:(r // k + 1) * k, c // k * k:(c // k + 1) * k].any() for r, c in cells):
        k //= 2
    return k
