"""PPO with Stable-Baselines3's defaults on a SamplerGym id, against goal bias tuned on the tuning split.

What a researcher's first run is: ``PPO("MultiInputPolicy", env)`` with no arguments, ``learn(steps)``,
then the model as a planner sampler (``learning.SB3Sampler``). ``train_default_ppo`` does exactly that
on the id's training maps (generated seeds from ``planners.maps.generators.TRAIN_SEEDS``);
``tune_goal_bias`` picks RRT's goal bias on the tuning maps; ``compare`` runs both, and uniform
sampling, on held-out test maps (``TEST_SEED0`` onwards) and reports iterations, success and time per
run. ``scripts/sb3_defaults.py`` is its command line.
"""

from __future__ import annotations

import os
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from planners import GoalBiasedSampler, Problem, make_planner
from planners.base.fileio import InputError, check_int
from planners.maps.generators import FAMILIES, TEST_SEED0, TRAIN_SEEDS, TUNING_SEED0, generate

#: Goal biases the comparison chooses from on the tuning maps (0 is uniform sampling).
BIAS_GRID = (0.0, 0.01, 0.05, 0.1, 0.2, 0.5)
#: Map side, step and iteration cap of the family ids (``SamplerEnv``'s defaults).
SIZE, STEP, CAP = 64, 4.0, 2000
#: The 6-DoF body's id on the generated scene sets (a training scene each episode; vector observations).
RIGID_ID = "SamplerGym/RRT-RigidScenes-v1"


def family_id(family: str) -> str:
    """The ``SamplerGym/RRT-<Family>-v2`` id of a generated family."""
    if family not in FAMILIES:
        raise InputError(f"family must be one of {FAMILIES}, got {family!r}")
    return "SamplerGym/RRT-" + "".join(p.title() for p in family.split("_")) + "-v2"


def train_default_ppo(family: str, steps: int, seed: int, out: str | os.PathLike):
    """``PPO("MultiInputPolicy", env, seed=seed).learn(steps)`` on the family's training maps; saved to ``out``.

    Nothing but the seed is set (and one torch thread): the environment is ``gym.make(id)`` with its map
    seeds limited to the training range. Returns the model.
    """
    return train_ppo_on(family_id(family), steps, seed, out, source_kwargs={"seeds": np.arange(*TRAIN_SEEDS)})


def train_ppo_on(env_id: str, steps: int, seed: int, out: str | os.PathLike, **env_kwargs):
    """PPO with SB3's defaults on ``gym.make(env_id, **env_kwargs)`` for ``steps`` steps; saved to ``out``.

    ``"MultiInputPolicy"`` for Dict observations, ``"MlpPolicy"`` for a vector (``RIGID_ID``'s); nothing but the
    seed is set (and one torch thread), so the same call gives the same model. Returns the model.
    """
    import gymnasium as gym
    import torch
    from stable_baselines3 import PPO

    import samplergym  # noqa: F401 (registers the ids)

    check_int(steps, "steps")
    env = gym.make(env_id, **env_kwargs)
    policy = "MultiInputPolicy" if isinstance(env.observation_space, gym.spaces.Dict) else "MlpPolicy"
    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # one thread per process on small machines (docs/first-steps.md, "Threads")
    try:
        model = PPO(policy, env, seed=seed)
        model.learn(steps)
    finally:
        torch.set_num_threads(threads)
    model.save(out)
    return model


def maps(family: str, seed0: int, n: int) -> list[Problem]:
    """``n`` generated maps of ``family`` with consecutive seeds from ``seed0`` (a split's maps)."""
    return [generate(family, seed0 + i, SIZE) for i in range(n)]


def run_sampler(sampler, problems: Sequence[Problem], seeds: int) -> dict[str, np.ndarray]:
    """RRT with ``sampler`` on each problem and planner seed: iterations (the cap if unsolved), solved, seconds."""
    its, ok, secs = [], [], []
    for p in problems:
        for s in range(seeds):
            t0 = time.perf_counter()
            r = make_planner("rrt", p, extension_step=STEP, sampler=sampler, seed=s).solve(CAP)
            secs.append(time.perf_counter() - t0)
            its.append(r.iterations if r.solved else CAP)
            ok.append(r.solved)
    return {"iterations": np.asarray(its), "solved": np.asarray(ok), "seconds": np.asarray(secs)}


