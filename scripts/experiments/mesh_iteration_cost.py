"""Time per iteration of RRT-Connect on OMPL.app's mesh problems, for comparing two checkouts run after run.

    PYTHONPATH=$PWD python scripts/experiments/mesh_iteration_cost.py --omplapp DIR
    PYTHONPATH=$PWD python scripts/experiments/mesh_iteration_cost.py --omplapp DIR --problems Home --iterations 600

For each problem: one short untimed solve (the kernels compile or load there), then RRT-Connect at ``--seed`` for
``--iterations`` iterations (fewer where it solves first), timed; prints the iterations, the collision checks and
the microseconds per iteration as one JSON line. A change that leaves the runs the same (the same iterations and
checks) and moves the time shows in the last figure; run it on each checkout in turns, as the machine's speed
drifts between runs.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

#: problem -> iterations timed by default (about a second or two each on a 2-core machine)
DEFAULT = {"alpha-1.5": 600, "Twistycool": 15000, "cubicles": 3000, "Home": 3000, "Easy": 3000}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--omplapp", help="OMPL.app's root or resources/3D folder (default $SAMPLERGYM_OMPLAPP_DIR)")
    ap.add_argument("--problems", nargs="+", default=list(DEFAULT), help="names of .cfg files")
    ap.add_argument("--iterations", type=int, default=None, help="iterations per problem (default: per problem)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    if args.iterations is not None and args.iterations < 1:
        print(f"--iterations: must be at least 1, got {args.iterations}", file=sys.stderr)
        return 2
    from planners import make_planner
    from planners.base.fileio import InputError
    from planners.worlds.omplapp import load_omplapp, omplapp_dir

    try:
        folder = omplapp_dir(args.omplapp)
        if folder is None:
            raise InputError("give --omplapp DIR or set SAMPLERGYM_OMPLAPP_DIR (OMPL.app's root or resources/3D)")
        tasks = {name: load_omplapp(folder / f"{name}.cfg") for name in args.problems}
    except (InputError, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    out = {}
    for name, task in tasks.items():
        make_planner("RRTConnect", task.problem, seed=args.seed).solve(max_iterations=5)  # compile outside the timing
        planner = make_planner("RRTConnect", task.problem, seed=args.seed)
        start = time.perf_counter()
        r = planner.solve(max_iterations=args.iterations or DEFAULT.get(name, 3000))
        took = time.perf_counter() - start
        out[name] = {"iterations": r.iterations, "checks": r.collision_checks,
                     "us_per_iteration": round(took / r.iterations * 1e6, 1)}
    print(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
