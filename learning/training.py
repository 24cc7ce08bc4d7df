"""Training a guided sampler policy: DAgger imitation of the expert, then PPO fine-tuning.

Why this route: sparse-reward PPO from scratch learns nothing in a useful budget (the issue measured
300k steps of nothing on 64x64 maps), while imitation of the privileged expert gives a policy that
already beats goal bias after a few minutes. PPO (Stable-Baselines3) then optimises the real
objective, minus iterations-to-solution, starting from that policy; its critic is pre-trained during
imitation and has its own feature extractor so fitting it cannot disturb the actor. The final
checkpoint is whichever of the imitation and PPO policies does better on a validation split of maps.

Map seeds: training draws from ``[0, 100_000)``, validation uses ``[200_000, ...)``; evaluation
(``learning.evaluation``) uses ``[1_000_000, ...)`` and tunes goal bias on ``[300_000, ...)``, so no
evaluated map was ever trained on.
"""

from __future__ import annotations

import json
import math
import os
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import torch

from learning.fast_policy import FastActor
from learning.imitation import Dataset, behaviour_cloning, collect
from learning.policy_sampler import OBS_VERSION, PolicySampler
from planners import RRT
from planners.generators import FAMILIES, generate

TRAIN_SEEDS = (0, 100_000)
VALIDATION_SEED0 = 200_000
TUNING_SEED0 = 300_000
TEST_SEED0 = 1_000_000


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
    extra: dict = field(default_factory=dict)

    def sampler_config(self) -> dict:
        """What a ``PolicySampler`` needs, embedded in the checkpoint."""
        return {"step_size": self.step_size, "uniform_floor": self.uniform_floor, "batch": self.batch,
                "obs_version": OBS_VERSION, "max_iterations": 20000, "stuck_threshold": self.stuck_threshold,
                "families": list(self.families), "sizes": list(self.sizes), "seed": self.seed}

    @classmethod
    def from_json(cls, path) -> TrainConfig:
        raw = json.loads(Path(path).read_text())
        known = {f for f in cls.__dataclass_fields__}
        unknown = set(raw) - known
        if unknown:
            raise ValueError(f"{path}: unknown config keys {sorted(unknown)}")
        for k in ("families", "sizes", "dagger_betas", "conv_channels"):
            if k in raw:
                raw[k] = tuple(raw[k])
        return cls(**raw)


def lower_bound(problem, step_size: float) -> int:
    """ceil((L* - tolerance) / step): iterations no sampler can beat."""
    return max(1, math.ceil((problem.reference_length - problem.goal_tolerance) / step_size))


def _maps(cfg: TrainConfig, rng: np.random.Generator, per_family: int, seed0: int | None = None):
    out = []
    for f in cfg.families:
        for i in range(per_family):
            size = cfg.sizes[int(rng.integers(len(cfg.sizes)))] if seed0 is None else cfg.sizes[i % len(cfg.sizes)]
            seed = int(rng.integers(*TRAIN_SEEDS)) if seed0 is None else seed0 + i
            out.append(generate(f, seed, size, goal_tolerance=cfg.goal_tolerance))
    return out


def validation_score(actor: FastActor, cfg: TrainConfig) -> tuple[float, dict]:
    """Geometric mean over families of the median iterations / lower bound on validation maps."""
    sampler = PolicySampler(actor, cfg.sampler_config())
    per_family = {}
    for f in cfg.families:
        ratios = []
        for i in range(cfg.validation_maps):
            p = generate(f, VALIDATION_SEED0 + i, cfg.sizes[i % len(cfg.sizes)], goal_tolerance=cfg.goal_tolerance)
            r = RRT(p, step_size=cfg.step_size, sampler=sampler, seed=i).solve(max_iterations=20000)
            ratios.append(r.iterations / lower_bound(p, cfg.step_size) if r.solved else 20000.0)
        per_family[f] = float(np.median(ratios))
    return float(np.exp(np.mean(np.log(list(per_family.values()))))), per_family


class _MixedFamilies:
    """Training map source: a random family and size each episode, seeds from the training range."""

    dim = 2

    def __init__(self, cfg: TrainConfig) -> None:
        self.choices = [(f, s) for f in cfg.families for s in cfg.sizes]
        self.goal_tolerance = cfg.goal_tolerance

    def __call__(self, np_random):
        family, size = self.choices[int(np_random.integers(len(self.choices)))]
        return generate(family, int(np_random.integers(*TRAIN_SEEDS)), size, goal_tolerance=self.goal_tolerance)


