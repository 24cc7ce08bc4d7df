"""The route encoder's field for one query after its convolutions, compiled in one call.

Everything a query of ``RouteVIN`` does after its local network is small arithmetic over the block grid: read which
blocks have no free cell and which holds the goal, search the learned move costs with inference's walls
(``planners.maps.gridsearch``), read the cell head at the start to see whether the learned walls leave it a route,
search again without them where they do not, and run the cell head over the map (``learning.models.cell_head``); a
later query on a map whose parts the encoder keeps first runs the local network and its heads over the goal's window
(``learning.models.local_net``) and patches them into copies of the kept parts. On maps of a few thousand blocks each
of those steps is tens of microseconds of compiled work, and made one call at a time from Python each paid as much
again in checks, conversions and new arrays. ``query_field`` and ``window_field`` make the same calls from compiled
code, in the same order: the same values, bit for bit.

One step is skipped where it cannot change the answer. Where the learned walls shut every route from the start, the
search with them served only to read the start's cell head and was thrown away; a breadth-first walk over the same
open moves (``reaches_block``) tells whether the search reaches the start's block, and where it does not, the start's
cell head is read from the walk alone: the head reads a neighbour's value only through its difference from the
start's value, clamped to ``REACH``, so any reached neighbour reads ``-REACH`` whatever its value, on a grid where no
route's sum of prices comes near ``UNREACHED`` (checked; a larger one runs the search). The search with the walls then
runs only if that value does not shut the start after all, and the answer is the same.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from learning.models.cell_head import cell_head_rows, cell_head_value
from learning.models.local_net import heads_into, local_layers
from planners.maps.gridsearch import MOVES, incoming_prices, reaches_block, settle_prices

_DR = np.array([dr for dr, _ in MOVES], dtype=np.int64)
_DC = np.array([dc for _, dc in MOVES], dtype=np.int64)
#: Working arrays of no size: ``query_field`` makes its own (a query whose arrays the encoder does not keep).
NO_WORK = (np.empty((0, len(MOVES)), dtype=np.float32), np.empty(0, dtype=np.float32), np.empty(0, dtype=np.int8),
           np.empty(0, dtype=np.int32), np.empty(0, dtype=np.int32), np.empty(0, dtype=np.int32),
           np.empty(0, dtype=np.uint8))


@nb.njit(cache=True)
def blocked_cells(cells, k, flags):
    """``cells[:, :k] >= 0.5`` into ``flags`` (bool, C order, at least as long), for ``cells`` (B, C, h, w); returns
    whether each of those cells is 0 or 1 (``np.array_equal`` of them and their flags).
    """
    n, _, h, w = cells.shape
    other = 0  # cells other than 0 and 1: unequal to their flags, as numpy compares a float with a bool
    at = 0
    for b in range(n):
        for c in range(k):
            for r in range(h):
                row = cells[b, c, r]
                out = flags[at:at + w]
                for q in range(w):  # two loops over the row, each of which runs in vectors
                    out[q] = row[q] >= 0.5
                for q in range(w):
                    v = row[q]
                    other += (v != 0.0) & (v != 1.0)
                at += w
    return other == 0


@nb.njit(cache=True)
def single_mark(plane):
    """The flat index of the one entry of ``plane`` (h, w) above 0.5, or -1 where not exactly one is."""
    h, w = plane.shape
    at = -1
    for r in range(h):
        for c in range(w):
            if plane[r, c] > 0.5:
                if at >= 0:
                    return -1
                at = r * w + c
    return at


@nb.njit(cache=True)
def _walls_and_goal(cells, block):
    """From ``route_input``'s channels (block**2 + 1, h, w): the blocks with no free cell, and the goal's blocks."""
    k = block * block
    h, w = cells.shape[1], cells.shape[2]
    walls = np.empty((h, w), dtype=np.bool_)
    goal = np.empty((h, w), dtype=np.bool_)
    for r in range(h):
        for c in range(w):
            blocked = True
            for i in range(k):
                if not cells[i, r, c] > 0.5:  # as numpy's least over the cells, NaN included, compared with 0.5
                    blocked = False
                    break
            walls[r, c] = blocked
            goal[r, c] = cells[k, r, c] > 0.5
    return walls, goal


@nb.njit(cache=True)
def query_field(cells, block, costs, pre, gate, most, capped, w_rel, w_out, b_out, reach, unreached, check,
                start_row, start_col, scale, limit, inc, dist, state, nxt, prv, where, seen, out):
    """One query's field into ``out`` ((h * block, w * block) float32): ``RouteVIN.compiled_field``'s work.

    ``cells``: the query's ``route_input`` channels (block**2 + 1, h, w); ``costs`` (8, h, w) and ``pre`` (C, h, w):
    its learned move costs and the cell head's first layer; ``gate`` (8, h, w) bool: the moves some cell steps (all
    True without the step walls); ``most`` (8,): the learned walls' caps, where ``capped``. ``w_rel``, ``w_out``,
    ``b_out``, ``reach`` and ``unreached`` (float32): as ``cell_head_field`` takes them. ``check``: whether to check
    the start (``start_row``, ``start_col``, a cell of the map) against ``limit`` (``Reach``: the start's cell head
    times ``scale``); where the learned walls shut it, the search runs again without them. ``inc`` .. ``seen``: the
    search's working arrays (``NO_WORK``: made here). Returns whether the search ran without the learned walls.
    """
    A, h, w = costs.shape
    walls, goal = _walls_and_goal(cells, block)
    n = (h + 2) * (w + 2)
    if inc.shape[0] != h * w:
        inc = np.empty((h * w, A), dtype=costs.dtype)
    if dist.shape[0] != n:
        dist = np.empty(n, dtype=costs.dtype)
        state = np.empty(n, dtype=np.int8)
        nxt = np.empty(n, dtype=np.int32)
        prv = np.empty(n, dtype=np.int32)
        where = np.empty(n, dtype=np.int32)
    if seen.shape[0] != h * w:
        seen = np.empty(h * w, dtype=np.uint8)
    uncapped = np.empty_like(most)
    uncapped[:] = np.inf
    cap = most if capped else uncapped
    low, high = incoming_prices(costs, unreached, gate, cap, inc)
    if not (check and capped):
        v = settle_prices(inc, low, high, costs, goal, walls, unreached, gate, cap, dist, state, nxt, prv, where)
        cell_head_rows(v, pre, w_rel, w_out, b_out, block, reach, unreached, _DR, _DC, out)
        return False
    sr, sc = start_row // block, start_col // block
    shut = False
    if float(h * w) * high < 0.5 * float(unreached) and not reaches_block(inc, goal, walls, unreached, sr, sc, seen):
        # the search would leave the start's block unreached: its cell head from the walk's answer alone
        near = np.empty((h, w), dtype=costs.dtype)
        near[:] = unreached
        for a in range(A):
            rr, cc = sr + _DR[a], sc + _DC[a]
            if 0 <= rr < h and 0 <= cc < w and seen[rr * w + cc]:
                near[rr, cc] = 0.0
        value = cell_head_value(near, pre, w_rel, w_out, b_out, block, reach, unreached, _DR, _DC, start_row,
                                start_col)
        shut = np.float64(value) * scale >= limit
    if not shut:
        v = settle_prices(inc, low, high, costs, goal, walls, unreached, gate, cap, dist, state, nxt, prv, where)
        value = cell_head_value(v, pre, w_rel, w_out, b_out, block, reach, unreached, _DR, _DC, start_row, start_col)
        shut = np.float64(value) * scale >= limit
        if not shut:
            cell_head_rows(v, pre, w_rel, w_out, b_out, block, reach, unreached, _DR, _DC, out)
            return False
    low, high = incoming_prices(costs, unreached, gate, uncapped, inc)
    v = settle_prices(inc, low, high, costs, goal, walls, unreached, gate, uncapped, dist, state, nxt, prv, where)
    cell_head_rows(v, pre, w_rel, w_out, b_out, block, reach, unreached, _DR, _DC, out)
    return True


@nb.njit(cache=True)
def window_field(cells, block, region, pads, window, w_first, b_first, w_rest, b_rest, channels, w_cost, b_cost,
                 lengths, wall_log, w_pre, b_pre, kept_costs, kept_pre, gate, most, capped, w_rel, w_out, b_out, reach,
                 unreached, check, start_row, start_col, scale, limit, inc, dist, state, nxt, prv, where, seen, out):
    """``query_field`` of a later query on a map whose parts are kept (``kept_costs``, ``kept_pre``, neither written):
    first the local network over ``region`` (rows ``r0:r1``, columns ``c0:c1`` of blocks; ``pads`` (top, bottom,
    left, right): 1 where a side is the map's edge) and its heads over the goal's ``window`` (``k0:k1``, ``j0:j1``),
    patched into copies of the kept parts: ``RouteVIN.window_parts`` and ``RouteVIN.reusing_field``'s patching. The
    weights as ``local_layers`` and ``heads_into`` take them.
    """
    r0, r1, c0, c1 = region
    top, bottom, left, right = pads
    k0, k1, j0, j1 = window
    f = local_layers(cells[:, r0:r1, c0:c1], w_first, b_first, w_rest, b_rest, top, bottom, left, right)
    # where a side is not the map's edge the layers shrink the region by one block each
    depth = 1 + w_rest.shape[0]
    fr, fc = r0 + depth * (1 - top), c0 + depth * (1 - left)
    f = np.ascontiguousarray(f[:, k0 - fr:k1 - fr, j0 - fc:j1 - fc])
    win_costs = np.empty((kept_costs.shape[0], k1 - k0, j1 - j0), dtype=np.float32)
    win_pre = np.empty((kept_pre.shape[0], k1 - k0, j1 - j0), dtype=np.float32)
    heads_into(f, channels, w_cost, b_cost, lengths, wall_log, w_pre, b_pre, win_costs, win_pre)
    costs = kept_costs.copy()
    costs[:, k0:k1, j0:j1] = win_costs
    pre = kept_pre.copy()
    pre[:, k0:k1, j0:j1] = win_pre
    return query_field(cells, block, costs, pre, gate, most, capped, w_rel, w_out, b_out, reach, unreached, check,
                       start_row, start_col, scale, limit, inc, dist, state, nxt, prv, where, seen, out)
