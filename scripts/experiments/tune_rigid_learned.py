"""Uniform-angle share, angle noise and temperature of the learned 6-DoF sampler (``rigid_route``), on tuning scenes.

    PYTHONPATH=$PWD python scripts/experiments/tune_rigid_learned.py --scenes 2 --shares 0.1 0.25 0.5
    PYTHONPATH=$PWD python scripts/experiments/tune_rigid_learned.py --shares 0.5 --noises 0.03 0.3 \\
        --planners RRTConnect

Runs ``rigid_route`` at each (``uniform_share``, ``angle_noise``) with the seed set-ups of RRT-Connect and
RRT on the tuning part of the rigid-body scene set (never validation or test) and prints success and median
iterations per setting. The rule: the most RRT-Connect successes, then the lowest RRT-Connect median, then
the most RRT successes, then the smaller share and noise.
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
    ap.add_argument("--shares", type=float, nargs="+", default=[0.1, 0.25, 0.5])
    ap.add_argument("--noises", type=float, nargs="+", default=[0.1])
    ap.add_argument("--temperatures", type=float, nargs="+", default=[1.0])
    ap.add_argument("--centre", type=int, default=0, help="reach in voxels of the route's centring (0: none)")
    ap.add_argument("--planners", nargs="+", default=["RRTConnect", "RRT"])
    ap.add_argument("--path", help="orientation model file (default the shipped one)")
    args = ap.parse_args(argv)
    scenes = RigidSceneSet(counts={"tuning": args.scenes}, test_only=())
    print(f"centre {args.centre}\n| planner | uniform_share | angle_noise | temperature | success | median iterations "
          "| median time (s) |\n|---|---|---|---|---|---|---|", flush=True)
    grid = [(share, noise, temp) for share in args.shares for noise in args.noises for temp in args.temperatures]
    for share, noise, temp in grid:
        params = {"uniform_share": share, "angle_noise": noise, "temperature": temp, "centre": args.centre}
        if args.path:
            params["path"] = args.path
        rows = evaluate_rigid(scenes, "tuning", planners=args.planners, samplers=("rigid_route",),
                              seeds=range(args.seeds), sampler_params={"rigid_route": params})
        for s in summarize(rows):
            print(f"| {s['planner']} | {share:g} | {noise:g} | {temp:g} | {s['solved']}/{s['runs']} | "
                  f"{s['median_iterations']:,.0f} | {s['median_time']:.2f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
