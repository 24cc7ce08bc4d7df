"""The route encoder's step walls two ways: each block's moves looked up from its window of cells, or its pairs tested.

    PYTHONPATH=$PWD python scripts/experiments/step_walls.py
    PYTHONPATH=$PWD python scripts/experiments/step_walls.py --sides 512 1024 4096 --rounds 5

``planners.maps.gridsearch.padded_block_steps`` at the encoder's blocks of 2 cells, on a generated forest and maze of
each side (seed 123): ``lookup=True`` (the default, each block's window read once and its moves looked up in a
table of every window) against ``lookup=False`` (each move's cell pairs tested in turn). Both in this process, in
turns, the order flipping each round; each round's figure is the best of ``--repeat`` calls after an untimed one.
Prints, per map, both medians over the rounds in milliseconds, the median of the rounds' ratios, and whether the two
gave the same walls.
"""

from __future__ import annotations

import argparse
import statistics
from functools import partial

import numpy as np

from planners.maps.generators import generate
from planners.maps.gridsearch import padded_block_steps
from planners.tools.benchmark import best_ms


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sides", type=int, nargs="+", default=[128, 1024])
    ap.add_argument("--families", nargs="+", default=["forest", "maze"])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--repeat", type=int, default=9)
    args = ap.parse_args(argv)
    if min(args.sides) < 2 or args.rounds < 1 or args.repeat < 1:
        ap.error("--sides must be at least 2, --rounds and --repeat at least 1")
    print("| map | side | lookup ms | pairs ms | ratio (median of rounds) | same walls |")
    print("|---|---|---|---|---|---|")
    for side in args.sides:
        for family in args.families:
            free = ~np.asarray(generate(family, 123, size=side).world.obstacles)
            padded = np.zeros((free.shape[0] + 2, free.shape[1] + 2), dtype=np.uint8)
            padded[1:-1, 1:-1] = free
            same = np.array_equal(padded_block_steps(padded, 2), padded_block_steps(padded, 2, lookup=False))
            fast, slow = [], []
            for k in range(args.rounds):
                calls = [(fast, True), (slow, False)]
                for out, lookup in (calls if k % 2 == 0 else calls[::-1]):
                    out.append(best_ms(partial(padded_block_steps, padded, 2, lookup=lookup), args.repeat))
            ratio = statistics.median(f / s for f, s in zip(fast, slow, strict=True))
            print(f"| {family} | {side} | {statistics.median(fast):.3f} | {statistics.median(slow):.3f} | "
                  f"{ratio:.2f} | {'yes' if same else 'NO'} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
