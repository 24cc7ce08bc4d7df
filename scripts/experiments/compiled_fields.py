"""How far the route encoder's compiled inference moves its field from the torch pass, on the validation maps.

    python scripts/experiments/compiled_fields.py                  # 6 maps a row, sides 128 and 256
    python scripts/experiments/compiled_fields.py --maps 2 --sides 64

On the validation maps (the training families, seeds from ``VALIDATION_SEED0 + 500``, ``--maps`` per family at
each of ``--sides``), for each map's own goal and two more free cells of it, in that order on one kept map (a first
query, then later ones): the largest difference at any reached cell between the shipped encoder's field as the
library computes it (``RouteVIN.compiled_inference``: walls gating the Dijkstra, the compiled cell head, strips of
rows, kept maps) and one whole torch pass (``compiled_inference`` and ``map_cache_bytes`` off), and whether the two
reach the same cells. Prints one row per family and side, and the verdict against ``--bound`` (default 1e-4 steps).
"""

from __future__ import annotations

import argparse

import numpy as np

from learning.models.route_net import load_route_net
from learning.models.shipped import SHIPPED_ROUTE
from planners.base.fileio import InputError, check_int_flags
from planners.maps.generators import TRAINING_FAMILIES, VALIDATION_SEED0, generate


def goals_of(problem) -> list[tuple[int, int]]:
    """The map's own goal, then the free cells a third of the way and two thirds of the way through the map."""
    free = np.argwhere(~np.asarray(problem.world.obstacles, dtype=bool))
    own = tuple(int(v) for v in problem.world.cell_of(problem.goal))
    return [own] + [tuple(int(v) for v in free[len(free) * k // 3]) for k in (1, 2)]


def row(net, family: str, side: int, maps: int) -> dict:
    """One family and side: the largest difference over its maps and goals, and whether the reached cells agree."""
    worst, same = 0.0, True
    for i in range(maps):
        problem = generate(family, VALIDATION_SEED0 + 500 + i, side)
        obstacles = np.asarray(problem.world.obstacles, dtype=bool)
        net.clear_map_cache()
        for goal in goals_of(problem):
            compiled = net.predict(obstacles, goal)
            net.compiled_inference, net.map_cache_bytes = False, 0
            try:
                whole = net.predict(obstacles, goal)
            finally:
                del net.compiled_inference, net.map_cache_bytes  # back to the class's values
            reached = whole < 1e5
            same &= bool(np.array_equal(reached, compiled < 1e5))
            worst = max(worst, float(np.abs(compiled - whole)[reached].max(initial=0.0)))
    return {"family": family, "side": side, "maps": maps, "largest difference": worst, "same reached cells": same}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--maps", type=int, default=6, help="validation maps per family and side")
    ap.add_argument("--sides", type=int, nargs="+", default=[128, 256])
    ap.add_argument("--families", nargs="+", default=list(TRAINING_FAMILIES), choices=TRAINING_FAMILIES)
    ap.add_argument("--bound", type=float, default=1e-4, help="the largest difference allowed, in steps")
    args = ap.parse_args(argv)
    try:
        check_int_flags(args, ("maps",), low=1)
        if any(s < 16 for s in args.sides):
            raise InputError(f"--sides {args.sides}: expected sides of at least 16 cells")
    except InputError as exc:
        ap.error(str(exc))
    net = load_route_net(SHIPPED_ROUTE).eval()
    rows = []
    print("| family | side | maps | largest difference (steps) | same reached cells |\n|---|---|---|---|---|")
    for side in args.sides:
        for family in args.families:
            r = row(net, family, side, args.maps)
            rows.append(r)
            print(f"| {family} | {side} | {r['maps']} | {r['largest difference']:.3g} | "
                  f"{'yes' if r['same reached cells'] else 'no'} |", flush=True)
    worst = max(r["largest difference"] for r in rows)
    ok = worst < args.bound and all(r["same reached cells"] for r in rows)
    print(f"\nlargest difference {worst:.3g} steps: {'within' if ok else 'NOT within'} {args.bound:g}"
          + ("" if all(r["same reached cells"] for r in rows) else "; the reached cells differ"))
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