def make_env(cfg: TrainConfig, seed: int):
    """The vectorised training environment (guided actions, egocentric observations, scaled reward)."""
    import gymnasium as gym
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv

    from envs import SamplerEnv

    def factory():
        env = SamplerEnv(_MixedFamilies(cfg), planner="rrt", step_size=cfg.step_size,
                         max_iterations=cfg.max_iterations, action_mode="guided", observation="egocentric",
                         uniform_floor=cfg.uniform_floor, shaping=cfg.shaping, shaping_gamma=cfg.gamma)
        return gym.wrappers.TransformReward(env, lambda r: r * cfg.reward_scale)

    return make_vec_env(factory, n_envs=cfg.n_envs, seed=seed, vec_env_cls=DummyVecEnv)


def _save(model, cfg: TrainConfig, path: Path, state: dict) -> None:
    """Write the checkpoint atomically, with the sampler config inside and the run state beside it."""
    model.samplergym_config = cfg.sampler_config()
    tmp = path.with_name(f".{path.stem}.tmp.zip")
    model.save(tmp)
    os.replace(tmp, path)
    (path.parent / "state.json").write_text(json.dumps(state, indent=2))


def train(cfg: TrainConfig, out_dir: str | os.PathLike, *, resume: bool = False, progress: bool = True,
          log_stdout: bool = True) -> Path:
    """Run (or resume) training; returns the path of the final checkpoint ``<run>/final.zip``."""
    from stable_baselines3.common.logger import configure

    run = Path(out_dir) / cfg.name
    run.mkdir(parents=True, exist_ok=True)
    ckpt = run / "checkpoint.zip"
    state_path = run / "state.json"
    if resume:
        if not ckpt.is_file() or not state_path.is_file():
            raise FileNotFoundError(f"nothing to resume in {run}: no checkpoint.zip/state.json")
        saved = TrainConfig.from_json(run / "config.json")
        if asdict(saved) != asdict(cfg):
            raise ValueError(f"{run}/config.json differs from the requested config; resume with the same config")
        state = json.loads(state_path.read_text())
    else:
        state = {"phase": "bc", "round": -1, "ppo_steps": 0}
    (run / "config.json").write_text(json.dumps(asdict(cfg), indent=2))
    torch.set_num_threads(cfg.torch_threads)
    torch.manual_seed(cfg.seed)
    env = make_env(cfg, cfg.seed)
    logger = configure(str(run / "tb"), ["tensorboard", "csv"] + (["stdout"] if log_stdout else []))
    try:
        return _train_phases(cfg, run, state, env, logger, resume=resume, progress=progress)
    finally:  # a run that stops, however it stops, leaves no open log files
        logger.close()
        env.close()


