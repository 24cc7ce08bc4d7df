"""When should the lazy route sampler compute the encoder's field? Its switches chosen by time to solution.

    PYTHONPATH=$PWD python scripts/experiments/lazy_route_rule.py [--maps 8 4 2] [--seeds 2] [--out DIR]

``LazyRouteSampler`` (``learning.samplers.lazy_route``) runs RRT on the straight-line field and computes the
encoder's field once the run has not solved within ``after`` iterations per step-sized square of the map (at least
``floor``, at most ``cap`` iterations), or once its tree has come no closer to the goal for ``stall`` iterations.
Every combination of ``--after``, ``--cap``, ``--floor`` and ``--stall`` candidates (with after = 0, the route
sampler, as a reference unless ``--no-reference``) plans the validation maps of each family at 128, 256 and 512
cells (``--sizes``; ``--maps`` of each size; ``planner_maps("validation", ...)``) at planner seeds 0 upwards, RRT
step 4, at most 20,000 iterations, one process and one thread, in turn on each (query, seed) after two untimed
warm-up queries, the candidates' order turning by one from one (query, seed) to the next and the reference last (a
run just after an encoder's pass finds the caches cold: in a fixed order the first candidate after the reference took
up to 1.6 times as long on 1024-cell maps). ``--planner RRTConnect`` does the same for RRT-Connect's switch
(``connect_after``, given as ``--after``, ``connect_floor``, as ``--floor``, and ``connect_cap``, as ``--cap``: both
trees uniform until then, then the route field's two fields), and ``--planner PRM`` for the roadmaps'
(``roadmap_after``, ``roadmap_floor`` and ``roadmap_cap``: uniform samples, then the field's corridor). ``--planner
RRTstar`` runs RRT* to its first solution with RRT's switches (``LazyConvergingSampler`` takes RRT's), to compare
the lazy rule for RRT* with the route rule (the reference). A run's time
goes from the planner's construction (the sampler's bind and its own field: no cache) to the end of its solve; an
unsolved run never solves, so a cell's median is not reached where half its runs or more are unsolved (as the clock
comparison counts them).

The rule: the fewest cells whose median is not reached wins; among those, the lowest geometric mean of the median
times over the (family, size) cells where every such candidate reaches its median, and a candidate within 3% of it
with a larger ``cap`` (nearer the area's budget alone), then a smaller ``floor``, then a smaller ``stall``, then a
smaller ``after``, wins over it (the reference takes no part). Prints a table per candidate (geometric mean, pooled
mean time, median iterations and success per cell), the choice and how often paired bootstrap resamples of the runs
choose each candidate (``--bootstrap``: where no candidate is chosen in most resamples, the validation runs cannot
tell them apart); ``--out`` also writes the runs as JSON.
"""

from __future__ import annotations

import argparse
import inspect
import json
import math
import time
from pathlib import Path

import numpy as np

from learning.evaluation.every_planner import planner_maps
from learning.models.threads import planning_threads
from learning.samplers.lazy_route import LazyRouteSampler
from learning.samplers.registry import make_sampler
from planners import make_planner

STEP, BUDGET, SIZES = 4.0, 20000, (128, 256, 512)
AFTER = (0.35, 0.7, 1.4, math.inf)
STALL = (10.0, 25.0, 50.0, 100.0, 200.0, math.inf)
#: RRT-Connect's and PRM's candidates (``--planner RRTConnect``: ``connect_after``, the trees' uniform budget;
#: ``--planner PRM``: ``roadmap_after``, the roadmap's; stall unused).
CONNECT_AFTER = (0.05, 0.1, 0.2, 0.35, 0.7, 1.4, math.inf)
#: Each planner's switch, floor and cap among ``LazyRouteSampler``'s arguments (given as --after, --floor, --cap).
SWITCHES = {"RRT": ("after", "floor", "cap"), "RRTConnect": ("connect_after", "connect_floor", "connect_cap"),
            "PRM": ("roadmap_after", "roadmap_floor", "roadmap_cap"), "RRTstar": ("after", "floor", "cap")}
#: A candidate within this share of the lowest geometric mean, with a smaller ``after``, wins over it.
TIE = 0.03


def run(problem, sampler, seed: int, planner_name: str = "RRT") -> dict:
    t0 = time.perf_counter()
    first = {"stop_on_first_solution": True} if planner_name == "RRTstar" else {}  # RRT*: to its first solution
    planner = make_planner(planner_name, problem, sampler=sampler, seed=seed, extension_step=STEP, **first)
    r = planner.solve(BUDGET)
    seconds = time.perf_counter() - t0
    return {"solved": bool(r.solved), "iterations": int(r.iterations), "ms": 1e3 * seconds,
            "switched": bool(planner.sampler.switched)}


