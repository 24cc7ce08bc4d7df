"""First-call benchmark: how long a new user waits for a first plan, with an empty and with a filled kernel cache.

Each planner runs in a fresh interpreter (``python -c``) with ``NUMBA_CACHE_DIR`` pointing at a new,
empty folder: ``make_planner(name, problem, seed=0).solve(max_iterations=2000)`` on a 96x64 map (the
6-DoF rows: a thin-wall scene). "start to solved" is the whole process, interpreter start and imports
included; the same run is then repeated in another fresh interpreter with the folder now filled.
"compiling" is the time the first process spent in numba's compiler (``compile_seconds``); its CPU
time (the process's own) says what the wall time would be on an idle machine when others share it.

    python scripts/benchmark_first_call.py                    # every row, this checkout
    python scripts/benchmark_first_call.py --rows rrt-goal rrt-connect --repeat 3
    python scripts/benchmark_first_call.py --code /path/to/other/checkout   # the same rows on other code
    python scripts/benchmark_first_call.py --rows prm --against /path/to/parent --repeat 3   # alternating A/B
    python scripts/benchmark_first_call.py --save    # also store the compile figures the notice quotes
    python scripts/benchmark_first_call.py --rows rrt-goal --breakdown 10   # where the compile time goes
    python scripts/benchmark_first_call.py --omplapp DIR --rows mesh-easy mesh-cubicles   # OMPL.app's problems

The mesh rows (``mesh-easy``, ``mesh-cubicles``: RRT-Connect on OMPL.app's Easy and cubicles; ``mesh-cubicles-prm``:
PRM on cubicles; meshes read and checked exactly, under the ``.cfg``'s time limit) need the ``mesh`` extra and
OMPL.app's files (``--omplapp DIR`` or ``SAMPLERGYM_OMPLAPP_DIR``; not shipped); "start to solved" then includes
reading the meshes.

``--save`` writes, per row, the CPU seconds compiling added (empty-cache run minus filled-cache run) to
``planners/kernels/compile_seconds.json`` with the machine's CPU count and the date, keyed by planner and world kind
(``RRT/2d``, ``PRM/6dof`` for the box world, ``RRTConnect/mesh``); the one-line notice before a first compilation
quotes them (``planners.kernels.cache``).

Prints a Markdown table (the minimum over ``--repeat`` runs of each figure: other load on the machine
only ever adds time). With ``--against DIR`` the rows also run on that checkout, the two codes taking turns
run by run (a machine whose speed drifts then slows both alike), and a second table gives every run's
"start to solved" and "of it compiling" for both. Targets: goal-biased RRT and RRT-Connect within 5 s cold;
every planner within 15 s cold; a first solve within 0.3 s warm.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

#: row -> (label, planner name, problem, sampler): "grid" is the 96x64 map, "rigid" the 6-DoF scene
ROWS = {
    "rrt-goal": ("RRT (goal-biased 0.05)", "RRT", "grid", "goal"),
    "rrt-connect": ("RRT-Connect", "RRTConnect", "grid", None),
    "rrtstar": ("RRT*", "RRTstar", "grid", None),
    "informed": ("Informed RRT*", "InformedRRTstar", "grid", None),
    "prm": ("PRM", "PRM", "grid", None),
    "lazyprm": ("Lazy-PRM", "LazyPRM", "grid", None),
    "obprm": ("OB-PRM", "OBPRM", "grid", None),
    "rrt-6dof": ("6-DoF RRT", "RRT", "rigid", None),
    "prm-6dof": ("6-DoF PRM", "PRM", "rigid", None),
    "mesh-easy": ("RRT-Connect, OMPL.app's Easy (meshes)", "RRTConnect", "omplapp:Easy", None),
    "mesh-cubicles": ("RRT-Connect, OMPL.app's cubicles (meshes)", "RRTConnect", "omplapp:cubicles", None),
    "mesh-cubicles-prm": ("PRM, OMPL.app's cubicles (meshes)", "PRM", "omplapp:cubicles", None),
}
#: Rows that need OMPL.app's files: run only when named, with ``--omplapp DIR`` or ``SAMPLERGYM_OMPLAPP_DIR``.
MESH_ROWS = ("mesh-easy", "mesh-cubicles", "mesh-cubicles-prm")

# Only public names that every version of the library has, so --code can point at older checkouts.
CHILD = r"""
import json, sys, time
t_start = float(sys.argv[4])
by_function = {}
if sys.argv[5] == "breakdown":
    from numba.core import event

    class PerFunction(event.Listener):
        # CPU seconds each dispatcher's compilation took, less the compilations nested in it
        stack = []

        def on_start(self, ev):
            f = getattr(ev.data["dispatcher"], "py_func", None)
            self.stack.append([getattr(f, "__module__", "?") + "." + getattr(f, "__qualname__", "?"),
                               time.process_time(), 0.0])

        def on_end(self, ev):
            name, t0, nested = self.stack.pop()
            dt = time.process_time() - t0
            by_function[name] = by_function.get(name, 0.0) + dt - nested
            if self.stack:
                self.stack[-1][2] += dt

    event.register("numba:compile", PerFunction())
