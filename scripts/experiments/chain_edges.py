"""The roadmaps' chain along the route where the roadmap's edges are bounded, on the validation maps.

    PYTHONPATH=$PWD python scripts/experiments/chain_edges.py                 # edges of one step (4 cells), as plan.py
    PYTHONPATH=$PWD python scripts/experiments/chain_edges.py --edge 8 --maps 12 --first-map 6

The comparison's PRM and Lazy-PRM have unbounded edges (k nearest neighbours at any distance), which the chain's
rule was chosen on (``tune_route_rules.py --chains``); a roadmap built with ``max_edge_length`` (``plan.py`` gives
PRM its step) tells the sampler its longest edge and the chain keeps its links within it (``CorridorSampler.at_edge``).
For PRM and Lazy-PRM with edges of at most ``--edge`` cells, the learned field's corridor with and without the chain
(``chain`` 64 and 0) on ``--maps`` validation maps of each family from its ``--first-map``-th, ``--seeds`` planner
seeds, at most 20,000 samples: per family the median samples (an unconnected run counts at the cap), their geometric
mean and the share connected. Validation maps only, never test maps.
"""

from __future__ import annotations

import argparse

import numpy as np

from learning.evaluation.every_planner import planner_maps
from learning.models.threads import planning_threads
from learning.samplers.registry import ModelCache, make_sampler
from learning.samplers.route_rules import CorridorSampler
from planners import make_planner

CAP = 20000


def main(argv: list[str] | None = None) -> int:
    """Command line entry point."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--edge", type=float, default=4.0, help="the roadmap's longest edge, in cells (default 4)")
    ap.add_argument("--maps", type=int, default=6, help="validation maps per family (default 6)")
    ap.add_argument("--first-map", type=int, default=0, help="each family's maps from its K-th on (default 0)")
    ap.add_argument("--seeds", type=int, default=2, help="planner seeds per map (default 2)")
    args = ap.parse_args(argv)
    if args.edge <= 0 or args.maps < 1 or args.first_map < 0 or args.seeds < 1:
        ap.error(f"--edge takes a length > 0, --maps and --seeds counts >= 1 and --first-map >= 0, got {args.edge}, "
                 f"{args.maps}, {args.seeds} and {args.first_map}")
    maps = {f: problems[args.first_map:] for f, problems in
            planner_maps("validation", args.first_map + args.maps).items()}
    models = ModelCache()
    with planning_threads(1):
        for planner in ("PRM", "LazyPRM"):
            for chain in (0.0, 64.0):
                medians, solved = [], []
                for problems in maps.values():
                    its = []
                    for p in problems:
                        for seed in range(args.seeds):
                            sampler = CorridorSampler(make_sampler("route", models=models), chain=chain)
                            r = make_planner(planner, p, sampler=sampler, seed=seed,
                                             max_edge_length=args.edge * p.world.resolution).solve(max_iterations=CAP)
                            its.append(r.iterations if r.solved else CAP)
                            solved.append(r.solved)
                    medians.append(float(np.median(its)))
                mean = float(np.exp(np.mean(np.log(medians))))
                print(f"{planner:8s} edge {args.edge:g} chain {chain:g}  geomean {mean:8.1f}  per family "
                      f"{' '.join(f'{m:7.1f}' for m in medians)}  connected {np.mean(solved):.2f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
