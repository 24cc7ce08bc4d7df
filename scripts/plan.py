"""Plan a path on any map: a floor plan, a drawn map, a ROS map.yaml, a MovingAI .map or a .npy array.

    python scripts/plan.py floor.png --start 40 60 --goal 900 700
    python scripts/plan.py floor.png                        # double-click start, then goal, in a window
    python scripts/plan.py maze.png --start 5 5 --goal 1990 1990 --planner rrt --sampler goal-bias \\
        --goal-bias 0.1 --metric manhattan --step 25 --no-smooth --out results/maze --headless
    python scripts/plan.py map.yaml --start 0.5 -1.2 --goal 2 1.5 --radius 0.1 --save-path path.csv
    python scripts/plan.py floor.png --start 40 60 --goal 900 700 --sampler policy   # the learned sampler
    python scripts/plan.py floor.png --start 40 60 --goal 900 700 --sampler route    # the shipped route encoder
    python scripts/plan.py floor.png --start 40 60 --goal 900 700 --sampler mine=my_module:make_sampler
    python scripts/plan.py --map-set tests/data/ros --list-queries            # a map set's queries, numbered
    python scripts/plan.py --map-set tests/data/ros --split test --query 3    # plan one of them

A map set (--map-set: a folder of maps, a manifest .json, or "generated", "shifted", "movingai"; see
docs/map-sets.md) gives the map, start, goal and goal radius instead of a map file and --start/--goal:
--query K plans the K-th query (from 0) of its part --split (default test); --list-queries prints
the queries with their numbers (of --split, or of every part) and plans nothing.

Dark pixels (gray below --threshold) are obstacles. Coordinates are the map's world units: for
pictures, pixels with x to the right and y downwards, as image viewers show them; for a ROS
map.yaml, metres in the map frame with y upwards, as RViz shows them. --radius inflates the
obstacles by the robot's radius. Writes plan.png (map, tree or roadmap, raw and smoothed path) and
plan.gif (the tree growing, then the path) under --out, optionally the path (--save-path), and
prints iterations, collision checks, time and path length. Time limits exclude one-off numba
compilation (the first run after an install compiles for a while; later runs load the compiled code).

Exit status: 0 solved, 1 not solved within the budget, 2 bad input (nothing written), 3 an output
could not be written (the message names it; no file is left half-written).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

from planners import planner_names
from planners.base.fileio import InputError
from planners.base.registry import planner_class, planner_name_arg
from planners.maps.mapset import PARTS, MapQuery, MapSet
from planners.tools.workflow import (
    METRICS,
    SAMPLERS,
    OutputError,
    check_output_dir,
    check_path_file,
    load_map,
    plan_on_image,
)

#: Exit statuses (documented in the module docstring and --help).
EXIT_SOLVED, EXIT_UNSOLVED, EXIT_BAD_INPUT, EXIT_WRITE_FAILED = 0, 1, 2, 3
#: Cells per step the shipped route encoder was trained for: its samplers' default step.
ROUTE_STEP = 4
#: The samplers that measure in the encoder's step (the route field's, learned, lazy, ablation and exact).
ROUTE_SAMPLERS = ("route", "route_lazy", "route_ablation", "exact_route")
#: Set to 1 to print, once the picking window is drawn, how map coordinates map to window pixels.
PICK_DEBUG_ENV = "SAMPLERGYM_PICK_DEBUG"


def display_available() -> bool:
    """True if a matplotlib window can be opened here."""
    if sys.platform in ("win32", "darwin"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def pick_start_goal(grid) -> tuple[tuple[float, float], tuple[float, float]]:
    """Show the map in a window; the first double-click is the start, the second the goal.

    With ``SAMPLERGYM_PICK_DEBUG=1`` each draw or resize that moves the axes prints one line
    ``pick-debug {json}``: the window title and the affine map from world coordinates to pixels of
    the window (from its top left corner), so a GUI test can click chosen map points.
    """
    import json

    import matplotlib.pyplot as plt

    from planners.viz import plotting

    picks: list[tuple[float, float]] = []
    fig, ax = plt.subplots(figsize=(8, 8))
    title = "SamplerGym: pick start and goal"
    fig.canvas.manager.set_window_title(title)
    plotting.draw_world(ax, grid)
    ax.set_title("double-click the start")

    def on_click(event) -> None:
        if not event.dblclick or event.inaxes is not ax or event.xdata is None:
            return
        q = (float(event.xdata), float(event.ydata))
        why = grid.explain_invalid(q)
        if why:
            ax.set_title(f"({q[0]:.4g}, {q[1]:.4g}) {why}; double-click a free spot")
            fig.canvas.draw_idle()
            return
        picks.append(q)
        ax.plot(*q, "o" if len(picks) == 1 else "*",
                color=plotting.START_COLOR if len(picks) == 1 else plotting.GOAL_COLOR,
                markersize=10)
        ax.set_title("double-click the goal" if len(picks) == 1 else "planning...")
        fig.canvas.draw_idle()
        if len(picks) == 2:
            plt.close(fig)

    shown: list[str] = []

    def on_view(event) -> None:
        # display coordinates are the window system's (physical) pixels, y up from the bottom of
        # the canvas, which is the window's top part (the toolbar sits below it)
        (a, b, tx), (c, d, ty), _ = ax.transData.get_matrix()
        height = fig.canvas.get_width_height(physical=True)[1]
        line = "pick-debug " + json.dumps({"title": title, "world_to_window": [[a, b, tx], [-c, -d, height - ty]]})
        if not shown or shown[-1] != line:  # again only if a resize moved the axes
            shown.append(line)
            print(line, flush=True)

    fig.canvas.mpl_connect("button_press_event", on_click)
    if os.environ.get(PICK_DEBUG_ENV) == "1":
        for name in ("draw_event", "resize_event"):  # a resize is not always drawn at once
            fig.canvas.mpl_connect(name, on_view)
    plt.show()
    if len(picks) < 2:
        raise ValueError("the window was closed before a start and a goal were double-clicked")
    return picks[0], picks[1]


def learned_sampler(arg: str, step: float, goal_bias: float, policy: Path | None):
    """``--sampler``'s sampler from ``learning``'s registry, or a user's ``NAME=SPEC`` (``learning`` is imported
    only here: plan.py runs without it for the planners' own samplers)."""
    try:
        from learning import make_sampler, user_sampler
        from learning.samplers.registry import REGISTRY, parse_user_sampler
    except ImportError as exc:
        raise InputError(f"--sampler {arg}: needs the learning package and its dependencies (torch, "
                         f"stable-baselines3): {exc}") from None
    if "=" in arg:
        return user_sampler(parse_user_sampler(arg)[1])
    if arg not in REGISTRY:
        names = ", ".join(dict.fromkeys((*SAMPLERS, *REGISTRY)))
        raise InputError(f"--sampler {arg!r}: choose from {names} or give NAME=SPEC (MODEL.zip@ENV_ID or "
                         "module:callable)")
    if arg == "goal_bias":
        return make_sampler(arg, bias=goal_bias)
    if arg == "uniform":
        return make_sampler(arg)
    if arg == "policy" and policy is not None:
        if not policy.is_file():
            raise InputError(f"--policy {str(policy)!r} does not exist")
        return make_sampler(arg, path=str(policy), step_size=step)
    return make_sampler(arg, step_size=step)


