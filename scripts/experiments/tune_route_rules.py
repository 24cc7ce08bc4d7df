"""The roadmaps' corridor (``learning.samplers.route_rules.CorridorSampler``) tuned on validation maps.

    python scripts/experiments/tune_route_rules.py --maps 6 --seeds 2

For each field (the route encoder, its straight-line ablation, the exact cost-to-go) and each corridor
``margin`` and uniform ``floor`` of the grid, PRM and Lazy-PRM run on the five families' validation maps
(``learning.evaluation.every_planner.planner_maps("validation")``; never test maps); prints the median samples per
family and their geometric mean, the score the settings are chosen by (lowest), with the success share.
"""

from __future__ import annotations

import argparse
import itertools

import numpy as np

from learning.evaluation.every_planner import Setup, planner_maps, run_setup, summarize_runs
from learning.samplers.registry import ModelCache, make_sampler
from learning.samplers.route_rules import CorridorSampler


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--maps", type=int, default=6, help="validation maps per family")
    ap.add_argument("--seeds", type=int, default=2, help="planner seeds per map")
    ap.add_argument("--margins", type=float, nargs="+", default=[0.1, 0.3, 0.6, 1.0])
    ap.add_argument("--floors", type=float, nargs="+", default=[0.1, 0.3])
    ap.add_argument("--fields", nargs="+", default=["route", "route_ablation", "exact_route"])
    ap.add_argument("--planners", nargs="+", default=["PRM", "LazyPRM"])
    args = ap.parse_args(argv)
    maps = planner_maps("validation", args.maps)
    models = ModelCache()
    for planner in args.planners:
        for field, margin, floor in itertools.product(args.fields, args.margins, args.floors):
            medians, success = [], []
            for problems in maps.values():
                runs = [run_setup(Setup(field, planner, field), p, s, models=models,
                                  sampler=CorridorSampler(make_sampler(field, models=models), margin, floor))
                        for p in problems for s in range(args.seeds)]
                row = summarize_runs(runs)
                medians.append(row["iterations"])
                success.append(row["success"])
            score = float(np.exp(np.mean(np.log(medians))))
            print(f"{planner:8s} {field:15s} margin {margin:4.2f} floor {floor:4.2f}  geomean {score:7.1f}  "
                  f"per family {' '.join(f'{m:6.0f}' for m in medians)}  success {min(success):.2f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
