"""Training a guided sampler policy: DAgger imitation of the expert, then PPO fine-tuning.

Why this route: sparse-reward PPO from scratch learns little in a useful budget (a policy rarely
solves a map by chance, so it rarely sees a reward), while imitation of the privileged expert gives
a policy that beats goal bias after a few minutes (README: how the sampler is learned,
                                                   and why). PPO (Stable-Baselines3) then optimises the real
objective, minus iterations-to-solution, starting from that policy; its critic is pre-trained during
imitation and has its own feature extractor so fitting it cannot disturb the actor. The final
checkpoint is whichever of the imitation and PPO policies does better on a validation split of maps.

Map seeds: the splits of ``planners.maps.generators`` (``TRAIN_SEEDS``, ``VALIDATION_SEED0``;
evaluation uses ``TUNING_SEED0`` and ``TEST_SEED0``), so no evaluated map was ever trained on.
With ``map_set`` (map sets, ``planners.maps.mapset``) the training maps come from the sets' training
parts (mixed by ``map_set_weight``) and the validation maps from their validation parts instead.

This module holds the training loop (:func:`train`); the pieces it runs live beside it and are
importable from here too: the configuration (``learning.training.config``), the maps and the training
environment (``learning.training.maps``), the validation score (``learning.training.validation``), the
checkpoints and run state (``learning.training.checkpoints``) and the logs (``learning.training.logs``).
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
import torch
from stable_baselines3.common.callbacks import BaseCallback
from tqdm.auto import tqdm

from learning.device import deterministic
from learning.models.checkpoint import read_sb3_zip
from learning.models.fast_policy import FastActor
from learning.training.checkpoints import CONFIG_KEY, STATE_KEY, commit_checkpoint, read_state, save_model
from learning.training.config import TrainConfig
from learning.training.imitation import Dataset, behaviour_cloning, collect
from learning.training.logs import ResumableCSV, RunLogger, run_logger, trim_events
from learning.training.maps import dagger_maps, make_env, open_map_sets
from learning.training.validation import sampler_validation_score, validation_score
from planners.base.fileio import InputError, atomic_write_text, run_lock
from planners.maps.mapset import MixedMapSet
from planners.tools.parallel import Backend

__all__ = ["CONFIG_KEY", "STATE_KEY", "TrainConfig", "make_env", "open_map_sets", "read_state",
           "sampler_validation_score", "train", "validation_score"]

_CPU = torch.device("cpu")


def train(cfg: TrainConfig, out_dir: str | os.PathLike, *, resume: bool = False, progress: bool = True,
          log_stdout: bool = True, backend: Backend | None = None, device: str | torch.device = "cpu") -> Path:
    """Run (or resume) training; returns the path of the final checkpoint ``<run>/final.zip``.

    DAgger's rollouts and the validation runs go to ``backend`` (default: this process); the weights
    do not depend on it. The networks train on ``device`` (a torch device; ``learning.device.resolve_device``
    turns ``"auto"`` into one); the same seed gives the same weights on the same machine and device.
    With ``cfg.map_set`` the sets are opened and checked (``open_map_sets``) before the lock is
    taken, and their record (split rule and parts) is written to ``<run>/map_sets.json``.

    The run folder ``<out_dir>/<name>`` is locked while the run writes it (:func:`run_lock`): a second
    run on the same folder gets a ``LockedError`` naming the first.

    A resumed run ends with the same weights, bit for bit, as one that was never interrupted:
    each DAgger round depends only on the committed weights and data, and each PPO segment
    (``checkpoint_every`` steps) starts from a fresh, seeded environment reset and RNG state.
    """
    cfg.check()
    sets = open_map_sets(cfg)
    run = Path(out_dir) / cfg.name
    with run_lock(run, f"training {cfg.name} (seed {cfg.seed})"):
        return _train(cfg, run, resume=resume, progress=progress, log_stdout=log_stdout, backend=backend,
                      sets=sets, device=torch.device(device))


def _train(cfg: TrainConfig, run: Path, *, resume: bool, progress: bool, log_stdout: bool,
           backend: Backend | None, sets: MixedMapSet | None, device: torch.device) -> Path:
    """``train``'s work, with the run folder's lock held."""
    for stale in (*run.glob(".*.tmp*"), *run.glob("tb/.*.tmp*")):  # half-written files of a killed run
        stale.unlink()
    if resume:
        state = read_state(run)
        if state is None:
            raise FileNotFoundError(f"nothing to resume in {run}: no checkpoint.zip (the run was stopped before "
                                    "its first checkpoint; start it again without --resume)")
        saved = TrainConfig.from_json(run / "config.json")
        if asdict(saved) != asdict(cfg):
            raise InputError(f"{run}/config.json differs from the requested config; resume with the same config")
    else:
        state = {"phase": "bc", "round": -1, "ppo_steps": 0, "log_rows": 0}
        run.mkdir(parents=True, exist_ok=True)
        atomic_write_text(run / "config.json", json.dumps(asdict(cfg), indent=2) + "\n")
        if sets is not None:
            atomic_write_text(run / "map_sets.json", json.dumps(sets.record(), indent=1) + "\n")
    torch.set_num_threads(cfg.torch_threads)
    torch.manual_seed(cfg.seed)
    deterministic(device)
    env = make_env(cfg, cfg.seed, sets)
    # a resumed run keeps its events up to the checkpoint; a fresh one in an old run's folder, none
    trim_events(run / "tb", state.get("log_time") if resume else 0.0)
    logger, csv_log = run_logger(run, state["log_rows"] if resume else None, log_stdout)
    try:
        phases = _TrainingRun(cfg, run, state, env, logger, csv_log, resume=resume, progress=progress,
                              backend=backend, sets=sets, device=device)
        phases.dagger()
        phases.ppo()
        return phases.select()
    finally:  # a run that stops, however it stops, leaves no open log files
        logger.close()
        env.close()


def _segments(cfg: TrainConfig) -> list[tuple[int, int]]:
    """PPO's step ranges between checkpoints: every ``checkpoint_every`` steps and at the end of the warm-up."""
    ends = {*range(cfg.checkpoint_every, cfg.ppo_steps, cfg.checkpoint_every), cfg.ppo_steps}
    if 0 < cfg.value_warmup < cfg.ppo_steps:
        ends.add(cfg.value_warmup)
    bounds = [0, *sorted(e for e in ends if e > 0)]
    return list(zip(bounds[:-1], bounds[1:], strict=True))


