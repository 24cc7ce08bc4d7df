"""Plan a 6-DoF rigid-body scene with one of the seed project's set-ups; write a 3-D figure and a GIF.

    python scripts/plan3d.py planners/scenes/window.scene --setup prm --out results/plan3d
    python scripts/plan3d.py my.scene --setup rrt --seed 3 --out results/rrt3
    python scripts/plan3d.py omplapp/resources/3D/Easy.cfg --time-limit 20 --out results/easy   # a mesh problem
    python scripts/plan3d.py my.scene --setup rrt --sampler rigid_route     # the learned 6-DoF sampler

Set-ups (planners.worlds.rigid3d.setup_planner): ``prm``: PRM, 5,000 samples, k = 3, Dijkstra on the
(x, y, z, cos, sin of each angle) metric; ``rrt``: RRT, step 0.01 of the scene's longest side, goal
distance 1.0, 5% goal bias, at most 20,000 iterations. Scene format: planners.worlds.rigid3d.load_scene.
Writes plan3d.png (the scene, the path and the body along it) and, when solved, plan3d.gif (the body
flying the path) under --out, each atomically, and prints iterations, checks, time and path length.
The planning time is split into planning proper and numba's one-off compilation (the first run after
an install compiles the rigid-body kernels for a while; later runs load the compiled code).
``--sampler NAME`` replaces the set-up's sampling by a sampler of the registry (``make_sampler(NAME)``; e.g.
``rigid_route``, the learned 6-DoF sampler (box scenes, mesh scenes and ``.cfg`` problems), or ``gaussian``);
its per-query work (a route search, a model's pass) is timed apart from the planning.
An OMPL.app ``.cfg`` problem (planners.worlds.omplapp; needs the ``mesh`` extra) is planned with
RRT-Connect at its default step under ``--time-limit`` (default the file's ``time_limit``), or with
``--setup`` by that set-up within the same limit, and drawn with its meshes (large ones as a seeded subset
of their triangles). The seed project's PRM with the learned sampler connects Twistycool's passage:

    python scripts/plan3d.py omplapp/resources/3D/Twistycool.cfg --setup prm --sampler rigid_route

``--restarts UNIT`` (``.cfg`` problems with RRT-Connect) restarts the run by Luby's sequence times ``UNIT``
iterations (``planners.solve_with_restarts``; off by default: on the validation scenes restarts lose, though
they cut the learned sampler's stalls on Twistycool):

    python scripts/plan3d.py omplapp/resources/3D/Twistycool.cfg --sampler rigid_route --restarts 1000
Exit status: 0 solved, 1 not solved within the budget, 2 bad input or an output that cannot be written.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from planners.base.fileio import InputError, check_output_place
from planners.maps.readers import MAP_READERS
from planners.worlds.rigid3d import SETUPS, load_scene, setup_planner


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", type=Path, help="scene file (format: planners.worlds.rigid3d.load_scene) or an "
                                             "OMPL.app .cfg problem")
    ap.add_argument("--setup", choices=SETUPS, help="the seed project's PRM or RRT set-up (required for a scene file; "
                                                    "for a .cfg problem, in place of RRT-Connect)")
    ap.add_argument("--time-limit", type=float, help="seconds for a .cfg problem (default: its time_limit)")
    ap.add_argument("--seed", type=int, default=0, help="planner seed (>= 0)")
    ap.add_argument("--sampler", default=None, metavar="NAME",
                    help="a registry sampler in place of the set-up's own (e.g. rigid_route, the learned 6-DoF "
                         "sampler; learning.sampler_names() lists them)")
    ap.add_argument("--restarts", type=int, default=0, metavar="UNIT",
                    help="a .cfg problem's run restarts by Luby's sequence times UNIT iterations (0: none)")
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
    try:
        check_output_place(args.out, "--out")  # before the solve: a file there, a figure's name, no write access
    except InputError as exc:
        return fail(str(exc))
    mesh = args.scene.suffix.lower() == ".cfg"
    if args.scene.suffix.lower() in MAP_READERS:
        return fail(f"{args.scene} is a 2-D map ({args.scene.suffix}); plan it with scripts/plan.py. plan3d.py takes "
                    "a box .scene or an OMPL.app .cfg")
    if not mesh and args.setup is None:
        return fail("--setup is required for a scene file (prm or rrt)")
    if args.time_limit is not None and not (args.time_limit > 0):
        return fail(f"--time-limit must be a positive number of seconds, got {args.time_limit}")
    if args.restarts < 0:
        return fail(f"--restarts must be 0 (none) or a number of iterations, got {args.restarts}")
    if args.restarts and not (mesh and args.setup is None):
        return fail("--restarts is for OMPL.app .cfg problems planned with RRT-Connect; a set-up (--setup) plans "
                    "without restarts")
    try:
        if mesh:
            from planners.worlds.omplapp import load_omplapp

            task = load_omplapp(args.scene)
            problem = task.problem
            limit = args.time_limit or task.time_limit or 60.0
        else:
            problem = load_scene(args.scene)
    except (FileNotFoundError, InputError, ImportError) as exc:
        return fail(str(exc))
    sampler = None
    if args.sampler is not None:
        from learning.samplers.registry import make_sampler

        try:
            sampler = make_sampler(args.sampler)
        except (InputError, OSError) as exc:
            return fail(f"--sampler {args.sampler}: {exc}")
    from planners.base.planner import compile_seconds

    # making the planner binds its sampler (the sampler's per-query work): timed apart, its compilation apart too
    c_bind, t0 = compile_seconds(), time.perf_counter()
    try:
        if mesh and args.restarts:  # each attempt binds its sampler again: timed with the planning
            from planners import solve_with_restarts

            c0 = compile_seconds()
            r = solve_with_restarts("RRTConnect", problem, seed=args.seed, unit=args.restarts, time_limit=limit,
                                    **({} if sampler is None else {"sampler": sampler}))
            compiled, planned = compile_seconds() - c0, problem
            budget, args.setup = f"{limit:g} s, restarts by Luby's sequence x {args.restarts}", "RRT-Connect"
        elif mesh and args.setup is None:
            from planners import RRTConnect

            planner, budget = RRTConnect(problem, seed=args.seed, sampler=sampler), f"{limit:g} s"
            args.setup = "RRT-Connect"
        elif sampler is not None:
            from learning.evaluation.rigid import build_planner

            planner, budget = build_planner("PRM" if args.setup == "prm" else "RRT", problem, sampler, args.seed)
        else:
            planner, budget = setup_planner(problem, args.setup, seed=args.seed)
    except InputError as exc:
        return fail(f"--sampler {args.sampler}: {exc}" if sampler is not None else str(exc))
    if not args.restarts:
        c_bind = compile_seconds() - c_bind  # a first run compiles the world's and the sampler's kernels here
        t_sampler = time.perf_counter() - t0 - c_bind
        if mesh and args.setup in SETUPS:  # the set-up's budget, within the problem's time limit too
            r = planner.solve(max_iterations=budget, time_limit=limit)
            budget = f"{budget} iterations, {limit:g} s"
        else:
            r = planner.solve(time_limit=limit) if mesh else planner.solve(max_iterations=budget)
        compiled, planned = planner.compile_time + c_bind, planner.problem

    # imported only now: matplotlib costs a second, and bad input should fail fast
    from planners.viz.plotting import save_figure
    from planners.viz.plotting3d import animate_rigid, plot_scene

    files = []
    t0 = time.perf_counter()
    try:
        fig = plot_scene(planned, r.path if r.solved else None,
                         title=f"{problem.name}: {r.planner} ({args.setup} set-up, seed {args.seed})")
        files.append(save_figure(fig, args.out / "plan3d.png", dpi=100))
        if r.solved:
            files.append(animate_rigid(planned, r.path, args.out / "plan3d.gif", frames=args.frames))
    except OSError as exc:
        return fail(f"cannot write under {args.out}: {exc}")
    t_out = time.perf_counter() - t0
    print(f"scene:            {args.scene} ({problem.world!r})")
    unit = "" if mesh else " iterations"  # a .cfg problem's budget names its own units
    how = f", sampler {args.sampler}" if args.sampler else ""
    print(f"set-up:           {args.setup}: {r.planner}{how}, seed {args.seed}, budget {budget}{unit}")
    print(f"solved:           {r.solved} ({r.stop_reason})")
    print(f"iterations:       {r.iterations}" + (f" over {r.restarts + 1} attempts" if args.restarts else ""))
    print(f"collision checks: {r.collision_checks}")
    print(f"vertices:         {r.num_vertices}")
    if args.restarts:  # each attempt made its planner and bound its sampler inside the timed call
        print(f"time:             {r.time - compiled:.3f} s to {'a path' if r.solved else 'stop'}, every attempt's "
              f"planner and sampler binding included; {compiled:.3f} s one-off compilation, {t_out:.1f} s figure "
              f"and GIF")
    else:
        print(f"time:             {t_sampler + r.time - planner.compile_time:.3f} s to "
              f"{'a path' if r.solved else 'stop'}: {t_sampler:.3f} s making the planner and binding its sampler, "
              f"{r.time - planner.compile_time:.3f} s planning; "
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
