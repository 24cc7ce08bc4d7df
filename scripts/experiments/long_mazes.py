"""The route encoder on long winding routes: validation mazes whose corridors keep the training width at any side.

    python scripts/experiments/long_mazes.py                 # sides 256 and 512, 4 maps each, 2 planner seeds
    python scripts/experiments/long_mazes.py --sides 512 --maps 8
    python scripts/experiments/long_mazes.py --diagonal --sides 256 --maps 6 --offset 1100   # walls at a slant
    python scripts/experiments/long_mazes.py --route runs/route/route.pt                     # another encoder

``planners.maps.generators.long_maze`` (the training maze's 16-cell corridors and 1-2-cell walls, on a larger
map: more corridors, a longer route) on seeds from ``VALIDATION_SEED0 + offset``. Medians of iterations-to-solution
(the cap counting for an unsolved run) of the route ablation, the shipped route encoder and the exact reference,
RRT at the evaluation's step and cap, beside the success rates. No test map is used. ``--wall-cost none`` runs the
encoder without its inference threshold on wall prices (``learning.models.route_vin.WALL_COST``), and
``--step-walls off`` lets value iteration take a block move that no cell can step where the network prices it below
the threshold (the shipped inference makes it a wall whatever its price: ``learning.models.route_vin.cell_steps``,
``RouteVIN.step_walls``).
``--diagonal`` turns the mazes by 45 degrees (``diagonal_maze``): their walls become staircases at a slant.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from learning.models.route_net import load_route_net
from learning.models.route_vin import WALL_COST, RouteVIN
from learning.samplers.registry import make_sampler
from learning.samplers.route import SHIPPED, shipped_sampler
from planners import make_planner
from planners.maps.generators import VALIDATION_SEED0, diagonal_maze, long_maze
from planners.tools.benchmark import MAX_ITERATIONS, STEP


def wall_cost_arg(text: str) -> float | None:
    """``--wall-cost``: a number of blocks > 0, or none (no threshold on wall prices)."""
    if text.lower() == "none":
        return None
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not value > 0:
        raise argparse.ArgumentTypeError(f"takes a number of blocks > 0 or none, got {text!r}")
    return value


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sides", type=int, nargs="+", default=[256, 512])
    ap.add_argument("--maps", type=int, default=4, help="validation maps per side (default 4)")
    ap.add_argument("--offset", type=int, default=800, help="the first map's seed after VALIDATION_SEED0 (default 800)")
    ap.add_argument("--seeds", type=int, default=2, help="planner seeds per map (default 2)")
    ap.add_argument("--wall-cost", type=wall_cost_arg, default=WALL_COST, metavar="K|none",
                    help=f"the encoder's inference: a move priced above K blocks per block of length is a wall "
                         f"(default the shipped {WALL_COST:g}; none: no threshold)")
    ap.add_argument("--step-walls", choices=("on", "off"), default="on" if RouteVIN.step_walls else "off",
                    help="treat a block move that no cell can step as a wall at inference (default: the shipped "
                         "setting)")
    ap.add_argument("--diagonal", action="store_true", help="the mazes turned by 45 degrees (diagonal_maze)")
    ap.add_argument("--route", type=Path, default=SHIPPED, help="a value-iteration encoder file (default: shipped)")
    args = ap.parse_args(argv)
    if args.maps < 1 or args.seeds < 1 or args.offset < 0 or min(args.sides) < 64:
        ap.error(f"--maps and --seeds take counts >= 1, --offset a number >= 0 and --sides sides >= 64; got "
                 f"{args.maps}, {args.seeds}, {args.offset} and {args.sides}")
    if not args.route.is_file():
        ap.error(f"--route {args.route}: no such file")
    net = load_route_net(args.route)
    net.wall_cost = args.wall_cost
    net.step_walls = args.step_walls == "on"
    build = diagonal_maze if args.diagonal else long_maze
    samplers = {"ablation": lambda: make_sampler("route_ablation"), "route encoder": lambda: shipped_sampler(net),
                "exact": lambda: make_sampler("exact_route")}
    print("| side | " + " | ".join(f"{name}: median (success)" for name in samplers) + " |")
    print("|---|" + "---|" * len(samplers))
    for side in args.sides:
        its: dict[str, list[int]] = {name: [] for name in samplers}
        for i in range(args.maps):
            problem = build(VALIDATION_SEED0 + args.offset + i, side)
            for name, make in samplers.items():
                for seed in range(args.seeds):
                    r = make_planner("RRT", problem, extension_step=STEP, sampler=make(),
                                     seed=seed).solve(max_iterations=MAX_ITERATIONS)
                    its[name].append(r.first_solution_iteration if r.solved else MAX_ITERATIONS)
        cells = [f"{np.median(v):g} ({np.mean(np.array(v) < MAX_ITERATIONS):.2f})" for v in its.values()]
        print(f"| {side} | " + " | ".join(cells) + " |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
