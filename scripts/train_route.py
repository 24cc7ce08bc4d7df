"""Train the route encoder (``learning.models.route_vin.RouteVIN``, or the U-Net ``RouteNet``) on the training maps.

    python scripts/train_route.py                           # the shipped teacher's recipe (about 7 min on 2 cores)
    python scripts/train_route.py --resume                  # continue an interrupted run from its last epoch
    python scripts/train_route.py --epochs 3 --maps 20      # a quicker variation
    python scripts/train_route.py --kind unet --channels 24 --attention 2 --maps 1600 --epochs 30 --batch 32 --lr 1e-3
                                                            # the earlier U-Net encoder's recipe (about an hour)
    python scripts/evaluate.py --route runs/route/route.pt  # the comparison with it as the route encoder
    python scripts/distill_route.py --teacher runs/route/route.pt   # a third of its pass (the shipped encoder's way)

With no options it trains the recipe of the shipped encoder's teacher (``learning/data/route_teacher.json``; the
shipped encoder is its 16-channel student, ``scripts/distill_route.py``): the value-iteration
encoder (``--kind vin``: learned move costs of 48 channels and 4 local layers over blocks of half a step,
``--blocks-per-step 2``, value iteration over them), 12 epochs over 100 maps per training family
(``--families``: the five test families' training generators, caves and strokes, which no test set holds) at
sides 64 and 128, each turned by one of the square's 8 symmetries, batches of 16, Adam from 2e-3 down to 0
along a cosine (``--lr-schedule``). Maps come from the training seeds only (validation, tuning and test seeds
are never seen). The encoder learns the grid search's cost-to-go of every cell (see
``learning.training.vin_losses``); ``RouteSampler`` follows its prediction.

Writes ``<out>/route.pt`` and ``<out>/route.json`` (recipe, loss, time) as one unit: the folder is
built beside ``<out>`` and swapped into place whole, so a kill leaves the old pair or the new pair.
While it trains, ``<out>/checkpoint.pt`` holds the state after the last finished epoch, and
``--resume`` continues from it to the same weights an uninterrupted run reaches. ``<out>`` is locked
while a run writes it (``.<out>.lock`` beside it): a second run on it exits 2 naming the first.
One torch thread, and torch, oneDNN and MKL held to the AVX2 instruction set (``learning.device.pin_cpu_arithmetic``,
recorded in route.json), so a machine with wider vector units (AVX-512) runs the arithmetic the shipped teacher was
trained with; the same seed on the same device gives the same weights. docs/report.md ("Training and
reproducibility") gives the spread over seeds.

Your own maps: ``--map-set DIR`` (a folder of maps, a manifest ``.json`` or a built-in set such as
``generated``; see docs/map-sets.md) trains on the training part of the set and keeps the epoch with
the lowest loss on its validation part; several ``--map-set`` flags mix sets, drawn by
``--map-set-weight`` (one per set, default equal). ``--maps`` queries are drawn from the training
parts, seeded by ``--seed``; route.json records each set's split rule and parts. One planner step is
``--step`` cells of every map (in world units, ``--step`` times the map's resolution), or give
``--step-size`` in world units: it must come to the same whole number of cells on every map.

    python scripts/train_route.py --map-set tests/data/ros --maps 200 --epochs 5 --out runs/ros

``--device auto|cpu|cuda`` (Stable-Baselines3's convention: ``auto`` takes a GPU when torch sees one)
says where the encoder trains; the targets (grid searches) are made on ``--workers`` CPU processes
while the first epoch trains, in the order it uses them, so the weights do not depend on the worker
count.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
import torch

from learning.device import DEVICES, pin_cpu_arithmetic, resolve_device
from learning.models.route_net import KINDS, make_route_net, save_route_set
from learning.training.route import (
    SCHEDULES,
    GeneratedProblem,
    check_route_map,
    default_workers,
    loss_rise,
    train_route_net,
)
from planners.base.fileio import (
    InputError,
    check_int_flags,
    check_output_place,
    run_lock,
)
from planners.maps.generators import TRAIN_SEEDS, TRAINING_FAMILIES, check_size
from planners.maps.mapset import MapSet, MixedMapSet

#: Free disk a run needs: the encoder and its checkpoint are a few MB each.
NEED_BYTES = 50 * 2**20
#: ``--mix-generated auto`` mixes the generated families in where the training parts hold fewer maps than this,
#: at this weight against 1 for each of the user's sets (docs/worked-example.md has the measurement behind it).
MIX_BELOW, MIX_WEIGHT = 20, 3.0


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--maps", type=int, default=100, help="training maps per family and size (default 100)")
    ap.add_argument("--size", type=int, nargs="+", default=[64, 128], help="map sides; --maps maps of each")
    ap.add_argument("--families", nargs="+", default=list(TRAINING_FAMILIES), metavar="FAMILY",
                    help=f"generated training families (default {' '.join(TRAINING_FAMILIES)}; caves and strokes "
                         "are in no test set)")
    ap.add_argument("--epochs", type=int, default=12)
    ap.add_argument("--batch", type=int, default=16, help="maps per batch (fewer where maps are large)")
    ap.add_argument("--lr", type=float, default=2e-3, help="Adam's learning rate (its peak, with --lr-schedule cosine)")
    ap.add_argument("--lr-schedule", choices=SCHEDULES, default="cosine",
                    help="cosine (default): from --lr down to 0 over the run's steps; or constant")
    ap.add_argument("--grad-clip", type=float, metavar="NORM",
                    help="cut the gradients' total norm to NORM before each step (default: never, as the shipped "
                         "recipe; docs/report.md gives the spread over seeds with and without)")
    ap.add_argument("--kind", choices=KINDS, default="vin",
                    help="the encoder: unet (a U-Net with axial attention) or vin (learned move costs and value "
                         "iteration over them; --depth is then its local layers, --attention 0)")
    ap.add_argument("--channels", type=int, default=48)
    ap.add_argument("--depth", type=int, default=4,
                    help="the VIN's local 3x3 layers, or the times the U-Net halves the block grid")
    ap.add_argument("--attention", type=int, default=0,
                    help="axial attention layers of the U-Net (a row then a column each; the shipped U-Net had 2)")
    ap.add_argument("--attention-level", type=int, default=0,
                    help="times the block grid is halved where the attention runs (0: full resolution)")
    ap.add_argument("--step", type=int, default=4, help="the planner's step in cells")
    ap.add_argument("--blocks-per-step", type=int,
                    help="blocks across one step: the value-iteration encoder's default is 2 (blocks of half a step), "
                         "the U-Net's 1 (it takes no other); --step must divide by it")
    ap.add_argument("--augment", action=argparse.BooleanOptionalAction, default=True,
                    help="turn each map by one of the square's 8 symmetries (default on)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--map-set", action="append", metavar="DIR_OR_SPEC",
                    help="train on this map set's training part, choose on its validation part (repeat to mix "
                         "sets); default the generated families at --size")
    ap.add_argument("--map-set-weight", type=float, action="append", metavar="W",
                    help="one weight per --map-set: how often a training query comes from it (default equal)")
    ap.add_argument("--mix-generated", choices=("auto", "yes", "no"), default="auto",
                    help="with --map-set: also draw training queries from the generated families (their training "
                         "seeds; their validation maps join the choice of epoch). auto (default): where your sets' "
                         f"training parts together hold fewer than {MIX_BELOW} maps; yes: always; no: never")
    ap.add_argument("--mix-weight", type=float, default=MIX_WEIGHT, metavar="W",
                    help=f"the generated families' weight against 1 for each of your sets (default {MIX_WEIGHT:g})")
    ap.add_argument("--split-seed", type=int, help="split seed of folder and manifest map sets (default theirs: 0)")
    ap.add_argument("--step-size", type=float, metavar="WORLD_UNITS",
                    help="with --map-set: the planner's step in world units; it sets --step to the cells it "
                         "comes to on every map (one number for all of them)")
    ap.add_argument("--device", default="auto", metavar="|".join(DEVICES),
                    help="where the encoder trains (default auto: CUDA when torch sees it, else the CPU)")
    ap.add_argument("--workers", type=int, default=default_workers(),
                    help="CPU processes that make the training targets (default min(cores, 8))")
    ap.add_argument("--out", type=Path, default=Path("runs/route"))
    ap.add_argument("--resume", action="store_true", help="continue the run in --out from its last finished epoch")
    ap.add_argument("--export", type=Path, help="also copy the encoder here (and its .json beside it)")
    return ap


def _check(args) -> None:
    """Every argument and output place, before any map is generated (``InputError`` naming the flag).

    Opens the map sets (each checks its maps and queries) into ``args.sets``, sets ``args.step`` from
    ``--step-size`` and resolves ``--device`` into ``args.torch_device``.
    """
    if args.blocks_per_step is None:
        args.blocks_per_step = 2 if args.kind == "vin" else 1
    check_int_flags(args, ("maps", "epochs", "batch", "channels", "depth", "step", "blocks_per_step", "workers"))
    if not (math.isfinite(args.lr) and args.lr > 0):
        raise InputError(f"--lr {args.lr:g}: expected a positive number")
    if args.grad_clip is not None and not (math.isfinite(args.grad_clip) and args.grad_clip > 0):
        raise InputError(f"--grad-clip {args.grad_clip:g}: expected a positive finite norm")
    check_int_flags(args, ("attention", "attention_level", "seed"), low=0)
    args.torch_device = resolve_device(args.device)
    args.mixed_generated = False
    for flag, value in (("--map-set-weight", args.map_set_weight), ("--split-seed", args.split_seed),
                        ("--step-size", args.step_size)):
        if value is not None and not args.map_set:
            shown = " ".join(f"{v:g}" for v in value) if isinstance(value, list) else f"{value:g}"
            raise InputError(f"{flag} {shown}: it applies to --map-set, and none is given")
    args.sets = _open_sets(args) if args.map_set else None
    args.block = _block(args)
    try:  # the encoder's own rules
        make_route_net(args.kind, args.block, args.channels, args.depth, args.attention, args.attention_level,
                       step=args.step)
    except ValueError as exc:
        raise InputError(f"--kind / --channels / --depth / --attention / --attention-level / --blocks-per-step: "
                         f"{exc}") from None
    for family in args.families:
        if family not in TRAINING_FAMILIES:
            raise InputError(f"--families {family}: expected some of {', '.join(TRAINING_FAMILIES)}")
    for size in args.size:
        check_size(size, "--size")
        if args.sets is None:
            try:
                check_route_map(f"generated {size} x {size}", (size, size), args.block)
            except InputError as exc:
                raise InputError(f"--size {size}: {exc}") from None
    if args.sets is None and args.maps > TRAIN_SEEDS[1] - TRAIN_SEEDS[0]:
        raise InputError(f"--maps {args.maps}: the training split holds {TRAIN_SEEDS[1] - TRAIN_SEEDS[0]} maps "
                         "per family")
    check_output_place(args.out, "--out", need_bytes=NEED_BYTES)
    if args.export:
        check_output_place(args.export, "--export", folder=False)
        check_output_place(args.export.with_suffix(".json"), "--export (its .json)", folder=False)
    if args.resume and not (args.out / "checkpoint.pt").is_file():
        raise InputError(f"--resume: nothing to resume in {args.out} (no checkpoint.pt); start without --resume")


def _block(args) -> int:
    """The encoder's block in cells: ``--step`` over ``--blocks-per-step``; an ``InputError`` if it does not divide."""
    if args.step % args.blocks_per_step:
        raise InputError(f"--blocks-per-step {args.blocks_per_step}: a step of {args.step} cells does not divide into "
                         f"{args.blocks_per_step} whole blocks (--blocks-per-step 1 takes blocks of one step)")
    return args.step // args.blocks_per_step


