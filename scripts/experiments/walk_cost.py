"""What the walk to the route sampler's target costs, strictly downhill, across ripples and cut at the sight line.

    python scripts/experiments/walk_cost.py
    python scripts/experiments/walk_cost.py --whole --walks 2000 --side 512      # walks over the whole route

Times ``planners.guidance.follow.walk_path`` (the walk the route sampler runs, into one buffer) from
200,000 free cells (drawn with seed 0) of a 256-cell validation caves map, down the shipped encoder's field, for
12 cells of path (the shipped lookahead of 3 steps of 4 cells): strictly downhill, at a fixed tolerance of 0.1
step, and at the shipped 0.1 + 0.01 x cost-to-go, each without and with the cut where the walk leaves the
start cell's sight (``last_in_sight``, shipped).
Best of 3 rounds, after one call that compiles. One walk per planner iteration while the tree makes progress.

``--whole``: the walk the roadmaps' chain and RRT-Connect's goal tree take instead, at the shipped tolerance, from
each cell as far as it goes (a buffer the map's size, so the walk keeps its visits in a hash set), on a caves map of
``--side`` cells; prints the moves per walk and the time per move.
"""

from __future__ import annotations

import argparse
import time

import numba as nb
import numpy as np

from learning.models.route_net import load_route_net
from learning.samplers.route import SHIPPED, SHIPPED_SETTINGS
from planners.guidance.follow import last_in_sight, walk_path
from planners.maps.generators import VALIDATION_SEED0, generate


@nb.njit
def _walks(field, blocked, cells, length, tolerance, growth, sight):
    visited = np.empty(int(length) + 2, np.int64)
    reached = 0
    for k in range(cells.shape[0]):
        moves = walk_path(field, blocked, cells[k], length, tolerance, growth, visited)
        reached += last_in_sight(blocked, visited, moves) if sight else visited[moves - 1]
    return reached


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--walks", type=int, default=200_000)
    ap.add_argument("--whole", action="store_true", help="walks over the whole route, as far as each goes")
    ap.add_argument("--side", type=int, default=256, help="the map's side in cells (default 256)")
    args = ap.parse_args(argv)
    if args.walks < 1:
        ap.error(f"--walks takes a count >= 1, got {args.walks}")
    if args.side < 16:
        ap.error(f"--side takes a map side of at least 16 cells, got {args.side}")
    p = generate("caves", VALIDATION_SEED0 + 500, args.side)
    grid = p.world
    field = load_route_net(SHIPPED).predict(grid.obstacles, grid.cell_of(p.goal), 1).astype(np.float64)
    field[grid.obstacles] = np.inf
    cells = np.random.default_rng(0).choice(np.flatnonzero(~grid.obstacles.ravel()), args.walks)
    shipped = (SHIPPED_SETTINGS["ripple"], SHIPPED_SETTINGS["ripple_growth"])
    if args.whole:
        blocked = grid.kernel.grid
        _whole(field, blocked, cells[:2], *shipped)
        moves = _whole(field, blocked, cells, *shipped)
        best = min(_timed_whole(field, blocked, cells, shipped) for _ in range(3))
        print(f"whole route, shipped (ripple {shipped[0]:g}, growth {shipped[1]:g}): {moves / len(cells):.0f} moves "
              f"per walk, {best / moves * 1e9:.1f} ns per move")
        return 0
    for name, (tolerance, growth) in (("strictly downhill", (0.0, 0.0)), ("tolerance 0.1 step", (0.1, 0.0)),
                                      ("shipped", shipped)):
        for sight in (False, True):
            _walks(field, grid.kernel.grid, cells[:10], 12.0, tolerance, growth, sight)
            best = min(_timed(field, grid.kernel.grid, cells, tolerance, growth, sight) for _ in range(3))
            print(f"{name} (ripple {tolerance:g}, growth {growth:g}), {'cut at the sight line' if sight else 'uncut'}: "
                  f"{best / cells.shape[0] * 1e9:.0f} ns per walk")
    return 0


@nb.njit
def _whole(field, blocked, cells, tolerance, growth):
    visited = np.empty(blocked.size + 2, np.int64)
    moves = 0
    for k in range(cells.shape[0]):
        moves += walk_path(field, blocked, cells[k], float(blocked.size), tolerance, growth, visited) - 1
    return moves


def _timed_whole(field, blocked, cells, shipped) -> float:
    t0 = time.perf_counter()
    _whole(field, blocked, cells, *shipped)
    return time.perf_counter() - t0


def _timed(field, blocked, cells, tolerance, growth, sight) -> float:
    t0 = time.perf_counter()
    _walks(field, blocked, cells, 12.0, tolerance, growth, sight)
    return time.perf_counter() - t0


if __name__ == "__main__":
    raise SystemExit(main())
