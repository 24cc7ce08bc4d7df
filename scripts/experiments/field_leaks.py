"""Where value iteration leaks through a wall: the learned field against the exact cost-to-go on one query.

    python scripts/experiments/field_leaks.py lak303d --step-walls off   # the leak, as before the step walls
    python scripts/experiments/field_leaks.py lak303d                    # the shipped inference

For the map's longest scenario (``--movingai`` or ``SAMPLERGYM_MOVINGAI_DIR``): the start's cost-to-go in cells by
the shipped encoder and by the grid search, the rank correlation of the two fields over the free cells, and the
block moves that no cell can step (``learning.models.route_vin.cell_steps``) but that the network prices below the
drop in exact cost-to-go they make, those that skip a detour (a drop above ``DETOUR`` blocks per block of length)
listed with their prices. The shipped inference makes such moves walls (``RouteVIN.step_walls``); ``--step-walls
off`` lets value iteration take them. A diagnosis of one query: nothing here is chosen on it.
"""

from __future__ import annotations

import argparse

import numpy as np
import torch

from learning.evaluation.protocol import scenarios
from learning.models.route_net import load_route_net, route_input
from learning.models.route_vin import MOVES, RouteVIN, cell_steps
from learning.samplers.route import SHIPPED
from learning.training.vin_losses import block_targets
from planners import movingai_dir
from planners.base.fileio import InputError
from planners.maps.gridsearch import distance_field

#: A drop in exact cost-to-go above this many blocks per block of length: the move skips a detour behind a wall.
DETOUR = 16.0


def ranks(a: np.ndarray) -> np.ndarray:
    return np.argsort(np.argsort(a))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("map", help="a MovingAI map's name, e.g. lak303d")
    ap.add_argument("--movingai", default=None,
                    help="the MovingAI folder (default: SAMPLERGYM_MOVINGAI_DIR, else ../shared)")
    ap.add_argument("--step-walls", choices=("on", "off"), default="on" if RouteVIN.step_walls else "off",
                    help="a block move no cell can step is a wall (default: the shipped setting)")
    args = ap.parse_args(argv)
    try:
        problems = scenarios(str(movingai_dir(args.movingai)), args.map, 4.0)
    except (InputError, OSError, ValueError) as exc:
        ap.error(str(exc))
    p = max(problems, key=lambda q: q.reference_length or 0.0)
    obstacles, goal, start = p.world.obstacles, p.world.cell_of(p.goal), p.world.cell_of(p.start)
    net = load_route_net(SHIPPED).eval()
    net.step_walls = args.step_walls == "on"
    exact = distance_field(obstacles, goal)
    learned = net.predict(obstacles, goal) * net.step
    free = np.isfinite(exact)
    corr = np.corrcoef(ranks(exact[free]), ranks(learned[free]))[0, 1]
    print(f"{p.name}: start {start}, goal {goal}; cost-to-go at the start: learned {learned[start]:.1f} cells, "
          f"exact {exact[start]:.1f}; rank correlation over the free cells {corr:.4f}")
    x = torch.from_numpy(route_input(obstacles, goal, net.block)[None])[:, :net.block ** 2 + 1]
    with torch.inference_mode():
        _, costs = net.move_costs(x)
        steps = cell_steps(x, net.block)[0].numpy()
    costs = costs[0].numpy()
    b = net.block
    h, w = costs.shape[1:]
    pad = np.full((h * b, w * b), np.inf)
    pad[:exact.shape[0], :exact.shape[1]] = exact / b
    blocks = block_targets(torch.from_numpy(pad)[None], b)[0].numpy()  # each block's least exact cost-to-go, NaN: none
    leaks = []
    for a, (dr, dc) in enumerate(MOVES):
        length = float(np.hypot(dr, dc))
        for r, c in zip(*np.nonzero(~steps[a]), strict=True):
            rr, cc = r + dr, c + dc
            if 0 <= rr < h and 0 <= cc < w and np.isfinite(blocks[r, c]) and np.isfinite(blocks[rr, cc]):
                drop = (blocks[r, c] - blocks[rr, cc]) / length
                if costs[a, r, c] / length < drop:
                    leaks.append((float(costs[a, r, c]) / length, drop, (int(r), int(c)), (dr, dc)))
    skips = sorted((leak for leak in leaks if leak[1] > DETOUR), key=lambda leak: -leak[1])
    print(f"block moves no cell can step, priced below the drop they make: {len(leaks)}; of those, skipping a "
          f"detour (a drop above {DETOUR:g} blocks per block of length): {len(skips)}")
    for price, drop, block, move in skips[:10]:
        print(f"  block {block} move {move}: {price:.1f} blocks per length, drop {drop:.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