def map_set_conflict(args) -> str | None:
    """Why the arguments do not go with ``--map-set`` (a message naming the flag), or None."""
    if args.map is not None:
        return f"give a map file ({args.map}) or --map-set {args.map_set}, not both"
    if args.start is not None or args.goal is not None:
        return "--start / --goal: a --map-set query brings its own; choose one with --split and --query"
    if args.invert:
        return "--invert: a map set reads its maps by its own rules (docs/map-sets.md)"
    if args.split is not None and args.split not in PARTS:
        return f"--split {args.split!r}: expected one of {', '.join(PARTS)}"
    if args.query is not None and args.list_queries:
        return f"--query {args.query}: --list-queries plans nothing; give one or the other"
    if args.query is not None and args.query < 0:
        return f"--query {args.query}: expected a query number from 0 (see --list-queries)"
    if args.split_seed is not None and args.split_seed < 0:
        return f"--split-seed {args.split_seed}: expected a non-negative integer"
    return None


def open_map_set(args) -> MapSet:
    """``--map-set`` with the options given for it (``InputError`` naming the flag and value)."""
    options = {"split_seed": args.split_seed, "robot_radius": args.radius or None, "threshold": args.threshold}
    options = {k: v for k, v in options.items() if v is not None}
    try:
        return MapSet.open(args.map_set, **options)
    except TypeError:  # the built-in sets take none of these
        flags = {"split_seed": "--split-seed", "robot_radius": "--radius", "threshold": "--threshold"}
        given = " / ".join(flags[k] for k in options)
        raise InputError(f"{given}: map set {args.map_set!r} has its own maps and split; give {given} only with "
                         "folders and manifests") from None
    except InputError as exc:
        raise InputError(f"--map-set {args.map_set}: {exc}") from None


