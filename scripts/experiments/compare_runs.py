"""Are two ``runs.csv`` files (``scripts/evaluate.py``) the same runs, row for row? Timing columns aside.

    python scripts/experiments/compare_runs.py baseline/runs.csv results/evaluation/runs.csv

Rows are joined on (map set, query, split, planner, sampler, seed); every row must be in both files,
with the same iterations and the same success. Prints the counts and the first differences; exits 0
when the files agree, 1 when they differ, 2 on a bad argument.
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

KEY = ("map", "query", "split", "planner", "sampler", "seed")
COMPARED = ("iterations", "solved")


def read_runs(path: Path) -> dict[tuple[str, ...], dict[str, str]]:
    """The rows of a ``runs.csv`` by their key; a repeated key or a missing column is an error naming the file."""
    with path.open(newline="") as f:
        reader = csv.DictReader(f)
        missing = [c for c in (*KEY, *COMPARED) if c not in (reader.fieldnames or [])]
        if missing:
            raise ValueError(f"{path}: no column {', '.join(missing)} (is it a runs.csv of scripts/evaluate.py?)")
        rows: dict[tuple[str, ...], dict[str, str]] = {}
        for line, row in enumerate(reader, start=2):
            key = tuple(row[k] for k in KEY)
            if key in rows:
                raise ValueError(f"{path}, line {line}: the run {key} appears twice")
            rows[key] = row
    return rows


def compare(old: dict, new: dict) -> tuple[list[tuple], list[tuple], list[tuple]]:
    """(keys only in ``old``, keys only in ``new``, (key, column, old value, new value) for each difference)."""
    differ = [(k, c, old[k][c], new[k][c]) for k in sorted(old.keys() & new.keys()) for c in COMPARED
              if old[k][c] != new[k][c]]
    return sorted(old.keys() - new.keys()), sorted(new.keys() - old.keys()), differ


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("old", type=Path, help="the reference runs.csv")
    ap.add_argument("new", type=Path, help="the runs.csv to check against it")
    ap.add_argument("--show", type=int, default=10, help="differences to print (default 10)")
    args = ap.parse_args(argv)
    for name in ("old", "new"):
        if not getattr(args, name).is_file():
            ap.error(f"{name} {getattr(args, name)}: no such file")
    try:
        old, new = read_runs(args.old), read_runs(args.new)
    except ValueError as exc:
        ap.error(str(exc))
    only_old, only_new, differ = compare(old, new)
    print(f"{len(old)} runs in {args.old}, {len(new)} in {args.new}; {len(old.keys() & new.keys())} in both; "
          f"{len(only_old)} only in the first, {len(only_new)} only in the second; "
          f"{len(differ)} differences in {' or '.join(COMPARED)}")
    for k in only_old[:args.show]:
        print("only in the first: ", dict(zip(KEY, k, strict=True)))
    for k in only_new[:args.show]:
        print("only in the second:", dict(zip(KEY, k, strict=True)))
    for k, c, a, b in differ[:args.show]:
        print(f"{dict(zip(KEY, k, strict=True))}: {c} {a} -> {b}")
    return 0 if not (only_old or only_new or differ) else 1


if __name__ == "__main__":
    sys.exit(main())
