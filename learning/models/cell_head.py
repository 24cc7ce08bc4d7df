"""The route encoder's cell head at inference, compiled: every cell's cost-to-go from the block values.

``RouteVIN.cell_field`` in torch reads each block's neighbours' values relative to its own (clamped to ``REACH``),
joins them to the local features, and runs two 1x1 layers per block: a dozen small tensor operations, each
allocating a map-sized tensor. ``cell_head_field`` does the same arithmetic in float32, one block row at a time,
with the features' part of the first layer (``pre``: its weights on the features, and its bias) computed before:
the same values up to the rounding of another order of summation (well within the ``1e-4`` steps the encoder's
fields are held to), in a fraction of the time. Training keeps the torch head (it needs gradients).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from planners.maps.gridsearch import MOVES

_DR = np.array([dr for dr, _ in MOVES], dtype=np.int64)
_DC = np.array([dc for _, dc in MOVES], dtype=np.int64)


@nb.njit(cache=True)
def cell_head_rows(v, pre, w_rel, w_out, b_out, block, reach, unreached, dr, dc, out):
    """Compiled (for compiled callers): ``cell_head_field`` into ``out``, the arrays as it checks them (``reach`` and
    ``unreached`` float32; ``dr``, ``dc`` the moves' offsets in ``MOVES`` order), unchecked.
    """
    h, w = v.shape
    C = pre.shape[0]
    A = len(dr)
    zero = np.float32(0.0)
    rel = np.empty((A, w), dtype=np.float32)
    hid = np.empty((C, w), dtype=np.float32)
    acc = np.empty(w, dtype=np.float32)
    for r in range(h):
        for a in range(A):
            rr = r + dr[a]
            for c in range(w):
                cc = c + dc[a]
                there = unreached
                if 0 <= rr < h and 0 <= cc < w:
                    there = v[rr, cc]
                d = there - v[r, c]
                rel[a, c] = min(max(d, -reach), reach)
        for k in range(C):
            row = hid[k]
            for c in range(w):
                row[c] = pre[k, r, c]
            for a in range(A):
                wk = w_rel[k, a]
                for c in range(w):
                    row[c] += wk * rel[a, c]
            for c in range(w):
                row[c] = max(row[c], zero)
        for j in range(w_out.shape[0]):
            i, jj = j // block, j % block
            for c in range(w):
                acc[c] = b_out[j]
            for k in range(C):
                wk = w_out[j, k]
                for c in range(w):
                    acc[c] += wk * hid[k, c]
            line = out[r * block + i]
            for c in range(w):
                line[c * block + jj] = v[r, c] + acc[c]
    return out


@nb.njit(cache=True)
def cell_head_value(v, pre, w_rel, w_out, b_out, block, reach, unreached, dr, dc, row, col):
    """Compiled: ``cell_head_at`` (``cell_head_rows``' arithmetic, in its order, for the one cell (``row``, ``col``)
    of the field), the arrays as ``cell_head_rows`` takes them, unchecked.
    """
    h, w = v.shape
    r, c = row // block, col // block
    j = (row % block) * block + col % block
    zero = np.float32(0.0)
    rel = np.empty(len(dr), dtype=np.float32)
    for a in range(len(dr)):
        rr, cc = r + dr[a], c + dc[a]
        there = unreached
        if 0 <= rr < h and 0 <= cc < w:
            there = v[rr, cc]
        d = there - v[r, c]
        rel[a] = min(max(d, -reach), reach)
    acc = b_out[j]
    for k in range(pre.shape[0]):
        hid = pre[k, r, c]
        for a in range(len(dr)):
            hid += w_rel[k, a] * rel[a]
        acc += w_out[j, k] * max(hid, zero)
    return v[r, c] + acc


@nb.njit(cache=True)
def _padded_free(cells, block, out):
    for i in range(block):
        for j in range(block):
            ch = cells[i * block + j]
            for r in range(ch.shape[0]):
                line = out[r * block + i + 1]
                for c in range(ch.shape[1]):
                    line[c * block + j + 1] = 1 if ch[r, c] < 0.5 else 0
    return out


def padded_free_cells(cells: np.ndarray, block: int) -> np.ndarray:
    """The map's free cells from the encoder's cell channels, padded with one blocked cell on every side.

    ``cells``: (block**2, h, w), channel ``i * block + j`` the cell at row ``i``, column ``j`` of each block, below
    0.5 where free (``route_input``). Returns (h * block + 2, w * block + 2) uint8, 1 where free
    (``planners.maps.gridsearch.padded_block_steps`` reads it).
    """
    cells = np.ascontiguousarray(cells, dtype=np.float32)
    _, h, w = cells.shape
    out = np.zeros((h * block + 2, w * block + 2), dtype=np.uint8)
    return _padded_free(cells, int(block), out)


def cell_head_field(v: np.ndarray, pre: np.ndarray, w_rel: np.ndarray, w_out: np.ndarray, b_out: np.ndarray,
                    block: int, reach: float, unreached: float, out: np.ndarray | None = None) -> np.ndarray:
    """Every cell's cost-to-go, (h * block, w * block) float32, from the block values and the head's weights.

    Args:
        v: (h, w) block values (float32); a neighbour off the grid reads ``unreached``.
        pre: (C, h, w) the head's first layer on the block features, its bias included (float32).
        w_rel: (C, 8) that layer's weights on the neighbours' relative values, the moves in ``MOVES`` order.
        w_out: (block**2, C) the last layer's weights; output channel ``i * block + j`` is the cell at row ``i``,
            column ``j`` of its block (``pixel_shuffle``'s order).
        b_out: (block**2,) its bias.
        block: Cells per block side.
        reach: The relative values are clamped to ``[-reach, reach]``.
        unreached: The value off the grid.
        out: Where to write the field ((h * block, w * block) float32, C-contiguous); a new array by default.
    """
    f32 = np.float32
    v, pre = np.ascontiguousarray(v, dtype=f32), np.ascontiguousarray(pre, dtype=f32)
    h, w = v.shape
    if pre.ndim != 3 or pre.shape[1:] != (h, w):
        raise ValueError(f"pre must be (C, {h}, {w}), got {pre.shape}")
    w_rel, w_out = np.ascontiguousarray(w_rel, dtype=f32), np.ascontiguousarray(w_out, dtype=f32)
    b_out = np.ascontiguousarray(b_out, dtype=f32)
    if w_rel.shape != (pre.shape[0], len(MOVES)) or w_out.shape != (block * block, pre.shape[0]) \
            or b_out.shape != (block * block,):
        raise ValueError(f"weights of shapes {w_rel.shape}, {w_out.shape}, {b_out.shape} do not fit {pre.shape[0]} "
                         f"channels and blocks of {block} x {block} cells")
    if out is None:
        out = np.empty((h * block, w * block), dtype=f32)
    elif out.shape != (h * block, w * block) or out.dtype != f32 or not out.flags.c_contiguous:
        raise ValueError(f"out must be a C-contiguous ({h * block}, {w * block}) float32 array, got {out.shape} "
                         f"{out.dtype}")
    return cell_head_rows(v, pre, w_rel, w_out, b_out, int(block), f32(reach), f32(unreached), _DR, _DC, out)


def cell_head_at(v: np.ndarray, pre: np.ndarray, w_rel: np.ndarray, w_out: np.ndarray, b_out: np.ndarray,
                 block: int, reach: float, unreached: float, cell: tuple[int, int]) -> float:
    """``cell_head_field(...)[cell]`` alone: the cost-to-go of one cell, from its block's values and features.

    The same arithmetic in the same order, so the same float32 value; it reads one block where the whole head reads
    them all (``RouteVIN.predict_reaching`` asks it whether the field reaches the query's start before the whole head
    runs). Arrays as ``cell_head_field`` takes them (float32, C-contiguous); ``cell``: (row, column) within
    ``(h * block, w * block)``.
    """
    h, w = v.shape
    row, col = int(cell[0]), int(cell[1])
    if not (0 <= row < h * block and 0 <= col < w * block):
        raise ValueError(f"cell {cell} is outside the {h * block} x {w * block} field")
    f32 = np.float32
    return float(cell_head_value(np.ascontiguousarray(v, dtype=f32), np.ascontiguousarray(pre, dtype=f32),
                               np.ascontiguousarray(w_rel, dtype=f32), np.ascontiguousarray(w_out, dtype=f32),
                               np.ascontiguousarray(b_out, dtype=f32), int(block), f32(reach), f32(unreached),
                               _DR, _DC, row, col))
