"""Do RRT-Connect's and RRT*'s compiled loops with the route field's draws plan the same runs, and how much sooner?

    PYTHONPATH=$PWD python scripts/experiments/fused_loops.py [--maps 4] [--seeds 3]

RRT-Connect (``BidirectionalRouteSampler``) and RRT* to its first solution (``ConvergingRouteSampler``), step 4,
over the route encoder, its ablation and the exact reference, on ``--maps`` validation maps of each family at 128
cells (``planner_maps("validation", ...)``), planner seeds 0 upwards: once with the draws fused into the planner's
compiled loop (the library's way) and once through ``draw``, one Python call per iteration, in turn query by query
after two warm-up queries. Prints the median bind (the fields: a sampler's set-up) and solve times of each, the
median iterations, and how many runs are the same in success, iterations, checks, candidates, vertices, cost and
path, bit for bit. Then RRT-Connect solved in pieces (steps, then solves of 3, 11 and 2 iterations) against one
solve, and anytime RRT* run 200 iterations past its first solution (its loop hands the draws back), fused and not,
on 10 queries each.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from learning.evaluation.every_planner import planner_maps
from learning.samplers.registry import make_sampler
from learning.samplers.route_rules import BidirectionalRouteSampler, ConvergingRouteSampler
from planners import make_planner

STEP = 4.0


class UnfusedBidirectional(BidirectionalRouteSampler):
    """The same rule, drawn through ``draw`` once per iteration."""

    fuse = None


class UnfusedConverging(ConvergingRouteSampler):
    """The same rule, drawn through ``draw`` once per iteration to the first solution."""

    fuse = None


RULES = {"RRTConnect": (BidirectionalRouteSampler, UnfusedBidirectional),
         "RRTstar": (ConvergingRouteSampler, UnfusedConverging)}


def _run(planner_name: str, problem, sampler, seed: int, budget: int = 20000, first: bool = True
         ) -> tuple[float, float, tuple]:
    options = {"stop_on_first_solution": first} if planner_name == "RRTstar" else {}
    t0 = time.perf_counter()
    planner = make_planner(planner_name, problem, sampler=sampler, seed=seed, step_size=STEP, **options)
    t1 = time.perf_counter()
    r = planner.solve(budget)
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
    print("| planner | sampler | loop | median bind (ms) | median solve (ms) | median iterations | solved | same runs "
          "|")
    print("|---|---|---|---|---|---|---|---|")
    for planner_name, (fused_rule, unfused_rule) in RULES.items():
        for name in ("route", "route_ablation", "exact_route"):
            route = make_sampler(name).at_step(STEP)
            rules = {"fused": fused_rule(route), "draw": unfused_rule(route)}
            for p in problems[:2]:  # compile and warm up
                for rule in rules.values():
                    _run(planner_name, p, rule, 0)
            out = {k: ([], [], []) for k in rules}
            for p in problems:
                for seed in range(args.seeds):
                    for k, rule in rules.items():
                        bind, solve, run = _run(planner_name, p, rule, seed)
                        out[k][0].append(bind)
                        out[k][1].append(solve)
                        out[k][2].append(run)
            same = sum(a == b for a, b in zip(out["fused"][2], out["draw"][2], strict=True))
            for k, (bind, solve, runs) in out.items():
                print(f"| {planner_name} | {name} | {k} | {1e3 * np.median(bind):.2f} | {1e3 * np.median(solve):.2f} | "
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
    print(f"\nRRT-Connect solved in pieces, the same run as one solve: {equal}/{min(10, len(problems))}")
    route = make_sampler("route").at_step(STEP)
    equal = 0
    for p in problems[:10]:
        first = _run("RRTstar", p, ConvergingRouteSampler(route), 5)[2]
        budget = first[1] + 200
        runs = [_run("RRTstar", p, rule(route), 5, budget, first=False)[2] for rule in RULES["RRTstar"]]
        equal += runs[0] == runs[1]
    print(f"anytime RRT* 200 iterations past its first solution, the same run fused and not: {equal}/"
          f"{min(10, len(problems))}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