def median_ms(runs: list[dict]) -> float:
    """The median time to solution of a cell's runs, an unsolved run never solving (inf where half or more are)."""
    return float(np.median([r["ms"] if r["solved"] else math.inf for r in runs]))


def objective(runs: dict[tuple, dict[tuple, list[dict]]], judged=None) -> dict[tuple, tuple[int, float]]:
    """Each candidate's (cells whose median is not reached, geometric mean of the median times over the cells where
    every ``judged`` candidate (default: all) with the fewest such cells reaches its median)."""
    medians = {k: {c: median_ms(rs) for c, rs in by.items()} for k, by in runs.items()}
    missed = {k: sum(math.isinf(m) for m in ms.values()) for k, ms in medians.items()}
    judged = list(runs) if judged is None else list(judged)
    fewest = min(missed[k] for k in judged)
    cells = [c for c in next(iter(medians.values()))
             if all(math.isfinite(medians[k][c]) for k in judged if missed[k] == fewest)]
    return {k: (missed[k], math.exp(np.mean([math.log(ms[c]) for c in cells])) if cells else math.inf)
            for k, ms in medians.items()}


def stability(runs: dict[tuple, dict[tuple, list[dict]]], judged, draws: int, seed: int = 0) -> dict[tuple, float]:
    """The share of ``draws`` paired bootstrap resamples in which the rule chooses each ``judged`` candidate.

    A resample draws each cell's (query, seed) runs with replacement, the same draws for every candidate (their runs
    are in the same order), and applies ``objective`` and ``choose`` to it: how often the choice would come out the
    same from validation runs like these.
    """
    rng, judged = np.random.default_rng(seed), list(judged)
    counts = dict.fromkeys(judged, 0)
    cells = list(runs[judged[0]])
    for _ in range(draws):
        picks = {c: rng.integers(0, len(runs[judged[0]][c]), len(runs[judged[0]][c])) for c in cells}
        resampled = {k: {c: [runs[k][c][i] for i in picks[c]] for c in cells} for k in judged}
        counts[choose(objective(resampled))] += 1
    return {k: n / draws for k, n in counts.items()}


