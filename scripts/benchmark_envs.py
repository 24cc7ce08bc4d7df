"""Environment throughput: steps per second for every registered id, random actions, one process.

    python scripts/benchmark_envs.py [--steps 20000] [--modes point,relative]     # every id and mode: 3.8 min
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

import envs
from planners.base.fileio import InputError, check_flags, check_int_flags
from planners.tools.benchmark import markdown_table

gym.register_envs(envs)


def steps_per_second(env: gym.Env, steps: int, seed: int = 0) -> tuple[float, int]:
    env.reset(seed=seed)
    env.action_space.seed(seed)
    actions = [env.action_space.sample() for _ in range(1000)]
    episodes = 0
    t = time.perf_counter()
    for i in range(steps):
        _, _, term, trunc, _ = env.step(actions[i % 1000])
        if term or trunc:
            env.reset()
            episodes += 1
    return steps / (time.perf_counter() - t), episodes


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--steps", type=int, default=20000)
    ap.add_argument("--modes", default=",".join(envs.ACTION_MODES))
    ap.add_argument("--files", nargs="*", help="map images for SamplerGym/RRT-Files-v2 (default: a generated PNG)")
    args = ap.parse_args(argv)

    def check() -> None:
        check_int_flags(args, ("steps",))
        for mode in args.modes.split(","):
            if mode not in envs.ACTION_MODES:
                raise InputError(f"--modes: {mode!r} is not an action mode; choose from {','.join(envs.ACTION_MODES)}")
        for f in args.files or ():
            if not Path(f).is_file():
                raise InputError(f"--files: {f} is not a file")

    check_flags(check)
    files = args.files
    if not files:
        import tempfile

        from PIL import Image

        from planners.maps.generators import generate

        obs = generate("rooms", 0, 128).world.obstacles
        files = [str(Path(tempfile.mkdtemp()) / "rooms.png")]
        Image.fromarray(np.where(obs, 0, 255).astype(np.uint8)).save(files[0])
    rows = []
    for env_id in sorted(envs.ENV_IDS):
        kw = {}
        if env_id.endswith("Files-v2"):
            kw["source_kwargs"] = {"paths": files}
        for mode in args.modes.split(","):
            if mode == "guided" and "Rigid" in env_id:
                continue  # guided actions are defined on 2-D grids only (the 6-DoF ids: RigidBody, RigidScenes)
            try:
                obs_kw = {"observation": "egocentric"} if mode == "guided" else {}
                env = gym.make(env_id, action_mode=mode, **kw, **obs_kw)
            except (FileNotFoundError, InputError) as exc:  # e.g. the MovingAI maps are not on this machine
                print(f"skipping {env_id}: {exc}", file=sys.stderr)
                break
            steps_per_second(env, 500)  # load compiled kernels
            sps, eps = steps_per_second(env, args.steps)
            obs_kind = "egocentric" if mode == "guided" else "default"
            rows.append({"id": env_id, "action_mode": mode, "observation": obs_kind, "steps_per_s": sps,
                         "episodes": eps})
            print(markdown_table(rows[-1:]).splitlines()[-1], flush=True)
    print()
    print(markdown_table(rows, floatfmt=".0f"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
