"""Train PPO with Stable-Baselines3's defaults on a SamplerGym family id, then compare it with tuned goal bias.

    python scripts/sb3_defaults.py --family forest --steps 10000 --train-seeds 0 1 2 --out runs/sb3   # 85 s
    python scripts/sb3_defaults.py --rigid --steps 1500000 --train-seeds 0 --seeds 2 --out runs/sb3-rigid

Trains one model per seed (``learning.sb3_defaults.train_default_ppo``; skipped when its .zip exists),
tunes goal bias on the tuning maps and prints a table on held-out test maps (``compare``).
``--tune-batch`` instead measures SB3Sampler's decision batch on the tuning maps (``tune_batch``).
``--rigid`` trains on ``SamplerGym/RRT-RigidScenes-v1`` instead (the 6-DoF body on the generated training scenes,
``"MlpPolicy"`` on its vector observations: ``train_ppo_on``) and runs each model in the 6-DoF comparison
(``learning.evaluation.rigid.evaluate_rigid``: the seed project's RRT and RRT-Connect) beside uniform sampling, goal
bias, ``rigid_route_ablation`` and ``rigid_route`` on ``--part`` (``--scenes`` a family, ``--seeds`` planner seeds).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from learning.sb3_defaults import (
    BATCH_GRID,
    RIGID_ID,
    choose_batch,
    compare,
    train_default_ppo,
    train_ppo_on,
    tune_batch,
)
from planners.base.fileio import InputError, check_flags, check_int_flags, check_output_place
from planners.maps.generators import FAMILIES


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--family", default="forest")
    ap.add_argument("--steps", type=int, default=10_000, help="PPO steps per training seed")
    ap.add_argument("--train-seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--out", default="runs/sb3_defaults", help="folder for the models")
    ap.add_argument("--n-test", type=int, default=20, help="held-out test maps")
    ap.add_argument("--n-tune", type=int, default=20, help="tuning maps for goal bias")
    ap.add_argument("--seeds", type=int, default=3, help="planner seeds per map")
    ap.add_argument("--train-only", action="store_true")
    ap.add_argument("--rigid", action="store_true", help=f"train on {RIGID_ID} and compare in the 6-DoF comparison")
    ap.add_argument("--part", choices=("validation", "test"), default="validation",
                    help="--rigid: the scene set's part to compare on (test: the test-only families too)")
    ap.add_argument("--scenes", type=int, default=2, help="--rigid: scenes per family")
    ap.add_argument("--tune-batch", action="store_true",
                    help="instead of the test comparison: SB3Sampler's batch per model on the tuning maps")
    ap.add_argument("--batch", type=int, default=None, help="SB3Sampler's batch (default: its own)")
    ap.add_argument("--deterministic", action="store_true", help="SB3Sampler takes the policy's most likely class")
    a = ap.parse_args(argv)

    def check() -> None:
        check_int_flags(a, ("steps", "n_test", "n_tune", "seeds", "scenes"))
        if not a.rigid and a.family not in FAMILIES:
            raise InputError(f"--family: {a.family!r} is not a generated family; choose from {', '.join(FAMILIES)}")
        if a.batch is not None:
            check_int_flags(a, ("batch",))
        check_output_place(a.out, "--out")  # before any training

    check_flags(check)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for seed in a.train_seeds:
        path = out / f"{'rigid-scenes' if a.rigid else a.family}-{a.steps}-seed{seed}.zip"
        if not path.exists():
            if a.rigid:
                train_ppo_on(RIGID_ID, a.steps, seed, path)
            else:
                train_default_ppo(a.family, a.steps, seed, path)
            print(f"trained {path}", flush=True)
        paths.append(path)
    if a.train_only:
        return
    if a.rigid:
        from learning.evaluation.rigid import evaluate_rigid, format_table, summarize
        from planners.worlds.rigid_scenes import TEST_ONLY_FAMILIES, TRAINING_FAMILIES, RigidSceneSet

        scenes = RigidSceneSet(TRAINING_FAMILIES, TEST_ONLY_FAMILIES if a.part == "test" else (), {a.part: a.scenes})
        users = {f"PPO seed {seed}": f"{path}@{RIGID_ID}" for seed, path in zip(a.train_seeds, paths, strict=True)}
        rows = evaluate_rigid(scenes, a.part, planners=("RRT", "RRTConnect"), seeds=range(a.seeds),
                              samplers=("uniform", "goal_bias", "rigid_route_ablation", "rigid_route"),
                              user_samplers=users)
        print(format_table(summarize(rows)))
        return
    if a.tune_batch:
        per_model = [tune_batch(a.family, p, BATCH_GRID, a.n_tune, a.seeds) for p in paths]
        for p, res in zip(paths, per_model, strict=True):
            print(p.name, "batch -> (median iterations, median ms per run) on the tuning maps:", res)
        print("chosen batch:", choose_batch(per_model))
        return
    rows = compare(a.family, paths, n_test=a.n_test, n_tune=a.n_tune, seeds=a.seeds, batch=a.batch,
                   deterministic=True if a.deterministic else None)
    print("| sampler | median iterations | mean | success | median ms per run | queries won vs tuned goal bias |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['sampler']} | {r['median']:g} | {r['mean']:.1f} | {r['success']:.0%} | {r['ms_per_run']:.1f} | "
              f"{r.get('wins', '')} |")


if __name__ == "__main__":
    main()