def _train_phases(cfg: TrainConfig, run: Path, state: dict, env, logger, *, resume: bool, progress: bool) -> Path:
    """DAgger, then PPO fine-tuning, then the choice between them on validation maps (see ``train``)."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from tqdm.auto import tqdm

    from learning.extractor import policy_kwargs

    ckpt = run / "checkpoint.zip"
    if resume:
        model = PPO.load(ckpt, env=env, device="cpu")
        model.set_random_seed(cfg.seed + 7919 * (state["round"] + 2) + state["ppo_steps"])
    else:
        arch = policy_kwargs(cfg.features_dim, cfg.hidden, cfg.conv_channels, cfg.vector_dim)
        model = PPO("MultiInputPolicy", env, policy_kwargs=arch,
                    learning_rate=cfg.ppo_lr, n_steps=cfg.ppo_n_steps, batch_size=cfg.ppo_batch,
                    n_epochs=cfg.ppo_epochs, clip_range=cfg.ppo_clip, ent_coef=cfg.ppo_ent_coef, gamma=cfg.gamma,
                    seed=cfg.seed, device="cpu", verbose=0)
    model.set_logger(logger)

    def log(stats: dict, step: int) -> None:
        for k, v in stats.items():
            logger.record(k, v)
        logger.dump(step)

    # --- phase 1: DAgger -----------------------------------------------------------------------
    data_path = run / "dagger_data.npz"
    data = Dataset.load(data_path) if resume and data_path.is_file() else None
    rounds = range(state["round"] + 1, cfg.dagger_rounds) if state["phase"] == "bc" else range(0)
    for k in tqdm(rounds, desc="DAgger", disable=not progress):
        rng = np.random.default_rng([cfg.seed, k])
        problems = _maps(cfg, rng, cfg.maps_per_round)
        actor = FastActor(model.policy.state_dict()) if k > 0 else None
        beta = cfg.dagger_betas[min(k, len(cfg.dagger_betas) - 1)]
        t0 = time.perf_counter()
        new, its = collect(problems, actor, beta, seed=cfg.seed * 1_000_003 + k * 10_007, batch=cfg.batch,
                           step_size=cfg.step_size, stuck_threshold=cfg.stuck_threshold,
                           uniform_floor=cfg.uniform_floor, max_iterations=cfg.max_iterations, gamma=cfg.gamma,
                           reward_scale=cfg.reward_scale)
        data = new if data is None else Dataset.concat([data, new])
        # with shaping the critic must predict shaped returns: leave it to PPO's warm-up
        stats = behaviour_cloning(model.policy, data, epochs=cfg.bc_epochs, batch_size=cfg.bc_batch, lr=cfg.bc_lr,
                                  seed=cfg.seed + k, value_weight=0.0 if cfg.shaping else 0.5)
        score, fam = validation_score(FastActor(model.policy.state_dict()), cfg)
        log({**stats, "dagger/round": k, "dagger/beta": beta, "dagger/samples": len(data),
             "dagger/median_iterations": float(np.median(its)), "dagger/collect_seconds": time.perf_counter() - t0,
             "validation/score": score, **{f"validation/{f}": v for f, v in fam.items()}}, k)
        data.save(data_path)
        state = {"phase": "bc", "round": k, "ppo_steps": 0, "bc_validation": score}
        _save(model, cfg, ckpt, state)
    if state["phase"] == "bc":
        _save(model, cfg, run / "imitation.zip", state)
        state = {**state, "phase": "ppo", "ppo_steps": 0}
        _save(model, cfg, ckpt, state)

    # --- phase 2: PPO fine-tuning ----------------------------------------------------------------
    class Checkpointer(BaseCallback):
        def __init__(self) -> None:
            super().__init__()
            self.last = state["ppo_steps"]

        def _on_step(self) -> bool:
            done = state["ppo_steps"] + self.num_timesteps - self.model._num_timesteps_at_start
            if done - self.last >= cfg.checkpoint_every:
                self.last = done
                _save(self.model, cfg, ckpt, {**state, "ppo_steps": done})
            return True

    # the critic warms up first with the actor frozen, so early, noisy advantages cannot undo imitation
    actor = [p for name, p in model.policy.named_parameters()
             if name.startswith(("pi_features_extractor", "mlp_extractor.policy_net", "action_net"))]
    for stage_end in (min(cfg.value_warmup, cfg.ppo_steps), cfg.ppo_steps):
        remaining = stage_end - state["ppo_steps"]
        if remaining <= 0:
            continue
        for p in actor:
            p.requires_grad_(state["ppo_steps"] >= cfg.value_warmup)
        cb = Checkpointer()
        try:
            model.learn(total_timesteps=remaining, reset_num_timesteps=False, progress_bar=progress, callback=cb,
                        tb_log_name="ppo")
        except KeyboardInterrupt:
            done = state["ppo_steps"] + model.num_timesteps - model._num_timesteps_at_start
            _save(model, cfg, ckpt, {**state, "ppo_steps": done})
            raise
        state = {**state, "ppo_steps": stage_end}
        _save(model, cfg, ckpt, state)
    for p in actor:
        p.requires_grad_(True)

    # --- selection on validation maps ----------------------------------------------------------------
    from stable_baselines3.common.save_util import load_from_zip_file

    ppo_score, ppo_fam = validation_score(FastActor(model.policy.state_dict()), cfg)
    _, imitation_params, _ = load_from_zip_file(run / "imitation.zip", device="cpu", print_system_info=False)
    bc_score, bc_fam = validation_score(FastActor(imitation_params["policy"]), cfg)
    chosen = "ppo" if ppo_score <= bc_score else "imitation"
    summary = {"chosen": chosen, "validation_ppo": ppo_score, "validation_imitation": bc_score,
               "validation_ppo_families": ppo_fam, "validation_imitation_families": bc_fam}
    log({"validation/final_ppo": ppo_score, "validation/final_imitation": bc_score}, cfg.dagger_rounds + 1)
    final = run / "final.zip"
    if chosen == "ppo":
        _save(model, cfg, final, {**state, **summary})
    else:
        model.policy.load_state_dict(imitation_params["policy"])
        _save(model, cfg, final, {**state, **summary})
    (run / "summary.json").write_text(json.dumps(summary, indent=2))
    return final
