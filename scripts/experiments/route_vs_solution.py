"""The workspace route of an OMPL.app problem beside the solution OMPL.app ships with it.

    PYTHONPATH=$PWD python scripts/experiments/route_vs_solution.py --omplapp DIR --problems cubicles Twistycool Easy

For each ``.cfg`` that has a ``.path`` beside it, it prints the straight distance between start and goal, the length
of the exact workspace route the route samplers follow (``planners.guidance.workspace_route.voxel_route``, at the
world's route voxel), the length the body's centre travels along OMPL.app's solution, and how many of the solution's
states have their centre on a voxel the route search counts free (``MeshWorld.centre_free_voxels``): a state off
those voxels would show the route search closing a passage the body passes. Nothing is timed.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--omplapp", type=Path, required=True, help="OMPL.app's resources/3D folder")
    ap.add_argument("--problems", nargs="+", default=["cubicles", "Twistycool", "Easy"])
    args = ap.parse_args(argv)
    missing = [p for p in args.problems if not (args.omplapp / f"{p}.cfg").is_file()
               or not (args.omplapp / f"{p}.path").is_file()]
    if missing:
        ap.error(f"--omplapp {args.omplapp}: no .cfg with a .path for {', '.join(missing)}")

    import numpy as np

    from planners.guidance.workspace_route import voxel_route
    from planners.worlds.omplapp import load_omplapp, read_omplapp_path

    def length(points):
        return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())

    print("| problem | straight distance | route (voxel side) | OMPL.app's solution, centre travel | "
          "its states on free route voxels |")
    print("|---|---|---|---|---|")
    for name in args.problems:
        task = load_omplapp(args.omplapp / f"{name}.cfg")
        world, start, goal = task.problem.world, task.problem.start, task.problem.goal
        route = voxel_route(world, start, goal)
        solution = read_omplapp_path(args.omplapp / f"{name}.path")
        cell = float(world.route_cell)
        free = world.centre_free_voxels(cell)
        idx = np.clip(np.floor((solution[:, :3] - np.asarray(world.low3)) / cell).astype(np.int64), 0,
                      np.array(free.shape) - 1)
        on = int(free[idx[:, 0], idx[:, 1], idx[:, 2]].sum())
        routed = "none" if route is None else f"{length(route):,.0f} ({cell:.3g})"
        print(f"| {name} | {float(np.linalg.norm(goal[:3] - start[:3])):,.0f} | {routed} | "
              f"{length(solution[:, :3]):,.0f} | {on} of {len(solution)} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
