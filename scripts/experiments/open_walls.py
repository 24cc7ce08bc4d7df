"""The route encoder on the comparison's MovingAI tuning scenarios, with and without its open-walls pass.

    python scripts/experiments/open_walls.py                       # every MovingAI map of the comparison
    python scripts/experiments/open_walls.py --maps 32room_000 room-64-64-8 --movingai DIR

Where the encoder's field leaves the start unreached (its learned wall rule has shut a door), the route sampler
asks it for a second pass without that rule (``FieldEncoder.open_walls``). This runs RRT (step 4, tolerance 4,
cap 20,000; planner seeds 0 and 1) with the shipped encoder at ``SHIPPED_SETTINGS`` on the tuning scenarios of
the full comparison's MovingAI split (never its test scenarios), once as shipped and once with the second pass
off, and prints per map whether the start was unreached, the median iterations and the runs solved of each, and
what the query's field costs: the median over its scenarios of the best of ``--repeat`` first queries on the map (its
kept parts forgotten before each, one torch thread), in one pass that checks the start
(``RouteVIN.predict_reaching``, as the sampler asks) and as two ``predict`` calls (``FieldEncoder.predict_reaching``:
the pass, and where it shuts the start a second one without the rule), the same field either way.
About 4 minutes on one core with the 12 maps.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from learning.evaluation.protocol import MOVINGAI_MAPS, Protocol, movingai_queries
from learning.models.field import FieldEncoder
from learning.models.threads import planning_threads
from learning.samplers.route import SHIPPED_SETTINGS, RouteSampler
from planners import make_planner, movingai_dir
from planners.tools.benchmark import MAX_ITERATIONS, STEP


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--maps", nargs="+", default=list(MOVINGAI_MAPS), help="MovingAI map names")
    ap.add_argument("--movingai", default=None,
                    help="the MovingAI folder (default: SAMPLERGYM_MOVINGAI_DIR, else ../shared)")
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=5, help="timed first queries per scenario and way (best of)")
    args = ap.parse_args(argv)
    if args.seeds < 1 or args.repeat < 1:
        ap.error(f"--seeds {args.seeds}, --repeat {args.repeat}: expected at least 1 each")
    unknown = sorted(set(args.maps) - set(MOVINGAI_MAPS))
    if unknown:
        ap.error(f"--maps: {', '.join(unknown)} not among the comparison's MovingAI maps ({', '.join(MOVINGAI_MAPS)})")
    directory = str(movingai_dir(args.movingai))
    protocol, cache = Protocol(), {}
    queries = [q for q in movingai_queries(directory, args.maps, protocol.scenarios, protocol.tuning_scenarios, STEP,
                                           cache) if q.split == "tuning"]
    net = RouteSampler.load().net
    half = 0.5 * net.unreached_steps
    print("| map | start unreached (scenarios) | as shipped: median, solved | second pass off: median, solved "
          "| field, one pass (ms) | field, two calls (ms) |")
    print("|---|---|---|---|---|---|")
    for name in args.maps:
        shut, its, ms = 0, {"shipped": [], "off": []}, {"one": [], "two": []}
        for q in (q for q in queries if q.family == name):
            p = q.problem(directory, STEP, cache)
            grid = p.world
            shut += bool(net.predict(grid.obstacles, grid.cell_of(p.goal))[grid.cell_of(p.start)] >= half)
            query = (grid.obstacles, grid.cell_of(p.goal), grid.cell_of(p.start))
            ms["one"].append(_first_query_ms(net, lambda q=query: net.predict_reaching(*q), args.repeat))
            ms["two"].append(_first_query_ms(net, lambda q=query: FieldEncoder.predict_reaching(net, *q), args.repeat))
            for mode in its:
                sampler = RouteSampler(net, **SHIPPED_SETTINGS)
                if mode == "off":
                    sampler.net = _WallsKept(net)
                for seed in range(args.seeds):
                    r = make_planner("RRT", p, extension_step=STEP, sampler=sampler, seed=seed).solve(
                        max_iterations=MAX_ITERATIONS)
                    its[mode].append((r.first_solution_iteration if r.solved else MAX_ITERATIONS, r.solved))
        n = len(its["shipped"]) // args.seeds
        cells = " | ".join(f"{np.median([i for i, _ in v]):g}, {sum(s for _, s in v)}/{len(v)}" for v in its.values())
        times = " | ".join(f"{np.median(v):.2f}" for v in ms.values())
        print(f"| {name} | {shut}/{n} | {cells} | {times} |", flush=True)
    return 0


def _first_query_ms(net, field, repeat: int) -> float:
    """The best of ``repeat`` calls of ``field`` (after one untimed), each a first query on its map, in ms."""
    best = float("inf")
    with planning_threads(1):
        for i in range(repeat + 1):
            net.clear_map_cache()
            t0 = time.perf_counter()
            field()
            if i:
                best = min(best, time.perf_counter() - t0)
    return best * 1e3


class _WallsKept:
    """The encoder as it is, but with no open-walls pass to offer (``open_walls`` gives None)."""

    def __init__(self, net) -> None:
        self._net = net

    def open_walls(self):
        return None

    def predict_reaching(self, obstacles, goal_cell, start_cell, symmetries=1, *, threads=None):
        return self._net.predict(obstacles, goal_cell, symmetries, threads=threads), False

    def __getattr__(self, name):
        return getattr(self._net, name)


if __name__ == "__main__":
    raise SystemExit(main())