def tune_goal_bias(family: str, n_maps: int, seeds: int) -> tuple[float, dict[float, float]]:
    """The goal bias of ``BIAS_GRID`` with the lowest median iterations on the family's tuning maps."""
    problems = maps(family, TUNING_SEED0, n_maps)
    medians = {b: float(np.median(run_sampler(GoalBiasedSampler(b), problems, seeds)["iterations"]))
               for b in BIAS_GRID}
    return min(medians, key=medians.get), medians


def tune_batch(family: str, model: str | os.PathLike, batches: Sequence[int], n_maps: int, seeds: int) -> dict:
    """Median iterations and median ms per run of ``SB3Sampler(model, batch=b)`` on the tuning maps, per batch."""
    from learning.samplers.sb3 import SB3Sampler

    problems = maps(family, TUNING_SEED0, n_maps)
    out = {}
    for b in batches:
        sampler = SB3Sampler(model, family_id(family), batch=b)
        run_sampler(sampler, problems[:1], 1)  # first use compiles and loads; not timed
        res = run_sampler(sampler, problems, seeds)
        out[b] = (float(np.median(res["iterations"])), 1000 * float(np.median(res["seconds"])))
    return out


#: Batches ``choose_batch`` chooses from.
BATCH_GRID = (1, 4, 8, 16, 32)


def choose_batch(per_model: Sequence[dict]) -> int:
    """The largest batch whose median iterations, averaged over models, is within 10% of deciding every sample's.

    ``per_model``: ``tune_batch`` results of several models (batch -> (median iterations, ms per run)).
    """
    pooled = {b: float(np.mean([m[b][0] for m in per_model])) for b in per_model[0]}
    return max(b for b, v in pooled.items() if v <= 1.1 * pooled[min(pooled)])


def compare(family: str, models: Sequence[str | os.PathLike], *, n_test: int, n_tune: int, seeds: int,
            deterministic: bool | None = None, batch: int | None = None) -> list[dict]:
    """Rows (sampler, median and mean iterations, success, median ms per run) on held-out test maps.

    Goal bias is tuned on ``n_tune`` tuning maps first; each model in ``models`` is an SB3 ``.zip``
    trained on ``family_id(family)``. The last row per model compares it query by query with the
    tuned goal bias (``wins``: queries whose median over planner seeds is lower).
    """
    from learning.samplers.sb3 import SB3Sampler

    bias, _ = tune_goal_bias(family, n_tune, seeds)
    test = maps(family, TEST_SEED0, n_test)
    rows = []
    base = run_sampler(GoalBiasedSampler(bias), test, seeds)
    base_q = base["iterations"].reshape(n_test, seeds)
    rows.append(_row(f"goal bias {bias:g} (tuned)", base, None))
    named = [(f"PPO {Path(p).stem}", p) for p in models] + [("PPO untrained (the no-learning ablation)",
                                                               _untrained(family))]
    for name, model in named:
        sampler = SB3Sampler(model, family_id(family), deterministic=deterministic, batch=batch)
        run_sampler(sampler, test[:1], 1)  # first use compiles and loads; not timed
        res = run_sampler(sampler, test, seeds)
        rows.append(_row(name, res, base_q))
    return rows


def _untrained(family: str):
    """PPO's initial policy on the family id (seed 0): nearly uniform over the action classes."""
    import gymnasium as gym
    from stable_baselines3 import PPO

    return PPO("MultiInputPolicy", gym.make(family_id(family)), seed=0)


def _row(name: str, res: dict, base_q: np.ndarray | None) -> dict:
    row = {"sampler": name, "median": float(np.median(res["iterations"])), "mean": float(res["iterations"].mean()),
           "success": float(res["solved"].mean()), "ms_per_run": 1000 * float(np.median(res["seconds"]))}
    if base_q is not None:
        q = np.median(res["iterations"].reshape(base_q.shape), axis=1)
        row["wins"] = f"{int((q < np.median(base_q, axis=1)).sum())}/{len(q)}"
    return row
