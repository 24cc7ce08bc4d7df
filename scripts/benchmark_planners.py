"""Planner benchmark: speed against OMPL in the same run, and every planner on every map family.

    python scripts/benchmark_planners.py                 # full run (~8 min on 2 cores), OMPL if installed
    python scripts/benchmark_planners.py --quick         # smoke-sized run
    python scripts/benchmark_planners.py --no-ompl
    python scripts/benchmark_planners.py --rigid DIR --rigid-ompl   # OMPL.app's .cfg problems instead, with OMPL

Prints Markdown tables and writes them, with the raw runs as CSV, under --out; also one OMPL
benchmark log per map (ompl/<map>.log) that OMPL's ompl_benchmark_statistics.py and Planner Arena open.
On 2-D maps it compares time per iteration; time to a first solution, every sampler's own work included, against
OMPL's RRT-Connect on the same queries in the same run is ``scripts/benchmark_clock.py``'s.

With ``--rigid DIR`` (OMPL.app's root or its ``resources/3D`` folder; needs the ``mesh`` extra) it runs
instead our RRT-Connect and goal-biased RRT on every ``.cfg`` problem there, with the problem's own time
limit and run count (``--rigid-time-limit`` and ``--rigid-runs`` cap them, ``--rigid-problems`` and
``--rigid-planners`` choose), and prints and writes (``rigid.md``) the success rate, median time, tree
states, collision checks and time per iteration; ``--rigid-ompl`` adds OMPL's RRT-Connect and RRT
(``planners.tools.ompl_bridge.ompl_rigid``: OMPL.app's set-up, our state check) and the ratio of the
median times. ``--rigid-samplers NAME ...`` adds, for each of our set-ups, a row per sampler of the registry
(``make_sampler(NAME)``, e.g. ``rigid_route_ablation``: the workspace route of the body's centre) in place of
the set-up's own sampling; a run's time then includes the sampler's set-up (its route search). Every run goes
to ``rigid_runs.csv`` and to one OMPL benchmark log per problem (``ompl/<problem>.log``).
"""

from __future__ import annotations

import argparse
import io
import platform
import re
import statistics
import sys
from pathlib import Path

import numpy as np

from planners import (
    OccupancyGrid,
    Problem,
    load_movingai_scenarios,
    movingai_dir,
)
from planners.base.fileio import (
    InputError,
    atomic_write_text,
    check_flags,
    check_int_flags,
    check_number,
    check_output_place,
)
from planners.maps.generators import FAMILIES, check_size, generate
from planners.tools import benchmark, ompl_bridge
from planners.tools.benchmark_log import PlannerRuns, experiment_name, write_log
from planners.tools.parallel import add_backend_arguments, check_backend_arguments, make_backend


