"""``PolicySampler``: a trained sampler policy as a planner ``Sampler``, outside any environment.

    sampler = PolicySampler.load("checkpoints/guided.zip")
    RRT(problem, step_size=4.0, sampler=sampler, seed=0).solve(max_iterations=20000)

One forward pass of the policy (compiled, see ``learning.fast_policy``) yields a distribution over
the guided actions; ``batch`` samples are drawn from it at once and handed to the planner. Egocentric
samples are offsets resolved against the tree's progress vertex when used, so the batch follows the
tree. The distribution is reused for further batches while the progress vertex stays the same and
fewer than ``reuse`` iterations have passed since the forward pass, the stretches in which the
observation's decisive parts (the windows around that vertex) barely change. A ``uniform_floor``
share of samples is uniform: probabilistic completeness is kept. When the tree has made no progress
towards the goal for ``patience`` iterations the uniform share grows with the time stuck (up to
``max_floor``): a tree pinned against a wall by its own biased samples gets RRT's Voronoi bias back,
which cuts the heavy tail of failures on narrow passages without changing the medians. The policy
sees only its observation: the map, the tree, start and goal.
"""

from __future__ import annotations

import json
import os
import zipfile
from pathlib import Path

import numba as nb
import numpy as np

from envs.frontier import cdf_search, softmax_cdf
from envs.guided import N_ACTIONS, GuidedSampling
from learning.fast_policy import FastActor
from planners import OccupancyGrid, SamplerBase

#: Keys of the training config a checkpoint must carry.
CONFIG_KEYS = ("step_size", "uniform_floor", "batch", "obs_version")
OBS_VERSION = 1


@nb.njit(cache=True)
def sample_classes(logits, temperature, u):
    """Indices drawn from softmax(logits / temperature) by inverse CDF, one per uniform in ``u``."""
    cdf = np.empty(logits.shape[0])
    acc = softmax_cdf(logits, temperature, cdf)
    out = np.empty(u.shape[0], dtype=np.int64)
    for k in range(u.shape[0]):
        out[k] = cdf_search(cdf, logits.shape[0], u[k] * acc)
    return out


class PolicySampler(SamplerBase):
    """A learned sampler for ``OccupancyGrid`` problems of any size.

    Args:
        actor: The compiled actor (from ``load``).
        config: Training config (``step_size``, ``uniform_floor``, ``batch``, ...).
        step_size: The planner's step in world units; default: the training step.
        batch: Samples per batch; default: the training batch.
        temperature: Softmax temperature of the action distribution.
        reuse: Longest stretch of iterations one forward pass may serve (1: a pass per batch).
        patience: Iterations without progress after which the uniform share starts to grow.
        max_floor: The largest uniform share that growth reaches.
    """

    def __init__(self, actor: FastActor, config: dict, *, step_size: float | None = None, batch: int | None = None,
                 temperature: float = 1.0, reuse: int = 32, patience: int = 200, max_floor: float = 0.5) -> None:
        missing = [k for k in CONFIG_KEYS if k not in config]
        if missing:
            raise ValueError(f"policy config lacks {missing}")
        if config["obs_version"] != OBS_VERSION:
            raise ValueError(f"policy was trained on observation version {config['obs_version']}, "
                             f"this SamplerGym builds version {OBS_VERSION}")
        if actor.num_actions != N_ACTIONS:
            raise ValueError(f"policy has {actor.num_actions} actions, the guided action space has {N_ACTIONS}")
        self.actor, self.config = actor, dict(config)
        self.step_size = float(step_size if step_size is not None else config["step_size"])
        self.batch = int(batch if batch is not None else config["batch"])
        self.temperature = float(temperature)
        self.reuse = int(reuse)
        self.patience, self.max_floor = int(patience), float(max_floor)
        if not (self.step_size > 0 and self.batch >= 1 and self.temperature > 0 and self.reuse >= 1
                and self.patience >= 1 and 0.0 <= self.max_floor <= 1.0):
            raise ValueError(f"need step_size, batch, temperature, reuse, patience > 0 and 0 <= max_floor <= 1, got "
                             f"{self.step_size}, {self.batch}, {self.temperature}, {self.reuse}, {self.patience}, "
                             f"{self.max_floor}")
        self.forward_passes = 0

    @classmethod
    def load(cls, path: str | os.PathLike, **kwargs) -> PolicySampler:
        """Load a checkpoint written by ``scripts/train.py`` (an SB3 zip carrying the SamplerGym config)."""
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"policy checkpoint {path} does not exist")
        try:
            from stable_baselines3.common.save_util import load_from_zip_file

            data, params, _ = load_from_zip_file(path, device="cpu", print_system_info=False)
        except (zipfile.BadZipFile, KeyError, ValueError, RuntimeError, EOFError, json.JSONDecodeError) as exc:
            raise ValueError(f"{path} is not a readable SamplerGym policy checkpoint: {exc}") from None
        if not params or "policy" not in params:
            raise ValueError(f"{path} holds no policy weights")
        config = (data or {}).get("samplergym_config")
        if not isinstance(config, dict):
            raise ValueError(f"{path} is a Stable-Baselines3 model without a SamplerGym config: "
                             "was it trained by scripts/train.py?")
        try:
            actor = FastActor(params["policy"])
        except ValueError as exc:
            raise ValueError(f"{path}: {exc}") from None
        return cls(actor, config, **kwargs)

    def _setup(self) -> None:
        if not isinstance(self.problem.world, OccupancyGrid):
            raise ValueError("PolicySampler plans on OccupancyGrid problems (2-D maps of any size)")
        self.guide = GuidedSampling(self.problem, self.step_size, uniform_floor=self.config["uniform_floor"],
                                    max_iterations=int(self.config.get("max_iterations", 20000)))
        self.forward_passes = 0
        self._logits = None
        self._anchor = -1
        self._since = 0

    def draw(self, rng, n, view):
        self.guide.update(view)
        if self._logits is None or view.best_vertex != self._anchor or view.iteration - self._since >= self.reuse:
            obs = self.guide.observe(view)
            self._logits = self.actor.logits(obs["local"], obs["vector"]).astype(np.float64)
            self._anchor, self._since = view.best_vertex, view.iteration
            self.forward_passes += 1
        stuck = self.guide.stuck(view)
        floor = None if stuck < self.patience else min(self.max_floor, self.guide.uniform_floor * stuck / self.patience)
        return self.guide.samples_from_logits(self._logits, self.temperature, min(n, self.batch), rng, floor)

    def __repr__(self) -> str:
        return f"PolicySampler(step_size={self.step_size:g}, batch={self.batch})"
