"""The distilled students of the research report's "Narrower cost networks", as they were made.

    python scripts/experiments/distill_route.py --out runs/d16/route.pt                # 16 channels, 60 maps
    python scripts/experiments/distill_route.py --maps 150 --sizes 32 64 128 256 --epochs 24 --wall-hinge \\
        --out runs/d16h/route.pt                                                        # the report's second student
    python scripts/experiments/vin_validation.py --route runs/d16/route.pt             # then judge it

``learning.training.distill`` (``scripts/distill_route.py``) with this probe's defaults (60 maps per family and side
at 64 and 128, 10 epochs, every move's price unless ``--wall-hinge``), the machine's own instruction set unless
``--avx2``, and the student's initial weights drawn after the teacher's file is read (as these students were made;
the product command draws them first, so its weights differ). The report's students were trained on an AVX-512 CPU.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import torch

from learning.device import pin_cpu_arithmetic
from learning.models.route_net import load_route_net, save_route_net
from learning.models.route_vin import RouteVIN
from learning.models.shipped import SHIPPED_ROUTE_TEACHER
from learning.training.distill import DistillConfig, distill_route_net
from planners.base.fileio import check_int_flags, check_output_place


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--teacher", type=Path, default=SHIPPED_ROUTE_TEACHER)
    ap.add_argument("--channels", type=int, default=16)
    ap.add_argument("--maps", type=int, default=60, help="training maps per family and side")
    ap.add_argument("--sizes", type=int, nargs="+", default=[64, 128])
    ap.add_argument("--epochs", type=int, default=10)
    ap.add_argument("--batch", type=int, default=16)
    ap.add_argument("--lr", type=float, default=2e-3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--wall-hinge", action="store_true",
                    help="learn the teacher's walls as walls (learning.training.distill.move_cost_loss)")
    ap.add_argument("--avx2", action="store_true",
                    help="hold torch, oneDNN and MKL to AVX2 (learning.device.pin_cpu_arithmetic)")
    ap.add_argument("--out", type=Path, default=Path("runs/distilled/route.pt"))
    args = ap.parse_args(argv)
    check_int_flags(args, ("channels", "maps", "epochs", "batch"))
    check_output_place(args.out, "--out", folder=False)
    if args.avx2:
        print(f"arithmetic: {pin_cpu_arithmetic()}", flush=True)  # before any tensor operation
    torch.manual_seed(args.seed)
    teacher = load_route_net(args.teacher)  # building it draws from torch's generator before the student does
    student = RouteVIN(teacher.block, args.channels, teacher.depth, teacher.step)
    config = DistillConfig(args.channels, args.maps, tuple(args.sizes), args.epochs, args.batch, args.lr, args.seed,
                           walls=args.wall_hinge)
    student = distill_route_net(teacher, config, student=student)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    save_route_net(student, args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
