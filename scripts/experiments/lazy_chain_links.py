"""How short must the lazy roadmap's second chain's links be? Chosen on validation maps by time to solution.

    PYTHONPATH=$PWD python scripts/experiments/lazy_chain_links.py [--at 150 400] [--bounds 1 3 8 inf]

``LazyCorridorSampler`` (``learning.samplers.lazy_route``) samples uniformly, then at its switch computes the route
fields and draws the corridor's chain along the route first. A chain point connects to the one before only where
that one is among its nearest roadmap vertices, so after the switch the chain is drawn a second time with no link
longer than the radius of a disc holding ``LINK_VERTICES`` of the roadmap's vertices on average (``inf``: no second
chain). This script asks which bound: for each switch
point of ``--at`` (the switch forced there: ``roadmap_floor`` that many samples, ``roadmap_after`` 0) it plans the
validation maps of every family at each of ``--sizes`` (``--maps`` each; ``planner_maps("validation", ...)``) with
PRM at its defaults (10 neighbours) and planner seed 0, once per bound of ``--bounds``, the
bounds' order turning by one from one map to the next, one process and one thread. It keeps the maps where some
bound's run reaches the switch, and prints per bound the samples after the switch and the geometric mean of the time
to solution (the planner's construction, the uniform phase, the encoder's passes and the corridor) over those runs.

The rule: the lowest geometric mean at each switch point, pooled; a bound within 3% of it that is smaller (a chain
whose links are tried more surely) wins over it.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

from learning.evaluation.every_planner import planner_maps
from learning.models.threads import planning_threads
from learning.samplers import lazy_route
from learning.samplers.registry import make_sampler
from planners import make_planner

TIE = 0.03


def run(bound: float, problem, at: int) -> tuple[bool, int, float, bool]:
    """One PRM run with the chain bound ``bound`` and the switch at ``at``: (solved, samples, ms, switched)."""
    lazy_route.LINK_VERTICES = bound  # read at the switch; an experiment's setting, restored by the caller
    t = time.perf_counter()
    planner = make_planner("PRM", problem, sampler=make_sampler("route_lazy", roadmap_floor=at, roadmap_after=0),
                           seed=0)
    result = planner.solve(max_iterations=20000)
    return result.solved, result.iterations, (time.perf_counter() - t) * 1e3, planner.sampler.switched


def timed(bounds: list[float], problem, at: int, repeat: int) -> dict[float, tuple[bool, int, float, bool]]:
    """Each bound's run on ``problem``, ``repeat`` times in turn (the runs repeat exactly), its median time kept."""
    runs: dict[float, list] = {b: [] for b in bounds}
    for _ in range(repeat):
        for b in bounds:
            runs[b].append(run(b, problem, at))
    return {b: (*rs[0][:2], statistics.median(r[2] for r in rs), rs[0][3]) for b, rs in runs.items()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--at", type=int, nargs="+", default=[150, 400], help="switch points in samples (default 150 400)")
    ap.add_argument("--bounds", type=float, nargs="+", default=[1.0, 3.0, 8.0, math.inf],
                    help="vertices per link disc (inf: no second chain; default 1 3 8 inf)")
    ap.add_argument("--sizes", type=int, nargs="+", default=[256, 512], help="map sides (default 256 512)")
    ap.add_argument("--maps", type=int, default=12, help="validation maps per family and size (default 12)")
    ap.add_argument("--repeat", type=int, default=3, help="runs of each (map, bound), the median time kept (default 3)")
    args = ap.parse_args(argv)
    if any(a < 1 for a in args.at) or any(not b > 0 for b in args.bounds) or min(args.maps, args.repeat) < 1:
        ap.error("--at, --maps and --repeat must be >= 1 and every bound > 0")
    shipped, pooled = lazy_route.LINK_VERTICES, {b: [] for b in args.bounds}
    try:
        with planning_threads(1):
            maps = [p for size in args.sizes for probs in planner_maps("validation", args.maps, size=size).values()
                    for p in probs]
            for at in args.at:
                rows = {b: [] for b in args.bounds}
                for i, problem in enumerate(maps):
                    order = args.bounds[i % len(args.bounds):] + args.bounds[:i % len(args.bounds)]
                    runs = timed(order, problem, at, args.repeat)
                    if any(r[3] for r in runs.values()):
                        for b in args.bounds:
                            rows[b].append(runs[b])
                print(f"switch at {at} samples: {len(rows[args.bounds[0]])} of {len(maps)} maps reach it")
                for b, rs in rows.items():
                    if not rs:
                        continue
                    after = [r[1] - at for r in rs]
                    gm = math.exp(statistics.mean(math.log(r[2]) for r in rs))
                    pooled[b].append(gm)
                    print(f"  bound {b:g}: solved {sum(r[0] for r in rs)}/{len(rs)}, samples after the switch median "
                          f"{statistics.median(after):g} (max {max(after)}), geometric mean {gm:.2f} ms")
    finally:
        lazy_route.LINK_VERTICES = shipped
    scores = {b: math.exp(statistics.mean(math.log(g) for g in gs)) for b, gs in pooled.items() if gs}
    if not scores:
        print("no map reached a switch: nothing to choose")
        return 1
    print("pooled geometric means: " + ", ".join(f"{b:g}: {s:.2f} ms" for b, s in scores.items()))
    print(f"chosen: {choose(scores):g} (shipped: {shipped:g})")
    return 0


def choose(scores: dict[float, float]) -> float:
    """The bound of the lowest score, or the smallest bound within ``TIE`` of it."""
    best = min(scores.values())
    return min(b for b, s in scores.items() if s <= best * (1 + TIE))


if __name__ == "__main__":
    raise SystemExit(main())
