"""Which broad-phase grid (``MeshWorld(grid_cells=...)``) a mesh world should default to: time per iteration.

    PYTHONPATH=$PWD python scripts/experiments/tune_mesh_grid.py --omplapp DIR \\
        --problems Twistycooler Apartment spirelli --seeds 3 --iterations 5000 --cells 96 128 192 256

A mesh world's grid (``grid_cells`` voxels along the longest side of its bounds, grown by the body's radius) gives
each pose a lower bound on its clearance; the exact test (``planners.kernels.mesh.exact_clearance``) is asked
only where the bound cannot certify ``delta / 2``. A finer grid certifies more poses and costs more memory and more
cover points per pose. This runs our RRT-Connect (defaults, uniform sampling) on OMPL.app's *tuning* problems
(never cubicles, Twistycool or another test problem) at each candidate, each run to ``--iterations`` iterations or
its solution, and prints per problem and candidate the median time per iteration over the seeds (compilation and
the world's construction left out) and the geometric mean over the problems relative to the default's.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time


def main(argv=None) -> int:
    from planners import make_planner
    from planners.base.fileio import InputError
    from planners.worlds.mesh import DEFAULT_GRID_CELLS
    from planners.worlds.omplapp import load_omplapp, omplapp_dir

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--omplapp", required=True, metavar="DIR", help="OMPL.app's resources/3D folder")
    ap.add_argument("--problems", nargs="+", default=["Twistycooler", "Apartment", "spirelli"],
                    help="tuning problems (.cfg names); default Twistycooler Apartment spirelli")
    ap.add_argument("--seeds", type=int, default=3, help="runs per problem and candidate, seeds 0 upwards")
    ap.add_argument("--iterations", type=int, default=5000, help="iterations per run (or to its solution)")
    ap.add_argument("--cells", type=int, nargs="+", default=[96, DEFAULT_GRID_CELLS, 192, 256],
                    help=f"candidate grid_cells (8 to 512; the default {DEFAULT_GRID_CELLS} is always run)")
    args = ap.parse_args(argv)
    if args.seeds < 1 or args.iterations < 1 or not all(8 <= c <= 512 for c in args.cells):
        ap.error("--seeds and --iterations must be at least 1 and every --cells from 8 to 512")
    cells = sorted(set(args.cells) | {DEFAULT_GRID_CELLS})
    folder = omplapp_dir(args.omplapp)
    for name in args.problems:
        if not (folder / f"{name}.cfg").is_file():
            raise InputError(f"--problems {name}: no {name}.cfg in {folder}")
    per = {c: [] for c in cells}
    print("| problem | grid cells | voxels | median µs per iteration | solved |")
    print("|---|---|---|---|---|")
    for name in args.problems:
        for c in cells:
            problem = load_omplapp(folder / f"{name}.cfg", grid_cells=c).problem
            world = problem.world
            make_planner("RRTConnect", problem, seed=0).solve(max_iterations=2)  # compile outside the timing
            us, solved = [], 0
            for seed in range(args.seeds):
                planner = make_planner("RRTConnect", problem, seed=seed)
                t0 = time.perf_counter()
                r = planner.solve(max_iterations=args.iterations)
                seconds = time.perf_counter() - t0 - planner.compile_time
                us.append(seconds / max(r.iterations, 1) * 1e6)
                solved += r.solved
            per[c].append(statistics.median(us))
            print(f"| {name} | {c} | {world.grid.size:,} | {statistics.median(us):.1f} | {solved}/{args.seeds} |")
    base = math.exp(statistics.mean(math.log(v) for v in per[DEFAULT_GRID_CELLS]))
    print("\n| grid cells | geometric mean µs per iteration | over the default |\n|---|---|---|")
    for c in cells:
        g = math.exp(statistics.mean(math.log(v) for v in per[c]))
        print(f"| {c} | {g:.1f} | {g / base:.3f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
