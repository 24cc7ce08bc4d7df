"""Train the route encoder (``learning.route.RouteNet``) on the generated training maps.

    python scripts/train_route.py                                          # the README's recipe (about 5 min)
    python scripts/evaluate.py --sampler route=learning.route:trained_sampler   # compare it

Maps come from the training seeds only (validation, tuning and test seeds are never seen). The
encoder learns the grid search's cost-to-go of every cell; ``RouteSampler`` follows its prediction.
Writes ``runs/route/route.pt`` and ``runs/route/route.json`` (recipe, loss, time); a file is written
whole or not at all. One torch thread: the same seed on the same machine gives the same weights.
"""

from __future__ import annotations

import argparse
import json
import shutil
import time
from pathlib import Path

import torch

from learning.route import RouteNet, save_route_net
from learning.route_training import check_speckle, train_route_net
from planners.base.fileio import InputError, atomic_write_text, check_int_flags
from planners.maps.generators import FAMILIES, MIN_SIZE, TRAIN_SEEDS, generate


def main(argv=None) -> Path:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--maps", type=int, default=400, help="training maps per family")
    ap.add_argument("--size", type=int, nargs="+", default=[128], help="map sides; --maps maps of each")
    ap.add_argument("--epochs", type=int, default=40)
    ap.add_argument("--channels", type=int, default=24)
    ap.add_argument("--depth", type=int, default=4, help="times the encoder halves the block grid")
    ap.add_argument("--attention", type=int, default=0,
                    help="axial attention layers (a row then a column each)")
    ap.add_argument("--attention-level", type=int, default=0,
                    help="times the block grid is halved where the attention runs (0: full resolution)")
    ap.add_argument("--step", type=int, default=4, help="the planner's step in cells: the encoder's block")
    ap.add_argument("--grad-weight", type=float, default=0.0, help="weight of the slope error in the loss")
    ap.add_argument("--augment", action="store_true", help="turn each map by one of the square's 8 symmetries")
    ap.add_argument("--thicken", type=int, default=0, metavar="R",
                    help="grow each map's obstacles by 0 to R cells (drawn per map): thicker walls, narrower gaps")
    ap.add_argument("--speckle", type=float, default=0.0, metavar="P",
                    help="block single cells of each map at a density drawn from [0, P) per map")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("runs/route"))
    ap.add_argument("--export", type=Path, help="also copy the encoder (and its .json) here")
    args = ap.parse_args(argv)
    try:
        check_int_flags(args, ("maps", "epochs", "channels", "depth", "step"))
        check_int_flags(args, ("attention", "attention_level"), low=0)
        try:  # the encoder's own rules, checked before any map is generated
            RouteNet(args.step, args.channels, args.depth, args.attention, args.attention_level)
        except ValueError as exc:
            raise InputError(f"--channels / --depth / --attention / --attention-level: {exc}") from None
        for size in args.size:
            if size < MIN_SIZE:
                raise InputError(f"--size must be at least {MIN_SIZE} (the smallest generated map), got {size}")
        if args.thicken < 0:
            raise InputError(f"--thicken must be 0 or more (cells), got {args.thicken}")
        try:
            check_speckle(args.speckle)
        except ValueError as exc:
            raise InputError(f"--speckle: {exc}") from None
        if args.seed < 0:
            raise InputError(f"--seed must be 0 or more, got {args.seed}")
        if not args.grad_weight >= 0:
            raise InputError(f"--grad-weight must be 0 or more, got {args.grad_weight}")
    except InputError as exc:
        ap.error(str(exc))
    if args.maps > TRAIN_SEEDS[1] - TRAIN_SEEDS[0]:
        ap.error(f"--maps {args.maps}: the training split holds {TRAIN_SEEDS[1] - TRAIN_SEEDS[0]} maps per family")
    torch.set_num_threads(1)
    t0 = time.perf_counter()
    problems = [generate(f, TRAIN_SEEDS[0] + s, size) for size in args.size for f in FAMILIES for s in range(args.maps)]
    losses: list[str] = []

    def log(line: str) -> None:
        losses.append(line)
        print(line, flush=True)

    net = train_route_net(problems, block=args.step, channels=args.channels, depth=args.depth,
                          attention=args.attention, attention_level=args.attention_level, epochs=args.epochs,
                          grad_weight=args.grad_weight, augment=args.augment, thicken_radius=args.thicken,
                          speckle=args.speckle, seed=args.seed, log=log)
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "route.pt"
    save_route_net(net, path)
    recipe = {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items()}
    atomic_write_text(args.out / "route.json", json.dumps(
        {"recipe": recipe, "parameters": sum(p.numel() for p in net.parameters()), "last_epoch": losses[-1],
         "minutes": round((time.perf_counter() - t0) / 60, 1)}, indent=1) + "\n")
    if args.export:
        tmp = args.export.with_name(args.export.name + ".tmp")
        shutil.copyfile(path, tmp)
        tmp.replace(args.export)
        shutil.copyfile(args.out / "route.json", args.export.with_suffix(".json"))
    print(f"wrote {path} in {(time.perf_counter() - t0) / 60:.1f} min")
    return path


if __name__ == "__main__":
    main()
