"""Time to solution: the route sampler against the fastest classical planner, and OMPL's RRT-Connect, on one clock.

    python scripts/benchmark_clock.py --quick                # about 10 min on 2 cores
    python scripts/benchmark_clock.py                        # the test sets at the comparison's sizes
    python scripts/benchmark_clock.py --quick --value-iteration   # the encoder's fixed point by value iteration
    python scripts/benchmark_clock.py --quick --torch-inference   # the encoder's pass through torch after its network

On the comparison's test queries (generated families at 128 cells, their shifted maps, the unseen families and
each MovingAI map), in this process and one thread, RRT with the route encoder, the lazy route sampler (the
straight line first, the encoder only where that has not solved in time) with RRT, and with RRT-Connect and PRM
(their uniform sampling first), the encoder's ablation and the exact reference, RRT with the goal bias tuned on the
tuning split, RRT-Connect, PRM and (with OMPL's Python bindings,
``pip install -c constraints.txt -e ".[bench]"``) OMPL's RRT-Connect plan every query at the same planner seeds;
see ``learning.evaluation.clock`` for what a run's time includes and the targets. Prints and writes (``--out``,
as one set) ``clock.md`` (the median time per query of every method on every set, which is fastest, the targets
held or not, and the fastest method by map size) and ``runs.csv``. ``--value-iteration`` computes the encoder's
fixed point the way it was computed before (value iteration, the same values bit for bit): the time it saves.
``--torch-inference`` runs the encoder's pass through torch after its convolutions (``RouteVIN.compiled_inference``
off; the same fields up to rounding): the time the CPU's compiled inference saves.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import torch

import learning.evaluation as E
from learning.evaluation import clock as C
from learning.evaluation.mapsets import pooled_tuned, unseen_queries
from learning.evaluation.protocol import MOVINGAI_MAPS
from learning.models.route_vin import RouteVIN
from learning.models.shipped import SHIPPED_ROUTE
from planners import movingai_dir
from planners.base.fileio import InputError, atomic_write_text, check_int_flags, check_output_place, output_set
from planners.maps.generators import FAMILIES
from planners.maps.unseen import UNSEEN_FAMILIES
from planners.tools import ompl_bridge
from planners.tools.benchmark import markdown_table, write_runs_csv

#: --quick: test queries per set, and planner seeds.
QUICK = {"maps": 8, "shifted_maps": 8, "unseen_maps": 4, "scenarios": 3, "seeds": 2}


def parse_args(argv=None) -> argparse.Namespace:
    d = E.Protocol()
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help=f"fewer test queries and seeds ({QUICK})")
    ap.add_argument("--maps", type=int, default=d.maps, help="test maps per generated family")
    ap.add_argument("--shifted-maps", type=int, default=d.shifted_maps, help="test maps per shifted family")
    ap.add_argument("--unseen-maps", type=int, default=d.unseen_maps, help="test maps per unseen family")
    ap.add_argument("--scenarios", type=int, default=d.scenarios, help="test scenarios per MovingAI map")
    ap.add_argument("--seeds", type=int, default=d.seeds, help="planner seeds per query")
    ap.add_argument("--tuning-maps", type=int, default=d.tuning_maps, help="tuning maps per family (goal bias)")
    ap.add_argument("--tuning-scenarios", type=int, default=d.tuning_scenarios, help="tuning scenarios per map")
    ap.add_argument("--families", nargs="*", default=list(FAMILIES), choices=FAMILIES)
    ap.add_argument("--no-shifted", action="store_true", help="leave out the shifted sets")
    ap.add_argument("--no-unseen", action="store_true", help="leave out the unseen families")
    ap.add_argument("--movingai", default=None, metavar="DIR",
                    help="MovingAI maps (default $SAMPLERGYM_MOVINGAI_DIR, else ../shared/maps/movingai; skipped, "
                         "saying so, where absent)")
    ap.add_argument("--movingai-maps", nargs="*", default=list(MOVINGAI_MAPS))
    ap.add_argument("--route", type=Path, default=SHIPPED_ROUTE, help="route encoder (default: the shipped one)")
    ap.add_argument("--value-iteration", action="store_true",
                    help="compute the encoder's fixed point by value iteration (the former way; same values)")
    ap.add_argument("--torch-inference", action="store_true",
                    help="the encoder's pass through torch after its convolutions (no compiled part; same fields)")
    ap.add_argument("--no-ompl", action="store_true", help="leave out OMPL's RRT-Connect")
    ap.add_argument("--processes", type=int, default=os.cpu_count() or 1,
                    help="processes for the goal bias's tuning runs (the timed runs use one)")
    ap.add_argument("--out", type=Path, default=Path("results/clock"))
    args = ap.parse_args(argv)
    if args.quick:
        for k, v in QUICK.items():
            if getattr(args, k) == getattr(d, k):
                setattr(args, k, v)
    try:
        check_int_flags(args, ("maps", "shifted_maps", "unseen_maps", "scenarios", "seeds", "tuning_maps",
                               "tuning_scenarios", "processes"), low=1)
        if not args.route.is_file():
            raise InputError(f"--route {args.route}: no such file")
        check_output_place(args.out, "--out")
    except InputError as exc:
        ap.error(str(exc))
    return args


def main(argv=None) -> int:
    args = parse_args(argv)
    torch.set_num_threads(1)
    RouteVIN.fixed_point = "iterate" if args.value_iteration else "dijkstra"
    RouteVIN.compiled_inference = not args.torch_inference
    use_ompl = not args.no_ompl and ompl_bridge.available()
    if not args.no_ompl and not use_ompl:
        print("OMPL's Python bindings are not installed (pip install -c constraints.txt -e '.[bench]'): "
              "its RRT-Connect is left out", file=sys.stderr)
    d = movingai_dir(args.movingai, required=False)
    maps = [] if d is None else [m for m in args.movingai_maps if (d / f"{m}.map").is_file()]
    if d is None:
        print("MovingAI maps not found (--movingai DIR or SAMPLERGYM_MOVINGAI_DIR): their rows are left out",
              file=sys.stderr)
    protocol = E.Protocol(movingai_dir=str(d or ""))
    queries = E.generated_queries(args.families, protocol.size, args.maps, args.tuning_maps)
    queries += [] if args.no_shifted else E.shifted_queries(args.families, args.shifted_maps)
    queries += [] if args.no_unseen else unseen_queries(protocol.size, args.unseen_maps, UNSEEN_FAMILIES)
    scen: dict = {}
    if maps:
        queries += E.movingai_queries(str(d), maps, args.scenarios, args.tuning_scenarios, protocol.tolerance, scen)
    context = E.RunContext(protocol, scenarios=scen)
    t0 = time.perf_counter()
    tuning = E.run_all(E.tuning_tasks(queries, "RRT"), context, args.processes, progress=False)
    families = [q.family for q in queries if q.split == "tuning" and q.size]
    biases = E.tuned_for_shifted(E.best_bias(tuning), queries)
    unseen = sorted({q.map_set for q in queries if not isinstance(q, E.Query)})
    biases.update(pooled_tuned(tuning, sorted(set(families)), E.best_bias, unseen) if unseen else {})
    tasks = C.clock_tasks(queries, protocol, str(args.route), biases, args.seeds)
    print(f"goal bias tuned on {len(tuning)} runs ({time.perf_counter() - t0:.0f} s); {len(tasks)} timed runs"
          + (" and OMPL's RRT-Connect" if use_ompl else "") + ", one process, one thread", flush=True)
    runs = C.run_clock(tasks, context, ompl=use_ompl,
                       progress=lambda i, n: print(f"  {i}/{n}", flush=True) if i % 200 == 0 else None)
    order = list(dict.fromkeys(q.map_set for q in queries if q.split == "test"))
    rows, verdict = C.clock_table(runs, order)
    sides = {}
    for q in dict.fromkeys(q for q in queries if q.split == "test"):
        p = context.problem(q)
        sides[p.name] = max(p.world.shape)
    by_size = C.fastest_by_size(runs, sides)
    load = f"{os.getloadavg()[0]:.1f}" if hasattr(os, "getloadavg") else "unknown"
    how = "value iteration" if args.value_iteration else "a compiled Dijkstra (the default)"
    how += "; its pass through torch after the convolutions" if args.torch_inference else ""
    text = (f"# Time to solution\n\n{len(runs)} runs in {(time.perf_counter() - t0) / 60:.1f} min, one process and "
            f"one thread (load average {load} at the end); the encoder's fixed point by {how}. Median time to "
            "solution in ms, from the planner's start to its first solution, the sampler's per-query work included, "
            "the share solved in brackets; an unsolved run never solves, so where half the runs or more are unsolved "
            "the median is not reached (\"> \" the median time they ran). Targets: the route encoder's (and the lazy "
            "route sampler's) median at most "
            f"{C.AT_MOST:g}x the fastest classical option's on every set, and at most {C.WHERE_SLOW:g}x where that is "
            f"above {C.SLOW_MS:g} ms; pooled, at most {C.OMPL_AT_MOST:g}x OMPL's RRT-Connect.\n\n"
            + "".join(f"{learned}: targets held on {verdict[f'{p}held']} of {verdict['sets']} sets "
                      f"({verdict[f'{p}slow held']} of {verdict['slow sets']} where the fastest takes more than "
                      f"{C.SLOW_MS:g} ms); pooled / OMPL RRT-Connect: {verdict[f'{p}pooled / OMPL RRT-Connect']:.2f}."
                      "\n\n" for learned, p in C.LEARNED.items())
            + f"The best learned method per set: targets held on {verdict['any held']} of {verdict['sets']} sets"
            + (f" (not on {', '.join(verdict['none held'])}).\n\n" if verdict["none held"] else ".\n\n")
            + markdown_table(rows) + "\n## The fastest method by map size\n\n" + markdown_table(by_size))
    with output_set(args.out) as tmp:
        write_runs_csv(runs, tmp / "runs.csv")
        atomic_write_text(tmp / "clock.md", text)
    print(text)
    print(f"wrote {args.out / 'clock.md'} and {args.out / 'runs.csv'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
