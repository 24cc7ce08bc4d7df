"""Plan a 6-DoF rigid-body scene with one of the seed project's set-ups; write a 3-D figure and a GIF.

    python scripts/plan3d.py planners/scenes/window.scene --setup prm --out results/plan3d
    python scripts/plan3d.py my.scene --setup rrt --seed 3 --out results/rrt3

Set-ups (planners.worlds.rigid3d.setup_planner): ``prm``: PRM, 5,000 samples, k = 3, Dijkstra on the
(x, y, z, cos, sin of each angle) metric; ``rrt``: RRT, step 0.01 of the scene's longest side, goal
distance 1.0, 5% goal bias, at most 20,000 iterations. Scene format: planners.worlds.rigid3d.load_scene.
Writes plan3d.png (the scene, the path and the body along it) and, when solved, plan3d.gif (the body
flying the path) under --out, each atomically, and prints iterations, checks, time and path length.
The planning time is split into planning proper and numba's one-off compilation (the first run after
an install compiles the rigid-body kernels for a while; later runs load the compiled code).
Exit status: 0 solved, 1 not solved within the budget, 2 bad input or an output that cannot be written.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from planners.base.fileio import InputError
from planners.worlds.rigid3d import SETUPS, load_scene, setup_planner


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", type=Path, help="scene file (format: planners.worlds.rigid3d.load_scene)")
    ap.add_argument("--setup", choices=SETUPS, required=True, help="the seed project's PRM or RRT set-up")
    ap.add_argument("--seed", type=int, default=0, help="planner seed (>= 0)")
    ap.add_argument("--out", type=Path, default=Path("results/plan3d"), help="folder for plan3d.png and plan3d.gif")
    ap.add_argument("--frames", type=int, default=None,
                    help="GIF frames (default: about two seconds per 10 units of path, 20 to 150)")
    args = ap.parse_args(argv)

    def fail(msg: str) -> int:
        print(f"error: {msg}", file=sys.stderr)
        return 2

    if args.seed < 0:
        return fail(f"--seed must be >= 0, got {args.seed}")
    if args.frames is not None and args.frames < 2:
        return fail(f"--frames must be at least 2, got {args.frames}")
    if args.out.exists() and not args.out.is_dir():
        return fail(f"--out {args.out} exists and is not a folder")
    try:
        problem = load_scene(args.scene)
    except (FileNotFoundError, InputError) as exc:
        return fail(str(exc))
    t0 = time.perf_counter()  # making the planner binds its sampler (the sampler's per-query work): timed apart
    planner, budget = setup_planner(problem, args.setup, seed=args.seed)
    t_sampler = time.perf_counter() - t0
    r = planner.solve(max_iterations=budget)

    # imported only now: matplotlib costs a second, and bad input should fail fast
    from planners.viz.plotting import save_figure
    from planners.viz.plotting3d import animate_rigid, plot_scene

    files = []
    t0 = time.perf_counter()
    try:
        fig = plot_scene(planner.problem, r.path if r.solved else None,
                         title=f"{problem.name}: {r.planner} ({args.setup} set-up, seed {args.seed})")
        files.append(save_figure(fig, args.out / "plan3d.png", dpi=100))
        if r.solved:
            files.append(animate_rigid(planner.problem, r.path, args.out / "plan3d.gif", frames=args.frames))
    except OSError as exc:
        return fail(f"cannot write under {args.out}: {exc}")
    t_out = time.perf_counter() - t0
    print(f"scene:            {args.scene} ({problem.world!r})")
    print(f"set-up:           {args.setup}: {r.planner}, seed {args.seed}, budget {budget} iterations")
    print(f"solved:           {r.solved} ({r.stop_reason})")
    print(f"iterations:       {r.iterations}")
    print(f"collision checks: {r.collision_checks}")
    print(f"vertices:         {r.num_vertices}")
    compiled = planner.compile_time
    print(f"time:             {t_sampler + r.time - compiled:.3f} s to {'a path' if r.solved else 'stop'}: "
          f"{t_sampler:.3f} s making the planner and binding its sampler, {r.time - compiled:.3f} s planning; "
          f"{compiled:.3f} s one-off compilation, {t_out:.1f} s figure and GIF")
    if r.solved:
        print(f"path length:      {r.cost:.2f} ({len(r.path)} states)")
    else:
        print("no path: the figure shows the scene only, and no GIF is written")
    for f in files:
        print(f"wrote {f}")
    return 0 if r.solved else 1


if __name__ == "__main__":
    raise SystemExit(main())