def choose(table: dict[tuple[float, ...], float | tuple[int, float]]) -> tuple[float, ...]:
    """The rule: the fewest unreached cells, then the lowest value wins; one within ``TIE`` of it with a larger cap,
    then a smaller floor, then a smaller (stall, after), wins over it.

    ``table`` maps (after, stall, cap, floor) to the geometric mean of the cells' median times, or to (unreached
    cells, that mean) as ``objective`` gives it (a key of three has no floor).
    """
    table = {k: v if isinstance(v, tuple) else (0, v) for k, v in table.items()}
    fewest = min(v[0] for v in table.values())
    table = {k: v[1] for k, v in table.items() if v[0] == fewest}
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
    ap.add_argument("--planner", choices=tuple(SWITCHES), default="RRT",
                    help="RRT (switches after and stall), RRTConnect or PRM (connect_after, roadmap_after: --after), "
                         "RRTstar (RRT's switches, to the first solution)")
    ap.add_argument("--after", type=float, nargs="+", default=None, help="candidates (default: the rule's)")
    ap.add_argument("--stall", type=float, nargs="+", default=list(STALL), help="candidates (default: the rule's)")
    ap.add_argument("--floor", type=float, nargs="+", default=None,
                    help="candidates for the fewest iterations before the switch (RRT: floor, RRTConnect: "
                         "connect_floor, PRM: roadmap_floor; default: the shipped one)")
    ap.add_argument("--cap", type=float, nargs="+", default=None,
                    help="candidates for the most iterations before the switch (RRT: cap, RRTConnect: connect_cap, "
                         "PRM: roadmap_cap; default: the shipped one; inf: none)")
    ap.add_argument("--no-reference", action="store_true", help="leave out after = 0 (the route rule)")
    ap.add_argument("--bootstrap", type=int, default=200, metavar="N",
                    help="paired bootstrap resamples of the runs that say how often the rule's choice comes out the "
                         "same (default 200; 0: none)")
    ap.add_argument("--out", type=Path, default=None, help="write runs.json here (a new or empty folder)")
    args = ap.parse_args(argv)
    connect = args.planner not in ("RRT", "RRTstar")  # one switch: connect_after or roadmap_after, given as --after
    if args.after is None:
        args.after = list(CONNECT_AFTER if connect else AFTER)
    after_name, floor_name, cap_name = SWITCHES[args.planner]
    shipped = inspect.signature(LazyRouteSampler).parameters
    if args.floor is None:
        args.floor = [shipped[floor_name].default]
    if args.cap is None:
        args.cap = [shipped[cap_name].default]
    if connect:
        args.stall = [math.inf]
    if min(args.maps) < 0 or args.seeds < 1 or args.bootstrap < 0 or not all(a >= 0 for a in args.after) or \
            not all(s >= 1 for s in args.stall) or not all(c >= 0 for c in args.cap + args.floor) or \
            len(args.maps) != len(args.sizes) or min(args.sizes) < 32:
        ap.error("--maps must be >= 0, one per --sizes (each >= 32), --seeds >= 1, --bootstrap >= 0, every --after, "
                 "--cap and --floor >= 0 and every --stall >= 1")
    if args.out is not None and args.out.exists() and any(args.out.iterdir()):
        ap.error(f"--out {args.out}: exists and is not empty")
    cells = {(family, size): problems for size, n in zip(args.sizes, args.maps, strict=True) if n
             for family, problems in planner_maps("validation", n, size=size).items()}
    judged = list(dict.fromkeys((a, s, c, f) for a in args.after for s in args.stall for c in args.cap
                                for f in args.floor))
    reference = None if args.no_reference else (0.0, math.inf, math.inf, 0.0)
    reference = None if reference in judged else reference
    pairs = judged + ([reference] if reference else [])
    samplers = {k: make_sampler("route_lazy", **{after_name: k[0], floor_name: k[3], cap_name: k[2]},
                                **({} if connect else {"stall": k[1]})) for k in pairs}
    runs: dict[tuple, dict] = {k: {c: [] for c in cells} for k in pairs}
    with planning_threads(1):
        warm = next(iter(cells.values()))[:2]
        for p in warm:
            for s in samplers.values():
                run(p, s, 0, args.planner)
        turn = 0
        for cell, problems in cells.items():
            for p in problems:
                for seed in range(args.seeds):
                    # a run just after an encoder pass finds the caches cold: the order turns by one candidate
                    # from one (query, seed) to the next, so that each comes first as often, the reference last
                    k, turn = turn % len(judged), turn + 1
                    for a in judged[k:] + judged[:k] + pairs[len(judged):]:
                        runs[a][cell].append(run(p, samplers[a], seed, args.planner))
    score = objective(runs, judged=[k for k in runs if k != reference])
    print("| after | stall | cap | floor | cells not reached | geometric mean of median ms | pooled mean ms | "
          "switched | " + " | ".join(f"{f} {s}: median its / ms / solved" for f, s in cells) + " |")
    print("|---|---|---|---|---|---|---|---|" + "---|" * len(cells))
    for a, by in runs.items():
        every = [r for rs in by.values() for r in rs]
        row = [f"{np.median([r['iterations'] for r in rs]):.0f} / {median_ms(rs):.2f} / "
               f"{sum(r['solved'] for r in rs)}/{len(rs)}" for rs in by.values()]
        print(f"| {a[0]:g} | {a[1]:g} | {a[2]:g} | {a[3]:g} | {score[a][0]} | {score[a][1]:.3f} | "
              f"{np.mean([r['ms'] for r in every]):.2f} | "
              f"{sum(r['switched'] for r in every)}/{len(every)} | " + " | ".join(row) + " |")
    ranked = {k: v for k, v in score.items() if k != reference}
    after, stall, cap, floor = choose(ranked)
    print(f"\nchosen: after = {after:g}, stall = {stall:g}, cap = {cap:g}, floor = {floor:g} (fewest cells not reached "
          f"{min(v[0] for v in ranked.values())}, then the lowest geometric mean "
          f"{min(v[1] for v in ranked.values() if v[0] == ranked[(after, stall, cap, floor)][0]):.3f} ms; ties "
          f"within {TIE:.0%} to the larger cap, then the smaller floor, stall, after)")
    if args.bootstrap and len(ranked) > 1:
        shares = stability({k: runs[k] for k in ranked}, ranked, args.bootstrap)
        print(f"stability: in {args.bootstrap} paired bootstrap resamples of the (query, seed) runs the rule chooses "
              + ", ".join(f"{' '.join(f'{v:g}' for v in k)}: {share:.0%}" for k, share in shares.items())
              + " (after stall cap floor)")
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        data = {" ".join(f"{v:g}" for v in a): {f"{f} {s}": rs for (f, s), rs in by.items()} for a, by in runs.items()}
        (args.out / "runs.json").write_text(json.dumps(data, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
