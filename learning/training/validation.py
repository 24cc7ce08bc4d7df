"""The validation score that picks a run's final policy: median iterations / lower bound on validation maps.

Validation maps come from ``VALIDATION_SEED0`` (``planners.maps.generators``), or from the validation
parts of the run's map sets, so no map the evaluation uses is ever looked at.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from learning.models.fast_policy import FastActor
from learning.samplers.policy import PolicySampler
from learning.training.config import TrainConfig
from planners import RRT, Sampler
from planners.maps.generators import VALIDATION_SEED0, generate
from planners.maps.gridsearch import distance_field
from planners.maps.mapset import MixedMapSet
from planners.tools.parallel import Backend, LocalBackend


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
