"""The value-iteration route encoder on the validation maps, against what it is made of.

    python scripts/experiments/vin_validation.py                     # the shipped encoder, sides 128 and 256
    python scripts/experiments/vin_validation.py --route runs/route/route.pt --maps 6 --sides 128 256
    python scripts/experiments/vin_validation.py --maps 12 --offset 600 --walk 0.1 0   # other maps, another walk

Medians of RRT iterations (step 4, tolerance 4, cap 20,000; planner seeds 0 and 1, ``--first-seed``) on
validation maps of the training families (the five test families', caves and strokes; seeds from
``VALIDATION_SEED0 + 500`` by default, ``--offset``; never test maps), at sides the encoder trained on (128)
and beyond (256), for:

- the route ablation (the straight line in place of the field: no learning),
- value iteration without learning: the same value iteration over the block grid with every move costing its
  length on blocks with any free cell (what the structure gives before any learning),
- the route encoder (the learned move costs and cell head),
- the exact cost-to-go at the same settings (the reference that shows the room).

``--step-walls off`` lets value iteration take a block move that no cell can step, where the network prices it
below the wall threshold (the shipped inference makes it a wall: ``RouteVIN.step_walls``). Prints one row per
family and side with the share of the room the encoder closes, ``(ablation - encoder) / (ablation - exact)`` where
the room is at least 20% of the ablation's median.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import torch

from learning.models.route_net import load_route_net
from learning.models.route_vin import WALL_COST, RouteVIN
from learning.references.expert import GeodesicRouteSampler
from learning.samplers.route import ABLATION_SETTINGS, SHIPPED, SHIPPED_SETTINGS, RouteSampler
from planners import make_planner
from planners.maps.generators import TRAINING_FAMILIES, VALIDATION_SEED0, generate
from planners.tools.benchmark import MAX_ITERATIONS, STEP

sys.path.insert(0, str(Path(__file__).resolve().parent))  # this folder's modules
from long_mazes import wall_cost_arg  # noqa: E402

#: The table's columns, in order.
SAMPLERS = ("ablation", "value iteration, no learning", "route encoder", "exact")


class LengthCosts(RouteVIN):
    """``RouteVIN``'s value iteration with nothing learned: every move costs its length; a block's cells share its
    value."""

    map_cache_bytes = 0  # its own move costs and cell field: every pass is a whole one

    def move_costs(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        b, _, h, w = x.shape
        return x.new_zeros(b, 1, h, w), self.lengths.expand(b, 8, h, w).clone()

    def cell_field(self, f: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
        return v.repeat_interleave(self.block, -1).repeat_interleave(self.block, -2)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--route", type=Path, default=SHIPPED, help="a value-iteration encoder file (default: shipped)")
    ap.add_argument("--maps", type=int, default=6, help="validation maps per family and side")
    ap.add_argument("--offset", type=int, default=500,
                    help="the first map's seed after VALIDATION_SEED0 (default 500; maps offset .. offset + maps - 1)")
    ap.add_argument("--sides", type=int, nargs="+", default=[128, 256])
    ap.add_argument("--seeds", type=int, default=2, help="planner seeds per map (default 2)")
    ap.add_argument("--first-seed", type=int, default=0,
                    help="the first planner seed (default 0: seeds 0 .. seeds - 1); another shows the medians' noise")
    ap.add_argument("--families", nargs="+", default=list(TRAINING_FAMILIES))
    ap.add_argument("--samplers", nargs="+", choices=SAMPLERS, default=list(SAMPLERS),
                    help="which columns to run (default: all)")
    ap.add_argument("--walk", type=float, nargs=2, metavar=("RIPPLE", "GROWTH"),
                    default=[SHIPPED_SETTINGS["ripple"], SHIPPED_SETTINGS["ripple_growth"]],
                    help="the walk's ripple tolerance and its growth per step of cost-to-go for the encoder, value "
                         "iteration without learning and the exact reference (default: the shipped settings)")
    ap.add_argument("--ablation-walk", type=float, nargs=2, metavar=("RIPPLE", "GROWTH"),
                    default=[ABLATION_SETTINGS["ripple"], ABLATION_SETTINGS["ripple_growth"]],
                    help="the same for the ablation (default: its settings, a strictly downhill walk)")
    ap.add_argument("--sight", choices=("on", "off"), default="on" if SHIPPED_SETTINGS["sight"] else "off",
                    help="cut the walk to the target where it leaves the sight of the progress cell, for the encoder, "
                         "value iteration without learning and the exact reference (default: the shipped setting)")
    ap.add_argument("--ablation-sight", choices=("on", "off"),
                    default="on" if ABLATION_SETTINGS["sight"] else "off",
                    help="the same for the ablation (default: its setting)")
    ap.add_argument("--step-walls", choices=("on", "off"), default="on" if RouteVIN.step_walls else "off",
                    help="treat a block move that no cell can step as a wall at inference, for the encoder and the "
                         "value iteration without learning (default: the shipped setting)")
    ap.add_argument("--wall-cost", type=wall_cost_arg, default=WALL_COST, metavar="K|none",
                    help=f"the encoder's inference: a move priced above K blocks per block of length is a wall "
                         f"(default the shipped {WALL_COST:g}; none: no threshold)")
    args = ap.parse_args(argv)
    if args.seeds < 1 or args.first_seed < 0 or args.maps < 1:
        ap.error(f"--maps and --seeds take counts >= 1 and --first-seed a seed >= 0, got {args.maps}, {args.seeds} "
                 f"and {args.first_seed}")
    if min(args.walk + args.ablation_walk) < 0:
        ap.error(f"--walk and --ablation-walk take depths >= 0, got {args.walk} and {args.ablation_walk}")
    net = load_route_net(args.route)
    plain = LengthCosts(net.block, 1, 1, net.step).eval()
    net.step_walls = plain.step_walls = args.step_walls == "on"
    net.wall_cost = args.wall_cost
    walk = {"ripple": args.walk[0], "ripple_growth": args.walk[1], "sight": args.sight == "on"}
    settings = {**SHIPPED_SETTINGS, **walk}
    samplers = {
        "ablation": lambda: RouteSampler(None, **{**ABLATION_SETTINGS, "ripple": args.ablation_walk[0],
                                                  "ripple_growth": args.ablation_walk[1],
                                                  "sight": args.ablation_sight == "on"}),
        "value iteration, no learning": lambda: RouteSampler(plain, **settings),
        "route encoder": lambda: RouteSampler(net, **settings),
        "exact": lambda: GeodesicRouteSampler(**settings),
    }
    samplers = {name: make for name, make in samplers.items() if name in args.samplers}
    print("| family | side | " + " | ".join(samplers) + " | share closed | unsolved (" + ", ".join(samplers) + ") |")
    print("|---|---|" + "---|" * (len(samplers) + 2))
    for family in args.families:
        for side in args.sides:
            its: dict[str, list[int]] = {name: [] for name in samplers}
            for i in range(args.maps):
                p = generate(family, VALIDATION_SEED0 + args.offset + i, side)
                for name, make in samplers.items():
                    for seed in range(args.first_seed, args.first_seed + args.seeds):
                        r = make_planner("RRT", p, extension_step=STEP, sampler=make(), seed=seed).solve(
                            max_iterations=MAX_ITERATIONS)
                        its[name].append(r.first_solution_iteration if r.solved else MAX_ITERATIONS)
            med = {name: float(np.median(v)) for name, v in its.items()}
            a, e, learned = (med.get(k, math.nan) for k in ("ablation", "exact", "route encoder"))
            if math.isnan(a + e + learned):
                share = "-"
            else:
                share = f"{(a - learned) / (a - e):.2f}" if a - e >= 0.2 * a else "no room"
            unsolved = ", ".join(str(sum(x >= MAX_ITERATIONS for x in v)) for v in its.values())
            print(f"| {family} | {side} | " + " | ".join(f"{v:g}" for v in med.values()) + f" | {share} | {unsolved} |",
                  flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
