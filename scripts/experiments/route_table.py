"""The route encoders of several evaluation runs side by side, with the room to the exact reference.

    python scripts/experiments/route_table.py results/evaluation/runs.csv
    python scripts/experiments/route_table.py vin=results/evaluation/runs.csv unet=old/runs.csv
    python scripts/experiments/route_table.py shipped=runs.csv "strict walk=runs.csv@strict walk"

Each argument is ``[LABEL=]runs.csv[@SAMPLER]`` of ``scripts/evaluate.py``: the sampler's runs (default
"route encoder"; another name is an ``evaluate.py --sampler NAME=...`` of the same run). The ablation and the
exact reference are taken from the first; each column's median is shown with its share of the room closed,
``(ablation - encoder) / (ablation - exact)`` where the room is at least 20% of the ablation's median
("no room" else), and its success rate. Rows: every test map set of the first run, then the MovingAI maps
pooled. Medians are of iterations-to-solution, an unsolved run counting as the cap.
"""

from __future__ import annotations

import csv
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

ENCODER, ABLATION, EXACT = "route encoder", "route ablation", "exact_route"
GENERATED = ("bugtrap", "forest", "maze", "narrow_passage", "rooms")


def _runs(path: str) -> dict[tuple[str, str], list[tuple[int, bool]]]:
    out: dict[tuple[str, str], list[tuple[int, bool]]] = defaultdict(list)
    with open(path, newline="", encoding="utf-8") as f:
        for r in csv.DictReader(f):
            if r["split"] == "test" and r["planner"] == "RRT":
                out[(r["map"], r["sampler"])].append((int(r["iterations"]), r["solved"] == "True"))
    return out


def _pooled(runs, sampler: str, sets: list[str]) -> list[tuple[int, bool]]:
    return [x for s in sets for x in runs.get((s, sampler), [])]


def main(argv: list[str]) -> int:
    if not argv or argv[0] in ("-h", "--help"):
        print(__doc__, file=sys.stderr if not argv else sys.stdout)
        return 2 if not argv else 0
    named = [(a.split("=", 1) if "=" in a else [a, a]) for a in argv]
    columns = []
    for label, spec in named:
        path, _, sampler = spec.partition("@")
        columns.append((label, path, sampler or ENCODER))
    for label, path, _ in columns:
        if not Path(path).is_file():
            print(f"route_table: {path!r} (column {label!r}) is not a file; expected an evaluate.py runs.csv",
                  file=sys.stderr)
            return 2
    files = {path: _runs(path) for _, path, _ in columns}
    for label, path, sampler in columns:
        if not any(s == sampler for _, s in files[path]):
            print(f"route_table: {path} holds no test runs of the sampler {sampler!r} (column {label!r})",
                  file=sys.stderr)
            return 2
    runs = [(label, files[path], sampler) for label, path, sampler in columns]
    base = runs[0][1]
    sets = sorted({m for m, s in base if s == EXACT}, key=lambda m: (
        0 if m in GENERATED else 1 if "shifted" in m else 2 if "unseen" in m else 3, m))
    movingai = [m for m in sets if m not in GENERATED and "(" not in m]
    heads = [f"{label}: median, share closed, success" for label, *_ in runs]
    print("| map set | exact | ablation | " + " | ".join(heads) + " |")
    print("|---|---|---|" + "---|" * len(runs))
    for name, pick in [*((m, [m]) for m in sets), *([("MovingAI (all)", movingai)] if movingai else [])]:
        exact = np.median([i for i, _ in _pooled(base, EXACT, pick)])
        abl_runs = _pooled(base, ABLATION, pick)
        abl = np.median([i for i, _ in abl_runs])
        cells = []
        for _, r, sampler in runs:
            enc_runs = _pooled(r, sampler, pick)
            if not enc_runs:
                cells.append("–")
                continue
            enc = np.median([i for i, _ in enc_runs])
            share = f"{(abl - enc) / (abl - exact):.2f}" if abl - exact >= 0.2 * abl else "no room"
            success = np.mean([s for _, s in enc_runs])
            cells.append(f"{enc:g}, {share}, {success:.2f}")
        abl_success = np.mean([s for _, s in abl_runs])
        print(f"| {name} | {exact:g} | {abl:g} ({abl_success:.2f}) | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
