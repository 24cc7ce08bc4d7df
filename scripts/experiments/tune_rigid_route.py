"""Which share of route samples (``route_fraction``) the 6-DoF workspace-route ablation should take, on tuning scenes.

    PYTHONPATH=$PWD python scripts/experiments/tune_rigid_route.py --scenes 2 --fractions 0.25 0.5 0.75 0.9

Runs ``rigid_workspace_route`` at each fraction with RRT and RRT-Connect (the seed set-ups) on the tuning
part of the rigid-body scene set (never validation or test) and prints success and median iterations
per fraction; the fraction with the most successes, then the lowest median, is the one to ship.
"""

from __future__ import annotations

import argparse
import sys


def main(argv=None) -> int:
    from learning.evaluation.rigid import evaluate_rigid, summarize
    from planners.worlds.rigid_scenes import RigidSceneSet

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", type=int, default=2, help="tuning scenes per training family")
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--fractions", type=float, nargs="+", default=[0.25, 0.5, 0.75, 0.9])
    ap.add_argument("--planners", nargs="+", default=["RRT", "RRTConnect"])
    args = ap.parse_args(argv)
    scenes = RigidSceneSet(counts={"tuning": args.scenes}, test_only=())
    print("| planner | route_fraction | success | median iterations |\n|---|---|---|---|")
    for f in args.fractions:
        rows = evaluate_rigid(scenes, "tuning", planners=args.planners, samplers=("rigid_workspace_route",),
                              seeds=range(args.seeds), sampler_params={"rigid_workspace_route": {"route_fraction": f}})
        for s in summarize(rows):
            print(f"| {s['planner']} | {f:g} | {s['solved']}/{s['runs']} | {s['median_iterations']:,.0f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
