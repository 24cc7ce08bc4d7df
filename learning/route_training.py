"""Training the route encoder: the grid search's cost-to-go as targets (training only, never at inference)."""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np
import torch
from torch import nn

from learning.route import RouteNet, route_input, symmetry
from planners.maps.gridsearch import distance_field


def cost_targets(obstacles: np.ndarray, goal_cell: tuple[int, int], block: int) -> np.ndarray:
    """The grid search's cost-to-go of every cell in steps (``block`` cells), padded to whole blocks.

    NaN where a cell is blocked or cut off from the goal. Training only: inference never searches.
    """
    D = distance_field(obstacles, goal_cell)
    H, W = D.shape
    pad = np.full((-(-H // block) * block, -(-W // block) * block), np.nan)
    pad[:H, :W] = np.where(np.isfinite(D), D / block, np.nan)
    return pad


def thicken(obstacles: np.ndarray, radius: int) -> np.ndarray:
    """The obstacles grown by ``radius`` cells (a square neighbourhood): thicker walls, narrower gaps."""
    if radius == 0:
        return obstacles
    H, W = obstacles.shape
    pad = np.pad(obstacles, radius)
    return np.logical_or.reduce([pad[radius + dy:radius + dy + H, radius + dx:radius + dx + W]
                                 for dy in range(-radius, radius + 1) for dx in range(-radius, radius + 1)])


def check_speckle(speckle: float) -> None:
    """``train_route_net``'s rule for ``speckle``: a density in [0, 1) (ValueError otherwise)."""
    if not 0.0 <= speckle < 1.0:
        raise ValueError(f"speckle = {speckle}, expected a density in [0, 1)")


def speckled(obstacles: np.ndarray, goal: tuple[int, int], density: float, rng: np.random.Generator) -> np.ndarray:
    """The obstacles with each cell also blocked with probability ``density``; the goal cell stays as it was."""
    out = obstacles | (rng.random(obstacles.shape) < density)
    out[goal] = obstacles[goal]
    return out


def train_route_net(problems: Sequence, *, block: int = 4, channels: int = 24, depth: int = 4, attention: int = 0,
                    attention_level: int = 0, epochs: int = 40, batch: int = 32, lr: float = 1e-3,
                    grad_weight: float = 0.0, augment: bool = False, thicken_radius: int = 0, speckle: float = 0.0,
                    seed: int = 0, log=print) -> RouteNet:
    """Fit a ``RouteNet`` to the grid search's cost-to-go on ``problems`` (grid problems; one map size per batch).

    The loss is the smooth-L1 error of the predicted cost-to-go, in steps, over the free cells that reach
    the goal, plus ``grad_weight`` times the L1 error of its differences between neighbouring cells
    (the sampler walks down the field, so its slope matters more than its level far from the
    goal). With ``augment`` every map is first turned by one of the square's 8 symmetries, drawn from
    ``seed``: the generators' fixed orientations (start and goal corners, trap openings) stop being
    something to learn. With ``thicken_radius`` R every map's obstacles are first grown by a radius drawn
    from 0..R (``thicken``; kept as generated where that would block the goal): wall thicknesses and
    gap widths the generators never make. With ``speckle`` P every map then gets single blocked cells
    at a density drawn from [0, P) per map (``speckled``; never on the goal): cell-level clutter, which
    the generators draw only as whole blocks. Same seed, same machine: the same weights.
    """
    check_speckle(speckle)
    torch.manual_seed(seed)
    turns = np.random.default_rng(seed).integers(0, 8, len(problems)) if augment else np.zeros(len(problems), int)
    # a stream of its own: recipes without it draw the same turns as before
    radii = np.random.default_rng([seed, 1]).integers(0, thicken_radius + 1, len(problems))
    clutter = np.random.default_rng([seed, 2])  # and another, drawn from only when speckle > 0
    by_size: dict[tuple[int, int], list] = {}
    for p, k, radius in zip(problems, turns, radii, strict=True):
        goal = p.world.cell_of(p.goal)
        obs = thicken(p.world.obstacles, int(radius))
        if obs[goal]:
            obs = p.world.obstacles
        if speckle > 0:
            obs = speckled(obs, goal, clutter.uniform(0.0, speckle), clutter)
        obs, goal = symmetry(obs, goal, int(k))
        by_size.setdefault(obs.shape, []).append((route_input(obs, goal, block), cost_targets(obs, goal, block)))
    data = [(torch.tensor(np.stack([e[0] for e in v])), None,
             torch.tensor(np.stack([e[1] for e in v]), dtype=torch.float32)) for v in by_size.values()]
    net = RouteNet(block, channels, depth, attention, attention_level,
                   trained_side=max(max(p.world.obstacles.shape) for p in problems))
    opt = torch.optim.Adam(net.parameters(), lr)
    order = torch.Generator().manual_seed(seed)
    t0 = time.perf_counter()
    for epoch in range(epochs):
        batches = [(i, idx) for i, (X, _, _) in enumerate(data)
                   for idx in torch.randperm(len(X), generator=order).split(batch)]
        total = 0.0
        for j in torch.randperm(len(batches), generator=order).tolist():
            i, idx = batches[j]
            X, _, Yc = data[i]
            out = net(X[idx])
            yc = Yc[idx]
            known = torch.isfinite(yc)
            loss = nn.functional.smooth_l1_loss(out[known], yc[known])
            if grad_weight:
                for dim in (1, 2):
                    dy, do = yc.diff(dim=dim), out.diff(dim=dim)
                    both = torch.isfinite(dy)
                    if both.any():
                        loss = loss + grad_weight * (do[both] - dy[both]).abs().mean()
            opt.zero_grad()
            loss.backward()
            opt.step()
            total += loss.item() * len(idx)
        log(f"epoch {epoch}: loss {total / sum(len(d[0]) for d in data):.3f} ({time.perf_counter() - t0:.0f} s)")
    return net.eval()
