"""What Lazy-PRM's searches cost: its time per query on the MovingAI test queries, one checkout against another.

    python scripts/experiments/lazy_search_cost.py --movingai ../shared/maps/movingai --out new.json
    PYTHONPATH=OLD python scripts/experiments/lazy_search_cost.py --movingai ../shared/maps/movingai --out old.json
    python scripts/experiments/lazy_search_cost.py --compare old.json new.json

Runs Lazy-PRM with uniform samples and with the lazy route sampler (``route_lazy``) on every test query of the
evaluation's quick protocol on each map (``--maps``; the protocol's queries, 20,000 samples at most), seeds 0 and 1,
one thread, and writes each run's samples, success, collision checks, path cost and seconds to ``--out`` (JSON).
Run it once per checkout (``PYTHONPATH`` names the other one; its kernels compile at its first run, which the
median of the query's runs hardly feels), taking turns. ``--compare`` prints, per map and sampler, the median
seconds of each file and their ratio, and every run whose samples, success, checks or cost differ.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

MAPS = ("maze512-32-0", "32room_000", "random512-10-0", "lak303d", "den312d", "Berlin_0_256", "room-64-64-8",
        "maze-32-32-2")
SAMPLERS = ("uniform", "route_lazy")


def measure(movingai: Path, maps: list[str]) -> dict[str, list]:
    """``{map|query|sampler|seed: [samples, solved, checks, cost, seconds]}`` over the maps' test queries."""
    from learning.evaluation.protocol import Protocol, movingai_queries
    from learning.models.threads import planning_threads
    from learning.samplers.registry import make_sampler

    protocol = Protocol(movingai_dir=str(movingai)).quick()
    out, cache = {}, {}
    with planning_threads(1):
        for name in maps:
            queries = [q for q in movingai_queries(protocol.movingai_dir, [name], protocol.scenarios,
                                                   protocol.tuning_scenarios, protocol.tolerance) if q.split == "test"]
            for query in queries:
                problem = protocol.problem(query, cache)
                for sampler in SAMPLERS:
                    for seed in (0, 1):
                        t0 = time.perf_counter()
                        planner, cap = protocol.planner("LazyPRM", problem, make_sampler(sampler), seed)
                        r = planner.solve(max_iterations=cap)
                        seconds = time.perf_counter() - t0
                        out[f"{name}|{query.key}|{sampler}|{seed}"] = [r.iterations, bool(r.solved), r.collision_checks,
                                                                       round(float(r.cost), 6), seconds]
    return out


def compare(old: dict, new: dict) -> str:
    """The per-map table of median seconds and the runs that differ, as text."""
    lines = ["| map | sampler | old ms | new ms | new / old |", "|---|---|---|---|---|"]
    groups = sorted({tuple(k.split("|")[i] for i in (0, 2)) for k in old})
    for name, sampler in groups:
        keys = [k for k in old if k.split("|")[0] == name and k.split("|")[2] == sampler and k in new]
        a = statistics.median(old[k][4] for k in keys) * 1e3
        b = statistics.median(new[k][4] for k in keys) * 1e3
        lines.append(f"| {name} | {sampler} | {a:.2f} | {b:.2f} | {b / a:.2f} |")
    differ = [k for k in old if k in new and old[k][:4] != new[k][:4]]
    lines.append(f"\n{len(differ)} of {len(old.keys() & new.keys())} runs differ in samples, success, checks or cost")
    lines += [f"- {k}: {old[k][:4]} -> {new[k][:4]}" for k in differ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Command line entry point."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--movingai", type=Path, help="folder of the MovingAI maps and scenarios")
    ap.add_argument("--maps", nargs="+", default=list(MAPS))
    ap.add_argument("--out", type=Path, help="JSON file for this checkout's runs")
    ap.add_argument("--compare", nargs=2, type=Path, metavar=("OLD", "NEW"), help="two files this script wrote")
    args = ap.parse_args(argv)
    if args.compare:
        for path in args.compare:
            if not path.is_file():
                ap.error(f"--compare: no file {path}")
        old, new = (json.loads(p.read_text()) for p in args.compare)
        print(compare(old, new))
        return 0
    if args.movingai is None or not args.movingai.is_dir():
        ap.error(f"--movingai: no folder {args.movingai} (the MovingAI maps, e.g. ../shared/maps/movingai)")
    if args.out is None or not args.out.parent.is_dir():
        ap.error(f"--out: give a file in an existing folder, got {args.out}")
    runs = measure(args.movingai, args.maps)
    tmp = args.out.with_name(args.out.name + ".part")
    tmp.write_text(json.dumps(runs))
    tmp.replace(args.out)  # a killed run leaves no half-written file under the name
    print(f"wrote {len(runs)} runs to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
