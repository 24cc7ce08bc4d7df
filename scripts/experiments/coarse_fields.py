"""The route encoder reading a large map coarser where that closes no passage (``RouteSampler.coarse_side``), on
validation maps.

    PYTHONPATH=$PWD python scripts/experiments/coarse_fields.py                       # sides 256 and 512, 6 maps
    PYTHONPATH=$PWD python scripts/experiments/coarse_fields.py --sides 1024 --maps 2 --sides-of 0 128

Per family and side of the validation maps (the training families', caves' and strokes'; seeds from
``VALIDATION_SEED0 + 900`` by default, ``--offset``; never test maps): how many maps each ``coarse_side`` reads
coarser, and over the runs on those maps (RRT, step 4, tolerance 4, cap 20,000, planner seeds 0 and 1) the median
iterations and the median time of a query (the planner's set-up with the sampler's bind, the encoder's pass
included, and its solve; one query a map, so every pass is a map's first), each against full resolution
(``coarse_side`` 0) on the same runs. One process, one thread; the first query of the run compiles and is left out.

The rule, fixed before the run: a ``coarse_side`` passes where, over the rows (family and side) with at least two
maps read coarser, the geometric mean of its median iterations over full resolution's is at most 1.05 with no row
above 1.25, and the geometric mean of its median time over full resolution's at most 0.8. Of those that pass, the
lowest geometric mean of the time is chosen; if none passes, every map is read at full resolution.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np
import torch

from learning.samplers.route import COARSE_MOST, SHIPPED, RouteSampler
from planners import make_planner
from planners.maps.generators import TRAINING_FAMILIES, VALIDATION_SEED0, generate
from planners.tools.benchmark import MAX_ITERATIONS, STEP


def run(problem, side: int, seed: int, most: int) -> tuple[int, float, int]:
    """(iterations, seconds, coarsening) of one RRT run with the shipped route sampler reading at ``side``, at most
    ``most`` times coarser."""
    sampler = RouteSampler.load(SHIPPED, step_size=STEP, device="cpu", coarse_side=side, coarse_most=most)
    t0 = time.perf_counter()
    planner = make_planner("RRT", problem, extension_step=STEP, sampler=sampler, seed=seed)
    r = planner.solve(max_iterations=MAX_ITERATIONS)
    seconds = time.perf_counter() - t0
    bound = planner.sampler
    k = bound._encoder_map(problem.world)[3] if side else 1
    return (r.first_solution_iteration if r.solved else MAX_ITERATIONS), seconds, k


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--maps", type=int, default=6, help="validation maps per family and side (default 6)")
    ap.add_argument("--offset", type=int, default=900, help="the first map's seed after VALIDATION_SEED0")
    ap.add_argument("--sides", type=int, nargs="+", default=[256, 512])
    ap.add_argument("--seeds", type=int, default=2, help="planner seeds per map (default 2)")
    ap.add_argument("--families", nargs="+", default=list(TRAINING_FAMILIES))
    ap.add_argument("--sides-of", type=int, nargs="+", default=[128, 64], metavar="S",
                    help="the coarse_side values asked against full resolution (default 128 64)")
    ap.add_argument("--most", type=int, default=COARSE_MOST, help=f"coarse_most (default {COARSE_MOST})")
    args = ap.parse_args(argv)
    if args.maps < 1 or args.seeds < 1 or min(args.sides_of) < 1:
        ap.error("--maps, --seeds and --sides-of take numbers >= 1")
    torch.set_num_threads(1)
    asked = [0, *args.sides_of]
    for family in args.families:  # compile, untimed
        warm = generate(family, VALIDATION_SEED0 + args.offset, min(args.sides))
        for side in asked:
            run(warm, side, 0, args.most)
    print("| family | side | " + " | ".join(f"coarse_side {s}: maps coarser (k), iterations / full, time / full"
                                            for s in args.sides_of) + " |")
    print("|---|---|" + "---|" * len(args.sides_of))
    ratios: dict[int, list[tuple[float, float]]] = {s: [] for s in args.sides_of}
    for family in args.families:
        for side in args.sides:
            runs = {s: [] for s in asked}  # per map: [(iterations, seconds, k) per seed]
            for i in range(args.maps):
                p = generate(family, VALIDATION_SEED0 + args.offset + i, side)
                for s in asked:
                    runs[s].append([run(p, s, seed, args.most) for seed in range(args.seeds)])
            cells = []
            for s in args.sides_of:
                coarser = [m for m in range(args.maps) if runs[s][m][0][2] > 1]
                ks = sorted({runs[s][m][0][2] for m in coarser})
                if not coarser:
                    cells.append("0")
                    continue
                its = statistics.median(r[0] for m in coarser for r in runs[s][m])
                full = statistics.median(r[0] for m in coarser for r in runs[0][m])
                t = statistics.median(r[1] for m in coarser for r in runs[s][m])
                tf = statistics.median(r[1] for m in coarser for r in runs[0][m])
                cells.append(f"{len(coarser)} ({', '.join(map(str, ks))}), {its:g} / {full:g} = {its / full:.2f}, "
                             f"{t * 1e3:.1f} / {tf * 1e3:.1f} ms = {t / tf:.2f}")
                if len(coarser) >= 2:
                    ratios[s].append((its / full, t / tf))
            print(f"| {family} | {side} | " + " | ".join(cells) + " |", flush=True)
    print()
    best, best_time = 0, math.inf
    for s in args.sides_of:
        rows = ratios[s]
        if not rows:
            print(f"coarse_side {s}: no row with two maps read coarser")
            continue
        gi = math.exp(np.mean([math.log(a) for a, _ in rows]))
        gt = math.exp(np.mean([math.log(b) for _, b in rows]))
        worst = max(a for a, _ in rows)
        ok = gi <= 1.05 and worst <= 1.25 and gt <= 0.8
        print(f"coarse_side {s}: {len(rows)} rows; iterations geometric mean {gi:.3f} (worst row {worst:.2f}), time "
              f"geometric mean {gt:.3f}: {'passes' if ok else 'fails'}")
        if ok and gt < best_time:
            best, best_time = s, gt
    print(f"chosen: coarse_side {best}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
