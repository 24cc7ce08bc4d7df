"""Imitation of the privileged expert with DAgger, in the planner itself.

Labels: the guided class containing the expert's target (one step ahead of the tree's geodesic
progress), or ``FRONTIER`` once the progress vertex has been stuck for more than
``stuck_threshold`` iterations, a signal the policy sees in its ``stuck`` feature. DAgger (Ross et
al. 2011, arXiv:1011.0686) executes a mixture of expert and current policy so that the policy also
learns in the states its own mistakes lead to.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch

from learning.models.fast_policy import FastActor
from learning.references.expert import GeodesicExpert
from learning.samplers.policy import sample_classes
from planners import RRT, Problem, SamplerBase
from planners.guidance.guided import ANGLES, FRONTIER, GuidedSampling
from planners.tools.parallel import Backend, LocalBackend


@dataclass
class Dataset:
    """Observations with expert labels and value targets."""

    local: np.ndarray  # (N, C, 16, 16) uint8
    vector: np.ndarray  # (N, k) float32
    label: np.ndarray  # (N,) int64
    value: np.ndarray  # (N,) float32, discounted return-to-go of the run, in scaled reward units

    def __len__(self) -> int:
        return len(self.label)

    @staticmethod
    def concat(parts: Sequence[Dataset]) -> Dataset:
        return Dataset(*(np.concatenate([getattr(p, f) for p in parts]) for f in ("local", "vector", "label", "value")))

    def head(self, n: int) -> Dataset:
        """The first ``n`` rows (a resumed run drops rows written after its checkpoint)."""
        if n > len(self):
            raise ValueError(f"the DAgger data holds {len(self)} rows, the checkpoint counts {n}")
        return Dataset(self.local[:n], self.vector[:n], self.label[:n], self.value[:n])

    def save(self, path) -> None:
        np.savez_compressed(path, local=self.local, vector=self.vector, label=self.label, value=self.value)

    @staticmethod
    def load(path) -> Dataset:
        with np.load(path) as z:
            return Dataset(z["local"], z["vector"], z["label"], z["value"])


class DaggerSampler(SamplerBase):
    """Records (observation, expert label) at every forward pass; executes expert or policy.

    Args:
        actor: Current policy (None: expert only).
        beta: Probability that a batch follows the expert's label instead of the policy.
        batch: Samples per decision (as at inference).
        step_size: Planner step.
        stuck_threshold: Label ``FRONTIER`` after this many iterations without progress.
        uniform_floor: As at inference.
    """

    def __init__(self, actor: FastActor | None, beta: float, batch: int, step_size: float, stuck_threshold: int,
                 uniform_floor: float, max_iterations: int) -> None:
        self.actor, self.beta, self.batch = actor, float(beta), int(batch)
        self.step_size, self.stuck_threshold = float(step_size), int(stuck_threshold)
        self.uniform_floor, self.max_iterations = float(uniform_floor), int(max_iterations)
        self.records: list = []

    def _setup(self) -> None:
        self.guide = GuidedSampling(self.problem, self.step_size, uniform_floor=self.uniform_floor,
                                    max_iterations=self.max_iterations)
        self.expert = GeodesicExpert(self.problem, self.step_size, lookahead=1.0)
        self.records = []

    def label(self, view) -> int:
        if self.guide.stuck(view) > self.stuck_threshold:
            return FRONTIER
        return self.guide.classify(view, self.expert.target())

    def draw(self, rng, n, view):
        self.guide.update(view)
        self.expert.update(view.vertices, view.num_vertices)
        obs = self.guide.observe(view)
        label = self.label(view)
        self.records.append((obs["local"], obs["vector"], label, view.iteration))
        m = min(n, self.batch)
        if self.actor is None or rng.random() < self.beta:
            classes = np.full(m, label)
        else:
            classes = sample_classes(self.actor.logits(obs["local"], obs["vector"]).astype(np.float64), 1.0,
                                     rng.random(m))
        return self.guide.samples(classes, rng)


def collect(problems: Sequence[Problem], actor: FastActor | None, beta: float, *, seed: int, batch: int,
            step_size: float, stuck_threshold: int, uniform_floor: float, max_iterations: int,
            gamma: float, reward_scale: float, backend: Backend | None = None) -> tuple[Dataset, list[int]]:
    """Run RRT with a ``DaggerSampler`` on each problem; returns the data and each run's iterations.

    The rollouts run on ``backend`` (default: this process); the actor goes to each worker once, and
    the data comes back in problem order, so the result does not depend on the backend.
    """
    context = {"actor": actor, "beta": beta, "seed": seed, "batch": batch, "step_size": step_size,
               "stuck_threshold": stuck_threshold, "uniform_floor": uniform_floor,
               "max_iterations": max_iterations, "gamma": gamma, "reward_scale": reward_scale}
    tasks = list(enumerate(problems))
    results = (backend or LocalBackend()).map(_rollout, tasks, context=context)
    parts = [data for data, _ in results if data is not None]
    return Dataset.concat(parts), [its for _, its in results]


def _rollout(task: tuple[int, Problem], c: dict) -> tuple[Dataset | None, int]:
    """One DAgger rollout: the expert-labelled records of problem ``i`` and its iterations."""
    i, p = task
    s = DaggerSampler(c["actor"], c["beta"], c["batch"], c["step_size"], c["stuck_threshold"], c["uniform_floor"],
                      c["max_iterations"])
    planner = RRT(p, step_size=c["step_size"], sampler=s, seed=c["seed"] + i)
    r = planner.solve(max_iterations=c["max_iterations"])
    recs = planner.sampler.records
    if not recs:
        return None, r.iterations
    it = np.array([x[3] for x in recs], dtype=np.float64)
    # return-to-go of -reward_scale per remaining iteration, discounted as PPO will
    k = r.iterations - it
    gamma = c["gamma"]
    value = -c["reward_scale"] * (1.0 - gamma**k) / (1.0 - gamma)
    return Dataset(np.stack([x[0] for x in recs]), np.stack([x[1] for x in recs]).astype(np.float32),
                   np.array([x[2] for x in recs], dtype=np.int64), value.astype(np.float32)), r.iterations


def mirror_labels(label: torch.Tensor) -> torch.Tensor:
    """Guided classes reflected across the goal axis: angle bin b -> 15 - b in its ring; the frontier stays."""
    ego = label < FRONTIER
    flipped = (label // ANGLES) * ANGLES + (ANGLES - 1 - label % ANGLES)
    return torch.where(ego, flipped, label)


def behaviour_cloning(policy, data: Dataset, *, epochs: int, batch_size: int, lr: float, seed: int,
                      value_weight: float = 0.5, mirror: bool = False, log=None) -> dict:
    """Fit an SB3 ``ActorCriticPolicy`` to expert labels (cross-entropy) and value targets (MSE).

    ``mirror``: reflect a random half of each batch across the goal axis (windows' rows reversed,
    labels by :func:`mirror_labels`): the goal frame's one symmetry, free data. The vector features
    do not change under it. The data stays on the CPU; each batch moves to the policy's device.
    """
    gen = torch.Generator().manual_seed(seed)
    device = policy.device
    opt = torch.optim.Adam(policy.parameters(), lr=lr)
    local = torch.as_tensor(data.local)
    vector = torch.as_tensor(data.vector)
    label = torch.as_tensor(data.label)
    value = torch.as_tensor(data.value)
    policy.set_training_mode(True)
    stats = {}
    for epoch in range(epochs):
        perm = torch.randperm(len(data), generator=gen)
        tot_ce = tot_v = correct = 0.0
        for b in range(0, len(data), batch_size):
            idx = perm[b:b + batch_size]
            obs = {"local": local[idx], "vector": vector[idx]}
            target = label[idx]
            if mirror:
                flip = torch.rand(len(idx), generator=gen) < 0.5
                obs["local"] = torch.where(flip[:, None, None, None], obs["local"].flip(2), obs["local"])
                target = torch.where(flip, mirror_labels(target), target)
            obs = {k: v.to(device) for k, v in obs.items()}
            target = target.to(device)
            values, log_prob, _ = policy.evaluate_actions(obs, target)
            ce = -log_prob.mean()
            v_loss = torch.nn.functional.mse_loss(values.flatten(), value[idx].to(device))
            loss = ce + value_weight * v_loss
            opt.zero_grad()
            loss.backward()
            opt.step()
            tot_ce += ce.item() * len(idx)
            tot_v += v_loss.item() * len(idx)
            with torch.no_grad():
                correct += (policy.get_distribution(obs).distribution.logits.argmax(1) == target).sum().item()
        stats = {"bc/cross_entropy": tot_ce / len(data), "bc/value_mse": tot_v / len(data),
                 "bc/accuracy": correct / len(data), "bc/epoch": epoch}
        if log is not None:
            log(stats)
    policy.set_training_mode(False)
    return stats
