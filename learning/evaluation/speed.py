"""Measurement helpers behind ``scripts/benchmark_policy.py``: what a learned sampler costs per query.

Two figures: the time of one forward pass of the compiled actor on observations taken from real
planning runs (their sparsity is what a pass sees in use), and per-query wall time of RRT with the
policy against goal bias, timed as ``learning.evaluation`` times a run (binding included), with the
forward passes each query took with and without the frontier hold.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numba as nb
import numpy as np

from learning.evaluation.protocol import Protocol
from learning.models.fast_policy import FastActor, actor_logits
from learning.samplers.policy import PolicySampler
from planners import RRT, GoalBiasedSampler, Problem, Sampler
from planners.guidance.guided import GuidedSampling

#: The comparison's protocol: its step and iteration cap are what a query is timed at.
DEFAULT = Protocol()


def observations(sampler: PolicySampler, problems: Sequence[Problem], step_size: float = DEFAULT.step,
                 seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """The egocentric observations the training environment builds at each draw of RRT runs with ``sampler``."""
    plain = PolicySampler(sampler.actor, sampler.config, fuse=False)
    local, vector = [], []
    for p in problems:
        guide = GuidedSampling(p, step_size, uniform_floor=plain.config["uniform_floor"],
                               max_iterations=plain.config["max_iterations"])
        planner = RRT(p, step_size=step_size, sampler=plain, seed=seed)
        draw = planner.sampler.draw

        def recording(rng, n, view, draw=draw, guide=guide):
            guide.update(view)
            obs = guide.observe(view)
            local.append(obs["local"])
            vector.append(obs["vector"])
            return draw(rng, n, view)

        planner.sampler.draw = recording
        planner.solve(max_iterations=DEFAULT.max_iterations)
    return np.stack(local), np.stack(vector).astype(np.float32)


@nb.njit(cache=True)
def _passes(local, vector, weights, scratch, logits):
    for i in range(local.shape[0]):
        actor_logits(local[i], vector[i], *weights, scratch, logits)


def forward_pass_us(actor: FastActor, local: np.ndarray, vector: np.ndarray, repeats: int = 20) -> float:
    """Microseconds per forward pass over the observations (best of ``repeats`` sweeps, compiled loop)."""
    scratch = np.empty(actor.scratch_size(local.shape[1], local.shape[2]), dtype=np.float32)
    logits = np.empty(actor.num_actions, dtype=np.float32)
    args = (np.ascontiguousarray(local), np.ascontiguousarray(vector), actor.weights, scratch, logits)
    _passes(*args)  # compile and warm up
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        _passes(*args)
        best = min(best, time.perf_counter() - t0)
    return best / len(local) * 1e6


def query_times(policy: PolicySampler, bias: float, problems: Sequence[Problem], seeds: int = 2,
                step_size: float = DEFAULT.step,
                extra: dict[str, Sampler] | None = None) -> dict[str, dict[str, float]]:
    """Medians per query: wall time (ms), iterations, forward passes and wall time per iteration (us).

    Samplers: the policy, the policy without its hold, goal bias, and ``extra`` (e.g. an ``SB3Sampler``).
    Runs of the samplers are interleaved query by query, so drifts in the machine's speed hit all alike.
    """
    samplers = {"policy": policy, "policy, no hold": PolicySampler(policy.actor, policy.config, hold=2.0),
                f"goal bias {bias:g}": GoalBiasedSampler(bias), **(extra or {})}
    rows: dict[str, list] = {k: [] for k in samplers}
    for p in problems:
        for seed in range(seeds):
            for name, sampler in samplers.items():
                t0 = time.perf_counter()
                planner = RRT(p, step_size=step_size, sampler=sampler, seed=seed)
                r = planner.solve(max_iterations=DEFAULT.max_iterations)
                wall = time.perf_counter() - t0
                rows[name].append((wall * 1e3, r.iterations, getattr(planner.sampler, "forward_passes", 0),
                                   wall * 1e6 / max(r.iterations, 1)))
    keys = ("wall_ms", "iterations", "forward_passes", "us_per_iteration")
    return {name: dict(zip(keys, np.median(np.array(v), axis=0).tolist(), strict=True)) for name, v in rows.items()}
