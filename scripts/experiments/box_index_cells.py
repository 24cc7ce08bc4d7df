"""How fine the box worlds' spatial index should be: the pose-check cost at several cells per box.

    PYTHONPATH=$PWD python scripts/experiments/box_index_cells.py                       # 4, 16 and 64 cells per box
    PYTHONPATH=$PWD python scripts/experiments/box_index_cells.py --cells 4 16 --counts 100 20000 --repeat 5

For each grid density, the best of ``--repeat`` timings of a pose check (``planners.tools.box_index_bench``:
the 16-point body, seeded poses in a 100-unit cube of boxes of sides 0.5 to 2) among each count of boxes, and
the ratio of the largest count's cost to the smallest's (the issue's target: at most 2 from 100 to 20,000 boxes).
The grid is ``planners.worlds.rigid3d.box_index``'s rule with another number of cells per box (at most
``--max-cells``). Wall-clock figures: run it on a quiet machine.
"""

from __future__ import annotations

import argparse

import numpy as np

from planners.kernels import rigid as rigid_kernels
from planners.tools import box_index_bench
from planners.worlds import rigid3d


def grid_rule(per_box: int, max_cells: int):
    """``box_index`` with ``per_box`` cells per box, at most ``max_cells`` (the shipped rule: 4 and 2**18)."""

    def box_index(boxes, low, high, margin):
        if len(boxes) <= rigid3d.INDEX_MIN_BOXES:
            return np.zeros((1, 1), dtype=np.int64), np.zeros(0)
        extent = high - low
        cells = min(max_cells, max(4096, per_box * len(boxes)))
        side = float(np.prod(extent) / cells) ** (1.0 / 3.0)
        shape = np.maximum(1, np.ceil(extent / side)).astype(np.int64)
        while int(np.prod(shape)) > max_cells:
            side *= 1.1
            shape = np.maximum(1, np.ceil(extent / side)).astype(np.int64)
        pad = margin * (1.0 + 1e-9) + 1e-12 * float(np.max(np.abs(np.concatenate([low, high]))) + 1.0)
        index = rigid_kernels.bin_boxes(np.ascontiguousarray(boxes), pad, np.ascontiguousarray(low), side, shape)
        return index, np.concatenate([low, [side], shape.astype(np.float64)])

    return box_index


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cells", type=int, nargs="+", default=[4, 16, 64], help="cells per box")
    ap.add_argument("--max-cells", type=int, default=1 << 22, help="most cells of a grid above 4 per box")
    ap.add_argument("--counts", type=int, nargs="+", default=[100, 1000, 20000], help="box counts")
    ap.add_argument("--poses", type=int, default=20000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    shipped = rigid3d.box_index
    print("| cells per box | " + " | ".join(f"{n:,} boxes, us per pose" for n in args.counts) + " | ratio |")
    print("|---" * (len(args.counts) + 2) + "|")
    try:
        for per in args.cells:
            cap = rigid3d.INDEX_MAX_CELLS if per <= 4 else args.max_cells
            rigid3d.box_index = grid_rule(per, cap)
            best = [min(box_index_bench.pose_check_cost(n, args.poses).indexed_us for _ in range(args.repeat))
                    for n in args.counts]
            print(f"| {per} | " + " | ".join(f"{b:.2f}" for b in best) + f" | {best[-1] / best[0]:.2f} |", flush=True)
    finally:
        rigid3d.box_index = shipped
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
