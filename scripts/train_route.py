"""Train the route encoder (``learning.route.RouteNet``) on the generated training maps.

    python scripts/train_route.py                           # the shipped encoder's recipe (about an hour)
    python scripts/train_route.py --resume                  # continue an interrupted run from its last epoch
    python scripts/train_route.py --epochs 5 --maps 100     # a quicker variation
    python scripts/evaluate.py --sampler route=learning.route:trained_sampler   # compare it

With no options it trains the shipped encoder's recipe (``learning/data/route.json``: 30 epochs, 1600
maps per family at sides 64 and 128, the 8 symmetries, 2 axial attention layers). Maps come from the
training seeds only (validation, tuning and test seeds are never seen). The encoder learns the grid
search's cost-to-go of every cell; ``RouteSampler`` follows its prediction.

Writes ``<out>/route.pt`` and ``<out>/route.json`` (recipe, loss, time) as one unit: the folder is
built beside ``<out>`` and swapped into place whole, so a kill leaves the old pair or the new pair.
While it trains, ``<out>/checkpoint.pt`` holds the state after the last finished epoch, and
``--resume`` continues from it to the same weights an uninterrupted run reaches. ``<out>`` is locked
while a run writes it (``.<out>.lock`` beside it): a second run on it exits 2 naming the first.
One torch thread: the same seed on the same machine gives the same weights.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import torch

from learning.route import RouteNet, save_route_net
from learning.route_training import train_route_net
from planners.base.fileio import (
    InputError,
    atomic_write_bytes,
    atomic_write_text,
    check_int_flags,
    check_output_place,
    output_set,
    run_lock,
)
from planners.maps.generators import FAMILIES, TRAIN_SEEDS, check_size, generate

#: Free disk a run needs: the encoder and its checkpoint are a few MB each.
NEED_BYTES = 50 * 2**20


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--maps", type=int, default=1600, help="training maps per family and size (default 1600)")
    ap.add_argument("--size", type=int, nargs="+", default=[64, 128], help="map sides; --maps maps of each")
    ap.add_argument("--epochs", type=int, default=30)
    ap.add_argument("--channels", type=int, default=24)
    ap.add_argument("--depth", type=int, default=4, help="times the encoder halves the block grid")
    ap.add_argument("--attention", type=int, default=2, help="axial attention layers (a row then a column each)")
    ap.add_argument("--attention-level", type=int, default=0,
                    help="times the block grid is halved where the attention runs (0: full resolution)")
    ap.add_argument("--step", type=int, default=4, help="the planner's step in cells: the encoder's block")
    ap.add_argument("--augment", action=argparse.BooleanOptionalAction, default=True,
                    help="turn each map by one of the square's 8 symmetries (default on)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("runs/route"))
    ap.add_argument("--resume", action="store_true", help="continue the run in --out from its last finished epoch")
    ap.add_argument("--export", type=Path, help="also copy the encoder here (and its .json beside it)")
    return ap


def _check(args) -> None:
    """Every argument and output place, before any map is generated (``InputError`` naming the flag)."""
    check_int_flags(args, ("maps", "epochs", "channels", "depth", "step"))
    check_int_flags(args, ("attention", "attention_level", "seed"), low=0)
    try:  # the encoder's own rules
        RouteNet(args.step, args.channels, args.depth, args.attention, args.attention_level)
    except ValueError as exc:
        raise InputError(f"--channels / --depth / --attention / --attention-level: {exc}") from None
    for size in args.size:
        check_size(size, "--size")
    if args.maps > TRAIN_SEEDS[1] - TRAIN_SEEDS[0]:
        raise InputError(f"--maps {args.maps}: the training split holds {TRAIN_SEEDS[1] - TRAIN_SEEDS[0]} maps "
                         "per family")
    check_output_place(args.out, "--out", need_bytes=NEED_BYTES)
    if args.export:
        check_output_place(args.export, "--export", folder=False)
        check_output_place(args.export.with_suffix(".json"), "--export (its .json)", folder=False)
    if args.resume and not (args.out / "checkpoint.pt").is_file():
        raise InputError(f"--resume: nothing to resume in {args.out} (no checkpoint.pt); start without --resume")


def main(argv=None) -> int:
    ap = _parser()
    args = ap.parse_args(argv)
    try:
        _check(args)
        with run_lock(args.out, "scripts/train_route.py " + " ".join(argv if argv is not None else sys.argv[1:])):
            return _train(args)
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        ckpt = args.out / "checkpoint.pt"
        kept = f"{ckpt} holds the last finished epoch; continue with --resume" if ckpt.is_file() else \
            "nothing was saved (no epoch finished)"
        print(f"\ninterrupted: {kept}", file=sys.stderr)
        return 130


def _train(args) -> int:
    torch.set_num_threads(1)
    t0 = time.perf_counter()
    problems = [generate(f, TRAIN_SEEDS[0] + s, size) for size in args.size for f in FAMILIES for s in range(args.maps)]
    args.out.mkdir(parents=True, exist_ok=True)
    ckpt = args.out / "checkpoint.pt"
    lines: list[str] = []

    def log(line: str) -> None:
        lines.append(line)
        print(line, flush=True)

    net = train_route_net(problems, block=args.step, channels=args.channels, depth=args.depth,
                          attention=args.attention, attention_level=args.attention_level, epochs=args.epochs,
                          augment=args.augment, seed=args.seed, log=log, checkpoint=ckpt, resume=args.resume)
    recipe = {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items() if k != "resume"}
    meta = json.dumps({"recipe": recipe, "parameters": sum(p.numel() for p in net.parameters()),
                       "last_epoch": lines[-1], "minutes": round((time.perf_counter() - t0) / 60, 1)}, indent=1) + "\n"
    with output_set(args.out) as folder:  # route.pt and route.json replace the old pair together
        save_route_net(net, folder / "route.pt")
        (folder / "route.json").write_text(meta, encoding="utf-8")
    if args.export:  # two files in a shared folder: each is written whole, the description first
        atomic_write_text(args.export.with_suffix(".json"), meta)
        atomic_write_bytes(args.export, (args.out / "route.pt").read_bytes())
    print(f"wrote {args.out / 'route.pt'} in {(time.perf_counter() - t0) / 60:.1f} min")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
