"""The configuration of a policy training run (``TrainConfig``) and its checked JSON reader.

A run's config is saved next to its weights (``<run>/config.json``) and read back, every value
checked, when the run resumes or when a user passes ``scripts/train.py --config``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from learning.samplers.policy import OBS_VERSION
from planners.base.fileio import InputError, check_number, read_json, short_repr
from planners.maps.generators import FAMILIES, MIN_SIZE, check_size


@dataclass
class TrainConfig:
    """Everything that determines a training run (saved next to the weights).

    The actor is small on purpose: it runs at every sampler decision, inside the planner's loop, so
    its size is paid in planning time. On the validation maps, convolutions of 8 and 16 channels and
    32-wide layers imitated the expert as well as 16/32 channels and 128-wide layers, at less than
    half the cost per forward pass. ``torch_threads=1`` keeps the weights bit-identical for a seed: with
    several threads the linear algebra may split its sums differently from run to run.
    """

    name: str = "guided"
    seed: int = 0
    families: tuple[str, ...] = FAMILIES
    sizes: tuple[int, ...] = (64, 128)
    step_size: float = 4.0
    goal_tolerance: float = 4.0
    batch: int = 8
    uniform_floor: float = 0.05
    stuck_threshold: int = 16
    max_iterations: int = 3000
    dagger_rounds: int = 8
    dagger_betas: tuple[float, ...] = (1.0, 0.5, 0.25, 0.0)
    maps_per_round: int = 100
    bc_epochs: int = 6
    bc_lr: float = 1e-3
    bc_batch: int = 512
    mirror: bool = False
    ppo_steps: int = 300_000
    value_warmup: int = 40_000
    shaping: bool = True
    ppo_lr: float = 5e-5
    ppo_n_steps: int = 1024
    ppo_batch: int = 256
    ppo_epochs: int = 4
    ppo_clip: float = 0.1
    ppo_ent_coef: float = 0.0
    gamma: float = 0.995
    reward_scale: float = 0.01
    n_envs: int = 2
    checkpoint_every: int = 50_000
    validation_maps: int = 20
    features_dim: int = 32
    hidden: int = 32
    conv_channels: tuple[int, ...] = (8, 16)
    vector_dim: int = 16
    torch_threads: int = 1
    map_set: tuple[str, ...] = ()
    map_set_weight: tuple[float, ...] = ()
    extra: dict = field(default_factory=dict)

    def sampler_config(self) -> dict:
        """What a ``PolicySampler`` needs, embedded in the checkpoint."""
        return {"step_size": self.step_size, "uniform_floor": self.uniform_floor, "batch": self.batch,
                "obs_version": OBS_VERSION, "max_iterations": 20000, "stuck_threshold": self.stuck_threshold,
                "families": list(self.families), "sizes": list(self.sizes), "seed": self.seed}

    @classmethod
    def from_json(cls, path) -> TrainConfig:
        """A config from a JSON file of ``TrainConfig`` fields, every value checked (``InputError`` naming the file)."""
        raw = read_json(path, "training config")
        if not isinstance(raw, dict):
            raise InputError(f"training config {path} holds a {type(raw).__name__}, expected a JSON object")
        unknown = set(raw) - set(cls.__dataclass_fields__)
        if unknown:
            raise InputError(f"{path}: unknown config keys {short_repr(sorted(unknown))}")
        for k in ("families", "sizes", "dagger_betas", "conv_channels", "map_set", "map_set_weight"):
            if k in raw:
                if not isinstance(raw[k], list):
                    raise InputError(f"{path}: {k} = {raw[k]!r}, expected a list")
                raw[k] = tuple(raw[k])
        cfg = cls(**raw)
        cfg.check(str(path))
        return cfg

    def check(self, source: str = "training config") -> None:
        """Refuse any value training cannot use, naming ``source`` and the field (``InputError``)."""
        if not isinstance(self.name, str) or not re.fullmatch(r"[A-Za-z0-9_][A-Za-z0-9_.-]*", self.name):
            raise InputError(f"{source}: name = {self.name!r}, expected letters, digits, '_', '-' or '.' "
                             "(it names the run's folder)")
        for key, low in (("seed", 0), ("stuck_threshold", 0), ("max_iterations", 1), ("batch", 1),
                         ("dagger_rounds", 1), ("maps_per_round", 1), ("bc_epochs", 1), ("bc_batch", 1),
                         ("ppo_steps", 0), ("value_warmup", 0), ("ppo_n_steps", 2), ("ppo_batch", 2),
                         ("ppo_epochs", 1), ("n_envs", 1), ("checkpoint_every", 1), ("validation_maps", 1),
                         ("features_dim", 1), ("hidden", 1), ("vector_dim", 1), ("torch_threads", 1)):
            check_number(source, key, getattr(self, key), integer=True, low=low)
        for key, low, high in (("step_size", 0.0, None), ("goal_tolerance", 0.0, None), ("bc_lr", 0.0, None),
                               ("ppo_lr", 0.0, None), ("ppo_clip", 0.0, None), ("reward_scale", 0.0, None),
                               ("gamma", 0.0, 1.0)):
            check_number(source, key, getattr(self, key), low=low, high=high, low_open=True)
        check_number(source, "uniform_floor", self.uniform_floor, low=0.0, high=1.0)
        check_number(source, "ppo_ent_coef", self.ppo_ent_coef, low=0.0)
        if not isinstance(self.shaping, bool):
            raise InputError(f"{source}: shaping = {self.shaping!r}, expected true or false")
        if not self.families or any(f not in FAMILIES for f in self.families):
            raise InputError(f"{source}: families = {list(self.families)!r}, expected some of {list(FAMILIES)}")
        for key, values, low, high, integer in (("sizes", self.sizes, MIN_SIZE, None, True),
                                                ("dagger_betas", self.dagger_betas, 0.0, 1.0, False),
                                                ("conv_channels", self.conv_channels, 1, None, True)):
            if not values:
                raise InputError(f"{source}: {key} is empty")
            for v in values:
                check_number(source, key, v, integer=integer, low=low, high=high)
        for v in self.sizes:
            check_size(v, f"{source}: sizes")
        if not isinstance(self.map_set, tuple) or any(not isinstance(m, str) or not m for m in self.map_set):
            raise InputError(f"{source}: map_set = {self.map_set!r}, expected folders, manifests or map set names")
        if self.map_set_weight and len(self.map_set_weight) != len(self.map_set):
            raise InputError(f"{source}: map_set_weight = {list(self.map_set_weight)!r}: {len(self.map_set_weight)} "
                             f"weights for {len(self.map_set)} map sets; give one per map set, in the same order")
        for v in self.map_set_weight:
            check_number(source, "map_set_weight", v, low=0.0, low_open=True)
        if len(self.conv_channels) != 2:
            raise InputError(f"{source}: conv_channels = {list(self.conv_channels)!r}, expected two widths")
        if not isinstance(self.extra, dict):
            raise InputError(f"{source}: extra = {self.extra!r}, expected an object")