def map_set(args) -> dict[str, list[Problem]]:
    """Queries per map: seeded generated maps of each family, and the longest MovingAI scenarios."""
    maps = {f"{f}-{args.size}": [generate(f, s, args.size) for s in range(args.seeds)] for f in FAMILIES}
    d = movingai_dir(args.movingai, required=False)
    if d is None:
        print("MovingAI maps not found (use --movingai DIR or SAMPLERGYM_MOVINGAI_DIR); skipping them", file=sys.stderr)
        return maps
    for scen in sorted(d.glob("*.scen")):
        ps = [p for p in load_movingai_scenarios(scen, goal_tolerance=args.tolerance)
              if p.distance(p.start, p.goal) > args.tolerance]
        ps.sort(key=lambda p: -p.reference_length)
        # spread the picks over the longest half of the scenarios
        picks = ps[: max(1, len(ps) // 2)][:: max(1, len(ps) // 2 // args.scenarios)][: args.scenarios]
        maps[scen.name.split(".")[0].replace("-random-1", "")] = picks
    return maps


def throughput(maps, args, use_ompl: bool) -> tuple[list[dict], list[benchmark.Run]]:
    """RRT per-iteration time, ours vs OMPL, uniform and goal-biased, on every map."""
    rows, records = [], []
    for name, problems in maps.items():
        for bias, ours_label in ((0.0, "RRT"), (0.05, "RRT+goal0.05")):
            ours = [benchmark.run_one(p, ours_label, step=args.step, seed=i, max_iterations=args.max_iterations,
                                      map_name=name)
                    for i, p in enumerate(problems)]
            records += ours
            row = {"map": name, "goal_bias": bias, "ours_us": _us(ours), "ours_solved": _rate(ours)}
            if use_ompl:
                om = []
                for i, p in enumerate(problems):
                    o = ompl_bridge.OmplGridPlanner(p, "RRT", step_size=args.step, goal_bias=bias,
                                                    seed=i).run(args.max_iterations)
                    bound = p.iteration_lower_bound(args.step)
                    om.append(benchmark.Run(
                        map=name, query=p.name, split="test", planner=f"OMPL RRT b={bias}", sampler="OMPL", seed=i,
                        solved=o.solved, iterations=o.iterations, lower_bound=-1 if bound is None else bound,
                        candidates=o.iterations, collision_checks=-1, wall_time=o.time,
                        us_per_iteration=o.time / max(o.iterations, 1) * 1e6, path_cost=o.cost, forward_passes=0,
                        vertices=o.num_vertices))
                records += om
                row |= {"ompl_us": _us(om), "ompl_solved": _rate(om), "ratio": _us(ours) / _us(om)}
            rows.append(row)
            print(benchmark.markdown_table([row]).splitlines()[-1], flush=True)
    return rows, records


def _us(rs) -> float:
    return sum(r.wall_time for r in rs) / max(sum(r.iterations for r in rs), 1) * 1e6


def _rate(rs) -> float:
    return float(np.mean([r.solved for r in rs]))


def growth(args, use_ompl: bool, d: Path | None) -> tuple[list[dict], list[dict]]:
    """Per-iteration time while a uniform-sampling RRT tree grows to 1k, 10k and 100k vertices."""
    checkpoints = [1000, 10000, 100000] if not args.quick else [1000, 10000]
    worlds = {"forest-512-0": generate("forest", 0, 512).world}
    if d is not None:
        worlds["random512-10-0"] = OccupancyGrid.from_movingai(d / "random512-10-0.map")
    rows, nn_rows = [], []
    for name, g in worlds.items():
        free = np.argwhere(~g.obstacles)
        c = free[np.argmin(np.abs(free - np.array(g.shape) // 2).sum(axis=1))]
        far = free[np.argmax(np.abs(free - c).sum(axis=1))]
        # a goal region of radius 1e-9 is never reached by uniform sampling: the tree just grows
        p = Problem(g, g.cell_center(*c), g.cell_center(*far), goal_tolerance=1e-9)
        step_fn = benchmark.ours_growth_step(p, args.step, 0)
        for w in benchmark.growth_profile(step_fn, checkpoints):
            rows.append({"map": name, "planner": "ours RRT", **w})
        if use_ompl:
            o = ompl_bridge.OmplGridPlanner(p, "RRT", step_size=args.step, goal_bias=0.0, seed=0)

            def ompl_step(k, o=o):
                r = o.run(k)
                return r.num_vertices, r.time

            for w in benchmark.growth_profile(ompl_step, checkpoints, chunk=5000):
                rows.append({"map": name, "planner": "OMPL RRT", **w})
        V = step_fn.planner.planner_data().vertices
        lo, hi = g.bounds
        for r in benchmark.nn_scaling(V, checkpoints, lo, hi):
            nn_rows.append({"map": name, **r})
    return rows, nn_rows


def all_planners(maps, args) -> list[benchmark.Run]:
    backend = make_backend(args.backend, processes=args.processes, address=args.address)
    try:
        return benchmark.run_all_setups(maps, step=args.step, max_iterations=args.max_iterations, backend=backend)
    finally:
        backend.close()


def write_ompl_logs(records: list[benchmark.Run], args, out_dir: Path) -> list[Path]:
    """One OMPL benchmark log per map: each planner label is one OMPL planner configuration.

    ``time`` is in seconds; ``time per iteration`` in microseconds. Counts a planner does not report
    (OMPL's collision checks, written as -1 in the CSV) are left empty, which the reader stores as NULL.
    """
    by_map: dict[str, dict[str, list[benchmark.Run]]] = {}
    for r in records:
        by_map.setdefault(r.map, {}).setdefault(r.planner, []).append(r)
    paths = []
    for name, planners in by_map.items():
        entries = {}
        for label, rs in planners.items():
            runs = [benchmark.ompl_run_values(r) for r in rs]
            entries[label] = PlannerRuns({"planner": label, "step_size": args.step,
                                          "max_iterations": args.max_iterations}, runs)
        setup = (f"SamplerGym planner benchmark on {name}: {len(next(iter(planners.values())))} queries per planner, "
                 f"each planner on the same queries and seeds, stopping at the first solution or after "
                 f"{args.max_iterations} iterations. 'time' is the planner's own solve time in seconds.")
        stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("_") or "map"
        paths.append(write_log(out_dir / f"{stem}.log", experiment_name(name), entries,
                               [(p, t) for p, t, _ in benchmark.OMPL_RUN_PROPERTIES], setup=setup,
                               total_time=sum(r.wall_time for rs in planners.values() for r in rs),
                               experiment_properties={"step_size": ("REAL", args.step),
                                                      "max_iterations": ("INTEGER", args.max_iterations)}))
    return paths


#: The set-ups the rigid benchmark compares (``benchmark.SETUPS`` labels), ours and OMPL's each.
RIGID_SETUPS = {"RRTConnect": "RRTConnect", "RRT+goal0.05": "RRT"}


def _rigid_run(problem_name: str, label: str, seed: int, sampler: str, solved: bool, iterations: int,
               candidates: int, checks: int, seconds: float, cost: float, vertices: int,
               solve_seconds: float | None = None) -> benchmark.Run:
    """One run as the benchmark records it; its time per iteration is the solve's own (``solve_seconds``, where
    ``seconds`` also holds a sampler's set-up)."""
    per = seconds if solve_seconds is None else solve_seconds
    return benchmark.Run(map=problem_name, query=problem_name, split="test", planner=label, sampler=sampler, seed=seed,
                         solved=bool(solved), iterations=int(iterations), lower_bound=-1, candidates=int(candidates),
                         collision_checks=int(checks), wall_time=float(seconds),
                         us_per_iteration=1e6 * per / max(int(iterations), 1), path_cost=float(cost),
                         forward_passes=0, vertices=int(vertices))


def _rigid_line(name: str, group: list[benchmark.Run], limit: float, ratio: str) -> str:
    """One row of the rigid table: ``group``'s runs of one planner on one problem (OMPL's report no checks)."""
    checks = statistics.median(r.collision_checks for r in group)
    return (f"| {name} | {group[0].planner} | {len(group)} | {limit:g} | "
            f"{100 * np.mean([r.solved for r in group]):.0f}% | {statistics.median(r.wall_time for r in group):.3f} | "
            f"{ratio} | "
            f"{statistics.median(r.vertices for r in group):.0f} | {'' if checks < 0 else f'{checks:.0f}'} | "
            f"{statistics.median(r.us_per_iteration for r in group):.0f} |\n")


def rigid(args) -> int:
    """RRT-Connect and goal-biased RRT, ours and OMPL's, on every OMPL.app problem in ``args.rigid``."""
    import time

    from planners import UniformSampler, make_planner, solve_with_restarts
    from planners.base.planner import compile_seconds
    from planners.worlds.omplapp import load_omplapp, omplapp_dir

    folder = omplapp_dir(args.rigid)
    cfgs = sorted(folder.glob("*.cfg"), key=lambda p: p.name.lower())
    if args.rigid_problems:
        known = {c.stem for c in cfgs}
        if unknown := [n for n in args.rigid_problems if n not in known]:
            raise InputError(f"--rigid-problems {unknown[0]}: no {unknown[0]}.cfg in {folder} (there: "
                             f"{', '.join(sorted(known)) or 'none'})")
        cfgs = [c for c in cfgs if c.stem in args.rigid_problems]
    labels = args.rigid_planners or list(RIGID_SETUPS)
    samplers = [None] + list(args.rigid_samplers or ())  # None: the set-up's own sampling
    if args.rigid_samplers:
        from learning.samplers.registry import make_sampler
    from planners.algorithms.rrt import diagonal_step
    from planners.base.world import DEFAULT_RANGE_FRACTION
    from planners.worlds.mesh import MESH_RANGE_FRACTION

    use_ompl = args.rigid_ompl and ompl_bridge.available()
    if args.rigid_ompl and not use_ompl:
        print("OMPL not installed (pip install -c constraints.txt -e '.[bench]'); running without it", file=sys.stderr)
    head = ("| problem | planner | runs | time limit (s) | success | median time (s) | ours / OMPL | median tree "
            "states | median checks | time per iteration (us) |\n|---|---|---|---|---|---|---|---|---|---|\n")
    out = io.StringIO()
    step = MESH_RANGE_FRACTION if args.rigid_step is None else args.rigid_step * DEFAULT_RANGE_FRACTION
    out.write(f"# RRT-Connect and RRT on OMPL.app's problems\n\n{platform.processor() or platform.machine()}, "
              f"Python {platform.python_version()}, our step {step:g} of the state box's diagonal (OMPL's keep "
              f"their default range, {DEFAULT_RANGE_FRACTION:g} of the space's extent), RRT's goal bias 0.05, seeds 0 "
              f"to runs - 1; time excludes compilation; 'ours / OMPL' is the ratio of the median times of the same "
              f"planner, where both solve at least half the runs; time per iteration is the median over runs of the "
              f"solve's own time (a sampler's set-up is in the median time only).\n\n" + head)
    print(out.getvalue(), end="", flush=True)
    records: list[benchmark.Run] = []
    logs: list[tuple] = []
    for cfg in cfgs:
        try:
            task = load_omplapp(cfg)
        except (InputError, ImportError) as e:
            line = f"| {cfg.stem} | | | | | not loaded: {str(e).split(': ', 1)[-1]} | | | | |\n"
            out.write(line)
            print(line, end="", flush=True)
            continue
        limit = min(task.time_limit or args.rigid_time_limit or 10.0, args.rigid_time_limit or np.inf)
        runs = min(task.run_count or args.rigid_runs or 10, args.rigid_runs or 10**9)
        name = cfg.stem
        started = time.perf_counter()
        mine: list[benchmark.Run] = []
        for label in labels:
            planner_name, kwargs = benchmark.SETUPS[label]
            for sampler_name in samplers:

                def arguments(planner_name=planner_name, kwargs=kwargs, sampler_name=sampler_name, task=task):
                    kw = kwargs()
                    if sampler_name is not None:  # in place of the set-up's own sampling (RRT's goal bias)
                        kw["sampler"] = make_sampler(sampler_name)
                    if args.rigid_step is not None:  # shares of OMPL's range, in place of the world's default step
                        kw["step_size"] = diagonal_step(task.problem, args.rigid_step * DEFAULT_RANGE_FRACTION)
                    return kw

                make_planner(planner_name, task.problem, seed=0, **arguments()).solve(max_iterations=2)  # compile
                row = label if sampler_name is None else f"{planner_name} with {sampler_name}"
                if args.rigid_restarts:
                    row += f", Luby restarts x {args.rigid_restarts}"
                    spec_label = type(arguments().get("sampler", UniformSampler())).__name__  # once, not per run
                rs = []
                for seed in range(runs):
                    t, c = time.perf_counter(), compile_seconds()
                    if args.rigid_restarts:  # every attempt binds its sampler: each set-up is part of the time
                        r = solve_with_restarts(planner_name, task.problem, seed=seed, unit=args.rigid_restarts,
                                                time_limit=limit, **arguments())
                        end, t_solve, sampler_label = time.perf_counter() - (compile_seconds() - c), t, spec_label
                    else:
                        planner = make_planner(planner_name, task.problem, seed=seed, **arguments())  # binds it
                        t_solve = time.perf_counter()
                        r = planner.solve(time_limit=limit)
                        end = time.perf_counter() - planner.compile_time
                        sampler_label = type(planner.sampler).__name__
                    rs.append(_rigid_run(name, row, seed, sampler_label, r.solved, r.iterations,
                                         r.candidates, r.collision_checks, end - t, r.cost, r.num_vertices,
                                         solve_seconds=end - t_solve))
                theirs = []
                if use_ompl and sampler_name is None:
                    for seed in range(runs):
                        o = ompl_bridge.ompl_rigid(task.problem, RIGID_SETUPS[label], seed=seed, time_limit=limit)
                        theirs.append(_rigid_run(name, f"OMPL {label}", seed, "OMPL", o.solved, o.iterations,
                                                 o.iterations, -1, o.time, o.cost, o.num_vertices))
                ratio = ""  # a median of runs cut at the limit says nothing: left out unless both solve most runs
                if theirs and min(np.mean([r.solved for r in g]) for g in (rs, theirs)) >= 0.5:
                    times = [statistics.median(r.wall_time for r in g) for g in (rs, theirs)]
                    ratio = f"{times[0] / times[1]:.3f}"
                line = _rigid_line(name, rs, limit, ratio) + (_rigid_line(name, theirs, limit, "") if theirs else "")
                out.write(line)
                print(line, end="", flush=True)
                mine += rs + theirs
        records += mine
        entries = {label: PlannerRuns({"planner": label}, [benchmark.ompl_run_values(r) for r in mine
                                                           if r.planner == label])
                   for label in dict.fromkeys(r.planner for r in mine)}
        logs.append((name, entries, runs, limit, time.perf_counter() - started))
    # everything written at the end, each file whole, so a run cut short leaves the last complete results
    atomic_write_text(args.out / "rigid.md", out.getvalue())
    benchmark.write_runs_csv(records, args.out / "rigid_runs.csv")
    for name, entries, runs, limit, seconds in logs:
        write_log(args.out / "ompl" / f"{experiment_name(name)}.log", experiment_name(name), entries,
                  [(p, t) for p, t, _ in benchmark.OMPL_RUN_PROPERTIES],
                  setup=f"SamplerGym rigid-body benchmark on OMPL.app's {name}: {runs} runs per planner, seeds 0 to "
                        f"{runs - 1}, each stopping at the first solution or at the time limit",
                  total_time=seconds, time_limit=limit)
    print(f"\nwrote {args.out / 'rigid.md'}, {args.out / 'rigid_runs.csv'} and {len(logs)} OMPL benchmark logs "
          f"under {args.out / 'ompl'} (Planner Arena opens them)")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=30, help="generated maps per family")
    ap.add_argument("--scenarios", type=int, default=10, help="queries per MovingAI map")
    ap.add_argument("--size", type=int, default=128, help="generated map side")
    ap.add_argument("--step", type=float, default=benchmark.STEP)
    ap.add_argument("--tolerance", type=float, default=benchmark.TOLERANCE, help="goal radius on MovingAI queries")
    ap.add_argument("--max-iterations", type=int, default=benchmark.MAX_ITERATIONS)
    ap.add_argument("--movingai", help="folder of MovingAI .map/.scen files (default ../shared/maps/movingai)")
    ap.add_argument("--no-ompl", action="store_true")
    ap.add_argument("--quick", action="store_true", help="3 seeds, 2 scenarios, growth to 10k only")
    ap.add_argument("--out", type=Path, default=Path("results/benchmark_planners"))
    ap.add_argument("--rigid", metavar="DIR", help="run RRT-Connect and RRT on OMPL.app's .cfg problems in DIR instead")
    ap.add_argument("--rigid-runs", type=int, help="at most this many runs per problem (default: its run_count)")
    ap.add_argument("--rigid-time-limit", type=float,
                    help="at most this many seconds per run (default: its time_limit)")
    ap.add_argument("--rigid-problems", nargs="+", help="only these problems (names of .cfg files)")
    ap.add_argument("--rigid-planners", nargs="+", choices=list(RIGID_SETUPS),
                    help=f"only these set-ups (default: {' '.join(RIGID_SETUPS)})")
    ap.add_argument("--rigid-samplers", nargs="+", metavar="NAME",
                    help="also run our set-ups with these registry samplers (e.g. rigid_route_ablation)")
    ap.add_argument("--rigid-restarts", type=int, default=0, metavar="UNIT",
                    help="our runs restart after Luby's sequence times UNIT iterations (planners.solve_with_restarts; "
                         "OMPL's do not); 0: none")
    ap.add_argument("--rigid-step", type=float, metavar="SHARE",
                    help="our trees' step as this share of OMPL's default range (default: the mesh world's own, 0.1 "
                         "of it)")
    ap.add_argument("--rigid-ompl", action="store_true",
                    help="OMPL's planners beside ours (OMPL.app's discrete motion check, our state check)")
    add_backend_arguments(ap, processes=1,
                          backend_help="where the all-planner comparison runs (the timed ours-vs-OMPL sections stay "
                                       "serial)",
                          processes_help="workers for it (1: serial; more share the cores, so times are not "
                                         "comparable)")
    args = ap.parse_args(argv)
    check_backend_arguments(ap, args)

    def check() -> None:
        check_int_flags(args, ("seeds", "scenarios", "max_iterations"))
        check_size(args.size, "--size")
        check_number("command line", "--step", args.step, low=0.0, low_open=True)
        check_number("command line", "--tolerance", args.tolerance, low=0.0, low_open=True)
        if args.movingai and not Path(args.movingai).is_dir():
            raise InputError(f"--movingai {args.movingai}: not a folder")
        check_output_place(args.out, "--out")
        if args.rigid_runs is not None:
            check_int_flags(args, ("rigid_runs",))
        if args.rigid_time_limit is not None:
            check_number("command line", "--rigid-time-limit", args.rigid_time_limit, low=0.0, low_open=True)
        check_int_flags(args, ("rigid_restarts",), low=0)
        if args.rigid_step is not None:
            check_number("command line", "--rigid-step", args.rigid_step, low=0.0, low_open=True)
        if args.rigid_samplers:
            from learning.samplers.registry import sampler_names

            if unknown := [n for n in args.rigid_samplers if n not in sampler_names()]:
                raise InputError(f"--rigid-samplers {unknown[0]}: not a registered sampler (choose from "
                                 f"{', '.join(sorted(sampler_names()))})")

    check_flags(check)
    if args.rigid is not None:
        try:
            return rigid(args)
        except (InputError, ImportError) as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
    if args.quick:
        args.seeds, args.scenarios = 3, 2
    use_ompl = not args.no_ompl and ompl_bridge.available()
    if not args.no_ompl and not use_ompl:
        print("OMPL not installed (pip install -c constraints.txt -e '.[bench]'); running without it", file=sys.stderr)
    maps = map_set(args)
    # load compiled kernels before any timing
    for label in benchmark.SETUPS:
        benchmark.run_one(next(iter(maps.values()))[0], label, step=args.step, seed=0, max_iterations=200)
    out = io.StringIO()
    header = (f"# Planner benchmark\n\n{platform.processor() or platform.machine()}, "
              f"Python {platform.python_version()}, "
              f"step {args.step}, cap {args.max_iterations} iterations, {args.seeds} seeds per family "
              f"({args.size}x{args.size}), {args.scenarios} scenarios per MovingAI map.\n")
    out.write(header + "\n")
    print(header)

    print("## RRT time per iteration, ours vs OMPL (same maps, same queries)\n", flush=True)
    rows, records = throughput(maps, args, use_ompl)
    cols = ["map", "goal_bias", "ours_us", "ompl_us", "ratio", "ours_solved", "ompl_solved"] if use_ompl else \
        ["map", "goal_bias", "ours_us", "ours_solved"]
    table = benchmark.markdown_table(rows, cols)
    out.write("## RRT time per iteration (us), ours vs OMPL\n\n" + table + "\n")
    if use_ompl:
        ratios = np.array([r["ratio"] for r in rows])
        line = (f"ratio ours/OMPL: median {np.median(ratios):.2f}, max {ratios.max():.2f} "
                f"over {len(ratios)} map x bias cells\n")
        out.write(line + "\n")
        print("\n" + line)

    print("## Tree growth (uniform RRT)\n", flush=True)
    g_rows, nn_rows = growth(args, use_ompl, movingai_dir(args.movingai, required=False))
    gt = benchmark.markdown_table(g_rows, ["map", "planner", "from_vertices", "to_vertices", "iterations",
                                           "us_per_iteration"])
    nt = benchmark.markdown_table(nn_rows, ["map", "vertices", "index_us", "numpy_scan_us"])
    out.write("## Per-iteration time while the tree grows\n\n" + gt
              + "\n## Nearest-neighbour query time\n\n" + nt + "\n")
    print(gt + "\n" + nt)

    print("## Every planner on every map\n", flush=True)
    recs = all_planners(maps, args)
    summary = benchmark.summarize(recs)
    st = benchmark.markdown_table(summary, ["map", "planner", "runs", "success", "median_iterations",
                                            "us_per_iteration",
                                    "median_cost", "median_checks"])
    out.write("## Every planner on every map (iterations to first solution)\n\n" + st)
    print(st)

    benchmark.write_runs_csv(records + recs, args.out / "runs.csv")
    atomic_write_text(args.out / "summary.md", out.getvalue())
    # our own runs of the throughput table repeat the all-planners runs (same queries, seeds and cap):
    # the logs take those once, plus OMPL's runs
    logs = write_ompl_logs(recs + [r for r in records if r.planner.startswith("OMPL")], args, args.out / "ompl")
    for old in set((args.out / "ompl").glob("*.log")) - set(logs):
        old.unlink()  # keep this run's logs only, so `ompl/*.log` never mixes in an earlier run's maps
    print(f"\nwrote {args.out / 'summary.md'}, {args.out / 'runs.csv'} and {len(logs)} OMPL benchmark logs "
          f"in {args.out / 'ompl'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
