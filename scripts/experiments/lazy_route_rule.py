"""When should the lazy route sampler compute the encoder's field? Its switches chosen by time to solution.

    PYTHONPATH=$PWD python scripts/experiments/lazy_route_rule.py [--maps 8 4 2] [--seeds 2] [--out DIR]

``LazyRouteSampler`` (``learning.samplers.lazy_route``) runs RRT on the straight-line field and computes the
encoder's field once the run has not solved within ``after`` iterations per step-sized square of the map (at least
``floor``, at most ``cap`` iterations), or once its tree has come no closer to the goal for ``stall`` iterations.
Every combination of ``--after``, ``--cap``, ``--floor`` and ``--stall`` candidates (with after = 0, the route
sampler, as a reference unless ``--no-reference``) plans the validation maps of each family at 128, 256 and 512
cells (``--sizes``; ``--maps`` of each size; ``planner_maps("validation", ...)``) at planner seeds 0 upwards, RRT
step 4, at most 20,000 iterations, one process and one thread, in turn on each (query, seed) after two untimed
warm-up queries. ``--planner RRTConnect`` does the same for RRT-Connect's switch (``connect_after``, given as
``--after``, and ``connect_floor``, as ``--floor``: both trees uniform until then, then the route field's two
fields), and ``--planner PRM`` for the roadmaps' (``roadmap_after`` and ``roadmap_floor``: uniform samples, then the
field's corridor). A run's time goes from the planner's construction (the sampler's bind and its own field: no
cache) to the end of its solve; an unsolved run counts with the time it ran.

The rule: the lowest geometric mean over the (family, size) cells of each candidate's median time wins, and a
candidate within 3% of it with a larger ``cap`` (nearer the area's budget alone), then a smaller ``floor``, then a
smaller ``stall``, then a smaller ``after``, wins over it (the reference takes no part). Prints a table per
candidate (geometric mean, pooled mean time, median iterations and success per cell) and the choice; ``--out`` also
writes the runs as JSON.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from learning.evaluation.every_planner import planner_maps
from learning.models.threads import planning_threads
from learning.samplers.lazy_route import SHIPPED_CAP, SHIPPED_CONNECT_FLOOR, SHIPPED_FLOOR, SHIPPED_ROADMAP_FLOOR
from learning.samplers.registry import make_sampler
from planners import make_planner

STEP, BUDGET, SIZES = 4.0, 20000, (128, 256, 512)
AFTER = (0.35, 0.7, 1.4, math.inf)
STALL = (10.0, 25.0, 50.0, 100.0, 200.0, math.inf)
#: RRT-Connect's and PRM's candidates (``--planner RRTConnect``: ``connect_after``, the trees' uniform budget;
#: ``--planner PRM``: ``roadmap_after``, the roadmap's; stall unused).
CONNECT_AFTER = (0.05, 0.1, 0.2, 0.35, 0.7, 1.4, math.inf)
#: A candidate within this share of the lowest geometric mean, with a smaller ``after``, wins over it.
TIE = 0.03


def run(problem, sampler, seed: int, planner_name: str = "RRT") -> dict:
    t0 = time.perf_counter()
    planner = make_planner(planner_name, problem, sampler=sampler, seed=seed, extension_step=STEP)
    r = planner.solve(BUDGET)
    seconds = time.perf_counter() - t0
    return {"solved": bool(r.solved), "iterations": int(r.iterations), "ms": 1e3 * seconds,
            "switched": bool(planner.sampler.switched)}


def choose(table: dict[tuple[float, ...], float]) -> tuple[float, ...]:
    """The rule: the lowest value wins; one within ``TIE`` of it with a larger cap, then a smaller floor, then a
    smaller (stall, after), wins over it.

    ``table`` maps (after, stall, cap, floor) to the geometric mean of the cells' median times (a key of three
    has no floor).
    """
    best = min(table.values())
    return min((k for k, v in table.items() if v <= (1 + TIE) * best),
               key=lambda k: (-k[2], k[3] if len(k) > 3 else 0.0, k[1], k[0]))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=list(SIZES), metavar="SIDE",
                    help=f"map sides of the validation cells (default {' '.join(map(str, SIZES))})")
    ap.add_argument("--maps", type=int, nargs="+", default=[8, 4, 2], metavar="N",
                    help="validation maps per family at each of --sizes (default 8 4 2)")
    ap.add_argument("--seeds", type=int, default=2, help="planner seeds per map (default 2)")
    ap.add_argument("--planner", choices=("RRT", "RRTConnect", "PRM"), default="RRT",
                    help="RRT (switches after and stall), RRTConnect or PRM (connect_after, roadmap_after: --after)")
    ap.add_argument("--after", type=float, nargs="+", default=None, help="candidates (default: the rule's)")
    ap.add_argument("--stall", type=float, nargs="+", default=list(STALL), help="candidates (default: the rule's)")
    ap.add_argument("--floor", type=float, nargs="+", default=None,
                    help="candidates for the fewest iterations before the switch (RRT: floor, RRTConnect: "
                         "connect_floor, PRM: roadmap_floor; default: the shipped one)")
    ap.add_argument("--cap", type=float, nargs="+", default=[SHIPPED_CAP],
                    help=f"RRT: candidates for the most iterations before the switch (default: {SHIPPED_CAP:g}, "
                         "the shipped; inf: none)")
    ap.add_argument("--no-reference", action="store_true", help="leave out after = 0 (the route rule)")
    ap.add_argument("--out", type=Path, default=None, help="write runs.json here (a new or empty folder)")
    args = ap.parse_args(argv)
    connect = args.planner != "RRT"  # one switch: connect_after or roadmap_after, given as --after
    if args.after is None:
        args.after = list(CONNECT_AFTER if connect else AFTER)
    floor_name = {"RRT": "floor", "RRTConnect": "connect_floor", "PRM": "roadmap_floor"}[args.planner]
    if args.floor is None:
        args.floor = [{"floor": SHIPPED_FLOOR, "connect_floor": SHIPPED_CONNECT_FLOOR,
                       "roadmap_floor": SHIPPED_ROADMAP_FLOOR}[floor_name]]
    if connect:
        args.stall, args.cap = [math.inf], [math.inf]
    switch = "connect_after" if args.planner == "RRTConnect" else "roadmap_after"
    if min(args.maps) < 0 or args.seeds < 1 or not all(a >= 0 for a in args.after) or \
            not all(s >= 1 for s in args.stall) or not all(c >= 0 for c in args.cap + args.floor) or \
            len(args.maps) != len(args.sizes) or min(args.sizes) < 32:
        ap.error("--maps must be >= 0, one per --sizes (each >= 32), --seeds >= 1, every --after, --cap and --floor "
                 ">= 0 and every --stall >= 1")
    if args.out is not None and args.out.exists() and any(args.out.iterdir()):
        ap.error(f"--out {args.out}: exists and is not empty")
    cells = {(family, size): problems for size, n in zip(args.sizes, args.maps, strict=True) if n
             for family, problems in planner_maps("validation", n, size=size).items()}
    pairs = [] if args.no_reference else [(0.0, math.inf, math.inf, 0.0)]
    pairs += [(a, s, c, f) for a in args.after for s in args.stall for c in args.cap for f in args.floor
              if (a, s, c, f) not in pairs]
    samplers = {k: make_sampler("route_lazy", **{switch: k[0], floor_name: k[3]}) if connect else
                make_sampler("route_lazy", after=k[0], stall=k[1], cap=k[2], floor=k[3]) for k in pairs}
    runs: dict[tuple, dict] = {k: {c: [] for c in cells} for k in pairs}
    with planning_threads(1):
        warm = next(iter(cells.values()))[:2]
        for p in warm:
            for s in samplers.values():
                run(p, s, 0, args.planner)
        for cell, problems in cells.items():
            for p in problems:
                for seed in range(args.seeds):
                    for a, s in samplers.items():
                        runs[a][cell].append(run(p, s, seed, args.planner))
    geo = {a: math.exp(np.mean([math.log(np.median([r["ms"] for r in rs])) for rs in by.values()]))
           for a, by in runs.items()}
    print("| after | stall | cap | floor | geometric mean of median ms | pooled mean ms | switched | "
          + " | ".join(f"{f} {s}: median its / ms / solved" for f, s in cells) + " |")
    print("|---|---|---|---|---|---|---|" + "---|" * len(cells))
    for a, by in runs.items():
        every = [r for rs in by.values() for r in rs]
        row = [f"{np.median([r['iterations'] for r in rs]):.0f} / {np.median([r['ms'] for r in rs]):.2f} / "
               f"{sum(r['solved'] for r in rs)}/{len(rs)}" for rs in by.values()]
        print(f"| {a[0]:g} | {a[1]:g} | {a[2]:g} | {a[3]:g} | {geo[a]:.3f} | {np.mean([r['ms'] for r in every]):.2f} | "
              f"{sum(r['switched'] for r in every)}/{len(every)} | " + " | ".join(row) + " |")
    reference = (0.0, math.inf, math.inf, 0.0)
    if args.no_reference or reference in [(a, s, c, f) for a in args.after for s in args.stall for c in args.cap
                                          for f in args.floor]:
        reference = None
    after, stall, cap, floor = choose({k: v for k, v in geo.items() if k != reference})
    print(f"\nchosen: after = {after:g}, stall = {stall:g}, cap = {cap:g}, floor = {floor:g} (lowest geometric mean "
          f"{min(geo.values()):.3f} ms; ties within {TIE:.0%} to the larger cap, then the smaller floor, stall, after)")
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        data = {" ".join(f"{v:g}" for v in a): {f"{f} {s}": rs for (f, s), rs in by.items()} for a, by in runs.items()}
        (args.out / "runs.json").write_text(json.dumps(data, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
