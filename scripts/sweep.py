"""Search the training recipe, or the baselines' parameters, on Ray Tune; pick on validation maps only.

    python scripts/sweep.py recipe --samples 100            # random search over learning.training.sweep.RECIPE_SPACE
    python scripts/sweep.py recipe --quick                   # the same code on a tiny recipe: 20 trials, 2.2 min
    python scripts/sweep.py baselines                        # goal bias and the ablation's p, every setting (67 s)
    python scripts/sweep.py recipe --samples 100 --resume    # continue an interrupted sweep
    python scripts/sweep.py recipe --address auto            # on your Ray cluster
    tensorboard --logdir results/sweeps                      # every trial's config and validation score

Times on a quiet 2-core machine: a recipe trial is a whole training run of the recipe it draws (the default
recipe alone takes about 7 minutes with scripts/train.py), so --samples 20 (the default) runs for hours there and
is meant for a cluster; --quick 2.2 minutes; baselines 67 s.

Needs the distributed extra: pip install -c constraints.txt -e ".[distributed]". Writes Tune's
experiment to <out>/<name>/ and the chosen trial to <out>/<name>.chosen.json (for a recipe sweep, the
whole recipe: pass it to scripts/train.py --config after removing the non-recipe keys, or read it).
The sweep folder is locked while a sweep runs (<out>/.<name>.lock): a second one exits 2 naming the first.

WARNING: --resume runs code from the sweep folder. Ray Tune keeps its state pickled (tuner.pkl and the
trials' state) and resuming unpickles it. Resume only sweeps you started yourself: a folder without
the samplergym-sweep.json this script writes when it starts a sweep is refused, but that file is a
guard against mistakes, not a signature. Never resume a folder someone sent you; read its JSON results.

Ctrl-C or SIGTERM stops the sweep and its workers (Ray is shut down), prints what was kept and
exits 130 (Ctrl-C) or 143 (SIGTERM); finished trials stay in the folder for --resume.
"""

from __future__ import annotations

import argparse
import json
import re
import signal
import sys
import time
from pathlib import Path

from learning.training.policy import TrainConfig
from planners.base.fileio import InputError, check_output_place

#: --quick: a tiny recipe (one family, 64x64, two DAgger rounds, a short PPO) and two validation maps per
#: family, so a whole sweep runs in about a minute; the same code as a full sweep.
QUICK_BASE = dict(name="quick", families=("forest",), sizes=(64,), dagger_rounds=2, maps_per_round=16, bc_epochs=4,
                  ppo_steps=1024, value_warmup=512, ppo_n_steps=256, ppo_batch=128, ppo_epochs=2,
                  validation_maps=2, checkpoint_every=10**9, max_iterations=1500)
QUICK_SPACE = {"bc_lr": [3e-4, 1e-3, 3e-3], "uniform_floor": [0.02, 0.05, 0.1]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("kind", choices=("recipe", "baselines"))
    ap.add_argument("--samples", type=int, default=20, help="recipe trials (random search)")
    ap.add_argument("--seed", type=int, default=0, help="seeds the recipe search's draws")
    ap.add_argument("--config", type=Path, help="JSON file of TrainConfig fields: the recipe the search varies")
    ap.add_argument("--name", default=None, help="the sweep's folder under --out (default <kind>-sweep)")
    ap.add_argument("--out", type=Path, default=Path("results/sweeps"))
    ap.add_argument("--resume", action="store_true",
                    help="continue the sweep stored under --out/--name; this unpickles Ray Tune's state from that "
                         "folder, which can run code: resume only sweeps you started yourself")
    ap.add_argument("--address", default=None, help="a Ray cluster to join (default: start a local one)")
    ap.add_argument("--processes", type=int, default=None, help="CPUs of the local Ray instance")
    ap.add_argument("--quick", action="store_true", help="a tiny recipe and space: the whole sweep in about a minute")
    args = ap.parse_args(argv)
    name = args.name or f"{args.kind}-sweep"
    try:
        if args.samples < 1:
            raise InputError(f"--samples must be at least 1, got {args.samples}")
        if args.seed < 0:
            raise InputError(f"--seed must be 0 or more, got {args.seed}")
        if args.processes is not None and args.processes < 1:
            raise InputError(f"--processes must be at least 1, got {args.processes}")
        if not re.fullmatch(r"[A-Za-z0-9_][A-Za-z0-9_.-]*", name):
            raise InputError(f"--name {name!r}: expected letters, digits, '_', '-' or '.' (it names a folder)")
        base = TrainConfig.from_json(args.config) if args.config else TrainConfig(**QUICK_BASE) if args.quick \
            else TrainConfig()
        check_output_place(args.out / name, "--out")
        check_output_place(args.out / f"{name}.chosen.json", "--out (its .chosen.json)", folder=False)
        from learning.training.sweep import check_resumable

        if args.resume:
            check_resumable(args.out.resolve() / name, args.kind)
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    from learning.training.sweep import SweepInterrupted, run_sweep

    signals = {"SIGINT": 130, "SIGTERM": 143}
    received: list[str] = []

    def stop(signum, frame):  # SIGTERM: unwind like Ctrl-C, so Ray is shut down and its workers stop
        received.append(signal.Signals(signum).name)
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, stop)
    t0 = time.perf_counter()
    try:
        chosen = run_sweep(args.kind, args.out, name=args.name, samples=args.samples, seed=args.seed, base=base,
                           space=QUICK_SPACE if args.quick else None, resume=args.resume, address=args.address,
                           processes=args.processes)
    except (InputError, ImportError) as exc:  # ImportError: Ray is not installed (the distributed extra)
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        kept = f"{exc.finished} of {exc.total} trials finished and are kept" if isinstance(exc, SweepInterrupted) \
            else "the trials that finished are kept"
        print(f"\ninterrupted: {kept} in {args.out / name}; continue with --resume", file=sys.stderr)
        return signals[received[0]] if received else 130
    finally:
        signal.signal(signal.SIGTERM, previous)
    print(f"{chosen['trials']} trials in {(time.perf_counter() - t0) / 60:.1f} min; chosen on {chosen['picked_on']}: "
          f"{json.dumps(chosen['config'])} (validation score {chosen['score']:.3g}); "
          f"{args.out / (name + '.chosen.json')}; TensorBoard: tensorboard --logdir {args.out / name}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
