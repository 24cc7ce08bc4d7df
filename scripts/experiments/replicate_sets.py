"""Replicate the route encoder's comparison with its ablation on fresh queries of named test sets.

    python scripts/experiments/replicate_sets.py maze-32-32-2 random-32-32-10 room-64-64-8 "narrow_passage (shifted)"
    python scripts/experiments/replicate_sets.py lak303d --queries 20 --csv runs.csv
    python scripts/experiments/replicate_sets.py room-64-64-8 maze --evaluation-queries --first-seed 3 --again

A target of ``evaluate.py`` judged on one set's few queries can fail by a run or two. This script asks whether
such a failure is a loss or noise, by running the same three samplers (the shipped route encoder, its ablation and
the exact reference at the encoder's settings; RRT at the evaluation's step, tolerance and cap, ``--seeds`` planner
seeds) on queries of the same set that the evaluation never ran:

- a MovingAI map: ``--queries`` scenarios spread evenly over the longest half of its scenarios, leaving out the
  evaluation's test and tuning scenarios (the maps come from ``--movingai`` / ``SAMPLERGYM_MOVINGAI_DIR``);
- a family's shifted maps (``"FAMILY (shifted)"``) or its own test maps (``FAMILY``): ``--queries`` maps on the
  seeds that follow the evaluation's, at the sides it uses.

``--evaluation-queries`` runs the evaluation's own test queries of each set instead, and ``--first-seed`` other planner
seeds: the test run's comparison again with only the seeds changed. ``--again`` also runs the ablation on the next
``--seeds`` seeds and sets it against itself: how far a set's ratio and success move by the planner's seeds alone.

``--step-walls off`` runs the encoder without its rule that a block move no cell can step is a wall
(``RouteVIN.step_walls``), still labelled "route encoder".

It prints, per set, the medians and success rates, the encoder's median over the ablation's and its success
minus the ablation's, each with its 95% interval from the same bootstrap over queries as the evaluation's targets
(``learning.evaluation.query_bootstrap``). Nothing is tuned or chosen here: the replication measures only.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from learning.evaluation.protocol import Protocol, Query, movingai_queries, scenarios, shifted_name
from learning.evaluation.roster import EXACT_ROUTE, ROUTE, ROUTE_ABLATION, Task
from learning.evaluation.runner import run_on_backend_args
from learning.evaluation.tables import median_ratio, query_bootstrap, success_difference, summarize
from learning.models.route_net import load_route_net
from learning.models.route_vin import RouteVIN
from learning.samplers.registry import SamplerSpec
from learning.samplers.route import SHIPPED, RouteSampler, shipped_sampler
from planners.base.fileio import InputError, check_output_place
from planners.maps.generators import FAMILIES, SHIFTED_SEED0, SHIFTED_SIZES, TEST_SEED0
from planners.maps.movingai import movingai_dir
from planners.tools.benchmark import markdown_table, write_runs_csv
from planners.tools.parallel import add_backend_arguments, check_backend_arguments

#: The evaluation's protocol: its step, tolerance, cap and how many queries it draws per set.
PROTOCOL = Protocol()
#: The label of ``--again``'s runs: the ablation once more, on the next planner seeds.
ABLATION_AGAIN = "route ablation (next seeds)"


def fresh_queries(name: str, n: int, directory: Path | None, *, evaluation: bool = False) -> list[Query]:
    """``n`` test queries of map set ``name`` that the evaluation (at its default sizes) never runs.

    With ``evaluation`` the evaluation's own test queries of the set instead (``n`` is not used).

    Raises:
        InputError: ``name`` is neither a family, a family's shifted set nor a MovingAI map in ``directory``, or
            a map has fewer than ``n`` unused scenarios in its longest half.
    """
    for family in FAMILIES:
        if name == shifted_name(family):
            first, n = (0, PROTOCOL.shifted_maps) if evaluation else (PROTOCOL.shifted_maps, n)
            return [Query(family, SHIFTED_SEED0 + i, SHIFTED_SIZES[i % len(SHIFTED_SIZES)], "test", shifted=True)
                    for i in range(first, first + n)]
        if name == family:
            first, n = (0, PROTOCOL.maps) if evaluation else (PROTOCOL.maps, n)
            return [Query(family, TEST_SEED0 + i, PROTOCOL.size, "test") for i in range(first, first + n)]
    if directory is None or not (directory / f"{name}.map").is_file():
        where = "no MovingAI folder" if directory is None else f"no {name}.map in {directory}"
        raise InputError(f"set {name!r}: expected a family ({', '.join(FAMILIES)}), a family's shifted set "
                         f"(\"FAMILY (shifted)\") or a MovingAI map ({where})")
    problems = scenarios(str(directory), name, PROTOCOL.tolerance)
    chosen = movingai_queries(str(directory), [name], PROTOCOL.scenarios, PROTOCOL.tuning_scenarios,
                              PROTOCOL.tolerance)
    if evaluation:
        return [q for q in chosen if q.split == "test"]
    used = {q.key for q in chosen}
    rest = [i for i in range(max(2, len(problems) // 2)) if i not in used]
    if len(rest) < n:
        raise InputError(f"set {name!r}: its longest half holds {len(rest)} scenarios the evaluation does not use; "
                         f"--queries {n} asks for more")
    picks = np.linspace(0, len(rest) - 1, n).round().astype(int)
    return [Query(name, rest[i], 0, "test") for i in picks]


def summary_rows(runs, sets: list[str], seed: int = 0) -> list[dict]:
    """One row per set: medians, success rates and the encoder against its ablation, with intervals."""
    by = {(r["family"], r["_sampler"]): r for r in summarize(runs, {})}
    rows = []
    for name in sets:
        cells = {short: by[(name, label)] for short, label in
                 (("ablation", ROUTE_ABLATION), ("encoder", ROUTE), ("exact", EXACT_ROUTE))}
        its = {k: c["median_iterations"] for k, c in cells.items()}
        solved = {k: c["success"] for k, c in cells.items()}
        row = {"set": name, "queries": len({r.query for r in runs if r.map == name}),
               "medians: ablation / encoder / exact": " / ".join(f"{its[k]:g}" for k in its),
               "success: ablation / encoder / exact": " / ".join(f"{solved[k]:.3f}" for k in solved)}
        lo, hi = query_bootstrap(runs, name, ROUTE, ROUTE_ABLATION, median_ratio, seed=seed)
        row["encoder / ablation [95%]"] = f"{its['encoder'] / max(its['ablation'], 1e-9):.2f} [{lo:.2f} to {hi:.2f}]"
        lo, hi = query_bootstrap(runs, name, ROUTE, ROUTE_ABLATION, success_difference, seed=seed)
        row["success difference [95%]"] = f"{solved['encoder'] - solved['ablation']:+.3f} [{lo:+.3f} to {hi:+.3f}]"
        row["exact / ablation"] = f"{its['exact'] / max(its['ablation'], 1e-9):.2f}"
        if (name, ABLATION_AGAIN) in by:
            again = by[(name, ABLATION_AGAIN)]["median_iterations"]
            lo, hi = query_bootstrap(runs, name, ABLATION_AGAIN, ROUTE_ABLATION, median_ratio, seed=seed)
            row["ablation again / ablation [95%]"] = f"{again / max(its['ablation'], 1e-9):.2f} [{lo:.2f} to {hi:.2f}]"
            row["success again"] = f"{by[(name, ABLATION_AGAIN)]['success']:.3f}"
        rows.append(row)
    return rows


@dataclass(frozen=True)
class EncoderWithStepWalls:
    """The shipped sampler around the encoder in ``path`` with its step walls set to ``on``: a task's sampler
    builder (``build`` and ``to_json``, as ``learning.evaluation.roster.Task`` takes), for a setting the registry's
    ``route`` spec does not carry. Its own network, so the shipped spec's cached one keeps its setting."""

    path: str
    step_size: float
    on: bool

    def build(self, models) -> RouteSampler:
        net = load_route_net(self.path)
        net.step_walls = self.on
        return shipped_sampler(net, step_size=self.step_size, device="cpu")

    def to_json(self) -> str:
        return json.dumps({"name": "route", "path": self.path, "step_size": self.step_size, "step_walls": self.on})


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("sets", nargs="+", help="map sets as evaluate.py names them")
    ap.add_argument("--queries", type=int, default=40, help="fresh queries per set (default 40)")
    ap.add_argument("--seeds", type=int, default=PROTOCOL.seeds,
                    help=f"planner seeds per query (default {PROTOCOL.seeds})")
    ap.add_argument("--first-seed", type=int, default=0,
                    help="the first planner seed (default 0: seeds 0 .. seeds - 1, the evaluation's)")
    ap.add_argument("--evaluation-queries", action="store_true",
                    help="the evaluation's own test queries of each set instead of fresh ones (--queries unused)")
    ap.add_argument("--again", action="store_true",
                    help="also the ablation on the next --seeds planner seeds, against itself: how far a ratio moves "
                         "by planner seeds alone")
    ap.add_argument("--route", type=Path, default=SHIPPED, help="route encoder file (default: the shipped one)")
    ap.add_argument("--movingai", type=Path, default=None, help="MovingAI folder (default SAMPLERGYM_MOVINGAI_DIR or "
                                                                "../shared/maps/movingai)")
    ap.add_argument("--step-walls", choices=("on", "off"), default="on" if RouteVIN.step_walls else "off",
                    help="a block move no cell can step is a wall (default: the shipped setting)")
    ap.add_argument("--csv", type=Path, help="also write every run here (runs.csv's columns)")
    add_backend_arguments(ap, processes=os.cpu_count() or 1, processes_help="local workers",
                          backend_help="a local process pool (default) or Ray")
    args = ap.parse_args(argv)
    check_backend_arguments(ap, args)
    if args.queries < 1 or args.seeds < 1 or args.first_seed < 0:
        ap.error(f"--queries and --seeds take counts >= 1 and --first-seed a seed >= 0, got {args.queries}, "
                 f"{args.seeds} and {args.first_seed}")
    try:
        if not args.route.is_file():
            raise InputError(f"--route {args.route}: no such file")
        directory = movingai_dir(args.movingai, required=False)
        queries = [q for name in args.sets
                   for q in fresh_queries(name, args.queries, directory, evaluation=args.evaluation_queries)]
        if args.csv is not None:
            check_output_place(args.csv, "--csv", folder=False)
    except (InputError, OSError) as exc:
        print(f"replicate_sets.py: {exc}", file=sys.stderr)
        return 2
    protocol = Protocol(movingai_dir="" if directory is None else str(directory))
    on = args.step_walls == "on"
    encoder = (SamplerSpec.of("route", path=str(args.route), step_size=protocol.step, device="cpu")
               if on == RouteVIN.step_walls else EncoderWithStepWalls(str(args.route), protocol.step, on))
    specs = [SamplerSpec.of("route_ablation", step_size=protocol.step), encoder,
             SamplerSpec.of("exact_route", step_size=protocol.step)]
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    tasks = [Task(q, "RRT", spec, seed, ROUTE if spec is encoder else "") for q in queries for spec in specs
             for seed in seeds]
    if args.again:
        tasks += [Task(q, "RRT", specs[0], seed + args.seeds, ABLATION_AGAIN) for q in queries for seed in seeds]
    runs = run_on_backend_args(tasks, protocol, args)
    if args.csv is not None:
        write_runs_csv(runs, args.csv)
    table = markdown_table(summary_rows(runs, list(dict.fromkeys(args.sets))), None)
    which = "the evaluation's test queries" if args.evaluation_queries else f"fresh queries per set: {args.queries}"
    print(f"{which}, planner seeds {seeds.start} to {seeds.stop - 1}, RRT step {protocol.step:g}, "
          f"cap {protocol.max_iterations}, step walls {args.step_walls}; medians of iterations to the first solution "
          "(the cap when unsolved)\n")
    print(table)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
