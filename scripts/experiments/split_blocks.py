"""How often a wall splits a block of the route encoder's grid: the share of blocks whose free cells fall apart.

    python scripts/experiments/split_blocks.py                 # blocks of 4 and 2 cells, 6 maps a family
    python scripts/experiments/split_blocks.py --blocks 4 2 1 --maps 20

Value iteration over blocks gives each block one value, so a block whose free cells form two or more pieces
(4-connected: a robot does not cut a blocked corner) cannot be on both sides of the wall that splits it. On maps
drawn outside every test range (the shifted forest and the unseen spiral and baffles at seeds 2,500,000 and
4,000,000, which no split uses) and on the validation strokes, this prints that share for each block size.
"""

from __future__ import annotations

import argparse

import numpy as np

from planners.maps.generators import VALIDATION_SEED0, generate
from planners.maps.gridsearch import free_components
from planners.maps.unseen import generate_unseen

#: Seeds outside every split: diagnosis only, never a test, tuning or validation map.
SHIFTED_SEED0, UNSEEN_SEED0 = 2_500_000, 4_000_000

SETS = {
    "forest (shifted)": lambda i, side: generate("forest", SHIFTED_SEED0 + i, side, shifted=True),
    "spiral (unseen)": lambda i, side: generate_unseen("spiral", UNSEEN_SEED0 + i, side),
    "baffles (unseen)": lambda i, side: generate_unseen("baffles", UNSEEN_SEED0 + i, side),
    "strokes (validation)": lambda i, side: generate("strokes", VALIDATION_SEED0 + 500 + i, side),
}


def pieces(free: np.ndarray) -> int:
    """The 4-connected pieces of ``free`` (a small bool array): ``planners.maps.gridsearch.free_components``."""
    return int(free_components(~free).max()) + 1


def split_share(obstacles: np.ndarray, block: int) -> tuple[int, int]:
    """(blocks with a free cell, those whose free cells are in two or more pieces) of whole ``block`` blocks."""
    H, W = obstacles.shape
    total = split = 0
    for r in range(0, H - H % block, block):
        for c in range(0, W - W % block, block):
            free = ~obstacles[r:r + block, c:c + block]
            if free.any():
                total += 1
                split += pieces(free) > 1
    return total, split


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--blocks", type=int, nargs="+", default=[4, 2], help="block sides in cells")
    ap.add_argument("--maps", type=int, default=6, help="maps per set")
    ap.add_argument("--side", type=int, default=128)
    args = ap.parse_args(argv)
    if min(args.blocks) < 1 or args.maps < 1:
        ap.error(f"--blocks {args.blocks} and --maps {args.maps}: expected positive whole numbers")
    print("| map set | " + " | ".join(f"split blocks of {b} cells" for b in args.blocks) + " |")
    print("|---|" + "---|" * len(args.blocks))
    for name, make in SETS.items():
        maps = [make(i, args.side).world.obstacles for i in range(args.maps)]
        cells = []
        for b in args.blocks:
            counts = np.array([split_share(m, b) for m in maps])
            total, split = counts.sum(0)
            cells.append(f"{split / total:.2%} ({split} of {total})")
        print(f"| {name} | " + " | ".join(cells) + " |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
