"""Probe for issue 18's route context: can a small learned map encoder tell where the route runs?

    python scripts/experiments/route_probe.py                          # dilated CNN, 200 maps per family, 20 epochs
    python scripts/experiments/route_probe.py --model recurrent  # one shared 3x3 update applied 40 times (VIN-like)
    python scripts/experiments/route_probe.py --model recurrent --channels 8 --iterations 20   # cheaper
    python scripts/experiments/route_probe.py --model unet --input cells   # multiscale, sees every cell of each block

The learned sampler fails where the route turns away from the goal (``scripts/experiments/imitation_ceiling.py``).
This measures whether a network that sees the whole map once per query, with no search at
inference, could supply that: per block of ``--block`` cells (one planner step), it predicts the
direction (16 bins) in which the shortest path leaves the block's best cell, ``--ahead`` cells along.
Training targets come from the grid search (allowed at training time); the network's input is the
map's blocked fraction per block (``--input cells``: every cell of the block, one channel each, so a
gap or a wall inside a block is not averaged away), the goal's block and the offset to the goal.

Printed per family, on validation maps: how often "straight at the goal" and the network are within one
bin of the route's direction, on all blocks and on the blocks where the route turns away from the goal;
and the network's forward time on one 128x128 map (32x32 blocks), the cost per query it would add.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
import torch
from torch import nn

from learning.models.route_net import UNet
from planners.base.fileio import InputError, check_int_flags
from planners.maps.generators import FAMILIES, MIN_SIZE, TRAIN_SEEDS, VALIDATION_SEED0, generate
from planners.maps.gridsearch import distance_field
from planners.tools.benchmark import markdown_table

ANGLES = 16


def _descent(D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Row and column of each cell's neighbour one octile step closer to the goal (no corner cutting)."""
    H, W = D.shape
    pad = np.full((H + 2, W + 2), np.inf)
    pad[1:-1, 1:-1] = D
    best = np.full((H, W), np.inf)
    nr, nc = np.mgrid[0:H, 0:W]
    rows, cols = nr.copy(), nc.copy()
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            if dr == dc == 0:
                continue
            v = pad[1 + dr:H + 1 + dr, 1 + dc:W + 1 + dc]
            if dr and dc:
                v = np.where(np.isinf(pad[1 + dr:H + 1 + dr, 1:W + 1]) | np.isinf(pad[1:H + 1, 1 + dc:W + 1 + dc]),
                             np.inf, v)
            m = v < best
            best[m], nr[m], nc[m] = v[m], (rows + dr)[m], (cols + dc)[m]
    return nr, nc


def _bin(dr: float, dc: float) -> int:
    return int((math.atan2(dr, dc) % (2 * math.pi)) / (2 * math.pi) * ANGLES + 0.5) % ANGLES


