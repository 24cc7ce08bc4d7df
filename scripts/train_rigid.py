"""Train the 6-DoF orientation model that ``make_sampler("rigid_route")`` uses, on the rigid-body training scenes.

    python scripts/train_rigid.py                                   # the shipped model's recipe (about 7 CPU minutes)
    python scripts/train_rigid.py --export learning/data/rigid_route.pt
    python scripts/train_rigid.py --scenes-per-family 5 --epochs 2 --out runs/rigid-quick

Runs ``learning.training.rigid.train_rigid_orientation``: examples from training scenes only (seeds drawn
from ``TRAIN_SEEDS`` with ``--seed``; never a validation, tuning or test scene, nor a test-only family),
the observation at the workspace route's points and a solution's (found by the privileged expert's long runs),
the label the orientation class the solution takes there (``--label solution``, the default; ``window`` and
``point``: which classes keep the motion check's clearance along the witness path), each scene an episode of the
orientation environment ``SamplerGym/RigidOrientation-v1`` (``envs.RigidOrientationEnv``) whose teacher gives the
label. One torch thread: the same seed gives the same weights.

Writes ``<out>/rigid_route.pt`` (tensors and plain numbers, read with ``torch.load(weights_only=True)``)
and ``<out>/rigid_route.json`` (the recipe, the log, the time); ``--export PATH`` copies the weights to
``PATH`` and the JSON beside it. Exit status: 0 done, 2 bad input.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import torch

from learning.device import pin_cpu_arithmetic
from learning.models.rigid_orientation import save_orientation_net
from learning.training.rigid import LABELS, OPEN_TESTS, RigidTrainConfig, train_rigid_orientation
from planners.base.fileio import InputError, atomic_write_bytes, atomic_write_text, check_output_place
from planners.worlds.rigid_scenes import TRAINING_FAMILIES


def main(argv=None) -> int:
    d = RigidTrainConfig()
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes-per-family", type=int, default=d.scenes_per_family)
    ap.add_argument("--families", nargs="+", default=list(TRAINING_FAMILIES))
    ap.add_argument("--epochs", type=int, default=d.epochs)
    ap.add_argument("--batch", type=int, default=d.batch)
    ap.add_argument("--lr", type=float, default=d.lr)
    ap.add_argument("--half", type=int, default=d.half, help="half the observation patch's side, in voxels")
    ap.add_argument("--channels", type=int, default=d.channels)
    ap.add_argument("--hidden", type=int, default=d.hidden)
    ap.add_argument("--poses", type=int, default=d.poses, help="jittered poses per point and class for the label")
    ap.add_argument("--open-keep", type=float, default=d.open_keep,
                    help="share of the points where every class fits that are kept")
    ap.add_argument("--label", choices=LABELS, default=d.label,
                    help="the class a solution by long runs takes nearest the point (default), or the classes that "
                         "fit along the path's window, or at the point alone")
    ap.add_argument("--open-test", choices=OPEN_TESTS, default=d.open_test,
                    help="how --label solution tells open space: the one-hot label (every point kept) or the clearance "
                         "of jittered poses of each class (points where all six fit kept at --open-keep)")
    ap.add_argument("--window", type=float, default=d.window, help="half the window of --label window, world units")
    ap.add_argument("--no-augment", action="store_true", help="no symmetries of the grid")
    ap.add_argument("--seed", type=int, default=d.seed)
    ap.add_argument("--out", type=Path, default=Path("runs/rigid_route"))
    ap.add_argument("--export", type=Path, help="also copy the weights here (and the JSON beside them)")
    args = ap.parse_args(argv)
    arithmetic = pin_cpu_arithmetic()  # before any tensor operation (learning.device.CPU_ARITHMETIC)
    torch.set_num_threads(1)
    try:
        config = RigidTrainConfig(scenes_per_family=args.scenes_per_family, families=tuple(args.families),
                                  epochs=args.epochs, batch=args.batch, lr=args.lr, channels=args.channels,
                                  hidden=args.hidden, poses=args.poses, open_keep=args.open_keep,
                                  augment=not args.no_augment, seed=args.seed,
                                  label=args.label, window=args.window, open_test=args.open_test,
                                  half=args.half).check()
        # the output places before the training's minutes: a file where the folder goes, no write access
        check_output_place(args.out, "--out")
        if args.export is not None:
            check_output_place(args.export, "--export", folder=False)
    except InputError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    net, log = train_rigid_orientation(config, progress=lambda msg: print(msg, flush=True))
    args.out.mkdir(parents=True, exist_ok=True)
    weights = args.out / "rigid_route.pt"
    save_orientation_net(net, weights)
    meta = json.dumps({"recipe": config.as_dict(), "log": log, "minutes": round(log["seconds"] / 60, 1),
                       "device": "cpu", "torch_threads": 1, "cpu_arithmetic": arithmetic}, indent=1) + "\n"
    atomic_write_text(args.out / "rigid_route.json", meta)
    print(f"wrote {weights} ({weights.stat().st_size:,} bytes) and rigid_route.json; {log['seconds']} s")
    if args.export is not None:
        atomic_write_bytes(args.export, weights.read_bytes())  # a kill leaves the old file or the new, whole
        atomic_write_text(args.export.with_suffix(".json"), meta)
        print(f"exported to {args.export}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
