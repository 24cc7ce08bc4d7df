"""A pose check among many boxes, with the box world's spatial index and by a full scan; time limits among 20,000 boxes.

    python scripts/benchmark_boxes.py            # 100 to 20,000 boxes, then every planner's time limit
    python scripts/benchmark_boxes.py --counts 100 20000 --poses 50000 --planners PRM RRT RRTConnect

Prints microseconds per pose check (the 10 x 5 x 2.5 body's 16 points, a margin of delta / 2, seeded
poses in a 100-unit cube strewn with boxes of sides 0.5 to 2; ``planners.tools.box_index_bench``),
and the seconds each planner takes under ``--time-limit`` among ``--limit-boxes`` boxes at
``--delta``. Wall-clock figures: run it on a quiet machine. Exit status: 0 done, 2 bad input.
"""

from __future__ import annotations

import argparse
import sys


def main(argv=None) -> int:
    from planners import planner_names
    from planners.tools.box_index_bench import pose_check_cost, time_limit_overrun

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--counts", type=int, nargs="+", default=[100, 1000, 5000, 20000], help="box counts")
    ap.add_argument("--poses", type=int, default=20000, help="poses timed per count")
    ap.add_argument("--planners", nargs="*", default=list(planner_names()),
                    help="planners timed under a limit (default: every registered one that plans the 6-DoF body)")
    ap.add_argument("--limit-boxes", type=int, default=20000, help="boxes in the time-limit scene")
    ap.add_argument("--time-limit", type=float, default=1.0)
    ap.add_argument("--delta", type=float, default=0.003, help="motion-check resolution of the time-limit scene")
    args = ap.parse_args(argv)
    if min(args.counts) < 1 or args.poses < 1 or args.limit_boxes < 1 or not args.time_limit > 0:
        print("error: --counts, --poses and --limit-boxes must be positive, --time-limit > 0", file=sys.stderr)
        return 2
    if unknown := [p for p in args.planners if p not in planner_names()]:
        print(f"error: --planners {unknown[0]}: unknown; expected some of {', '.join(planner_names())}",
              file=sys.stderr)
        return 2
    print("| boxes | us per pose, indexed | us per pose, full scan | answers that differ |")
    print("|---|---|---|---|")
    for n in args.counts:
        c = pose_check_cost(n, args.poses)
        print(f"| {n:,} | {c.indexed_us:.2f} | {c.scan_us:.2f} | {c.disagreements} |", flush=True)
    for planner in args.planners:
        try:
            took = time_limit_overrun(planner, args.limit_boxes, args.time_limit, args.delta)
        except ValueError as e:  # a planner that refuses the body's space (Informed RRT* needs a Euclidean one)
            print(f"{planner}: does not plan the 6-DoF body ({e})", flush=True)
            continue
        print(f"{planner}: {took:.3f} s under time_limit={args.time_limit:g} among {args.limit_boxes:,} boxes "
              f"(delta {args.delta:g})", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