def example(family: str, seed: int, size: int, block: int, ahead: int,
            cells: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(input (c, h, w), route direction per block (-1: none), straight-at-the-goal direction per block).

    The input's first channels are the blocked fraction per block (one channel) or, with ``cells``,
    each cell of the block (``block**2`` channels); the last three mark the goal's block and the
    offset to it.
    """
    p = generate(family, seed, size)
    obs = p.world.obstacles
    gr, gc = p.world.cell_of(p.goal)
    D = distance_field(obs, (gr, gc))
    nr, nc = _descent(D)
    h, w = obs.shape[0] // block, obs.shape[1] // block
    per_block = D[:h * block, :w * block].reshape(h, block, w, block).transpose(0, 2, 1, 3).reshape(h, w, -1)
    k = per_block.argmin(2)
    route, goalward = np.full((h, w), -1), np.full((h, w), -1)
    for i in range(h):
        for j in range(w):
            d = per_block[i, j, k[i, j]]
            if not np.isfinite(d) or d < ahead:
                continue
            r0, c0 = i * block + k[i, j] // block, j * block + k[i, j] % block
            r, c = r0, c0
            for _ in range(ahead):
                r, c = nr[r, c], nc[r, c]
            route[i, j], goalward[i, j] = _bin(r - r0, c - c0), _bin(gr - r0, gc - c0)
    blocks = obs[:h * block, :w * block].reshape(h, block, w, block)
    first = list(blocks.transpose(1, 3, 0, 2).reshape(-1, h, w)) if cells else [blocks.mean((1, 3))]
    ys, xs = np.mgrid[0:h, 0:w]
    x = np.stack([*first, (ys == gr // block) & (xs == gc // block), (gc // block - xs) / w, (gr // block - ys) / h])
    return x.astype(np.float32), route, goalward


class Recurrent(nn.Module):
    """Value-iteration-like: one shared 3x3 update applied ``k`` times over the block grid."""

    def __init__(self, channels: int = 24, k: int = 40, inputs: int = 4) -> None:
        super().__init__()
        self.inp = nn.Conv2d(inputs, channels, 3, padding=1)
        self.step = nn.Conv2d(channels, channels, 3, padding=1)
        self.out = nn.Conv2d(2 * channels, ANGLES, 3, padding=1)
        self.k = k

    def forward(self, x):
        e = self.inp(x)
        h = torch.relu(e)
        for _ in range(self.k):
            h = torch.relu(e + self.step(h))
        return self.out(torch.cat([h, torch.relu(e)], 1))


def dilated(channels: int = 32, dilations=(1, 2, 4, 8, 16, 1), inputs: int = 4) -> nn.Module:
    layers: list[nn.Module] = [nn.Conv2d(inputs, channels, 3, padding=1), nn.ReLU()]
    for d in dilations:
        layers += [nn.Conv2d(channels, channels, 3, padding=d, dilation=d), nn.ReLU()]
    return nn.Sequential(*layers, nn.Conv2d(channels, ANGLES, 1))


def _near(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = np.abs(a - b)
    return np.minimum(d, ANGLES - d) <= 1


def main(argv=None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", choices=("dilated", "recurrent", "unet"), default="dilated")
    ap.add_argument("--input", choices=("fraction", "cells"), default="fraction",
                    help="per block: its blocked fraction, or each of its cells")
    ap.add_argument("--maps", type=int, default=200, help="training maps per family")
    ap.add_argument("--val-maps", type=int, default=40, help="validation maps per family")
    ap.add_argument("--epochs", type=int, default=20)
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--block", type=int, default=4, help="cells per block (the planner's step)")
    ap.add_argument("--ahead", type=int, default=8, help="cells along the route that give its direction")
    ap.add_argument("--channels", type=int, default=24, help="recurrent model: channels of its state")
    ap.add_argument("--iterations", type=int, default=40, help="recurrent model: times its 3x3 update is applied")
    ap.add_argument("--depth", type=int, default=4, help="unet model: times the grid is halved")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    try:
        check_int_flags(args, ("maps", "val_maps", "epochs", "size", "block", "ahead", "channels", "iterations",
                                "depth"))
        if args.size < MIN_SIZE:
            raise InputError(f"--size must be at least {MIN_SIZE} (the smallest generated map), got {args.size}")
        if args.size < 2 * args.block:
            raise InputError(f"--size {args.size} holds fewer than two blocks of --block {args.block} cells")
    except InputError as exc:
        ap.error(str(exc))
    torch.manual_seed(args.seed)
    t0 = time.perf_counter()
    cells = args.input == "cells"
    train = [example(f, TRAIN_SEEDS[0] + s, args.size, args.block, args.ahead, cells) for f in FAMILIES
             for s in range(args.maps)]
    X = torch.tensor(np.stack([e[0] for e in train]))
    Y = torch.tensor(np.stack([e[1] for e in train]))
    inputs = X.shape[1]
    if args.model == "recurrent":
        model = Recurrent(args.channels, args.iterations, inputs)
    elif args.model == "unet":
        model = UNet(inputs, ANGLES, args.channels, args.depth)
    else:
        model = dilated(inputs=inputs)
    opt = torch.optim.Adam(model.parameters(), 1e-3)
    order = torch.Generator().manual_seed(args.seed)
    for epoch in range(args.epochs):
        perm = torch.randperm(len(X), generator=order)
        total = 0.0
        for b in range(0, len(X), 32):
            idx = perm[b:b + 32]
            loss = nn.functional.cross_entropy(model(X[idx]), Y[idx], ignore_index=-1)
            opt.zero_grad()
            loss.backward()
            opt.step()
            total += loss.item() * len(idx)
        print(f"epoch {epoch}: loss {total / len(X):.3f} ({time.perf_counter() - t0:.0f} s)", flush=True)
    model.eval()
    rows = []
    with torch.no_grad():
        for f in FAMILIES:
            val = [example(f, VALIDATION_SEED0 + 100 + s, args.size, args.block, args.ahead, cells)
                   for s in range(args.val_maps)]
            pred = model(torch.tensor(np.stack([e[0] for e in val]))).argmax(1).numpy()
            route, goalward = np.stack([e[1] for e in val]), np.stack([e[2] for e in val])
            known = route >= 0
            turns = known & ~_near(goalward, route)
            rows.append({"family": f, "blocks": int(known.sum()),
                         "straight at the goal": f"{_near(goalward, route)[known].mean():.2f}",
                         "network": f"{_near(pred, route)[known].mean():.2f}",
                         "blocks where the route turns away": f"{turns.sum() / max(known.sum(), 1):.2f}",
                         "network there": f"{_near(pred, route)[turns].mean():.2f}" if turns.any() else "-"})
        one = torch.zeros(1, inputs, 128 // args.block, 128 // args.block)
        t1 = time.perf_counter()
        for _ in range(20):
            model(one)
        ms = (time.perf_counter() - t1) / 20 * 1e3
    print(markdown_table(rows))
    params = sum(p.numel() for p in model.parameters())
    print(f"\n{args.model}: {params:,} parameters; forward on a 128x128 map ({128 // args.block}x{128 // args.block} "
          f"blocks) {ms:.2f} ms with torch on this CPU; {time.perf_counter() - t0:.0f} s in all")
    return rows


if __name__ == "__main__":
    main()
