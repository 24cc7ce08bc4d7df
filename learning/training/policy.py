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
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import os
import re
import time
import zipfile
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import torch
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.logger import KVWriter, Logger, make_output_format
from tqdm.auto import tqdm

from learning.models.checkpoint import read_sb3_zip
from learning.device import deterministic
from learning.models.fast_policy import FastActor
from learning.training.imitation import Dataset, behaviour_cloning, collect
from learning.samplers.policy import OBS_VERSION, PolicySampler
from planners import RRT, Sampler
from planners.base.fileio import (
    InputError,
    atomic_path,
    atomic_write_text,
    check_number,
    read_json,
    run_lock,
    short_repr,
)
from planners.maps.generators import FAMILIES, MIN_SIZE, TRAIN_SEEDS, VALIDATION_SEED0, check_size, generate
from planners.maps.gridsearch import distance_field
from planners.maps.mapset import MapSet, MixedMapSet
from planners.tools.parallel import Backend, LocalBackend


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


def _maps(cfg: TrainConfig, rng: np.random.Generator, per_family: int, seed0: int | None = None,
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


def validation_score(actor: FastActor, cfg: TrainConfig, backend: Backend | None = None,
                     sets: MixedMapSet | None = None) -> tuple[float, dict]:
    """The policy ``actor``'s :func:`sampler_validation_score`."""
    return sampler_validation_score(PolicySampler(actor, cfg.sampler_config()), cfg, backend, sets)


def sampler_validation_score(sampler: Sampler, cfg: TrainConfig, backend: Backend | None = None,
                             sets: MixedMapSet | None = None) -> tuple[float, dict]:
    """Geometric mean over families of ``sampler``'s median iterations / lower bound on validation maps.

    With ``sets`` (``open_map_sets``): over the groups of the sets' validation queries (a folder set
    is one group), the first ``validation_maps`` queries of each. The runs go to ``backend``
    (default: this process) with the sampler shipped once per worker.
    """
    if sets is not None:
        return _set_validation_score(sampler, cfg, backend, sets)
    tasks = [(f, i) for f in cfg.families for i in range(cfg.validation_maps)]
    context = {"sampler": sampler, "cfg": cfg}
    ratios = (backend or LocalBackend()).map(_validation_run, tasks, context=context)
    per_family = {f: float(np.median([r for (g, _), r in zip(tasks, ratios, strict=True) if g == f]))
                  for f in cfg.families}
    return float(np.exp(np.mean(np.log(list(per_family.values()))))), per_family


def _validation_run(task: tuple[str, int], context: dict) -> float:
    """Iterations / lower bound of the sampler on validation map ``i`` of a family (20,000 if unsolved)."""
    f, i = task
    cfg = context["cfg"]
    p = generate(f, VALIDATION_SEED0 + i, cfg.sizes[i % len(cfg.sizes)], goal_tolerance=cfg.goal_tolerance)
    r = RRT(p, step_size=cfg.step_size, sampler=context["sampler"], seed=i).solve(max_iterations=20000)
    return r.iterations / p.iteration_lower_bound(cfg.step_size) if r.solved else 20000.0


def _set_validation_score(sampler: Sampler, cfg: TrainConfig, backend: Backend | None,
                          sets: MixedMapSet) -> tuple[float, dict]:
    """``sampler_validation_score`` on the validation parts of map sets."""
    tasks, taken = [], {}
    for j, ms in enumerate(sets.sets):
        for q in ms.queries("validation"):
            group = q.group if len(sets.sets) == 1 else f"{ms.name}: {q.group}"
            if taken.get(group, 0) < cfg.validation_maps:
                taken[group] = taken.get(group, 0) + 1
                tasks.append((group, j, q))
    ratios = (backend or LocalBackend()).map(_set_validation_run, tasks,
                                             context={"sampler": sampler, "cfg": cfg, "sets": sets})
    per_group = {g: float(np.median([r for (h, _, _), r in zip(tasks, ratios, strict=True) if h == g]))
                 for g in taken}
    return float(np.exp(np.mean(np.log(list(per_group.values()))))), per_group


def _set_validation_run(task: tuple, context: dict) -> float:
    """Iterations / lower bound of the sampler on one validation query of a map set (20,000 if unsolved)."""
    _, j, q = task
    cfg = context["cfg"]
    p = context["sets"].sets[j].problem(q)
    if p.reference_length is None:  # a drawn query or a queries file: the grid search's octile length
        grid = p.world
        length = distance_field(grid.obstacles, grid.cell_of(p.goal))[grid.cell_of(p.start)] * grid.resolution
        p = dataclasses.replace(p, reference_length=float(length))
    r = RRT(p, step_size=cfg.step_size, sampler=context["sampler"], seed=q.key).solve(max_iterations=20000)
    return r.iterations / p.iteration_lower_bound(cfg.step_size) if r.solved else 20000.0


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

    from envs import SamplerEnv
    from envs.sources import MapSetSource

    def factory():
        source = _MixedFamilies(cfg) if sets is None else MapSetSource(sets, "train")
        env = SamplerEnv(source, planner="rrt", step_size=cfg.step_size,
                         max_iterations=cfg.max_iterations, action_mode="guided", observation="egocentric",
                         uniform_floor=cfg.uniform_floor, shaping=cfg.shaping, shaping_gamma=cfg.gamma)
        return gym.wrappers.TransformReward(env, lambda r: r * cfg.reward_scale)

    return make_vec_env(factory, n_envs=cfg.n_envs, seed=seed, vec_env_cls=DummyVecEnv)


#: Key of the run state inside a checkpoint's ``data`` entry.
STATE_KEY = "samplergym_state"
#: Key of the sampler config inside a checkpoint's ``data`` entry (read by ``PolicySampler.load``).
CONFIG_KEY = "samplergym_config"


def _save_model(model, cfg: TrainConfig, path: Path, state: dict) -> None:
    """Write ``model`` as an SB3 zip whose ``data`` also carries the sampler config and the run state.

    The two entries are added to the zip SB3 writes rather than set on the model, so nothing of
    ours lives in SB3's object; the file appears whole or not at all.
    """
    buf = io.BytesIO()
    model.save(buf)
    buf.seek(0)
    with atomic_path(path) as tmp, zipfile.ZipFile(buf) as src, zipfile.ZipFile(tmp, "w") as dst:
        for item in src.infolist():
            blob = src.read(item.filename)
            if item.filename == "data":
                data = json.loads(blob)
                data[CONFIG_KEY], data[STATE_KEY] = cfg.sampler_config(), state
                blob = json.dumps(data, indent=4).encode()
            dst.writestr(item, blob)


def _commit(model, cfg: TrainConfig, run: Path, state: dict, log: _ResumableCSV, data: Dataset | None = None) -> None:
    """One checkpoint, written so that a kill at any instant leaves the previous one or this one.

    ``checkpoint.zip`` is the commit point: it holds the weights, the optimiser and the run state.
    The DAgger data is written before it and only grows, so the state's row count tells how much of
    it belongs to the checkpoint; log rows after ``log_rows`` are dropped on resume the same way.
    ``state.json`` is a copy for people, written last and never read back.
    """
    state = {**state, "log_rows": log.rows, "log_time": time.time()}
    if data is not None:
        with atomic_path(run / "dagger_data.npz") as tmp:
            data.save(tmp)
        state["dagger_rows"] = len(data)
    _save_model(model, cfg, run / "checkpoint.zip", state)
    atomic_write_text(run / "state.json", json.dumps(state, indent=2) + "\n")


def _trim_events(folder: Path, until: float | None) -> None:
    """Drop the TensorBoard events written after wall time ``until`` (a killed run's, after its checkpoint).

    The redone steps are logged again on resume; kept, TensorBoard would draw each of them twice.
    Each events file is rewritten whole (temporary file, then rename); a file left with nothing after
    its header is removed.
    """
    if until is None or not folder.is_dir():
        return
    from tensorboard.backend.event_processing.event_file_loader import RawEventFileLoader
    from tensorboard.compat.proto import event_pb2
    from tensorboard.summary.writer.record_writer import RecordWriter

    for path in sorted(folder.glob("events.out.tfevents.*")):
        records = list(RawEventFileLoader(str(path)).Load())
        kept = [r for r in records if event_pb2.Event.FromString(r).wall_time <= until]
        if len(kept) == len(records):
            continue
        if len(kept) <= 1:  # at most the file-version header: the whole file came after the checkpoint
            path.unlink()
            continue
        with atomic_path(path) as tmp, open(tmp, "wb") as f:
            writer = RecordWriter(f)
            for r in kept:
                writer.write(r)
            writer.flush()


def read_state(run: str | os.PathLike) -> dict | None:
    """The run state committed in ``<run>/checkpoint.zip``, or None if the run has no checkpoint yet."""
    ckpt = Path(run) / "checkpoint.zip"
    if not ckpt.is_file():
        return None
    data, _ = read_sb3_zip(ckpt)
    state = data.get(STATE_KEY)
    if not isinstance(state, dict) or not {"phase", "round", "ppo_steps", "log_rows"} <= state.keys():
        raise InputError(f"{ckpt} carries no training state: it was not written by this version of "
                         "scripts/train.py; start the run again without --resume")
    if state["phase"] not in ("bc", "ppo"):
        raise InputError(f"{ckpt}: training state phase = {short_repr(state['phase'])}, expected 'bc' or 'ppo'")
    for key, low in (("round", -1), ("ppo_steps", 0), ("log_rows", 0), ("dagger_rows", 0)):
        if key in state:
            check_number(f"{ckpt}: training state", key, state[key], integer=True, low=low)
    if "log_time" in state:
        check_number(f"{ckpt}: training state", "log_time", state["log_time"])
    if state["phase"] == "bc" and state["round"] >= 0 and "dagger_rows" not in state:
        raise InputError(f"{ckpt}: training state in DAgger round {state['round']} has no dagger_rows")
    return state


class _ResumableCSV(KVWriter):
    """``progress.csv`` that a resumed run continues: rows after the checkpoint are dropped, not the rest.

    A Stable-Baselines3 ``KVWriter``. SB3's own CSV writer truncates the file when it opens it and
    rewrites it in place when a new column appears; this one rewrites atomically and appends otherwise.
    """

    def __init__(self, path: Path, keep_rows: int | None) -> None:
        self.path = path
        self.keys: list[str] = []
        self.table: list[list[str]] = []
        if keep_rows is not None and path.is_file():
            with open(path, newline="", encoding="utf-8") as f:
                rows = list(csv.reader(f))
            if rows:
                self.keys, self.table = rows[0], rows[1:keep_rows + 1]
        self._rewrite()

    @property
    def rows(self) -> int:
        return len(self.table)

    def _rewrite(self) -> None:
        with atomic_path(self.path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as f:
            w = csv.writer(f)
            if self.keys:
                w.writerow(self.keys)
            w.writerows(row + [""] * (len(self.keys) - len(row)) for row in self.table)
        self.file = open(self.path, "a", newline="", encoding="utf-8")  # noqa: SIM115 - closed in close()

    def write(self, key_values: dict, key_excluded: dict, step: int = 0) -> None:
        values = {k: v for k, v in key_values.items() if "csv" not in (key_excluded.get(k) or ())}
        new = [k for k in values if k not in self.keys]
        row = ["" if values.get(k) is None else str(values[k]) for k in self.keys + new]
        self.table.append(row)
        if new:
            self.keys += new
            self.file.close()
            self._rewrite()
        else:
            csv.writer(self.file).writerow(row)
            self.file.flush()

    def close(self) -> None:
        self.file.close()


class _RunLogger(Logger):
    """SB3 logger whose ``step_offset`` is added to every step: SB3 counts each PPO segment's steps from zero."""

    step_offset = 0

    def dump(self, step: int = 0) -> None:
        if self.step_offset:
            self.record("time/run_timesteps", step + self.step_offset)
        super().dump(step + self.step_offset)


def _logger(run: Path, keep_rows: int | None, stdout: bool) -> tuple[_RunLogger, _ResumableCSV]:
    """The run's logger: TensorBoard events and ``progress.csv`` under ``<run>/tb`` (and stdout)."""
    folder = run / "tb"
    folder.mkdir(parents=True, exist_ok=True)
    csv_log = _ResumableCSV(folder / "progress.csv", keep_rows)
    formats = [make_output_format("tensorboard", str(folder)), csv_log]
    if stdout:
        formats.append(make_output_format("stdout", str(folder)))
    return _RunLogger(str(folder), formats), csv_log


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
    _trim_events(run / "tb", state.get("log_time") if resume else 0.0)
    logger, csv_log = _logger(run, state["log_rows"] if resume else None, log_stdout)
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

    def __init__(self, cfg: TrainConfig, run: Path, state: dict, env, logger: _RunLogger, csv_log: _ResumableCSV, *,
                 resume: bool, progress: bool, backend: Backend | None = None, sets: MixedMapSet | None = None,
                 device: torch.device = torch.device("cpu")) -> None:
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
        _commit(self.model, self.cfg, self.run, state, self.csv_log, data)

    def dagger(self) -> None:
        """Rounds of expert labelling and behaviour cloning; ends by saving ``imitation.zip``."""
        cfg, model = self.cfg, self.model
        data = None
        if self.resume and self.state["phase"] == "bc" and self.state["round"] >= 0:
            data = Dataset.load(self.run / "dagger_data.npz").head(self.state["dagger_rows"])
        rounds = range(self.state["round"] + 1, cfg.dagger_rounds) if self.state["phase"] == "bc" else range(0)
        for k in tqdm(rounds, desc="DAgger", disable=not self.progress):
            rng = np.random.default_rng([cfg.seed, k])
            problems = _maps(cfg, rng, cfg.maps_per_round, sets=self.sets)
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
            _save_model(model, cfg, self.run / "imitation.zip", self.state)
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
        _save_model(model, cfg, final, {**self.state, **summary, "log_rows": self.csv_log.rows})
        atomic_write_text(self.run / "summary.json", json.dumps(summary, indent=2) + "\n")
        return final
