"""Where a route-encoder pass spends its time: the whole first query, and each of its parts alone.

    python scripts/experiments/route_breakdown.py
    python scripts/experiments/route_breakdown.py --side 256 --families forest maze rooms --repeat 30

On a generated map of each family (seed 123, its own goal) at one torch thread: the best of ``--repeat`` calls
(after one untimed call) of the shipped encoder's whole ``predict`` (a first query: nothing of the map kept), and
each part of it alone as the CPU's compiled inference runs it: the local network's convolutions and the two 1x1
heads over the whole block grid (``RouteVIN.map_features``; beside them the same with the 3x3 layers dense, as
training runs them, ``RouteVIN.prepacked`` off), the step walls (``cell_steps``), the fixed point
(``move_cost_field``, the compiled search, its moves gated by the walls) and the cell head
(``learning.models.cell_head``). Milliseconds; the parts do not add up to the whole (the input, the map's key and
the conversions come on top).
"""

from __future__ import annotations

import argparse

import numpy as np
import torch

from learning.models.cell_head import cell_head_field
from learning.models.field import route_input
from learning.models.route_net import load_route_net
from learning.models.route_vin import REACH, UNREACHED, cell_steps
from learning.models.shipped import SHIPPED_ROUTE
from planners.maps.generators import FAMILIES, generate
from planners.maps.gridsearch import move_cost_field
from planners.tools.benchmark import best_ms, markdown_table


def dense_features(net, x):
    """``net.map_features(x)`` with the 3x3 layers dense (``RouteVIN.prepacked`` off), as training runs them."""
    net.prepacked = False
    try:
        return net.map_features(x)
    finally:
        del net.prepacked  # back to the class's value


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
        costs, pre = net.map_features(x)
        goals, walls = (t[0].numpy() for t in net.goal_and_walls(x))
        steps = cell_steps(x, net.block)
        gate, most = steps[0].numpy(), (net.wall_cost * net.lengths).view(-1).numpy()
        c = costs[0].numpy()
        values = move_cost_field(c, goals, walls, UNREACHED, open_moves=gate, most=most)
        first, last = net.cells[0], net.cells[2]
        head = (first.weight[:, net.channels:, 0, 0].numpy(), last.weight[:, :, 0, 0].numpy(), last.bias.numpy())
        return {"family": family, "side": side,
                "whole first query": round(best_ms(first_query, repeat), 2),
                "convolutions": round(best_ms(lambda: net.map_features(x), repeat), 2),
                "dense convolutions": round(best_ms(lambda: dense_features(net, x), repeat), 2),
                "step walls": round(best_ms(lambda: cell_steps(x, net.block), repeat), 2),
                "Dijkstra": round(best_ms(lambda: move_cost_field(c, goals, walls, UNREACHED, open_moves=gate,
                                                                  most=most), repeat), 2),
                "cell head": round(best_ms(lambda: cell_head_field(values, pre[0].numpy(), *head, net.block, REACH,
                                                                   UNREACHED), repeat), 2)}


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
