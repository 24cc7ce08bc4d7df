"""Plan a path on any picture map: a floor plan, a drawn map, a MovingAI .map or a .npy array.

    python scripts/plan.py floor.png --start 40 60 --goal 900 700
    python scripts/plan.py floor.png                        # double-click start, then goal, in a window
    python scripts/plan.py maze.png --start 5 5 --goal 1990 1990 --planner rrt --sampler goal-bias \\
        --goal-bias 0.1 --metric manhattan --step 25 --no-smooth --out results/maze --headless

Dark pixels (gray below --threshold) are obstacles. Coordinates are pixels, x to the right and y
downwards, as image viewers show them. Writes plan.png (map, tree or roadmap, raw and smoothed path)
and plan.gif (the tree growing, then the path) under --out, and prints iterations, collision
checks, time and path length. Exit status: 0 solved, 1 not solved within the budget, 2 bad input
(nothing written).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from planners.workflow import METRICS, PLANNERS, SAMPLERS, load_map, plan_on_image  # noqa: E402


def display_available() -> bool:
    """True if a matplotlib window can be opened here."""
    if sys.platform in ("win32", "darwin"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def pick_start_goal(grid) -> tuple[tuple[float, float], tuple[float, float]]:
    """Show the map in a window; the first double-click is the start, the second the goal."""
    import matplotlib.pyplot as plt

    picks: list[tuple[float, float]] = []
    fig, ax = plt.subplots(figsize=(8, 8))
    ax.imshow(grid.obstacles, cmap="gray_r", origin="upper", extent=(0, grid.width, grid.height, 0))
    ax.set_title("double-click the start")

    def on_click(event) -> None:
        if not event.dblclick or event.inaxes is not ax or event.xdata is None:
            return
        q = (float(event.xdata), float(event.ydata))
        why = grid.explain_invalid(q)
        if why:
            ax.set_title(f"({q[0]:.0f}, {q[1]:.0f}) {why}; double-click a free spot")
            fig.canvas.draw_idle()
            return
        picks.append(q)
        ax.plot(*q, "o" if len(picks) == 1 else "*", color="#2ca02c" if len(picks) == 1 else "#d62728",
                markersize=10)
        ax.set_title("double-click the goal" if len(picks) == 1 else "planning...")
        fig.canvas.draw_idle()
        if len(picks) == 2:
            plt.close(fig)

    fig.canvas.mpl_connect("button_press_event", on_click)
    plt.show()
    if len(picks) < 2:
        raise ValueError("the window was closed before a start and a goal were double-clicked")
    return picks[0], picks[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("map", type=Path, help="image (PNG, JPG, BMP, ...), MovingAI .map or .npy map")
    ap.add_argument("--threshold", type=float, default=0.5, help="gray level in (0, 1) below which a pixel is blocked")
    ap.add_argument("--invert", action="store_true", help="light pixels are obstacles")
    ap.add_argument("--start", type=float, nargs=2, metavar=("X", "Y"), help="start in pixels")
    ap.add_argument("--goal", type=float, nargs=2, metavar=("X", "Y"), help="goal in pixels")
    ap.add_argument("--planner", choices=PLANNERS, default="rrt-connect")
    ap.add_argument("--sampler", choices=SAMPLERS, default=None,
                    help="default: goal-bias for rrt and rrtstar, uniform otherwise")
    ap.add_argument("--goal-bias", type=float, default=0.05, metavar="P", help="goal probability of goal-bias")
    ap.add_argument("--metric", choices=METRICS, default="euclidean")
    ap.add_argument("--step", type=float, default=None,
                    help="step size in pixels (default: 2%% of the map diagonal, at least 4)")
    ap.add_argument("--tolerance", type=float, default=None,
                    help="goal radius in pixels (default: 1%% of the diagonal)")
    ap.add_argument("--max-iterations", type=int, default=2_000_000)
    ap.add_argument("--time-limit", type=float, default=None,
                    help="seconds of planning (default: none; 10 for rrtstar and informed-rrtstar, which keep "
                         "improving until the budget is spent)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--smooth", action=argparse.BooleanOptionalAction, default=True, help="shortcut the path")
    ap.add_argument("--out", type=Path, default=Path("results/plan"), help="folder for plan.png and plan.gif")
    ap.add_argument("--no-gif", action="store_true", help="write the figure only")
    ap.add_argument("--frames", type=int, default=60, help="growth frames in the GIF at most")
    ap.add_argument("--headless", action="store_true", help="never open a window")
    args = ap.parse_args(argv)

    def fail(msg: str) -> int:
        print(f"error: {msg}", file=sys.stderr)
        return 2

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
    if not 0.0 < args.threshold < 1.0:
        return fail(f"--threshold must lie in (0, 1), got {args.threshold}")
    t0 = time.perf_counter()
    try:
        grid = load_map(args.map, args.threshold, invert=args.invert)
    except (FileNotFoundError, ValueError) as exc:
        return fail(str(exc))
    t_load = time.perf_counter() - t0
    start, goal = args.start, args.goal
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
    if step is None:
        w, h = grid.bounds[1]
        step = max(4.0 * grid.resolution, 0.02 * math.hypot(w, h))
    time_limit = args.time_limit
    if time_limit is None and args.planner in ("rrtstar", "informed-rrtstar"):
        time_limit = 10.0
    try:
        out = plan_on_image(grid, start, goal, planner=args.planner, sampler=args.sampler, goal_bias=args.goal_bias,
                            metric=args.metric, step=step, tolerance=args.tolerance,
                            max_iterations=args.max_iterations, time_limit=time_limit, seed=args.seed,
                            smooth=args.smooth, out_dir=args.out, gif=not args.no_gif, max_frames=args.frames)
    except (FileNotFoundError, ValueError) as exc:
        return fail(str(exc))
    r = out.result
    print(f"map:              {args.map} ({grid.width}x{grid.height}, {100 * grid.obstacles.mean():.1f}% blocked)")
    print(f"query:            start ({start[0]:g}, {start[1]:g}) -> goal ({goal[0]:g}, {goal[1]:g}), "
          f"tolerance {out.problem.goal_tolerance:g}, metric {args.metric}")
    print(f"planner:          {r.planner} (step {step:g}, seed {args.seed})")
    print(f"solved:           {r.solved} ({r.stop_reason})")
    print(f"iterations:       {r.iterations}")
    print(f"collision checks: {r.collision_checks}")
    print(f"vertices:         {r.num_vertices}")
    t = out.timings
    print(f"time:             {t['plan']:.3f} s planning (load {t_load:.3f} s, smooth {t['smooth']:.3f} s, "
          f"figure {t['figure']:.3f} s, gif {t['gif']:.3f} s)")
    if r.solved:
        print(f"path length:      {out.length:.2f} raw ({len(out.path)} states)")
        if out.smoothed is not None:
            print(f"                  {out.smoothed_length:.2f} smoothed ({len(out.smoothed)} states)")
    for f in out.files:
        print(f"wrote {f}")
    return 0 if r.solved else 1


if __name__ == "__main__":
    raise SystemExit(main())
