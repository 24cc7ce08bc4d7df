"""The shipped policy at other inference settings, for ``evaluate.py --sampler`` (factories, no CLI).

    python scripts/evaluate.py --sampler "batch1=policy_variants:batch_1" --sampler "batch2=policy_variants:batch_2"

``PolicySampler`` draws ``batch`` samples per decision (8, the training batch). A batch is drawn from
the distribution of the decision that starts it, and the sampler checks whether the tree's progress
vertex moved only between batches. These variants decide every sample or every second one.
"""

from __future__ import annotations

from pathlib import Path

from learning import PolicySampler

DEFAULT_POLICY = Path(__file__).resolve().parents[1] / "checkpoints" / "guided.zip"


def batch_1() -> PolicySampler:
    """The shipped policy deciding every sample."""
    return PolicySampler.load(DEFAULT_POLICY, batch=1)


def batch_2() -> PolicySampler:
    """The shipped policy deciding every second sample."""
    return PolicySampler.load(DEFAULT_POLICY, batch=2)
