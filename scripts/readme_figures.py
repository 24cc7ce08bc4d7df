"""Regenerate the README's pictures (docs/*.png) from the library and the shipped checkpoint.

    python scripts/readme_figures.py --best-bias 0.05 0.1 0.01   # docs/samplers.png, docs/shifted.png, docs/rigid.png

samplers.png: one held-out map per family, RRT with the tuned best goal bias, the route ablation (the
route sampler on the straight line, no learning) and the route encoder the README recommends, same
planner seed; each panel's title gives the iterations it took and its time (from the planner's start to
its first solution, the encoder's pass included; one thread, the machine's load included).
shifted.png: one test map per family (top) beside two of its shifted variant (below: 128x128, and
the first 256x256 one), the maps evaluate.py reports as "<family> (shifted)".
rigid.png: RRT-Connect moving a box body through the window of the example 6-DoF scene.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from planners.base.fileio import InputError, check_output_place

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=ROOT / "docs")
    ap.add_argument("--families", nargs="+", default=["bugtrap", "maze", "rooms"])
    ap.add_argument("--best-bias", nargs="+", type=float, default=None,
                    help="best goal bias per family (from evaluate.py's summary); default 0.2 for all")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    try:
        check_output_place(args.out, "--out")  # before the figures' runs
    except InputError as exc:
        ap.error(str(exc))

    import time

    import torch

    from learning import make_sampler
    from learning.evaluation import Protocol
    from planners import RRT, GoalBiasedSampler, RRTConnect, load_scene
    from planners.maps.generators import FAMILIES, SHIFTED_SEED0, SHIFTED_SIZES, TEST_SEED0, generate
    from planners.viz.plotting import new_figure, plot, save_figure
    from planners.viz.plotting3d import plot_scene

    torch.set_num_threads(1)  # as the comparison times a query: one thread
    protocol = Protocol()
    best = args.best_bias or [0.2] * len(args.families)
    fams = args.families
    fig = new_figure((3.3 * 3, 3.4 * len(fams)))
    for i, fam in enumerate(fams):
        problem = generate(fam, TEST_SEED0 + args.seed, protocol.size)
        for j, (label, make) in enumerate(((f"goal bias {best[i]:g} (tuned)", lambda b=best[i]: GoalBiasedSampler(b)),
                                           ("route ablation", lambda: make_sampler("route_ablation")),
                                           ("route encoder", lambda: make_sampler("route", device="cpu")))):
            # a first plan loads the kernels and the weights: paid once per process, not per query, so off the clock
            RRT(problem, step_size=protocol.step, sampler=make(), seed=args.seed).solve(max_iterations=1)
            sampler = make()
            t0 = time.perf_counter()
            planner = RRT(problem, step_size=protocol.step, sampler=sampler, seed=args.seed)
            r = planner.solve(max_iterations=protocol.max_iterations)
            ms = (time.perf_counter() - t0) * 1e3
            ax = fig.add_subplot(len(fams), 3, 3 * i + j + 1)
            plot(problem, planner, r, ax=ax, title=f"{fam}, {label}: {r.iterations} it., {ms:.0f} ms")
            ax.title.set_fontsize(8)
    p1 = save_figure(fig, args.out / "samplers.png", dpi=90)

    fig = new_figure((2.6 * len(FAMILIES), 2.7 * 3))
    big = SHIFTED_SIZES.index(256)
    for j, fam in enumerate(FAMILIES):
        maps = (generate(fam, TEST_SEED0 + args.seed, 128),
                generate(fam, SHIFTED_SEED0 + SHIFTED_SIZES.index(128), 128, shifted=True),
                generate(fam, SHIFTED_SEED0 + big, 256, shifted=True))
        for i, problem in enumerate(maps):
            ax = fig.add_subplot(3, len(FAMILIES), i * len(FAMILIES) + j + 1)
            plot(problem, ax=ax, title=problem.name)
            ax.title.set_fontsize(8)
    p3 = save_figure(fig, args.out / "shifted.png", dpi=80)

    problem = load_scene(ROOT / "planners" / "scenes" / "example.scene")
    r = RRTConnect(problem, step_size=0.5, seed=args.seed).solve(max_iterations=protocol.max_iterations)
    fig = plot_scene(problem, r.path if r.solved else None,
                     title=f"6-DoF box, RRT-Connect: {r.iterations} iterations")
    p2 = save_figure(fig, args.out / "rigid.png", dpi=90)
    print(p1, p3, p2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