def part_queries(ms: MapSet, part: str) -> list[MapQuery]:
    """The queries of ``part``, or an ``InputError`` naming it where there are none."""
    queries = ms.queries(part)
    if not queries:
        raise InputError(f"--split {part}: the {part!r} part of map set {ms.name} holds no query "
                         f"({ms.split.describe()})")
    return queries


def pick_query(ms: MapSet, part: str, k: int) -> MapQuery:
    """The ``k``-th query of ``part`` (``InputError`` naming ``--query`` when there is no such query)."""
    queries = part_queries(ms, part)
    if not 0 <= k < len(queries):
        raise InputError(f"--query {k}: the {part!r} part of map set {ms.name} holds {len(queries)} queries, "
                         f"numbered 0 to {len(queries) - 1} (see --list-queries)")
    return queries[k]


def list_queries(ms: MapSet, parts: list[str]) -> None:
    """Print each query of ``parts`` on a line: part, number (``--query``), map, start, goal, goal radius, origin."""
    print(ms.describe())
    if len(parts) == 1:
        part_queries(ms, parts[0])
    print("part        query  map  start -> goal (world units), goal radius, from")
    for part in parts:
        for k, q in enumerate(ms.queries(part)):
            p = ms.problem(q)
            print(f"{part:<11} {k:>5}  {q.map}  ({p.start[0]:g}, {p.start[1]:g}) -> ({p.goal[0]:g}, {p.goal[1]:g}), "
                  f"{p.goal_tolerance:g}, {q.origin or q.key}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("map", type=Path, nargs="?", default=None,
                    help="image (PNG, JPG, BMP, ...), ROS map.yaml, MovingAI .map or .npy map (or give --map-set)")
    ap.add_argument("--map-set", default=None, metavar="DIR_OR_SPEC",
                    help="plan a query of this map set instead: a folder or manifest .json of maps, or generated, "
                         "shifted, movingai (docs/map-sets.md); the map, start, goal and goal radius are the query's")
    ap.add_argument("--split", default=None, metavar="PART",
                    help=f"--map-set: the part the query comes from, one of {', '.join(PARTS)} (default test)")
    ap.add_argument("--query", type=int, default=None, metavar="K",
                    help="--map-set: the query's number in its part, from 0 (default 0; see --list-queries)")
    ap.add_argument("--list-queries", action="store_true",
                    help="--map-set: print the queries of --split (default: of every part) with their numbers, "
                         "plan nothing")
    ap.add_argument("--split-seed", type=int, default=None, metavar="N",
                    help="--map-set: the seed of a folder's or manifest's split into parts (default theirs: 0)")
    ap.add_argument("--threshold", type=float, default=None,
                    help="gray level in (0, 1) below which a pixel is blocked (default 0.5)")
    ap.add_argument("--invert", action="store_true", help="light pixels are obstacles")
    ap.add_argument("--start", type=float, nargs=2, metavar=("X", "Y"), help="start in map units")
    ap.add_argument("--goal", type=float, nargs=2, metavar=("X", "Y"), help="goal in map units")
    ap.add_argument("--radius", type=float, default=0.0, metavar="R",
                    help="robot radius in map units: obstacles are inflated by it (default 0: a point robot)")
    ap.add_argument("--planner", type=planner_name_arg, choices=planner_names(), default="RRTConnect",
                    help="a registered planner; case, '-' and '_' are ignored (rrt-connect = RRTConnect)")
    ap.add_argument("--sampler", default=None, metavar="NAME",
                    help=f"{', '.join(SAMPLERS)} (the planners' own), or a sampler of learning's registry: follower "
                         "(the straight-line follower), route (the shipped route encoder; default step: its block), "
                         "route_lazy (the same encoder, run only where a query needs it), route_ablation, policy (the "
                         "learned policy), policy_ablation, goal_bias, expert and exact_route (privileged references), "
                         "or NAME=SPEC (MODEL.zip@ENV_ID or module:callable). "
                         "Default: goal-bias for rrt and rrtstar, uniform otherwise")
    ap.add_argument("--policy", type=Path, default=None, metavar="ZIP",
                    help="checkpoint for --sampler policy (default: the shipped policy)")
    ap.add_argument("--goal-bias", type=float, default=0.05, metavar="P", help="goal probability of goal-bias")
    ap.add_argument("--metric", choices=METRICS, default="euclidean")
    ap.add_argument("--step", type=float, default=None,
                    help="step size in map units (default: 2%% of the map diagonal, at least 4 cells)")
    ap.add_argument("--tolerance", type=float, default=None,
                    help="goal radius in map units (default: 1%% of the diagonal)")
    ap.add_argument("--max-iterations", type=int, default=2_000_000)
    ap.add_argument("--time-limit", type=float, default=None,
                    help="seconds of planning, one-off compilation excluded (default: none; 10 for rrtstar and "
                         "informed-rrtstar, which keep improving until the budget is spent)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--smooth", action=argparse.BooleanOptionalAction, default=True, help="shortcut the path")
    ap.add_argument("--out", type=Path, default=Path("results/plan"), help="folder for plan.png and plan.gif")
    ap.add_argument("--no-gif", action="store_true", help="write the figure only")
    ap.add_argument("--frames", type=int, default=60,
                    help="growth frames in the GIF (fewer only if the run has fewer iterations)")
    ap.add_argument("--save-path", type=Path, default=None, metavar="FILE",
                    help="export the final path: .csv (x,y), .json (with units and frame) or .npy")
    ap.add_argument("--headless", action="store_true", help="never open a window")
    args = ap.parse_args(argv)

    def fail(msg: str, status: int = EXIT_BAD_INPUT) -> int:
        print(f"error: {msg}", file=sys.stderr)
        return status

    if args.map_set is not None:
        why = map_set_conflict(args)
        if why:
            return fail(why)
    elif args.map is None:
        return fail("give a map file, or --map-set DIR_OR_SPEC to plan one of a map set's queries")
    else:
        for flag, value in (("--split", args.split), ("--query", args.query), ("--split-seed", args.split_seed),
                            ("--list-queries", "" if args.list_queries else None)):
            if value is not None:
                return fail(f"{flag} {value}".rstrip() + ": it applies to --map-set, and none is given")
    if (args.start is None) != (args.goal is None):
        return fail(f"give both --start and --goal, or neither to pick them in a window "
                    f"(got only --{'start' if args.start is not None else 'goal'})")
    if args.seed < 0:
        return fail(f"--seed must be >= 0, got {args.seed}")
    if args.max_iterations < 1:
        return fail(f"--max-iterations must be positive, got {args.max_iterations}")
    for flag, v in (("--step", args.step), ("--tolerance", args.tolerance), ("--time-limit", args.time_limit)):
        if v is not None and not (math.isfinite(v) and v > 0):
            return fail(f"{flag} must be a positive number, got {v}")
    if not 0.0 <= args.goal_bias <= 1.0:
        return fail(f"--goal-bias must lie in [0, 1], got {args.goal_bias}")
    if args.threshold is not None and not 0.0 < args.threshold < 1.0:
        return fail(f"--threshold must lie in (0, 1), got {args.threshold}")
    if args.frames < 2:
        return fail(f"--frames must be at least 2, got {args.frames}")
    if not (math.isfinite(args.radius) and args.radius >= 0):
        return fail(f"--radius must be a non-negative number, got {args.radius}")
    if args.policy is not None and args.sampler != "policy":
        return fail("--policy is used with --sampler policy only")
    if args.sampler is not None and args.sampler not in SAMPLERS and "=" not in args.sampler:
        try:  # a name that is not a sampler is refused before the map is read
            from learning import sampler_names
        except ImportError as exc:
            return fail(f"--sampler {args.sampler}: needs the learning package and its dependencies: {exc}")
        if args.sampler not in sampler_names():
            names = ", ".join(dict.fromkeys((*SAMPLERS, *sampler_names())))
            return fail(f"--sampler {args.sampler!r}: choose from {names} or give NAME=SPEC (MODEL.zip@ENV_ID or "
                        "module:callable)")
    query = None
    if args.map_set is not None:
        try:
            ms = open_map_set(args)
            if args.list_queries:
                list_queries(ms, [args.split] if args.split else list(PARTS))
                return EXIT_SOLVED
            query = pick_query(ms, args.split or "test", args.query or 0)
        except InputError as exc:
            return fail(str(exc))
    # output locations are checked before anything slow happens
    try:
        if args.save_path is not None:
            check_path_file(args.save_path)
        check_output_dir(args.out)
    except OutputError as exc:
        return fail(str(exc), EXIT_WRITE_FAILED)
    except InputError as exc:
        return fail(str(exc))
    except ValueError as exc:
        return fail(f"--save-path: {exc}")
    t0 = time.perf_counter()
    tolerance = args.tolerance
    if query is not None:
        try:
            problem = ms.problem(query)
        except (FileNotFoundError, ValueError) as exc:
            return fail(f"--map-set {args.map_set}, {query.part} query {args.query or 0}: {exc}")
        grid, start, goal = problem.world, tuple(map(float, problem.start)), tuple(map(float, problem.goal))
        tolerance = tolerance or problem.goal_tolerance
    else:
        try:
            threshold = 0.5 if args.threshold is None else args.threshold
            grid = load_map(args.map, threshold, invert=args.invert, robot_radius=args.radius)
        except (FileNotFoundError, ValueError) as exc:
            return fail(str(exc))
        start, goal = args.start, args.goal
    t_load = time.perf_counter() - t0
    if start is None or goal is None:
        if args.headless or not display_available():
            return fail("no --start/--goal given and no display to pick them on (--headless or no DISPLAY); "
                        "give --start X Y --goal X Y")
        try:
            picked = pick_start_goal(grid)
        except ValueError as exc:
            return fail(str(exc))
        start, goal = picked
    step = args.step
    if step is None and args.sampler in ROUTE_SAMPLERS:
        step = ROUTE_STEP * grid.resolution  # the step the encoder was trained for
    if step is None:
        w, h = grid.bounds[1] - grid.bounds[0]
        step = max(4.0 * grid.resolution, 0.02 * math.hypot(w, h))
    time_limit = args.time_limit
    if time_limit is None and planner_class(args.planner).anytime:  # it would run to the iteration cap
        time_limit = 10.0
    sampler = args.sampler
    try:
        if sampler is not None and sampler not in SAMPLERS:
            sampler = learned_sampler(sampler, step, args.goal_bias, args.policy)
        out = plan_on_image(grid, start, goal, planner=args.planner, sampler=sampler, goal_bias=args.goal_bias,
                            metric=args.metric, step=step, tolerance=tolerance,
                            max_iterations=args.max_iterations, time_limit=time_limit, seed=args.seed,
                            smooth=args.smooth, out_dir=args.out, gif=not args.no_gif, max_frames=args.frames,
                            save_path=args.save_path)
    except OutputError as exc:
        return fail(str(exc), EXIT_WRITE_FAILED)
    except (FileNotFoundError, ValueError) as exc:
        return fail(str(exc))
    r = out.result
    radius = f", robot radius {args.radius:g}" if args.radius else ""
    if query is not None:
        print(f"map set:          {ms.name}, {query.part} query {args.query or 0} ({query.origin or query.key})")
    print(f"map:              {args.map or query.map} ({grid.width}x{grid.height}, {100 * grid.obstacles.mean():.1f}% "
          f"blocked{radius})")
    print(f"query:            start ({start[0]:g}, {start[1]:g}) -> goal ({goal[0]:g}, {goal[1]:g}), "
          f"tolerance {out.problem.goal_tolerance:g}, metric {args.metric}")
    sampler_name = args.sampler or "default"
    if args.sampler == "policy":
        sampler_name = f"policy {args.policy or 'shipped'}"
    print(f"planner:          {r.planner} (step {step:g}, seed {args.seed}, sampler {sampler_name})")
    print(f"solved:           {r.solved} ({r.stop_reason})")
    print(f"iterations:       {r.iterations}")
    print(f"collision checks: {r.collision_checks}")
    print(f"vertices:         {r.num_vertices}")
    t = out.timings
    compiled = out.planner.compile_time
    first_use = f", of which {compiled:.3f} s one-off compilation" if compiled >= 0.0005 else ""
    print(f"time:             {t['sampler'] + t['plan']:.3f} s to {'a path' if r.solved else 'stop'}: the sampler's "
          f"set-up {t['sampler']:.3f} s (a route encoder's pass, a grid search; the first compiles its kernels) and "
          f"{t['plan']:.3f} s planning"
          f"{first_use}")
    if compiled >= 1.0:  # a first use compiled kernels: they can be compiled once, ahead
        print("                  (python -m planners.compile and python -m learning.compile compile the planners' and "
              "the learned samplers' kernels once, ahead)")
    print(f"                  (and load {t_load:.3f} s, smooth {t['smooth']:.3f} s, figure {t['figure']:.3f} s, "
          f"gif {t['gif']:.3f} s)")
    if getattr(out.planner.sampler, "switched", False):  # a lazy route sampler ran its encoder inside the planning
        print("                  (the lazy route sampler computed the encoder's field during the planning: "
              f"{out.planner.sampler.forward_passes} pass(es))")
    if r.solved:
        print(f"path length:      {out.length:.2f} raw ({len(out.path)} states)")
        if out.smoothed is not None:
            print(f"                  {out.smoothed_length:.2f} smoothed ({len(out.smoothed)} states)")
    if args.save_path is not None and not r.solved:
        print(f"no path to save: {args.save_path} not written")
    for f in out.files:
        print(f"wrote {f}")
    return EXIT_SOLVED if r.solved else EXIT_UNSOLVED


if __name__ == "__main__":
    raise SystemExit(main())
