"""The value-iteration route encoder's training losses: its move costs against the grid search's cost-to-go.

Training only (``learning.training.route``): the grid search's cost-to-go of every cell gives each block's
cost-to-go (its best cell's), the move the search's path makes out of each block, and the drop in cost-to-go
of every move. The path's move should cost the drop it makes; no move may cost less than the drop it makes
(else value iteration would cut through a wall); and every cell's cost-to-go, from the block values, should
be the search's.
"""

from __future__ import annotations

import torch
from torch import nn

from learning.models.route_vin import LENGTHS, MOVES, UNREACHED, RouteVIN, neighbours

#: The most cost-to-go a move is asked to cost at least, per block of its length: a move whose drop is
#: above it passes a wall, and any cost above the cap keeps value iteration off it.
WALL = 64.0
#: The weight of the no-cheaper-than-the-drop loss: one move that costs too little opens a wall to every
#: block behind it, so it counts more than the error of one move's cost.
HINGE_WEIGHT = 10.0
#: Value iterations the cell loss trains the move costs through, after the values settle (without gradients).
GRAD_ITERATIONS = 4


def block_targets(cells: torch.Tensor, block: int) -> torch.Tensor:
    """Each block's cost-to-go: the least of its cells' (B, H, W), NaN where none is known."""
    B, H, W = cells.shape
    t = torch.where(torch.isfinite(cells), cells, torch.inf).view(B, H // block, block, W // block, block)
    t = t.amin((2, 4))
    return torch.where(torch.isfinite(t), t, torch.nan)


def _lengths(like: torch.Tensor) -> torch.Tensor:
    """``LENGTHS`` (the octile lengths of the 8 moves, cell or block) as (1, 8, 1, 1), of ``like``'s type and device."""
    return torch.tensor(LENGTHS, dtype=like.dtype, device=like.device).view(1, -1, 1, 1)


def path_moves(cells: torch.Tensor, block: int) -> torch.Tensor:
    """Each block's move along the grid search's path (B, h, w): an index into ``MOVES``, -1 where there is none.

    From the block's cell of least cost-to-go, the path's next cell (the neighbour of least cost-to-go
    plus length) lies in another block; the move is to that block. Training targets only.
    """
    B, H, W = cells.shape
    h, w = H // block, W // block
    t = torch.where(torch.isfinite(cells), cells, torch.inf)
    inner = t.view(B, h, block, w, block).permute(0, 1, 3, 2, 4).reshape(B, h, w, block * block)
    low, at = inner.min(-1)
    rows = torch.arange(h, device=cells.device).view(1, h, 1) * block + at // block
    cols = torch.arange(w, device=cells.device).view(1, 1, w) * block + at % block
    around = neighbours(t, torch.inf) + _lengths(t)
    b = torch.arange(B, device=cells.device).view(B, 1, 1)
    step = around[b, :, rows, cols].argmin(-1)  # (B, h, w): the cell move out of the block's best cell
    dr = torch.tensor([m[0] for m in MOVES], device=cells.device)[step]
    dc = torch.tensor([m[1] for m in MOVES], device=cells.device)[step]
    br = torch.div(rows + dr, block, rounding_mode="floor") - torch.arange(h, device=cells.device).view(1, h, 1)
    bc = torch.div(cols + dc, block, rounding_mode="floor") - torch.arange(w, device=cells.device).view(1, 1, w)
    code = (br + 1) * 3 + (bc + 1)  # 0..8, 4 = same block
    table = torch.full((9,), -1, dtype=torch.long, device=cells.device)
    for i, (mr, mc) in enumerate(MOVES):
        table[(mr + 1) * 3 + mc + 1] = i
    move = table[code]
    ok = torch.isfinite(low) & (low > 0) & (move >= 0)
    return torch.where(ok, move, -1)


def cost_losses(costs: torch.Tensor, cells: torch.Tensor, block: int) -> tuple[torch.Tensor, torch.Tensor]:
    """The move costs against the grid search's cost-to-go ``cells`` (B, H, W), in log steps: two losses.

    (the path's move should cost the drop in block cost-to-go it makes; no move may cost less than the
    drop it makes, up to ``WALL`` per block of length: a move that would gain more than that is through a wall).
    """
    tb = block_targets(cells, block)
    nb = neighbours(torch.nan_to_num(tb, nan=UNREACHED), UNREACHED)
    known = torch.isfinite(tb).unsqueeze(1) & (nb < UNREACHED)
    lengths = _lengths(costs)
    drop = torch.clamp(tb.unsqueeze(1) - nb, 0.5 * lengths, WALL * lengths)
    move = path_moves(cells, block)
    on = move >= 0
    pick = move.clamp_min(0).unsqueeze(1)
    zero = costs.sum() * 0
    log_c, log_d = costs.log(), drop.log()
    eq = nn.functional.smooth_l1_loss(log_c.gather(1, pick)[:, 0][on], log_d.gather(1, pick)[:, 0][on]) \
        if on.any() else zero
    under = torch.relu(log_d - log_c)[known]
    hinge = under.mean() if under.numel() else zero
    return eq, hinge


def vin_loss(net: RouteVIN, x: torch.Tensor, cells: torch.Tensor) -> torch.Tensor:
    """The training loss of ``net`` on a batch: ``route_input`` channels ``x`` and the search's cost-to-go ``cells``.

    The move-cost losses (``cost_losses``; the hinge weighted by ``HINGE_WEIGHT``) and the smooth-L1 error of
    every reached cell's predicted cost-to-go, through the last ``GRAD_ITERATIONS`` value iterations.
    """
    x = x[:, :net.block * net.block + 1]
    goal, walls = net.goal_and_walls(x)
    f, costs = net.move_costs(x)
    eq, hinge = cost_losses(costs, cells, net.block)
    v = net.settle(costs, goal, walls)
    v = net.iterate(costs, goal, walls, v, steps=GRAD_ITERATIONS)
    out = net.cell_field(f, v)
    known = torch.isfinite(cells) & (out < UNREACHED / 2)
    field = nn.functional.smooth_l1_loss(out[known], cells[known]) if known.any() else out.sum() * 0
    return eq + HINGE_WEIGHT * hinge + field
