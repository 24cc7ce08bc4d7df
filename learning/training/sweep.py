"""Searches over the training recipe and over the baselines' parameters, on Ray Tune.

Every trial is scored on the validation maps (seeds from ``VALIDATION_SEED0``): a recipe trial trains
a policy and scores it as training's own model selection does (:func:`learning.training.policy.validation_score`);
a baseline trial scores goal bias or the constant-distribution ablation at one setting the same way.
Tuning and test maps are never looked at, so a chosen config can be evaluated honestly afterwards.
Tune keeps the experiment's state on disk: an interrupted sweep resumes (:func:`run_sweep` with
``resume=True``) and reruns only the trials that had not finished. Each trial's config and score go to
TensorBoard (``tensorboard --logdir <out>/<name>``).

Resuming trusts the folder: Ray Tune stores its experiment state pickled (``tuner.pkl`` and the
trials' state), and restoring it unpickles, which can run code placed there. A sweep folder
therefore carries :data:`MANIFEST`, written by :func:`run_sweep` when it starts the sweep, and a
folder without it (or of another kind of sweep) is refused. The manifest is a guard against
resuming the wrong folder, not a signature: resume only sweeps you started yourself, never a folder
someone handed you (read its ``*.chosen.json`` and ``result.json`` files instead: plain JSON).
"""

from __future__ import annotations

import json
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np

from learning.samplers.ablation import FRONTIER_GRID, ConstantGuidedSampler
from learning.training.policy import TrainConfig, sampler_validation_score, train
from planners import GoalBiasedSampler
from planners.base.fileio import InputError, atomic_write_text, read_json, run_lock
from planners.maps.generators import VALIDATION_SEED0
from planners.tools.parallel import make_backend

#: The file :func:`run_sweep` writes into every sweep folder it starts; ``resume`` refuses a folder without it.
MANIFEST = "samplergym-sweep.json"

METRIC = "validation_score"  # geometric mean over families of median iterations / lower bound (lower is better)

#: The recipe search space: values per ``TrainConfig`` field, drawn at random per trial.
RECIPE_SPACE = {
    "dagger_rounds": [4, 6, 8, 10],
    "maps_per_round": [50, 100, 150],
    "bc_epochs": [4, 6, 8],
    "bc_lr": [3e-4, 1e-3, 3e-3],
    "uniform_floor": [0.02, 0.05, 0.1],
    "stuck_threshold": [8, 16, 32],
}
#: Goal biases and ablation frontier probabilities a baseline sweep tries (a grid, every value once).
BASELINE_GRID = [("goal_bias", b) for b in (0.0, 0.01, 0.02, 0.05, 0.1, 0.2, 0.3, 0.5)] + [
    ("constant", p) for p in FRONTIER_GRID]


def baseline_score(kind: str, value: float, cfg: TrainConfig) -> tuple[float, dict]:
    """The validation score of goal bias ``value`` or of the ablation at frontier probability ``value``.

    Same maps, seeds and metric as a trained policy's validation score under ``cfg``.
    """
    sampler = GoalBiasedSampler(value) if kind == "goal_bias" else ConstantGuidedSampler(value, step_size=cfg.step_size)
    return sampler_validation_score(sampler, cfg)


def _config(base: dict) -> TrainConfig:
    d = dict(base)
    for k in ("families", "sizes", "dagger_betas", "conv_channels"):
        d[k] = tuple(d[k])
    return TrainConfig(**d)


def _recipe_trial(params: dict, base: dict) -> None:
    from ray import tune

    cfg = replace(_config(base), name="trial", **params)
    cfg.check("sweep trial")
    run_dir = Path(tune.get_context().get_trial_dir())
    final = train(cfg, run_dir, progress=False, log_stdout=False)
    summary = json.loads((final.parent / "summary.json").read_text())
    score = min(summary["validation_ppo"], summary["validation_imitation"])
    tune.report({METRIC: score, "kept": summary["chosen"], "checkpoint": str(final)})


def _baseline_trial(params: dict, base: dict) -> None:
    from ray import tune

    kind, value = params["baseline"]
    score, per_family = baseline_score(kind, float(value), _config(base))
    tune.report({METRIC: score, **{f"validation_{f}": v for f, v in per_family.items()}})


