"""Is a learned sampler faster than a planner's best classical option, set by set? Read from a comparison's runs.

    PYTHONPATH=$PWD python scripts/experiments/clock_by_set.py RUNS.csv [--planner RRTstar] [--samplers "lazy route"]

Reads the ``runs.csv`` that ``scripts/evaluate.py`` writes (``--other-planners`` for planners other than RRT) and
prints, for each held-apart set (the shifted and unseen sets, and the MovingAI maps pooled), the median time to
solution of each of ``--samplers`` as a multiple of the planner's best classical option there: the fastest of uniform
sampling, the goal bias tuned for the set (a tree's ``goal_bias=P`` rows: the comparison runs only the tuned bias
with planners other than RRT) and obstacle-based sampling (a roadmap's), by median time on the set's own test runs,
which favours the classical option; an unsolved run counts as never solving. The MovingAI maps are pooled with each
map's fastest classical option. A ratio of at most 1 is "no slower than the best classical option" (the clock target
for other planners); the last line counts them per sampler. RRT's rows hold the whole goal-bias sweep, so RRT is
refused (``benchmark_clock.py`` is its clock).
"""

from __future__ import annotations

import argparse
import csv
import math
import statistics
import sys
from collections import defaultdict
from pathlib import Path

#: The generated families (their own test maps are not held apart); every other set without a tag is a MovingAI map.
GENERATED = ("forest", "maze", "bugtrap", "narrow_passage", "rooms")
#: The classical options' labels in runs.csv: uniform sampling, obstacle-based sampling (roadmaps) and, by prefix, the
#: goal bias tuned for the set (trees).
CLASSICAL = ("uniform", "obstacle-based")
GOAL_BIAS = "goal_bias="


def read_runs(path: Path, planner: str) -> dict[tuple[str, str], list[tuple[float, bool]]]:
    """(map set, sampler) -> [(wall seconds, solved)] of ``planner``'s test runs (the convergence part's left out)."""
    out: dict[tuple[str, str], list[tuple[float, bool]]] = defaultdict(list)
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        missing = {"map", "split", "planner", "sampler", "solved", "wall_time"} - set(reader.fieldnames or ())
        if missing:
            raise SystemExit(f"{path}: not a runs.csv of scripts/evaluate.py (no column {', '.join(sorted(missing))})")
        for r in reader:
            if r["planner"] == planner and r["split"] == "test" and "(RRT* cost)" not in r["map"]:
                out[(r["map"], r["sampler"])].append((float(r["wall_time"]), r["solved"] == "True"))
    return out


def median_time(runs: list[tuple[float, bool]]) -> float:
    """The median time to solution, an unsolved run never solving (inf where half or more are unsolved)."""
    return statistics.median([w if solved else math.inf for w, solved in runs])


def ratios(runs: dict, samplers: list[str]) -> list[tuple[str, dict[str, float]]]:
    """(held-apart set, {sampler: its median time over the best classical option's}), the MovingAI maps pooled."""
    sets = sorted({m for m, _ in runs})
    held = [m for m in sets if "(shifted)" in m or "(unseen)" in m]
    movingai = [m for m in sets if m not in GENERATED and "(" not in m]

    def best(m):
        biases = [c for mm, c in runs if mm == m and c.startswith(GOAL_BIAS)]
        if len(biases) > 1:
            raise SystemExit(f"{m}: the test runs hold {len(biases)} goal biases ({', '.join(sorted(biases))}), not "
                             f"one tuned for the set: RRT's sweep? (this reads the other planners' rows)")
        return min((runs[(m, c)] for c in (*CLASSICAL, *biases) if (m, c) in runs), key=median_time)

    out = []
    for m in held:
        base = median_time(best(m))
        out.append((m, {s: median_time(runs[(m, s)]) / base for s in samplers if (m, s) in runs}))
    if movingai:
        base = median_time([x for m in movingai for x in best(m)])
        out.append(("MovingAI pooled", {s: median_time([x for m in movingai for x in runs.get((m, s), [])]) / base
                                        for s in samplers}))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("runs", type=Path, help="a runs.csv written by scripts/evaluate.py")
    ap.add_argument("--planner", default="RRTstar", help="the planner's rows (default RRTstar)")
    ap.add_argument("--samplers", nargs="+", default=["lazy route", "route encoder"],
                    help="the samplers' labels in runs.csv (default: lazy route, route encoder)")
    args = ap.parse_args(argv)
    if args.planner == "RRT":
        ap.error("RRT's test rows hold the whole goal-bias sweep: its clock is scripts/benchmark_clock.py")
    if not args.runs.is_file():
        ap.error(f"{args.runs}: no such file")
    runs = read_runs(args.runs, args.planner)
    if not runs:
        ap.error(f"{args.runs}: no test runs of {args.planner}")
    rows = ratios(runs, args.samplers)
    print("| set | " + " | ".join(args.samplers) + " |")
    print("|---|" + "---|" * len(args.samplers))
    for m, r in rows:
        print(f"| {m} | " + " | ".join(f"{r.get(s, math.nan):.2f}" for s in args.samplers) + " |")
    print("\nno slower than the best classical option: " + ", ".join(
        f"{s} on {sum(r.get(s, math.inf) <= 1 for _, r in rows)} of {len(rows)}" for s in args.samplers))
    return 0


if __name__ == "__main__":
    sys.exit(main())
