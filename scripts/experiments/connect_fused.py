"""Does RRT-Connect's compiled loop with the route field's draws plan the same runs, and how much sooner?

    PYTHONPATH=$PWD python scripts/experiments/connect_fused.py [--maps 4] [--seeds 3]

RRT-Connect (step 4) with ``BidirectionalRouteSampler`` over the route encoder, its ablation and the exact
reference, on ``--maps`` validation maps of each family at 128 cells (``planner_maps("validation", ...)``),
planner seeds 0 upwards: once with the draws fused into RRT-Connect's compiled loop (the library's way) and once
through ``draw``, one Python call per iteration, in turn query by query after two warm-up queries. Prints the
median bind (the fields: a sampler's set-up) and solve times of each, the median iterations, and how many runs
are the same in success, iterations, checks, candidates, vertices, cost and path, bit for bit. Then 10 queries
solved in pieces (steps, then solves of 3, 11 and 2 iterations) against one solve.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from learning.evaluation.every_planner import planner_maps
from learning.samplers.registry import make_sampler
from learning.samplers.route_rules import BidirectionalRouteSampler
from planners import make_planner

STEP = 4.0


class UnfusedBidirectional(BidirectionalRouteSampler):
    """The same rule, drawn through ``draw`` once per iteration."""

    fuse = None


def _run(problem, sampler, seed: int) -> tuple[float, float, tuple]:
    t0 = time.perf_counter()
    planner = make_planner("RRTConnect", problem, sampler=sampler, seed=seed, step_size=STEP)
    t1 = time.perf_counter()
    r = planner.solve(20000)
    t2 = time.perf_counter()
    return t1 - t0, t2 - t1, (r.solved, r.iterations, r.num_vertices, r.collision_checks, r.candidates, r.cost,
                              None if r.path is None else r.path.tobytes())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--maps", type=int, default=4, help="validation maps per family (default 4)")
    ap.add_argument("--seeds", type=int, default=3, help="planner seeds per map (default 3)")
    args = ap.parse_args(argv)
    if args.maps < 1 or args.seeds < 1:
        ap.error("--maps and --seeds must be at least 1")
    problems = [p for ps in planner_maps("validation", args.maps).values() for p in ps]
    print("| sampler | loop | median bind (ms) | median solve (ms) | median iterations | solved | same runs |")
    print("|---|---|---|---|---|---|---|")
    for name in ("route", "route_ablation", "exact_route"):
        route = make_sampler(name).at_step(STEP)
        rules = {"fused": BidirectionalRouteSampler(route), "draw": UnfusedBidirectional(route)}
        for p in problems[:2]:  # compile and warm up
            for rule in rules.values():
                _run(p, rule, 0)
        out = {k: ([], [], []) for k in rules}
        for p in problems:
            for seed in range(args.seeds):
                for k, rule in rules.items():
                    bind, solve, run = _run(p, rule, seed)
                    out[k][0].append(bind)
                    out[k][1].append(solve)
                    out[k][2].append(run)
        same = sum(a == b for a, b in zip(out["fused"][2], out["draw"][2], strict=True))
        for k, (bind, solve, runs) in out.items():
            print(f"| {name} | {k} | {1e3 * np.median(bind):.2f} | {1e3 * np.median(solve):.2f} | "
                  f"{np.median([r[1] for r in runs]):.0f} | {sum(r[0] for r in runs)}/{len(runs)} | "
                  f"{same}/{len(runs)} |")
    sampler = BidirectionalRouteSampler(make_sampler("route").at_step(STEP))
    equal = 0
    for p in problems[:10]:
        whole = make_planner("RRTConnect", p, sampler=sampler, seed=5, step_size=STEP).solve(20000)
        planner = make_planner("RRTConnect", p, sampler=sampler, seed=5, step_size=STEP)
        for _ in range(7):
            planner.step()
        for size in (3, 11, 2):
            planner.solve(max_iterations=size)
        r = planner.solve(max_iterations=20000)
        equal += (r.iterations, r.collision_checks, r.path.tobytes()) == (whole.iterations, whole.collision_checks,
                                                                           whole.path.tobytes())
    print(f"\nsolved in pieces, the same run as one solve: {equal}/{min(10, len(problems))}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
