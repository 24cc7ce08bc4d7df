"""What the walk to the route sampler's target costs, strictly downhill, across ripples and cut at the sight line.

    python scripts/experiments/walk_cost.py

Times ``planners.guidance.follow.walk_path`` (the walk the route sampler runs, into one buffer) from
200,000 free cells (drawn with seed 0) of a 256-cell validation caves map, down the shipped encoder's field, for
12 cells of path (the shipped lookahead of 3 steps of 4 cells): strictly downhill, at a fixed tolerance of 0.1
step, and at the shipped 0.1 + 0.01 x cost-to-go, each without and with the cut where the walk leaves the
start cell's sight (``last_in_sight``, shipped).
Best of 3 rounds, after one call that compiles. One walk per planner iteration while the tree makes progress.
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
    args = ap.parse_args(argv)
    if args.walks < 1:
        ap.error(f"--walks takes a count >= 1, got {args.walks}")
    p = generate("caves", VALIDATION_SEED0 + 500, 256)
    grid = p.world
    field = load_route_net(SHIPPED).predict(grid.obstacles, grid.cell_of(p.goal), 1).astype(np.float64)
    field[grid.obstacles] = np.inf
    cells = np.random.default_rng(0).choice(np.flatnonzero(~grid.obstacles.ravel()), args.walks)
    shipped = (SHIPPED_SETTINGS["ripple"], SHIPPED_SETTINGS["ripple_growth"])
    for name, (tolerance, growth) in (("strictly downhill", (0.0, 0.0)), ("tolerance 0.1 step", (0.1, 0.0)),
                                      ("shipped", shipped)):
        for sight in (False, True):
            _walks(field, grid.kernel.grid, cells[:10], 12.0, tolerance, growth, sight)
            best = min(_timed(field, grid.kernel.grid, cells, tolerance, growth, sight) for _ in range(3))
            print(f"{name} (ripple {tolerance:g}, growth {growth:g}), {'cut at the sight line' if sight else 'uncut'}: "
                  f"{best / cells.shape[0] * 1e9:.0f} ns per walk")
    return 0


def _timed(field, blocked, cells, tolerance, growth, sight) -> float:
    t0 = time.perf_counter()
    _walks(field, blocked, cells, 12.0, tolerance, growth, sight)
    return time.perf_counter() - t0


if __name__ == "__main__":
    raise SystemExit(main())
