"""Train a guided sampler policy: DAgger imitation of the privileged expert, then PPO fine-tuning.

    python scripts/train.py                                   # the shipped checkpoint's recipe (6.7 min on 2 cores)
    python scripts/train.py --name mine --ppo-steps 100000    # variations
    python scripts/train.py --resume                          # continue an interrupted run
    python scripts/train.py --backend ray --address auto      # rollouts and validation on your Ray cluster
    python scripts/train.py --map-set my_maps --step-size 0.2 # your maps (docs/map-sets.md)
    tensorboard --logdir runs/                                # curves

Writes runs/<name>/{config.json, checkpoint.zip, imitation.zip, final.zip, state.json, tb/}; the run folder
is locked while a run writes it (runs/.<name>.lock: a second run on the same name exits 2 naming the
first; the lock of a run that was killed is taken over). A crash,
Ctrl-C or a kill leaves the last checkpoint (after each DAgger round and every --checkpoint-every PPO
steps) whole, and --resume continues from it to the same weights an uninterrupted run reaches.
--resume reads your own run's checkpoint with Stable-Baselines3's full loader, which unpickles: never
resume from a run someone else sent you (load their policy with learning.PolicySampler.load, which
reads JSON and tensors only). --export copies final.zip to a path of your choice (e.g.
learning/data/guided.zip, with its config beside it as JSON).

--map-set DIR_OR_SPEC (repeatable, mixed by --map-set-weight, one weight per set) trains on the
training parts of map sets (docs/map-sets.md) instead of the generated families: each DAgger round
draws --maps-per-round queries from them, PPO's episodes come from them, and the validation runs use
the first --validation-maps queries of each set's validation part. --step-size is then in the maps'
world units (it must span at least one cell of every map), and each map's goal tolerance is its
set's (--goal-tolerance applies to the generated families); runs/<name>/map_sets.json records the
sets' split rule and parts. --device auto|cpu|cuda (Stable-Baselines3's convention; default auto:
CUDA when torch sees it) says where the networks train; rollouts and validation stay on the CPU.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

from learning.device import DEVICES, pin_cpu_arithmetic, resolve_device
from learning.evaluation import worker_init
from learning.training.policy import TrainConfig, open_map_sets, read_state, train
from planners.base.fileio import InputError, atomic_write_bytes, atomic_write_text, check_output_place
from planners.tools.parallel import add_backend_arguments, check_backend_arguments, make_backend

#: Free disk a run needs: checkpoints of a few MB, DAgger data of tens of MB, TensorBoard events.
NEED_BYTES = 200 * 2**20


def _where(state: dict, cfg: TrainConfig) -> str:
    if state["phase"] == "bc":
        return f"DAgger round {state['round'] + 1} of {cfg.dagger_rounds}"
    return f"PPO step {state['ppo_steps']} of {cfg.ppo_steps}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--config", type=Path, help="JSON file of TrainConfig fields (flags override it)")
    ap.add_argument("--out", type=Path, default=Path("runs"))
    ap.add_argument("--resume", action="store_true")
    ap.add_argument("--export", type=Path, help="copy final.zip here (and its config as .json beside it)")
    ap.add_argument("--no-progress", action="store_true")
    ap.add_argument("--device", default="auto", metavar="|".join(DEVICES),
                    help="where the networks train (default auto: CUDA when torch sees it, else the CPU)")
    add_backend_arguments(ap, processes=1, processes_help="workers for them (1: this process)",
                          backend_help="where DAgger's rollouts and the validation runs execute (the weights do not "
                                       "depend on it)")
    for f in dataclasses.fields(TrainConfig):
        if f.name == "extra":
            continue
        flag = "--" + f.name.replace("_", "-")
        if f.name in ("map_set", "map_set_weight"):  # repeatable: one set (and weight) a flag
            ap.add_argument(flag, action="append", type=float if f.name == "map_set_weight" else str,
                            help="a map set to train on (repeat to mix)" if f.name == "map_set" else
                            "one weight per --map-set (default equal)")
        elif f.type in ("tuple[str, ...]", "tuple[int, ...]", "tuple[float, ...]"):
            ap.add_argument(flag, nargs="+",
                            help=f"default {f.default!r}" if f.default is not dataclasses.MISSING else None)
        elif f.type == "bool":
            ap.add_argument(flag, action=argparse.BooleanOptionalAction, default=None, help=f"default {f.default!r}")
        else:
            typ = {"int": int, "float": float, "str": str}[f.type]
            ap.add_argument(flag, type=typ, help=f"default {f.default!r}")
    args = ap.parse_args(argv)
    check_backend_arguments(ap, args)
    arithmetic = pin_cpu_arithmetic()  # before any tensor operation, and inherited by the rollout workers
    try:
        cfg = TrainConfig.from_json(args.config) if args.config else TrainConfig()
        changes = {}
        for f in dataclasses.fields(TrainConfig):
            v = getattr(args, f.name, None)
            if v is not None and f.name in ("map_set", "map_set_weight"):
                changes[f.name] = tuple(v)
            elif v is not None and f.name != "extra":
                changes[f.name] = tuple(type(getattr(cfg, f.name)[0])(x) for x in v) if isinstance(v, list) else v
        cfg = dataclasses.replace(cfg, **changes)
        cfg.check("command line" if not args.config else f"{args.config} with the command line's flags")
        device = resolve_device(args.device)
        sets = open_map_sets(cfg)
        if sets is not None:
            print(sets.describe(), flush=True)
        check_output_place(args.out / cfg.name, "--out", need_bytes=NEED_BYTES)
        if args.export:
            check_output_place(args.export, "--export", folder=False)
            check_output_place(args.export.with_suffix(".json"), "--export (its .json)", folder=False)
    except (InputError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    run = args.out / cfg.name
    t0 = time.perf_counter()
    try:
        backend = make_backend(args.backend, processes=args.processes, address=args.address, worker_init=worker_init)
    except ImportError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    try:
        final = train(cfg, args.out, resume=args.resume, progress=not args.no_progress, log_stdout=False,
                      backend=backend, device=device)
    except KeyboardInterrupt:
        try:
            state = read_state(run)
        except InputError:
            state = None
        if state is None:
            print("\ninterrupted before the first checkpoint: nothing was saved; run the command again "
                  "(without --resume)", file=sys.stderr)
        else:
            print(f"\ninterrupted: {run / 'checkpoint.zip'} holds the run up to {_where(state, cfg)}; "
                  "continue with --resume", file=sys.stderr)
        return 130
    except (InputError, FileNotFoundError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    finally:
        backend.close()
    minutes = (time.perf_counter() - t0) / 60
    summary = json.loads((final.parent / "summary.json").read_text())
    print(f"trained in {minutes:.1f} min; kept the {summary['chosen']} policy "
          f"(validation score {min(summary['validation_ppo'], summary['validation_imitation']):.2f}): {final}")
    if args.export:
        atomic_write_bytes(args.export, final.read_bytes())
        meta = {"config": dataclasses.asdict(cfg), "summary": summary, "minutes": round(minutes, 1),
                "cpu_arithmetic": arithmetic}
        atomic_write_text(args.export.with_suffix(".json"), json.dumps(meta, indent=2) + "\n")
        print(f"exported to {args.export}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
