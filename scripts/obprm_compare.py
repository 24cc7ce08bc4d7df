"""PRM vs Lazy-PRM vs OB-PRM on narrow passages of several widths and on an open forest map.

    python scripts/obprm_compare.py                  # 20 queries per map, 20,000-sample budget: 50 s
    python scripts/obprm_compare.py --quick          # 5 queries per map, 5,000-sample budget
    python scripts/obprm_compare.py --seeds 50 --gaps 1 2 4 8 16 --out results/obprm

Prints a Markdown table and writes it (summary.md) with the raw runs (runs.csv) under --out.
"""

from __future__ import annotations

import argparse
import csv
import io
import platform
import sys
from pathlib import Path

from planners.algorithms.obprm import compare_prm_variants
from planners.base.fileio import InputError, atomic_write_text, check_output_place
from planners.tools.benchmark import MAX_ITERATIONS, markdown_table

COLUMNS = ["map", "planner", "runs", "success", "median_samples", "median_candidates", "median_checks",
           "median_time_s"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=20, help="queries (seeded maps) per map kind")
    ap.add_argument("--size", type=int, default=128, help="map side in cells")
    ap.add_argument("--gaps", type=int, nargs="+", default=[1, 2, 4, 8], help="gap widths of the walls, in cells")
    ap.add_argument("--max-iterations", type=int, default=MAX_ITERATIONS, help="sample budget per run")
    ap.add_argument("--quick", action="store_true", help="5 queries per map, 5,000-sample budget")
    ap.add_argument("--out", type=Path, default=Path("results/obprm_compare"))
    args = ap.parse_args(argv)
    if args.quick:
        args.seeds, args.max_iterations = min(args.seeds, 5), min(args.max_iterations, 5000)
    if args.seeds < 1 or args.max_iterations < 1 or args.size < 32 or min(args.gaps) < 1:
        ap.error("--seeds and --max-iterations must be positive, --size >= 32, gaps >= 1")
    try:
        check_output_place(args.out, "--out")  # before the runs
    except InputError as exc:
        ap.error(str(exc))
    rows, runs = compare_prm_variants(seeds=args.seeds, size=args.size, gaps=args.gaps,
                                      max_iterations=args.max_iterations,
                                      progress=lambda line: print(line, file=sys.stderr, flush=True))
    header = (f"# PRM vs Lazy-PRM vs OB-PRM\n\n{platform.processor() or platform.machine()}, Python "
              f"{platform.python_version()}; {args.seeds} queries per map ({args.size}x{args.size}), budget "
              f"{args.max_iterations} samples. Medians over all runs, an unsolved run counting at the budget; "
              f"checks include OB-PRM's sampling checks.\n\n")
    table = markdown_table(rows, COLUMNS)
    print(header + table)
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(runs[0]))
    w.writeheader()
    w.writerows(runs)
    atomic_write_text(args.out / "runs.csv", buf.getvalue())
    atomic_write_text(args.out / "summary.md", header + table)
    print(f"wrote {args.out / 'summary.md'} and {args.out / 'runs.csv'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