def _open_sets(args) -> MixedMapSet:
    """The ``--map-set`` sets, mixed by ``--map-set-weight``, checked for the encoder (``InputError`` naming flags).

    Each set needs a training and a validation part; every map of those parts must fit the
    encoder's size limit in blocks of ``--step`` (set here from ``--step-size`` when given) over
    ``--blocks-per-step`` cells.
    """
    weights = args.map_set_weight
    if weights is not None and len(weights) != len(args.map_set):
        raise InputError(f"--map-set-weight: {len(weights)} weights {weights} for {len(args.map_set)} --map-set; "
                         "give one weight per map set, in the same order")
    if not math.isfinite(args.mix_weight) or args.mix_weight <= 0:
        raise InputError(f"--mix-weight {args.mix_weight:g}: expected a positive number")
    for w in weights or ():
        if not math.isfinite(w) or w <= 0:
            raise InputError(f"--map-set-weight {w:g}: expected a positive number")
    if args.step_size is not None and not (math.isfinite(args.step_size) and args.step_size > 0):
        raise InputError(f"--step-size {args.step_size:g}: expected a positive number of world units")
    if args.split_seed is not None and args.split_seed < 0:
        raise InputError(f"--split-seed {args.split_seed}: expected a non-negative integer")
    sets = []
    for spec in args.map_set:
        options = {} if args.split_seed is None else {"split_seed": args.split_seed}
        try:
            ms = MapSet.open(spec, **options)
        except TypeError:  # a built-in set splits by its own rule
            raise InputError(f"--split-seed: map set {spec!r} splits by its own rule; give --split-seed only "
                             "with folders and manifests") from None
        except InputError as exc:
            raise InputError(f"--map-set {spec}: {exc}") from None
        try:
            ms.validate(["train", "validation"])
        except InputError as exc:
            raise InputError(f"--map-set {spec}: {exc}") from None
        sets.append(ms)
    args.mixed_generated = _mix_generated(args, sets)
    if args.mixed_generated:
        weights = [*(weights or [1.0] * (len(sets) - 1)), args.mix_weight]
    grids = [(ms, name, shape, resolution) for ms in sets for name, shape, resolution in _training_grids(ms)]
    if args.step_size is not None:
        cells = {}
        for ms, name, _, resolution in grids:
            if args.mixed_generated and ms is sets[-1]:
                continue  # the generated maps mixed in are in cells: they take the step your maps come to
            c = args.step_size / resolution
            if abs(c - round(c)) > 1e-6 * max(1.0, c) or round(c) < 1:
                raise InputError(f"--step-size {args.step_size:g}: map {name!r} of {ms.name} has cells of "
                                 f"{resolution:g} world units, so a step is {c:g} cells; a step must be "
                                 "a whole number of cells")
            cells[name] = round(c)
        if len(set(cells.values())) > 1:
            raise InputError(f"--step-size {args.step_size:g} comes to different cell counts on the maps "
                             f"({', '.join(f'{n}: {c}' for n, c in sorted(cells.items()))}); the encoder's step is "
                             "one number of cells: give maps of one resolution, or --step in cells")
        args.step = next(iter(cells.values()))
    block = _block(args)
    for ms, name, shape, _ in grids:
        try:
            check_route_map(name, shape, block)
        except InputError as exc:
            raise InputError(f"--map-set {ms.name}: {exc}") from None
    return MixedMapSet(sets, weights)