class _StepBar(BaseCallback):
    """Advances a progress bar by the environment steps PPO takes (it draws no random numbers)."""

    def __init__(self, bar) -> None:
        super().__init__()
        self.bar = bar

    def _on_step(self) -> bool:
        self.bar.update(self.training_env.num_envs)
        return True


class _TrainingRun:
    """One training run's phases: DAgger, PPO fine-tuning, then the choice between them (see ``train``).

    Each phase starts from ``self.state`` (the committed run state) and commits after every unit of
    work, so a resumed run skips what is committed and redoes nothing else.
    """

    def __init__(self, cfg: TrainConfig, run: Path, state: dict, env, logger: RunLogger, csv_log: ResumableCSV, *,
                 resume: bool, progress: bool, backend: Backend | None = None, sets: MixedMapSet | None = None,
                 device: torch.device = _CPU) -> None:
        from stable_baselines3 import PPO

        from learning.models.extractor import policy_kwargs

        self.cfg, self.run, self.state, self.resume, self.progress = cfg, run, state, resume, progress
        self.backend, self.sets = backend, sets
        self.logger, self.csv_log = logger, csv_log
        if resume:  # our own run's checkpoint: SB3's full load (it unpickles; never point it at others' files)
            self.model = PPO.load(run / "checkpoint.zip", env=env, device=device)
        else:
            arch = policy_kwargs(cfg.features_dim, cfg.hidden, cfg.conv_channels, cfg.vector_dim)
            self.model = PPO("MultiInputPolicy", env, policy_kwargs=arch,
                             learning_rate=cfg.ppo_lr, n_steps=cfg.ppo_n_steps, batch_size=cfg.ppo_batch,
                             n_epochs=cfg.ppo_epochs, clip_range=cfg.ppo_clip, ent_coef=cfg.ppo_ent_coef,
                             gamma=cfg.gamma, seed=cfg.seed, device=device, verbose=0)
        self.model.set_logger(logger)

    def log(self, stats: dict, step: int) -> None:
        for k, v in stats.items():
            self.logger.record(k, v)
        self.logger.dump(step)

    def commit(self, state: dict, data: Dataset | None = None) -> None:
        self.state = state
        commit_checkpoint(self.model, self.cfg, self.run, state, self.csv_log, data)

    def dagger(self) -> None:
        """Rounds of expert labelling and behaviour cloning; ends by saving ``imitation.zip``."""
        cfg, model = self.cfg, self.model
        data = None
        if self.resume and self.state["phase"] == "bc" and self.state["round"] >= 0:
            data = Dataset.load(self.run / "dagger_data.npz").head(self.state["dagger_rows"])
        rounds = range(self.state["round"] + 1, cfg.dagger_rounds) if self.state["phase"] == "bc" else range(0)
        for k in tqdm(rounds, desc="DAgger", disable=not self.progress):
            rng = np.random.default_rng([cfg.seed, k])
            problems = dagger_maps(cfg, rng, cfg.maps_per_round, sets=self.sets)
            actor = FastActor(model.policy.state_dict()) if k > 0 else None
            beta = cfg.dagger_betas[min(k, len(cfg.dagger_betas) - 1)]
            t0 = time.perf_counter()
            new, its = collect(problems, actor, beta, seed=cfg.seed * 1_000_003 + k * 10_007, batch=cfg.batch,
                               step_size=cfg.step_size, stuck_threshold=cfg.stuck_threshold,
                               uniform_floor=cfg.uniform_floor, max_iterations=cfg.max_iterations, gamma=cfg.gamma,
                               reward_scale=cfg.reward_scale, backend=self.backend)
            data = new if data is None else Dataset.concat([data, new])
            # with shaping the critic must predict shaped returns: leave it to PPO's warm-up
            stats = behaviour_cloning(model.policy, data, epochs=cfg.bc_epochs, batch_size=cfg.bc_batch,
                                      lr=cfg.bc_lr, seed=cfg.seed + k, value_weight=0.0 if cfg.shaping else 0.5,
                                      mirror=cfg.mirror)
            score, fam = validation_score(FastActor(model.policy.state_dict()), cfg, self.backend, self.sets)
            self.log({**stats, "dagger/round": k, "dagger/beta": beta, "dagger/samples": len(data),
                      "dagger/median_iterations": float(np.median(its)),
                      "dagger/collect_seconds": time.perf_counter() - t0,
                      "validation/score": score, **{f"validation/{f}": v for f, v in fam.items()}}, k)
            self.commit({"phase": "bc", "round": k, "ppo_steps": 0, "bc_validation": score}, data)
        if self.state["phase"] == "bc":
            save_model(model, cfg, self.run / "imitation.zip", self.state)
            self.commit({**self.state, "phase": "ppo", "ppo_steps": 0})

    def ppo(self) -> None:
        """PPO fine-tuning in segments that each start from a seeded reset, with a checkpoint after each.

        The critic warms up first with the actor frozen, so early, noisy advantages cannot undo imitation.
        """
        cfg, model = self.cfg, self.model
        actor_params = [p for name, p in model.policy.named_parameters()
                        if name.startswith(("pi_features_extractor", "mlp_extractor.policy_net", "action_net"))]
        todo = [(start, end) for start, end in _segments(cfg) if end > self.state["ppo_steps"]]
        # PPO collects whole rollouts, so a segment of s steps runs ceil(s / rollout) rollouts: the bar
        # counts the environment steps PPO really takes, over the whole phase
        rollout = model.n_steps * model.get_env().num_envs
        bar = tqdm(total=sum(-(-(end - start) // rollout) * rollout for start, end in todo), desc="PPO",
                   unit="step", disable=not self.progress)
        for start, end in todo:
            for p in actor_params:
                p.requires_grad_(start >= cfg.value_warmup)
            # seeds every RNG PPO draws from (torch, SB3's use of numpy's global state, the env resets)
            model.set_random_seed(int(np.random.SeedSequence([cfg.seed, start]).generate_state(1)[0]))
            self.logger.step_offset = start
            model.learn(total_timesteps=end - start, reset_num_timesteps=True, callback=_StepBar(bar),
                        tb_log_name="ppo")
            self.logger.dump(model.num_timesteps)  # the last update's statistics, before the checkpoint, not after
            self.commit({**self.state, "ppo_steps": end})
        bar.close()
        for p in actor_params:
            p.requires_grad_(True)
        self.logger.step_offset = 0

    def select(self) -> Path:
        """Keep PPO's or imitation's weights, whichever scores better on the validation maps; write ``final.zip``."""
        cfg, model = self.cfg, self.model
        ppo_score, ppo_fam = validation_score(FastActor(model.policy.state_dict()), cfg, self.backend, self.sets)
        _, imitation_params = read_sb3_zip(self.run / "imitation.zip")
        bc_score, bc_fam = validation_score(FastActor(imitation_params), cfg, self.backend, self.sets)
        chosen = "ppo" if ppo_score <= bc_score else "imitation"
        summary = {"chosen": chosen, "validation_ppo": ppo_score, "validation_imitation": bc_score,
                   "validation_ppo_families": ppo_fam, "validation_imitation_families": bc_fam}
        self.log({"validation/final_ppo": ppo_score, "validation/final_imitation": bc_score}, cfg.dagger_rounds + 1)
        if chosen == "imitation":
            model.policy.load_state_dict(imitation_params)
        final = self.run / "final.zip"
        save_model(model, cfg, final, {**self.state, **summary, "log_rows": self.csv_log.rows})
        atomic_write_text(self.run / "summary.json", json.dumps(summary, indent=2) + "\n")
        return final
