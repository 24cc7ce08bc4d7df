"""Does reinforcement learning through the orientation environment learn what imitation through it learns?

    PYTHONPATH=$PWD python scripts/experiments/orientation_rl.py --steps 100000 --out FILE

``SamplerGym/RigidOrientation-v1`` (``envs.RigidOrientationEnv``) presents the route points of training scenes with
the shipped recipe's teacher (``learning.training.rigid.recipe_teacher``: the class that a solution found by the
expert's long runs takes nearest each point; reward 1 for it, 0 for the others). The shipped orientation model
learns from those points by imitation (``scripts/train_rigid.py``: the teacher's label as a soft target, 15 epochs
over 200 scenes, the grid's 48 symmetries). Here PPO with Stable-Baselines3's defaults (``PPO("MultiInputPolicy",
env, seed=S)``, one torch thread) learns from the rewards alone for ``--steps`` steps. Both are then asked on
validation scenes (``--scenes`` of each training family, never a test scene) how often the class they name is the
solution's (top-1 agreement), beside chance (1/6) and the best single class (chosen on those labels themselves: a
bound no constant answer passes); and, what counts, how RRT-Connect and RRT at the seed set-ups plan those scenes
(``--seeds`` each) with ``rigid_route`` as it ships, with PPO's policy in place of its model (the policy's action
logits as the class scores), and with its no-learning ablation (uniform angles). A measurement of the training
interface, not a choice of any setting.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch

from envs import ORIENTATION_ENV_ID, RigidOrientationEnv
from learning.device import pin_cpu_arithmetic
from learning.models.rigid_orientation import class_probabilities, load_orientation_net
from learning.models.shipped import SHIPPED_RIGID_ORIENTATION
from learning.training.rigid import RigidTrainConfig, recipe_teacher
from planners.base.fileio import atomic_write_text, check_output_place
from planners.guidance.rigid_orientation import N_CLASSES
from planners.worlds.rigid_scenes import TRAINING_FAMILIES, scene_seeds


def validation_points(scenes: int, config: RigidTrainConfig) -> dict[str, np.ndarray]:
    """Every point of ``scenes`` validation scenes a family, through the environment: observations and labels."""
    env = RigidOrientationEnv(part="validation", teacher=recipe_teacher(config), half=config.half)
    patches, directions, labels, family_of = [], [], [], []
    for family in TRAINING_FAMILIES:
        for seed in scene_seeds(family, "validation", scenes):
            obs, info = env.reset(options={"family": family, "scene_seed": seed, "teacher_seed": [config.seed, seed]})
            done = False
            while not done:
                patches.append(obs["patch"])
                directions.append(obs["direction"])
                labels.append(info["label"])
                family_of.append(family)
                obs, _, done, _, info = env.step(info["expert_action"])
    return {"patch": np.stack(patches), "direction": np.stack(directions), "label": np.stack(labels),
            "family": np.array(family_of)}


class PolicyClasses(torch.nn.Module):
    """PPO's policy as an orientation model (``OrientationNet``'s interface): its action logits at each observation."""

    def __init__(self, policy, half: int) -> None:
        super().__init__()
        self.policy, self.half = policy, half

    def forward(self, patches: torch.Tensor, directions: torch.Tensor) -> torch.Tensor:
        return self.policy.get_distribution({"patch": patches, "direction": directions}).distribution.logits


def planning(policy, scenes: int, seeds: int) -> dict[str, dict[str, str]]:
    """Success and median iterations (an unsolved run at its cap) per planner and sampler on the validation scenes."""
    from learning.evaluation.rigid import build_planner
    from learning.samplers.registry import make_sampler
    from planners.worlds.rigid_scenes import RigidSceneSet

    def with_policy():
        sampler = make_sampler("rigid_route")
        sampler.net = PolicyClasses(policy, sampler.net.half)
        return sampler

    samplers = {"rigid_route_ablation": lambda: make_sampler("rigid_route_ablation"),
                "rigid_route (imitation, shipped)": lambda: make_sampler("rigid_route"),
                "rigid_route with PPO's policy": with_policy}
    sets = RigidSceneSet(TRAINING_FAMILIES, (), {"validation": scenes})
    runs: dict[tuple[str, str], list[tuple[bool, int]]] = {}
    for q in sets.queries("validation"):
        problem = sets.problem(q)
        for planner in ("RRTConnect", "RRT"):
            for name, make in samplers.items():
                for seed in range(seeds):
                    pl, cap = build_planner(planner, problem, make(), seed)
                    r = pl.solve(max_iterations=cap)
                    runs.setdefault((planner, name), []).append((bool(r.solved), int(r.iterations if r.solved
                                                                                      else cap)))
    return {f"{planner}, {name}": {"solved": f"{sum(s for s, _ in rs)}/{len(rs)}",
                                   "median iterations": f"{np.median([i for _, i in rs]):,.0f}"}
            for (planner, name), rs in runs.items()}


def agreement(named: np.ndarray, points: dict[str, np.ndarray]) -> dict[str, float]:
    """The share of points where ``named`` is the label's class: over all and per family."""
    right = points["label"][np.arange(len(named)), named] > 0
    out = {"all": round(float(right.mean()), 4)}
    for family in TRAINING_FAMILIES:
        at = points["family"] == family
        out[family] = round(float(right[at].mean()), 4)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=100_000, help="PPO's environment steps")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--scenes", type=int, default=4, help="validation scenes per training family")
    ap.add_argument("--seeds", type=int, default=2, help="planner seeds per validation scene")
    ap.add_argument("--out", type=Path, help="a JSON file for the figures")
    args = ap.parse_args(argv)
    if args.steps < 1 or args.scenes < 1 or args.seeds < 1:
        ap.error("--steps, --scenes and --seeds must be positive")
    if args.out is not None:
        check_output_place(args.out, "--out", folder=False)
    pin_cpu_arithmetic()
    torch.set_num_threads(1)
    from stable_baselines3 import PPO

    config = RigidTrainConfig()
    t0 = time.perf_counter()
    points = validation_points(args.scenes, config)
    print(f"{len(points['label']):,} validation points in {time.perf_counter() - t0:.0f} s", flush=True)
    env = gym.make(ORIENTATION_ENV_ID, teacher=recipe_teacher(config))
    model = PPO("MultiInputPolicy", env, seed=args.seed, device="cpu")
    t0 = time.perf_counter()
    model.learn(args.steps)
    seconds = time.perf_counter() - t0
    obs = {"patch": points["patch"], "direction": points["direction"]}
    ppo = np.concatenate([model.predict({k: v[i:i + 1024] for k, v in obs.items()}, deterministic=True)[0]
                          for i in range(0, len(points["label"]), 1024)]).astype(np.int64)
    shipped = class_probabilities(load_orientation_net(SHIPPED_RIGID_ORIENTATION), points["patch"],
                                  points["direction"]).argmax(axis=1)
    counts = (points["label"] > 0).sum(axis=0)
    best = int(np.argmax(counts))
    rows = {
        f"PPO, SB3's defaults, {args.steps:,} steps": agreement(ppo, points),
        "imitation (the shipped model)": agreement(shipped, points),
        "the best single class (on these labels)": agreement(np.full(len(ppo), best), points),
    }
    print(f"PPO: {seconds / 60:.1f} min for {args.steps:,} steps; chance {1 / N_CLASSES:.3f}")
    width = max(len(k) for k in rows)
    print(f"{'':{width}}  " + "  ".join(f"{k:>8}" for k in rows[next(iter(rows))]))
    for name, row in rows.items():
        print(f"{name:{width}}  " + "  ".join(f"{v:8.3f}" for v in row.values()))
    plans = planning(model.policy, args.scenes, args.seeds)
    print("| planner, sampler | solved | median iterations |\n|---|---|---|")
    for name, row in plans.items():
        print(f"| {name} | {row['solved']} | {row['median iterations']} |")
    if args.out is not None:
        atomic_write_text(args.out, json.dumps({"steps": args.steps, "seed": args.seed, "scenes": args.scenes,
                                                "seeds": args.seeds, "ppo_minutes": round(seconds / 60, 2),
                                                "points": len(ppo), "agreement": rows, "planning": plans},
                                               indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
