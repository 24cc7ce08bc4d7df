"""The tuning split: which goal bias, frontier probability and policy batch each map set gets."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from learning.evaluation.protocol import Protocol, Query
from learning.evaluation.roster import CONSTANT, Task, bias_spec, constant_spec, policy_spec, spec_bias
from learning.samplers.ablation import FRONTIER_GRID
from learning.samplers.registry import SamplerSpec
from planners.tools.benchmark import Run

GOAL_BIASES = (0.01, 0.05, 0.1, 0.2, 0.5)


#: The grid the best goal bias is chosen from: uniform sampling (bias 0) and the sweep.
TUNING_BIASES = (0.0, *GOAL_BIASES)


def spec_of(run: Run) -> SamplerSpec | None:
    """The sampler spec a run recorded, or None where it recorded none."""
    return SamplerSpec.from_json(run.sampler_spec) if run.sampler_spec else None


def constant_tuning_tasks(queries: Sequence[Query], planner: str, protocol: Protocol, batch: int) -> list[Task]:
    """Runs that tune the ablation: every frontier probability of ``FRONTIER_GRID`` on every tuning query.

    The ablation decides every ``batch`` samples, as the policy does.
    """
    return [Task(q, planner, constant_spec(p, protocol, batch), 0) for q in queries if q.split == "tuning"
            for p in FRONTIER_GRID]


def constant_test_tasks(queries: Sequence[Query], planner: str, protocol: Protocol, batch: int, best: dict,
                        seeds: int) -> list[Task]:
    """The ablation on the test split, at the frontier probability tuned for each query's map set.

    Labelled as one sampler, ``constant (tuned)``, whatever that probability; the spec records it.
    """
    return [Task(q, planner, constant_spec(best[(q.map_set, planner)], protocol, batch), seed, CONSTANT)
            for q in queries if q.split == "test" and (q.map_set, planner) in best for seed in range(seeds)]


#: The policy's batches (samples per decision; the training batch is 8) tried on the tuning split.
POLICY_BATCHES = (8, 2, 1)


#: Planner seeds per tuning query for the batch: one choice for every map set deserves more than one seed.
POLICY_TUNING_SEEDS = 3


#: In the sum of log medians: batches within 1% of one family's median of the lowest count as tied.
BATCH_TIE = 0.01


def policy_tuning_tasks(queries: Sequence[Query], planner: str, policy: str,
                        batches: Sequence[int] = POLICY_BATCHES, seeds: int = POLICY_TUNING_SEEDS) -> list[Task]:
    """Runs that choose the batch of checkpoint ``policy``: every batch on every generated family's tuning query.

    MovingAI scenarios are left out, so the choice does not depend on whether those maps are at hand.
    """
    return [Task(q, planner, policy_spec(policy, b), s) for q in queries if q.split == "tuning" and q.size
            for b in batches for s in range(seeds)]


def best_policy_batch(runs: Sequence[Run]) -> tuple[int, dict[int, float]]:
    """(chosen batch, sum of log median iterations per batch) from ``policy_tuning_tasks``' runs.

    The score sums, over map sets, the log of the median iterations (unsolved runs count as the cap),
    so every family weighs the same whatever its scale. Batches within :data:`BATCH_TIE` of the lowest
    score are tied and the largest of them wins: it takes fewer forward passes.
    """
    groups: dict = {}
    for r in runs:
        spec = spec_of(r)
        b = spec.param("batch") if spec is not None and spec.name == "policy" else None
        if r.split == "tuning" and b is not None:
            groups.setdefault(b, {}).setdefault(r.map, []).append(r.iterations)
    if not groups:
        raise ValueError("no tuning runs of the policy's batches")
    score = {b: float(sum(np.log(np.median(its)) for its in fams.values())) for b, fams in groups.items()}
    low = min(score.values())
    return max(b for b, v in score.items() if v <= low + BATCH_TIE), score


def tuning_tasks(queries: Sequence[Query], planner: str) -> list[Task]:
    """Runs that choose the best goal bias: every bias of :data:`TUNING_BIASES` on every tuning query."""
    return [Task(q, planner, bias_spec(b), 0) for q in queries if q.split == "tuning" for b in TUNING_BIASES]


def pooled(runs: Sequence[Run], name: str, families: Sequence[str]) -> list[Run]:
    """Copies of the runs on ``families`` relabelled as one family ``name`` (e.g. all MovingAI maps).

    The best bias is then tuned, and the summary taken, over the pool as a whole.
    """
    from dataclasses import replace

    keep = set(families)
    return [replace(r, map=name) for r in runs if r.map in keep]


def best_bias(runs: Sequence[Run]) -> dict[tuple[str, str], float]:
    """Per (family, planner): the goal bias with the lowest median iterations on the tuning split.

    Uniform runs count as bias 0, so the choice is never worse than uniform on the tuning split
    (0 is returned where uniform is best). Test-split runs are never looked at.
    """
    return _best_on_tuning(runs, spec_bias)


def best_constant(runs: Sequence[Run]) -> dict[tuple[str, str], float]:
    """Per (family, planner): the ablation's frontier probability with the lowest median on the tuning split."""
    return _best_on_tuning(runs, lambda s: s.param("frontier") if s.name == "policy_ablation" else None)


def _best_on_tuning(runs: Sequence[Run], value_of) -> dict[tuple[str, str], float]:
    out: dict = {}
    groups: dict = {}
    for r in runs:
        spec = spec_of(r) if r.split == "tuning" else None
        b = None if spec is None else value_of(spec)
        if b is not None:
            groups.setdefault((r.map, r.planner, b), []).append(r.iterations if r.solved else math.inf)
    # ascending bias: a tie keeps the smaller bias, the one nearer uniform
    for (fam, planner, b), its in sorted(groups.items(), key=lambda kv: kv[0][2]):
        med = float(np.median(its))
        key = (fam, planner)
        if key not in out or med < out[key][1]:
            out[key] = (b, med)
    return {k: v[0] for k, v in out.items()}
