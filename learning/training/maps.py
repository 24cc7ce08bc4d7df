"""The maps a policy training run draws: map sets, DAgger's maps of a round, PPO's training environment.

Map seeds come from the training range of ``planners.maps.generators`` (``TRAIN_SEEDS``); with
``TrainConfig.map_set`` the maps come from the sets' training parts instead (mixed by ``map_set_weight``).
"""

from __future__ import annotations

import numpy as np

from learning.training.config import TrainConfig
from planners.base.fileio import InputError
from planners.maps.generators import TRAIN_SEEDS, generate
from planners.maps.mapset import MapSet, MixedMapSet


def open_map_sets(cfg: TrainConfig) -> MixedMapSet | None:
    """``cfg.map_set`` opened and mixed by ``cfg.map_set_weight`` (None without map sets), checked for training.

    Each set needs a training and a validation part, and the planner's step (``step_size``, world
    units) must span at least one cell of every map in them.

    Raises:
        InputError: Naming the set, the map and the value.
    """
    if not cfg.map_set:
        return None
    sets = []
    for spec in cfg.map_set:
        try:
            ms = MapSet.open(spec)
            ms.validate(["train", "validation"])
        except InputError as exc:
            raise InputError(f"map_set {spec}: {exc}") from None
        rec = ms.record()
        for name, m in (rec.get("maps") or {}).items():
            if name in (*ms.maps("train"), *ms.maps("validation")) and cfg.step_size < m["resolution"]:
                raise InputError(f"map_set {spec}: step_size {cfg.step_size:g} (world units) is less than one cell "
                                 f"of map {name!r} ({m['resolution']:g} world units); give a step of at least a cell")
        sets.append(ms)
    return MixedMapSet(sets, cfg.map_set_weight or None)


def dagger_maps(cfg: TrainConfig, rng: np.random.Generator, per_family: int, seed0: int | None = None,
                sets: MixedMapSet | None = None):
    """DAgger's maps of a round: ``per_family`` of each family, or ``per_family`` drawn from ``sets``' train parts."""
    if sets is not None:
        return [sets.sample("train", rng) for _ in range(per_family)]
    out = []
    for f in cfg.families:
        for i in range(per_family):
            size = cfg.sizes[int(rng.integers(len(cfg.sizes)))] if seed0 is None else cfg.sizes[i % len(cfg.sizes)]
            seed = int(rng.integers(*TRAIN_SEEDS)) if seed0 is None else seed0 + i
            out.append(generate(f, seed, size, goal_tolerance=cfg.goal_tolerance))
    return out


class _MixedFamilies:
    """Training map source: a random family and size each episode, seeds from the training range."""

    dim = 2

    def __init__(self, cfg: TrainConfig) -> None:
        self.choices = [(f, s) for f in cfg.families for s in cfg.sizes]
        self.goal_tolerance = cfg.goal_tolerance

    def __call__(self, np_random):
        family, size = self.choices[int(np_random.integers(len(self.choices)))]
        return generate(family, int(np_random.integers(*TRAIN_SEEDS)), size, goal_tolerance=self.goal_tolerance)


def make_env(cfg: TrainConfig, seed: int, sets: MixedMapSet | None = None):
    """The vectorised training environment (guided actions, egocentric observations, scaled reward).

    Episodes come from the generated families, or from ``sets``' training parts.
    """
    import gymnasium as gym
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv

    from samplergym import envs as env_package  # this library's envs, also beside a project's own envs/

    def factory():
        source = _MixedFamilies(cfg) if sets is None else env_package.MapSetSource(sets, "train")
        env = env_package.SamplerEnv(source, planner="rrt", step_size=cfg.step_size,
                         max_iterations=cfg.max_iterations, action_mode="guided", observation="egocentric",
                         uniform_floor=cfg.uniform_floor, shaping=cfg.shaping, shaping_gamma=cfg.gamma)
        return gym.wrappers.TransformReward(env, lambda r: r * cfg.reward_scale)

    return make_vec_env(factory, n_envs=cfg.n_envs, seed=seed, vec_env_cls=DummyVecEnv)