def run_sweep(kind: str, out_dir: str | Path, *, name: str | None = None, samples: int = 20, seed: int = 0,
              base: TrainConfig | None = None, space: dict | None = None, resume: bool = False,
              address: str | None = None, processes: int | None = None) -> dict:
    """Run (or resume) a sweep and return the chosen trial: ``{"config": ..., "score": ...}``.

    Args:
        kind: ``"recipe"`` (random search over ``space``) or ``"baselines"`` (every setting of ``BASELINE_GRID``).
        out_dir: Tune's storage folder; the sweep lives in ``out_dir/name``, the choice in ``name.chosen.json``.
        name: The sweep's folder name; default ``"<kind>-sweep"``.
        samples: Recipe trials.
        seed: Seeds the recipe search's draws.
        base: The recipe the search varies (and whose validation maps score every trial).
        space: Values per ``TrainConfig`` field for a recipe search; default ``RECIPE_SPACE``.
        resume: Continue the sweep stored at ``out_dir/name`` (finished trials are kept, not rerun).
        address: A Ray cluster to join; default a local instance.
        processes: CPUs of that local instance; default ``os.cpu_count()``.
    """
    if kind not in ("recipe", "baselines"):
        raise ValueError(f"unknown sweep {kind!r}; choose recipe or baselines")
    base = base or TrainConfig()
    base.check("sweep base config")
    name = name or f"{kind}-sweep"
    storage = Path(out_dir).resolve()
    if resume:
        check_resumable(storage / name, kind)
    with run_lock(storage / name, f"{kind} sweep {name}"):
        cluster = make_backend("ray", processes=processes, address=address)  # joins, or starts a local instance
        try:
            return _tune(kind, storage, name, samples, seed, base, space, resume)
        finally:  # however the sweep ends (an interrupt included), the workers stop with the instance
            cluster.close()


class SweepInterrupted(KeyboardInterrupt):
    """Tune stopped the sweep on an interrupt before every trial finished; ``finished`` of ``total`` are kept."""

    def __init__(self, finished: int, total: int) -> None:
        super().__init__(f"{finished} of {total} trials finished")
        self.finished, self.total = finished, total


def check_resumable(path: Path, kind: str) -> None:
    """Refuse to resume ``path`` unless this project started a ``kind`` sweep there (see the module docs)."""
    if not path.is_dir():
        raise InputError(f"nothing to resume in {path}: no sweep there (start it without --resume)")
    manifest = path / MANIFEST
    if not manifest.is_file():
        raise InputError(f"{path} was not started by scripts/sweep.py (no {MANIFEST}); resuming unpickles Ray "
                         "Tune's state, which can run code, so only sweeps started here are resumed")
    info = read_json(manifest, "sweep manifest")
    if not isinstance(info, dict) or info.get("kind") != kind:
        got = info.get("kind") if isinstance(info, dict) else None
        raise InputError(f"{manifest}: a {got!r} sweep, not a {kind!r} one; resume it with its own kind")


def _tune(kind: str, storage: Path, name: str, samples: int, seed: int, base: TrainConfig, space: dict | None,
          resume: bool) -> dict:
    from ray import tune
    from ray.tune.logger import CSVLoggerCallback, JsonLoggerCallback, TBXLoggerCallback
    from ray.tune.search.basic_variant import BasicVariantGenerator

    path = storage / name
    fn = _recipe_trial if kind == "recipe" else _baseline_trial
    trainable = tune.with_resources(tune.with_parameters(fn, base=asdict(base)), {"cpu": 1})
    if resume:
        if not tune.Tuner.can_restore(str(path)):
            raise InputError(f"nothing to resume in {path}: no Tune experiment there (start it without --resume)")
        tuner = tune.Tuner.restore(str(path), trainable=trainable, resume_unfinished=True, resume_errored=True)
    else:
        if kind == "recipe":
            space = {k: tune.choice(list(v)) for k, v in (space or RECIPE_SPACE).items()}
            search = BasicVariantGenerator(random_state=np.random.RandomState(seed))  # Tune's API takes this type
            tune_config = tune.TuneConfig(metric=METRIC, mode="min", num_samples=samples, search_alg=search)
        else:
            space = {"baseline": tune.grid_search([list(b) for b in BASELINE_GRID])}
            tune_config = tune.TuneConfig(metric=METRIC, mode="min", num_samples=1)
        path.mkdir(parents=True, exist_ok=True)
        record = {"kind": kind, "name": name, "written_by": "learning.training.sweep", "base": asdict(base)}
        atomic_write_text(path / MANIFEST, json.dumps(record, indent=1, default=list) + "\n")
        callbacks = [CSVLoggerCallback(), JsonLoggerCallback(), TBXLoggerCallback()]
        tuner = tune.Tuner(trainable, param_space=space, tune_config=tune_config,
                           run_config=tune.RunConfig(name=name, storage_path=str(storage), callbacks=callbacks,
                                                     verbose=0))
    results = tuner.fit()
    unfinished = [r for r in results if r.error is None and METRIC not in (r.metrics or {})]
    if unfinished:  # Tune stops gracefully on Ctrl-C and returns what it has
        raise SweepInterrupted(len(results) - len(unfinished), len(results))
    errors = [r.error for r in results if r.error is not None]
    if errors:
        raise RuntimeError(f"{len(errors)} of {len(results)} trials failed; the first: {errors[0]!r}")
    best = results.get_best_result(metric=METRIC, mode="min")
    chosen = {"kind": kind, "config": best.config, "score": best.metrics[METRIC], "trials": len(results),
              "scores": sorted(float(r.metrics[METRIC]) for r in results),
              "picked_on": f"validation maps: seeds {VALIDATION_SEED0}+, {base.validation_maps} per family"}
    if kind == "recipe":
        chosen["recipe"] = {**asdict(base), **best.config}
    atomic_write_text(storage / f"{name}.chosen.json", json.dumps(chosen, indent=2, default=str) + "\n")
    return chosen
