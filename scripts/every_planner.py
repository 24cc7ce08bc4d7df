"""Every planner with the route field: default sampling, classical option, learned, ablation, exact.

    python scripts/every_planner.py --maps validation --n 4                 # the maps settings are chosen on (66 s)
    python scripts/every_planner.py --maps shifted unseen --n 10            # held-apart maps, measured once
    python scripts/every_planner.py --maps shifted --convergence --n 4      # RRT*: iterations to within 5% / 1%
    python scripts/every_planner.py --maps shifted --later-queries --n 4    # a roadmap built for one query, for others

Prints one row per (map set, planner, sampler): success, median iterations (samples for roadmaps; an unsolved
run counts at the budget), median collision checks and median time (sampler set-up in, compilation out). With
``--convergence``: RRT* variants' median iterations to come within 5% and 1% of the best known cost (the best
any compared run reached within the budget). With ``--later-queries``: PRM's samples for the map's query and for
three more on the same roadmap, and the share of those it answers with no new sample. A thin CLI over
``learning.evaluation.every_planner``, for the validation maps settings are chosen on and quick looks at a few
queries; on the test sets the comparison itself measures the same (``scripts/evaluate.py --other-planners
--convergence --later-queries``).
"""

from __future__ import annotations

import argparse

from learning.evaluation.convergence import BUDGET
from learning.evaluation.every_planner import (
    CLASSICAL,
    MAP_SETS,
    compare_planners,
    convergence,
    later_queries,
    planner_maps,
    rrtstar_setups,
    setups_for,
)
from planners.tools.benchmark import MAX_ITERATIONS


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--maps", nargs="+", choices=MAP_SETS, default=["validation"], help="map sets to run on")
    ap.add_argument("--n", type=int, default=4, help="queries per family")
    ap.add_argument("--seeds", type=int, default=2, help="planner seeds per query")
    ap.add_argument("--planners", nargs="+", choices=tuple(CLASSICAL), default=list(CLASSICAL))
    ap.add_argument("--max-iterations", type=int, default=MAX_ITERATIONS, help="budget per run")
    ap.add_argument("--convergence", action="store_true", help="RRT*'s iterations to within 5%% and 1%% instead")
    ap.add_argument("--budget", type=int, default=BUDGET, help="RRT* iterations per run with --convergence")
    ap.add_argument("--later-queries", action="store_true", help="PRM: a roadmap built for one query, for three more")
    args = ap.parse_args(argv)
    if min(args.n, args.seeds, args.budget, args.max_iterations) < 1:
        ap.error(f"--n {args.n}, --seeds {args.seeds}, --budget {args.budget} and --max-iterations "
                 f"{args.max_iterations}: expected at least 1 each")
    seeds = tuple(range(args.seeds))
    for which in args.maps:
        maps = planner_maps(which, args.n)
        if args.later_queries:
            for row in later_queries(maps, setups_for("PRM"), seeds=seeds, max_iterations=args.max_iterations):
                print(f"{row['map']:26s} {row['sampler']:15s} first query {row['first']:6.0f}  later queries "
                      f"{row['later']:6.0f}, mean {row['later_mean']:6.1f} (served as built {row['served']:.2f}, "
                      f"success {row['success']:.2f})",
                      flush=True)
        elif args.convergence:
            for row in convergence(maps, rrtstar_setups(), seeds=seeds, budget=args.budget):
                print(f"{row['map']:26s} {row['sampler']:15s} within 5%: {row['iterations_0.05']:6.0f} "
                      f"({row['success_0.05']:.2f})  within 1%: {row['iterations_0.01']:6.0f} "
                      f"({row['success_0.01']:.2f})  final/best {row['final_over_best']:.3f}", flush=True)
        else:
            compare_planners(maps, args.planners, seeds=seeds, max_iterations=args.max_iterations,
                             progress=lambda line: print(line, flush=True))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
