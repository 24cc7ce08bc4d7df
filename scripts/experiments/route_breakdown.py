"""Where a route-encoder pass spends its time: the whole first query, and each of its parts alone.

    python scripts/experiments/route_breakdown.py
    python scripts/experiments/route_breakdown.py --side 256 --families forest maze rooms --repeat 30

On a generated map of each family (seed 123, its own goal) at one torch thread: the best of ``--repeat`` calls
(after one untimed call) of the shipped encoder's whole ``predict`` (a first query: nothing of the map kept), the
local network's four convolutions over the whole block grid, the step walls (``cell_steps``), the fixed point
(``RouteVIN.settle``, the compiled Dijkstra) and the cell head (``RouteVIN.cell_field``). Milliseconds; the
parts do not add up to the whole (the first query also runs the convolutions over the goal's window, the cost
head and the inputs).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import torch

from learning.models.field import route_input
from learning.models.route_net import load_route_net
from learning.models.route_vin import cell_steps
from learning.models.shipped import SHIPPED_ROUTE
from planners.maps.generators import FAMILIES, generate
from planners.tools.benchmark import markdown_table


def best_ms(call, repeat: int) -> float:
    """The least wall time of ``repeat`` calls after one untimed call, in milliseconds."""
    call()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return 1e3 * min(times)


def breakdown(family: str, side: int, repeat: int) -> dict:
    """One row: the whole first query and each part, best ms."""
    net = load_route_net(SHIPPED_ROUTE).eval()
    problem = generate(family, 123, side)
    obstacles = np.asarray(problem.world.obstacles, dtype=bool)
    goal = tuple(int(v) for v in problem.world.cell_of(problem.goal))
    x = torch.from_numpy(route_input(obstacles, goal, net.block))[None][:, :net.block * net.block + 1]

    def first_query():
        net.clear_map_cache()
        return net.predict(obstacles, goal)

    with torch.no_grad():
        features, costs = net.move_costs(x)
        goals, walls = net.goal_and_walls(x)
        walled = net.wall_rules(x, costs)
        values = net.settle(walled, goals, walls)
        return {"family": family, "side": side,
                "whole first query": round(best_ms(first_query, repeat), 2),
                "convolutions": round(best_ms(lambda: net.local(x), repeat), 2),
                "step walls": round(best_ms(lambda: cell_steps(x, net.block), repeat), 2),
                "Dijkstra": round(best_ms(lambda: net.settle(walled, goals, walls), repeat), 2),
                "cell head": round(best_ms(lambda: net.cell_field(features, values), repeat), 2)}


def main(argv: list[str] | None = None) -> int:
    """Command line entry point."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--side", type=int, default=128, help="map side in cells (default 128)")
    ap.add_argument("--families", nargs="+", choices=FAMILIES, default=["forest", "maze"])
    ap.add_argument("--repeat", type=int, default=15, help="timed calls per figure (default 15)")
    args = ap.parse_args(argv)
    if args.side < 16 or args.repeat < 1:
        ap.error(f"--side takes a map side >= 16 cells and --repeat a count >= 1, got {args.side} and {args.repeat}")
    torch.set_num_threads(1)
    print(markdown_table([breakdown(family, args.side, args.repeat) for family in args.families]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
