"""Distil the route encoder: a narrower one that learns a trained encoder's walls, move prices and cell head.

    python scripts/distill_route.py                          # the shipped encoder's recipe (about 22 min, one core)
    python scripts/distill_route.py --export learning/data/route.pt      # ... and copy it over the shipped one
    python scripts/distill_route.py --teacher runs/route/route.pt --out runs/mine    # from an encoder of your own
    python scripts/evaluate.py --route mine=runs/mine/route.pt           # then compare it with the shipped one

The shipped route encoder is a 16-channel student of a 48-channel encoder trained on the grid search's cost-to-go
(``learning/data/route_teacher.pt``, made by ``scripts/train_route.py``): a third of the teacher's pass, even with it
on the generated, shifted and unseen sets and a little behind on the MovingAI maps (docs/report.md, "The distilled
encoder"). With no options this makes it again from that teacher
(``learning.training.distill``): 150 training maps per family and side at sides 32, 64, 128 and 256 (training
seeds only), each turned by one of the square's 8 symmetries, 24 epochs, batches of 16, Adam from 2e-3 down to 0
along a cosine. ``--prices`` fits the price of every move instead of learning the teacher's walls as walls.

Writes ``<out>/route.pt`` and ``<out>/route.json`` (recipe, the teacher's file and checksum, loss, time) as one set,
locked while it runs. One torch thread, and torch, oneDNN and MKL held to AVX2 as every training script here does
(``--native-arithmetic``: the machine's own instruction set), so the same recipe gives the same weights on any x86
CPU with AVX2.
"""

from __future__ import annotations

import argparse
import hashlib
import sys
import time
from pathlib import Path

from learning.device import pin_cpu_arithmetic
from learning.models.route_net import load_route_net, save_route_set
from learning.models.route_vin import RouteVIN
from learning.models.shipped import SHIPPED_ROUTE_TEACHER
from learning.training.distill import DistillConfig, distill_route_net
from planners.base.fileio import InputError, check_int_flags, check_output_place, run_lock
from planners.maps.generators import check_size

DEFAULT = DistillConfig()


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--teacher", type=Path, default=SHIPPED_ROUTE_TEACHER,
                    help="the value-iteration encoder to learn from (default: the shipped encoder's teacher)")
    ap.add_argument("--channels", type=int, default=DEFAULT.channels)
    ap.add_argument("--maps", type=int, default=DEFAULT.maps, help="training maps per family and side")
    ap.add_argument("--sizes", type=int, nargs="+", default=list(DEFAULT.sizes), help="map sides")
    ap.add_argument("--epochs", type=int, default=DEFAULT.epochs)
    ap.add_argument("--batch", type=int, default=DEFAULT.batch)
    ap.add_argument("--lr", type=float, default=DEFAULT.lr)
    ap.add_argument("--seed", type=int, default=DEFAULT.seed)
    ap.add_argument("--prices", action="store_true",
                    help="fit every move's price, the teacher's walls included (default: learn its walls as walls)")
    ap.add_argument("--native-arithmetic", action="store_true",
                    help="the machine's own instruction set instead of AVX2 (other weights on other CPUs)")
    ap.add_argument("--out", type=Path, default=Path("runs/distilled"))
    ap.add_argument("--export", type=Path, help="also copy the encoder here (and its .json beside it)")
    return ap


def _check(args) -> RouteVIN:
    check_int_flags(args, ("channels", "maps", "epochs", "batch"))
    check_int_flags(args, ("seed",), low=0)
    for size in args.sizes:
        check_size(size, "--sizes")
    if not args.lr > 0:
        raise InputError(f"--lr {args.lr}: expected a learning rate > 0")
    check_output_place(args.out, "--out", need_bytes=20 * 2**20)
    if args.export is not None:
        check_output_place(args.export, "--export", folder=False)
    if not args.teacher.is_file():
        raise InputError(f"--teacher {args.teacher}: no such file; expected a route encoder (scripts/train_route.py)")
    teacher = load_route_net(args.teacher)  # an InputError naming the file where it is not an encoder
    if not isinstance(teacher, RouteVIN):
        raise InputError(f"--teacher {args.teacher}: a {type(teacher).__name__} file; distillation learns a "
                         f"value-iteration encoder's move costs (scripts/train_route.py --kind vin)")
    return teacher


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    # before any tensor operation (reading the teacher is one): the same weights on any x86 CPU with AVX2
    arithmetic = None if args.native_arithmetic else pin_cpu_arithmetic()
    try:
        teacher = _check(args)
        with run_lock(args.out, "scripts/distill_route.py " + " ".join(argv if argv is not None else sys.argv[1:])):
            return _distill(args, teacher, arithmetic)
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"\ninterrupted: nothing was written ({args.out} is as it was)", file=sys.stderr)
        return 130


def _distill(args, teacher: RouteVIN, arithmetic: dict | None) -> int:
    config = DistillConfig(args.channels, args.maps, tuple(args.sizes), args.epochs, args.batch, args.lr, args.seed,
                           walls=not args.prices)
    t0 = time.perf_counter()
    lines: list[str] = []

    def log(line: str) -> None:
        lines.append(line)
        print(line, flush=True)

    student = distill_route_net(teacher, config, log)
    info = {"recipe": {**config.record(), "kind": "distilled"},
            "teacher": {"file": args.teacher.name, "sha256": hashlib.sha256(args.teacher.read_bytes()).hexdigest()},
            "parameters": sum(p.numel() for p in student.parameters()),
            "last_epoch": lines[-1], "minutes": round((time.perf_counter() - t0) / 60, 1), "device": "cpu",
            "cpu_arithmetic": arithmetic}
    save_route_set(student, info, args.out, args.export)  # route.pt and route.json replace the old pair together
    print(f"wrote {args.out / 'route.pt'} in {(time.perf_counter() - t0) / 60:.1f} min")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