def _mix_generated(args, sets: list) -> bool:
    """Whether to mix the generated families in (``--mix-generated``); if so, their set is appended to ``sets``."""
    if args.mix_generated == "no" or any(ms.name == "generated" for ms in sets):
        return False
    held = sum(len(ms.maps("train")) for ms in sets)
    if args.mix_generated == "auto" and held >= MIX_BELOW:
        return False
    sets.append(MapSet.open("generated"))
    print(f"mixing in the generated families (weight {args.mix_weight:g} against 1 for each of your sets): "
          + (f"your training parts hold {held} map{'s' * (held != 1)}, fewer than {MIX_BELOW}; "
             if args.mix_generated == "auto" else "")
          + "--mix-generated no trains on yours alone", flush=True)
    return True


def _training_grids(ms: MapSet) -> list[tuple[str, tuple[int, int], float]]:
    """(name, shape in cells, resolution) of every map in ``ms``'s training and validation parts."""
    rec = ms.record()
    if rec.get("kind") == "generated":
        sides = sorted({*rec["train_sizes"], *rec["validation_sizes"]})
        return [(f"generated {s} x {s}", (s, s), 1.0) for s in sides]
    if rec.get("kind") != "files":
        return []  # built-in test-only sets have no training part: validate refused them
    used = {*ms.maps("train"), *ms.maps("validation")}
    return [(name, tuple(m["shape"]), float(m["resolution"])) for name, m in rec["maps"].items() if name in used]


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
    arithmetic = pin_cpu_arithmetic()  # before any tensor operation: the same weights on any x86 CPU with AVX2
    torch.set_num_threads(1)
    t0 = time.perf_counter()
    extra, validation, sets = {}, None, args.sets
    if sets is None:  # the generated families: each map made on a worker
        problems = [GeneratedProblem(f, TRAIN_SEEDS[0] + s, size)
                    for size in args.size for f in args.families for s in range(args.maps)]
    else:
        print(sets.describe(), flush=True)
        rng = np.random.default_rng(args.seed)
        problems = [sets.sample("train", rng) for _ in range(args.maps)]
        validation = [p for ms in sets.sets for p in ms.problems("validation")]
        extra = {"map_sets": sets.record()}
    args.out.mkdir(parents=True, exist_ok=True)
    ckpt = args.out / "checkpoint.pt"
    lines: list[str] = []

    def log(line: str) -> None:
        lines.append(line)
        print(line, flush=True)

    net = train_route_net(problems, block=args.block, step=args.step, channels=args.channels, depth=args.depth,
                          attention=args.attention, attention_level=args.attention_level, epochs=args.epochs,
                          batch=args.batch, lr=args.lr,
                          augment=args.augment, seed=args.seed, log=log, checkpoint=ckpt, resume=args.resume,
                          validation=validation, recipe_extra=extra, workers=args.workers, device=args.torch_device,
                          kind=args.kind, schedule=args.lr_schedule, grad_clip=args.grad_clip)
    skip = {"resume", "sets", "torch_device", "block"}
    recipe = {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items() if k not in skip}
    info = {"recipe": recipe, "parameters": sum(p.numel() for p in net.parameters()),
            "last_epoch": next(line for line in reversed(lines) if line.startswith("epoch")),
            "minutes": round((time.perf_counter() - t0) / 60, 1), "device": str(args.torch_device),
            "cpu_arithmetic": arithmetic}
    rise = loss_rise(lines)
    info["loss_rose"] = None if rise is None else {"lowest_epoch": rise[0], "lowest": rise[1], "last": rise[2]}
    if sets is not None:
        recipe["size"] = None  # the maps bring their sizes
        info["chosen_epoch"] = net.chosen_epoch
        info["chosen"] = lines[-1]
        info["step"] = {"cells": args.step, "world_units": {
            name: args.step * m["resolution"] for ms in sets.sets if ms.record().get("kind") == "files"
            for name, m in ms.record()["maps"].items()}}
        info["map_sets"] = extra["map_sets"]
    save_route_set(net, info, args.out, args.export)  # route.pt and route.json replace the old pair together
    print(f"wrote {args.out / 'route.pt'} in {(time.perf_counter() - t0) / 60:.1f} min")
    if rise is not None:
        print(f"warning: the training loss rose from {rise[1]:.3f} at epoch {rise[0]} to {rise[2]:.3f}: this run "
              f"diverged. Seeds of the shipped recipe spread (docs/report.md, training and reproducibility); compare "
              f"this encoder with the shipped one (evaluate.py --route NAME=FILE) or train with another --seed",
              file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