import numpy as np
from planners import GoalBiasedSampler, OccupancyGrid, Problem, make_planner, thin_wall_scene
from planners.base.planner import compile_seconds
name, world, sampler = sys.argv[1], sys.argv[2], sys.argv[3]
if world.startswith("omplapp:"):
    from planners.worlds.omplapp import load_omplapp

    task = load_omplapp(sys.argv[6] + "/" + world.split(":", 1)[1] + ".cfg")
    problem, limit = task.problem, task.time_limit or 20.0
elif world == "grid":
    obs = np.zeros((64, 96), dtype=bool)
    obs[12:52, 30:34] = True
    obs[0:30, 62:66] = True
    obs[40:64, 62:66] = True
    problem = Problem(OccupancyGrid(obs), (5.5, 5.5), (90.5, 58.5), goal_tolerance=2.0)
else:
    problem = thin_wall_scene(hole=4.0)
kw = {"sampler": GoalBiasedSampler(0.05)} if sampler == "goal" else {}
t0 = time.time()
if world.startswith("omplapp:"):
    r = make_planner(name, problem, seed=0, **kw).solve(max_iterations=10**7, time_limit=limit)
else:
    r = make_planner(name, problem, seed=0, **kw).solve(max_iterations=2000)
t1 = time.time()
print(json.dumps({"total": t1 - t_start, "cpu": time.process_time(), "first_solve": t1 - t0,
                  "compile": compile_seconds(), "solved": bool(r.solved), "iterations": int(r.iterations),
                  "by_function": by_function}))
