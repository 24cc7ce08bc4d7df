"""A candidate route encoder against the shipped one on the held-apart sets, and what the rule's bound can tell.

    python scripts/evaluate.py --quick --route mine=runs/mine/route.pt --out runs/eval_mine
    PYTHONPATH=$PWD python scripts/experiments/encoder_rule.py runs/eval_mine/runs.csv --candidate mine

From one ``evaluate.py`` run that holds both encoders (``--route NAME=FILE`` beside the shipped "route encoder"),
RRT's test runs, set by set: the median iterations of each (an unsolved run counting as the cap), their ratio
(candidate over shipped), the runs each solved, and the rule this library registers for a new encoder: the
geometric mean of the ratios at most ``--mean`` (1.05), no set above ``--worst`` (1.25; with ``--unclear``, none
whose 90% interval also lies above 1), and no set where the candidate solves more than one run fewer. Beside each
ratio, from ``--resamples`` paired bootstrap resamples of the set's queries (seeded): the ratio's 90% interval,
and how often two independent resamples of the *shipped* encoder's own runs differ by more than ``--worst`` (its
ratio against itself): where that is common, the bound cannot tell a candidate from the shipped encoder on that
set at its number of runs.
"""

from __future__ import annotations

import argparse
import csv
import math
from collections import defaultdict
from pathlib import Path

import numpy as np

SHIPPED = "route encoder"


def paired_runs(path: Path, candidate: str) -> dict[str, np.ndarray]:
    """Per test map set: (runs, 2, 2) of (iterations, solved) for (shipped, candidate), paired by query and seed."""
    by_set: dict[str, dict[tuple[str, str], dict[str, tuple[int, bool]]]] = defaultdict(dict)
    with open(path, newline="", encoding="utf-8") as f:
        for r in csv.DictReader(f):
            if r["split"] == "test" and r["planner"] == "RRT" and r["sampler"] in (SHIPPED, candidate):
                run = by_set[r["map"]].setdefault((r["query"], r["seed"]), {})
                run[r["sampler"]] = (int(r["iterations"]), r["solved"] == "True")
    return {name: np.array([[run[SHIPPED], run[candidate]] for run in runs.values() if len(run) == 2], dtype=float)
            for name, runs in by_set.items() if any(len(run) == 2 for run in runs.values())}


def set_rows(pairs: dict[str, np.ndarray], worst: float, resamples: int, seed: int) -> list[dict]:
    """One row per set: medians, ratio, solved runs, the ratio's 90% interval and the shipped-against-itself share."""
    rng = np.random.default_rng(seed)
    rows = []
    for name, p in pairs.items():
        n = len(p)
        shipped, cand = float(np.median(p[:, 0, 0])), float(np.median(p[:, 1, 0]))
        idx = rng.integers(n, size=(resamples, n))
        ratios = np.median(p[idx, 1, 0], 1) / np.median(p[idx, 0, 0], 1)
        a = np.median(p[rng.integers(n, size=(resamples, n)), 0, 0], 1)
        b = np.median(p[rng.integers(n, size=(resamples, n)), 0, 0], 1)
        rows.append({"set": name, "runs": n, "shipped": shipped, "candidate": cand, "ratio": cand / shipped,
                     "solved": (int(p[:, 0, 1].sum()), int(p[:, 1, 1].sum())),
                     "interval": (float(np.quantile(ratios, 0.05)), float(np.quantile(ratios, 0.95))),
                     "self_above": float(np.mean(b / a > worst))})
    return rows


def verdict(rows: list[dict], mean: float, worst: float, unclear: bool = False) -> tuple[bool, float, list[str]]:
    """(whether the rule holds, the geometric mean of the ratios, the reasons it does not).

    ``unclear``: a set above ``worst`` whose 90% interval holds 1 does not fail the rule (its runs cannot tell the
    candidate from the shipped encoder).
    """
    g = math.exp(sum(math.log(r["ratio"]) for r in rows) / len(rows))
    why = [f"geometric mean {g:.3f} > {mean}"] if g > mean else []
    why += [f"{r['set']}: {r['ratio']:.2f} > {worst}" for r in rows
            if r["ratio"] > worst and not (unclear and r["interval"][0] <= 1 <= r["interval"][1])]
    why += [f"{r['set']}: solved {r['solved'][1]} against {r['solved'][0]}" for r in rows
            if r["solved"][0] - r["solved"][1] > 1]
    return not why, g, why


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("runs", type=Path, help="an evaluate.py runs.csv holding both encoders' RRT test runs")
    ap.add_argument("--candidate", required=True, help="the candidate's sampler name in it (evaluate's --route NAME=)")
    ap.add_argument("--mean", type=float, default=1.05, help="the largest geometric mean of the ratios")
    ap.add_argument("--worst", type=float, default=1.25, help="the largest ratio on any set")
    ap.add_argument("--unclear", action="store_true",
                    help="a set above --worst whose 90%% interval holds 1 does not fail the rule")
    ap.add_argument("--resamples", type=int, default=4000)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    if not args.runs.is_file():
        ap.error(f"{args.runs}: not a file; expected an evaluate.py runs.csv")
    if not (args.mean > 0 and args.worst > 0 and args.resamples >= 1):
        ap.error(f"--mean {args.mean}, --worst {args.worst}, --resamples {args.resamples}: expected positive numbers")
    pairs = paired_runs(args.runs, args.candidate)
    if not pairs:
        ap.error(f"{args.runs}: no test runs of RRT with both {SHIPPED!r} and {args.candidate!r} on the same queries")
    rows = set_rows(pairs, args.worst, args.resamples, args.seed)
    print(f"| set | runs | shipped | {args.candidate} | ratio | 90% interval | shipped against itself above "
          f"{args.worst:g} | solved (shipped / {args.candidate}) |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        lo, hi = r["interval"]
        print(f"| {r['set']} | {r['runs']} | {r['shipped']:g} | {r['candidate']:g} | {r['ratio']:.2f} | {lo:.2f} to "
              f"{hi:.2f} | {r['self_above']:.2f} | {r['solved'][0]} / {r['solved'][1]} |")
    holds, g, why = verdict(rows, args.mean, args.worst, args.unclear)
    print(f"\n{len(rows)} sets, geometric mean {g:.3f}: the rule {'holds' if holds else 'fails'}"
          + ("" if holds else " (" + "; ".join(why) + ")"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
