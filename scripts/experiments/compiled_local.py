"""Where should the route encoder run its local network compiled rather than through torch? Timed as it plans.

    PYTHONPATH=$PWD python scripts/experiments/compiled_local.py [--sides 32 48 64 96 128] [--maps 4] [--rounds 3]

The shipped encoder computes its local network and heads either through torch (``RouteVIN.numba_local_blocks``
0) or compiled (``learning.models.local_net``; the limit raised past every map). On validation maps of the
training families (``--maps`` per family and side, seeds from ``VALIDATION_SEED0 + 500``), each map's own query
and two more between random free cells (seeded), both encoders give each query's field
(``predict_reaching``, its start's route checked as the route sampler asks), in turn, the order turning from
one query to the next, and each map's kept parts forgotten before its first query. ``--between`` (default
on): before each timed field, a uniform RRT-Connect run on the same map (its time not counted), so the field is
computed as it is in a planning loop, after a planner's code and data have taken the CPU's caches; without it,
back to back. Prints the median field time per side, first queries and later ones apart, for both ways and
their ratio, and the largest difference between their fields (steps, at the cells both reach).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import torch

from learning.models.route_net import load_route_net
from learning.models.shipped import SHIPPED_ROUTE
from planners import make_planner
from planners.maps.generators import TRAINING_FAMILIES, VALIDATION_SEED0, generate


def encoders() -> dict:
    torch_net, compiled = load_route_net(SHIPPED_ROUTE).eval(), load_route_net(SHIPPED_ROUTE).eval()
    torch_net.numba_local_blocks = 0
    compiled.numba_local_blocks = 1 << 62
    return {"torch": torch_net, "compiled": compiled}


def queries(problem, rng: np.random.Generator, extra: int) -> list[tuple[tuple[int, int], tuple[int, int]]]:
    """The problem's own (goal, start) in cells and ``extra`` more between random free cells."""
    grid = problem.world
    free = np.argwhere(~np.asarray(grid.obstacles, dtype=bool))
    out = [(tuple(int(v) for v in grid.cell_of(problem.goal)), tuple(int(v) for v in grid.cell_of(problem.start)))]
    for _ in range(extra):
        g, s = free[rng.integers(len(free))], free[rng.integers(len(free))]
        out.append(((int(g[0]), int(g[1])), (int(s[0]), int(s[1]))))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sides", type=int, nargs="+", default=[32, 48, 64, 96, 128])
    ap.add_argument("--maps", type=int, default=4, help="validation maps per family and side (default 4)")
    ap.add_argument("--rounds", type=int, default=3, help="passes over every map's queries (default 3)")
    ap.add_argument("--extra", type=int, default=2, help="random queries per map beside its own (default 2)")
    ap.add_argument("--no-between", dest="between", action="store_false",
                    help="time the fields back to back, without a planner run before each")
    args = ap.parse_args(argv)
    if args.maps < 1 or args.rounds < 1 or args.extra < 0 or min(args.sides) < 16:
        ap.error("--maps and --rounds take counts >= 1, --extra >= 0, --sides map sides >= 16 cells")
    torch.set_num_threads(1)
    nets = encoders()
    rng = np.random.default_rng(0)
    print("| side | blocks | first: torch ms | compiled ms | ratio | later: torch ms | compiled ms | ratio "
          "| largest difference (steps) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for side in args.sides:
        maps = [generate(f, VALIDATION_SEED0 + 500 + i, side) for f in TRAINING_FAMILIES for i in range(args.maps)]
        work = [(p, np.asarray(p.world.obstacles, dtype=bool), queries(p, rng, args.extra)) for p in maps]
        for _, obstacles, qs in work[:1]:  # compile and warm both ways once
            for net in nets.values():
                net.predict_reaching(obstacles, *qs[0])
        times = {(name, kind): [] for name in nets for kind in ("first", "later")}
        worst, turn = 0.0, 0
        for _ in range(args.rounds):
            for p, obstacles, qs in work:
                for net in nets.values():
                    net.clear_map_cache()
                for q, (goal, start) in enumerate(qs):
                    names = list(nets)[turn % 2:] + list(nets)[:turn % 2]
                    turn += 1
                    fields = {}
                    for name in names:
                        if args.between:
                            make_planner("RRTConnect", p, seed=q, extension_step=4.0).solve(max_iterations=20000)
                        t0 = time.perf_counter()
                        fields[name], _ = nets[name].predict_reaching(obstacles, goal, start)
                        times[name, "first" if q == 0 else "later"].append(time.perf_counter() - t0)
                    a, b = fields["torch"], fields["compiled"]
                    both = (a < 1e5) & (b < 1e5)
                    if both.any():
                        worst = max(worst, float(np.abs(a - b)[both].max()))
        cells = []
        for kind in ("first", "later"):
            t, c = (1e3 * float(np.median(times[name, kind])) if times[name, kind] else float("nan")
                    for name in ("torch", "compiled"))
            cells += [f"{t:.3f}", f"{c:.3f}", f"{c / t:.2f}"]
        blocks = -(-side // nets["torch"].block)
        print(f"| {side} | {blocks} x {blocks} | " + " | ".join(cells) + f" | {worst:.2g} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