"""


def run_child(code: Path, row: str, cache: str, breakdown: bool = False, omplapp: str = "-") -> dict:
    """One fresh interpreter running one row against ``cache``; its figures."""
    _, name, world, sampler = ROWS[row]
    env = dict(os.environ, NUMBA_CACHE_DIR=cache, PYTHONPATH=str(code), SAMPLERGYM_COMPILE_NOTICE="0")
    t = time.time()
    out = subprocess.run([sys.executable, "-c", CHILD, name, world, sampler or "-", repr(t),
                          "breakdown" if breakdown else "-", omplapp], env=env,
                         capture_output=True, text=True, cwd=code)
    if out.returncode != 0:
        raise RuntimeError(f"row {row} failed on {code}:\n{out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    """Command line entry point."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rows", nargs="+", default=[r for r in ROWS if r not in MESH_ROWS], metavar="ROW",
                    help=f"default: all but the mesh rows ({', '.join(ROWS)})")
    ap.add_argument("--omplapp", default=None,
                    help="OMPL.app's root or resources/3D folder, for the mesh rows (default $SAMPLERGYM_OMPLAPP_DIR)")
    ap.add_argument("--code", type=Path, default=ROOT,
                    help="checkout whose planners package is timed (default: this one)")
    ap.add_argument("--against", type=Path, default=None,
                    help="another checkout, timed in turns with --code run by run (an A/B comparison)")
    ap.add_argument("--repeat", type=int, default=1, help="runs per row; the table shows the minimum of each figure")
    ap.add_argument("--breakdown", type=int, default=0, metavar="N",
                    help="after each row, the N functions whose compilation took the most CPU time "
                         "(nested ones excluded)")
    ap.add_argument("--save", action="store_true",
                    help="store each row's compile CPU seconds in the timed checkout's "
                         "planners/kernels/compile_seconds.json")
    args = ap.parse_args(argv)
    bad = [r for r in args.rows if r not in ROWS]
    if bad:
        print(f"--rows: unknown row {bad[0]!r}; expected one of {', '.join(ROWS)}", file=sys.stderr)
        return 2
    omplapp = "-"
    if any(r in MESH_ROWS for r in args.rows):
        from planners.base.fileio import InputError
        from planners.worlds.omplapp import omplapp_dir

        try:
            folder = omplapp_dir(args.omplapp)
        except InputError as exc:
            print(exc, file=sys.stderr)
            return 2
        if folder is None:
            print("the mesh rows need OMPL.app's problems: give --omplapp DIR or set SAMPLERGYM_OMPLAPP_DIR",
                  file=sys.stderr)
            return 2
        omplapp = str(folder)
    for flag, code in (("--code", args.code), ("--against", args.against)):
        if code is not None and not (code / "planners" / "__init__.py").is_file():
            print(f"{flag}: {code} holds no planners package", file=sys.stderr)
            return 2
    if args.against is not None and args.save:
        print("--save: not with --against (which checkout's figures would it store?)", file=sys.stderr)
        return 2
    if args.against is not None and args.against.resolve() == args.code.resolve():
        print(f"--against: {args.against} is the checkout --code times; give another", file=sys.stderr)
        return 2
    if args.breakdown < 0:
        print(f"--breakdown: must be at least 0, got {args.breakdown}", file=sys.stderr)
        return 2
    if args.repeat < 1:
        print(f"--repeat: must be at least 1, got {args.repeat}", file=sys.stderr)
        return 2
    save_to = args.code / "planners" / "kernels" / "compile_seconds.json"
    if args.save and not os.access(save_to.parent, os.W_OK):
        print(f"--save: {save_to.parent} is not writable", file=sys.stderr)
        return 2
    print(f"code: {args.code.resolve()}  python: {sys.executable}  cpus: {os.cpu_count()}  repeat: {args.repeat}  "
          f"load: {os.getloadavg()[0]:.1f}")
    print()
    print("| planner | start to solved, empty cache | its CPU time | of it compiling | start to solved, filled cache "
          "| first solve, filled cache | iterations |")
    print("|---|---|---|---|---|---|---|")
    saved, breakdowns = {}, []
    codes = [args.code] + ([args.against] if args.against is not None else [])
    runs = {(code, row): ([], []) for code in codes for row in args.rows}
    for turn in range(args.repeat):
        # with --against, the codes take turns run by run, the first of each pair alternating
        for code in (codes if turn % 2 == 0 else codes[::-1]):
            for row in args.rows:
                with tempfile.TemporaryDirectory(prefix="first-call-") as d:
                    runs[code, row][0].append(run_child(code, row, d, args.breakdown > 0, omplapp))
                    runs[code, row][1].append(run_child(code, row, d, omplapp=omplapp))
    for row in args.rows:
        cold, warm = runs[args.code, row]
        c = {k: min(r[k] for r in cold) for k in ("total", "cpu", "compile")}
        w = {k: min(r[k] for r in warm) for k in ("total", "first_solve", "cpu")}
        _, name, world, _ = ROWS[row]
        # the notice's keys (planners.kernels.cache.figure_kind): the planar worlds, the box world, the mesh worlds
        key = f"{name}/{'mesh' if row in MESH_ROWS else '6dof' if world == 'rigid' else '2d'}"
        saved[key] = max(saved.get(key, 0.0), round(c["cpu"] - w["cpu"], 1))
        its = cold[0]["iterations"] if cold[0]["solved"] else f"unsolved after {cold[0]['iterations']}"
        print(f"| {ROWS[row][0]} | {c['total']:.1f} s | {c['cpu']:.1f} s | {c['compile']:.1f} s | {w['total']:.1f} s "
              f"| {w['first_solve']:.2f} s | {its} |", flush=True)
        if args.breakdown:
            top = sorted(cold[0]["by_function"].items(), key=lambda kv: -kv[1])[:args.breakdown]
            breakdowns.append(f"{ROWS[row][0]}: " + ", ".join(f"{n} {v:.2f} s" for n, v in top))
    for line in breakdowns:
        print(line)
    if args.against is not None:
        print(f"\nevery run, in turns: A = {args.code.resolve()}, B = {args.against.resolve()}\n")
        print("| planner | start to solved, A | start to solved, B | of it compiling, A | of it compiling, B |")
        print("|---|---|---|---|---|")
        for row in args.rows:
            a, b = runs[args.code, row][0], runs[args.against, row][0]
            cells = [", ".join(f"{r[k]:.1f}" for r in rs) for k in ("total", "compile") for rs in (a, b)]
            print(f"| {ROWS[row][0]} | " + " | ".join(cells) + " |", flush=True)
    print(f"load after: {os.getloadavg()[0]:.1f}")
    if args.save:
        old = json.loads(save_to.read_text()) if save_to.is_file() else {}
        # a date per figure: a --save of some rows leaves the others' figures and dates as they were
        old.setdefault("seconds", {}).update(saved)
        old.setdefault("dates", {}).update({key: datetime.date.today().isoformat() for key in saved})
        old["cpus"] = os.cpu_count()
        old["measured"] = ("CPU seconds a first solve spends compiling (empty-cache run minus filled-cache run, "
                           "scripts/benchmark_first_call.py --save), each measured on the date \"dates\" gives")
        save_to.write_text(json.dumps(old, indent=1, sort_keys=True) + "\n")
        print(f"saved {len(saved)} figures to {save_to}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
