"""Time per iteration of RRT-Connect on OMPL.app's mesh problems, for comparing two checkouts run after run.

    PYTHONPATH=$PWD python scripts/experiments/mesh_iteration_cost.py --omplapp DIR
    PYTHONPATH=$PWD python scripts/experiments/mesh_iteration_cost.py --omplapp DIR --problems Home --iterations 600
    PYTHONPATH=$PWD python scripts/experiments/mesh_iteration_cost.py --omplapp DIR --against /path/to/other --rounds 6

For each problem: one short untimed solve (the kernels compile or load there), then RRT-Connect at ``--seed`` for
``--iterations`` iterations (fewer where it solves first), timed; prints the iterations, the collision checks and
the microseconds per iteration as one JSON line. A change that leaves the runs the same (the same iterations and
checks) and moves the time shows in the last figure.

With ``--against DIR`` this process times nothing itself: it runs the same measurement in fresh interpreters on
this checkout (A) and on the one in ``DIR`` (B), each importing its own ``planners``, in turns: a first round that
fills each checkout's kernel cache and is not counted, then ``--rounds`` rounds, the order of A and B flipping from
one round to the next (the machine's speed drifts within minutes, by a third on a shared 2-core machine). It prints,
per problem, each side's median, the ratio of the medians, the median of the rounds' own ratios, and whether the
two sides made the same runs (a change meant to keep the answers must).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

#: problem -> iterations timed by default (about a second or two each on a 2-core machine)
DEFAULT = {"alpha-1.5": 600, "Twistycool": 15000, "cubicles": 3000, "Home": 3000, "Easy": 3000}

#: the checkout this script belongs to
ROOT = Path(__file__).resolve().parents[2]


def measure(tasks: dict, iterations: int | None, seed: int) -> dict:
    """Each problem's iterations, checks and microseconds per iteration in this process."""
    from planners import make_planner

    out = {}
    for name, task in tasks.items():
        make_planner("RRTConnect", task.problem, seed=seed).solve(max_iterations=5)  # compile outside the timing
        planner = make_planner("RRTConnect", task.problem, seed=seed)
        start = time.perf_counter()
        r = planner.solve(max_iterations=iterations or DEFAULT.get(name, 3000))
        took = time.perf_counter() - start
        out[name] = {"iterations": r.iterations, "checks": r.collision_checks,
                     "us_per_iteration": round(took / r.iterations * 1e6, 1)}
    return out


def run_on(code: Path, argv: list[str]) -> dict:
    """This script's measurement in a fresh interpreter importing ``code``'s ``planners``."""
    env = dict(os.environ, PYTHONPATH=str(code))
    out = subprocess.run([sys.executable, str(Path(__file__).resolve()), *argv], env=env, cwd=code,
                         capture_output=True, text=True)
    if out.returncode != 0:
        raise RuntimeError(f"the measurement failed on {code}:\n{out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def compare(a: Path, b: Path, argv: list[str], rounds: int) -> list[dict]:
    """A and B in turns (``rounds`` counted after one that fills the caches); one row per problem."""
    runs: dict[Path, list[dict]] = {a: [], b: []}
    for turn in range(rounds + 1):
        for code in ((a, b) if turn % 2 == 0 else (b, a)):
            result = run_on(code, argv)
            if turn:
                runs[code].append(result)
            print(f"round {turn}{' (filling the caches)' if turn == 0 else ''}, {'A' if code == a else 'B'}: "
                  f"{json.dumps(result)}", file=sys.stderr, flush=True)
    rows = []
    for name in runs[a][0]:
        ta = [r[name]["us_per_iteration"] for r in runs[a]]
        tb = [r[name]["us_per_iteration"] for r in runs[b]]
        paired = [y / x for x, y in zip(ta, tb, strict=True)]
        same = all((ra[name]["iterations"], ra[name]["checks"]) == (rb[name]["iterations"], rb[name]["checks"])
                   for ra, rb in zip(runs[a], runs[b], strict=True))
        rows.append({"problem": name, "A us/iteration": statistics.median(ta),
                     "B us/iteration": statistics.median(tb),
                     "B / A (medians)": round(statistics.median(tb) / statistics.median(ta), 3),
                     "B / A (median of rounds)": round(statistics.median(paired), 3),
                     "same runs": "yes" if same else "no"})
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--omplapp", help="OMPL.app's root or resources/3D folder (default $SAMPLERGYM_OMPLAPP_DIR)")
    ap.add_argument("--problems", nargs="+", default=list(DEFAULT), help="names of .cfg files")
    ap.add_argument("--iterations", type=int, default=None, help="iterations per problem (default: per problem)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--against", type=Path, default=None, metavar="DIR",
                    help="another checkout: time both in fresh interpreters, in turns (B is DIR, A this checkout)")
    ap.add_argument("--rounds", type=int, default=4, help="with --against: rounds counted (default 4)")
    args = ap.parse_args(argv)
    if args.iterations is not None and args.iterations < 1:
        print(f"--iterations: must be at least 1, got {args.iterations}", file=sys.stderr)
        return 2
    if args.rounds < 1:
        print(f"--rounds: must be at least 1, got {args.rounds}", file=sys.stderr)
        return 2
    if args.against is not None:
        if not (args.against / "planners" / "__init__.py").is_file():
            print(f"--against: {args.against} holds no planners package", file=sys.stderr)
            return 2
        if args.against.resolve() == ROOT:
            print(f"--against: {args.against} is this checkout; give another", file=sys.stderr)
            return 2
    from planners.base.fileio import InputError
    from planners.tools.benchmark import markdown_table
    from planners.worlds.omplapp import load_omplapp, omplapp_dir

    try:
        folder = omplapp_dir(args.omplapp)
        if folder is None:
            raise InputError("give --omplapp DIR or set SAMPLERGYM_OMPLAPP_DIR (OMPL.app's root or resources/3D)")
        if args.against is not None:  # the children read the problems; here only that they are there
            missing = [name for name in args.problems if not (folder / f"{name}.cfg").is_file()]
            if missing:
                raise InputError(f"{folder}: no {missing[0]}.cfg")
        else:
            tasks = {name: load_omplapp(folder / f"{name}.cfg") for name in args.problems}
    except (InputError, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if args.against is None:
        print(json.dumps(measure(tasks, args.iterations, args.seed)))
        return 0
    child = ["--omplapp", str(folder), "--problems", *args.problems, "--seed", str(args.seed)]
    if args.iterations is not None:
        child += ["--iterations", str(args.iterations)]
    rows = compare(ROOT, args.against.resolve(), child, args.rounds)
    print(f"A = {ROOT}, B = {args.against.resolve()}; {args.rounds} rounds, the order flipping each round")
    print(markdown_table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
