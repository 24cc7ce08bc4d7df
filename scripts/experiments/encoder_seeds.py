"""Route encoder files side by side on the validation maps at the shipped settings: what another seed gives.

    python scripts/train_route.py --seed 1 --out runs/seed1          # another seed of the shipped recipe
    python scripts/experiments/encoder_seeds.py learning/data/route.pt runs/seed1/route.pt

RRT (step 4, tolerance 4, cap 20,000; planner seeds 0 and 1) on the validation maps ``vin_validation.py`` uses
by default (6 maps per training family from ``VALIDATION_SEED0 + 500``, sides 128 and 256; never test maps),
each file's encoder in ``RouteSampler`` at ``SHIPPED_SETTINGS``. Prints per family and side, and pooled, the
median iterations and (in brackets) the unsolved runs of each file.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from learning.models.route_net import load_route_net
from learning.samplers.route import SHIPPED_SETTINGS, RouteSampler
from planners import make_planner
from planners.maps.generators import VALIDATION_SEED0, generate
from planners.tools.benchmark import MAX_ITERATIONS, STEP

FAMILIES = ("forest", "narrow_passage", "bugtrap", "maze", "rooms", "caves", "strokes")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("files", nargs="+", type=Path, help="route encoder files (route.pt)")
    ap.add_argument("--maps", type=int, default=6)
    ap.add_argument("--sides", type=int, nargs="+", default=[128, 256])
    args = ap.parse_args(argv)
    nets = [load_route_net(f) for f in args.files]
    print("| family | side | " + " | ".join(str(f) for f in args.files) + " |")
    print("|---|---|" + "---|" * len(args.files))
    pooled: list[list[int]] = [[] for _ in args.files]
    for family in FAMILIES:
        for side in args.sides:
            cells = []
            for k, net in enumerate(nets):
                its = []
                for i in range(args.maps):
                    p = generate(family, VALIDATION_SEED0 + 500 + i, side)
                    for seed in (0, 1):
                        r = make_planner("RRT", p, extension_step=STEP, sampler=RouteSampler(net, **SHIPPED_SETTINGS),
                                         seed=seed).solve(max_iterations=MAX_ITERATIONS)
                        its.append(r.first_solution_iteration if r.solved else MAX_ITERATIONS)
                pooled[k] += its
                cells.append(f"{np.median(its):g} ({sum(x >= MAX_ITERATIONS for x in its)})")
            print(f"| {family} | {side} | " + " | ".join(cells) + " |", flush=True)
    print("| pooled | | " + " | ".join(f"{np.median(v):g} ({sum(x >= MAX_ITERATIONS for x in v)})"
                                      for v in pooled) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
