"""The shipped policy at fixed batches, for ``evaluate.py --sampler`` (factories, no CLI).

    python scripts/evaluate.py --sampler "batch8=policy_variants:batch_8" --sampler "batch1=policy_variants:batch_1"

``PolicySampler`` draws ``batch`` samples per decision. A batch is drawn from the distribution of the
decision that starts it, and the sampler checks whether the tree's progress vertex moved only between
batches. ``evaluate.py`` tunes the policy's batch on the tuning split; these factories put the
policy at each batch beside the tuned one on the test maps.
"""

from __future__ import annotations

from learning import PolicySampler
from learning.models.shipped import SHIPPED_POLICY

DEFAULT_POLICY = SHIPPED_POLICY


def batch_8() -> PolicySampler:
    """The shipped policy deciding every eighth sample, as in training."""
    return PolicySampler.load(DEFAULT_POLICY, batch=8)


def batch_2() -> PolicySampler:
    """The shipped policy deciding every second sample."""
    return PolicySampler.load(DEFAULT_POLICY, batch=2)


def batch_1() -> PolicySampler:
    """The shipped policy deciding every sample."""
    return PolicySampler.load(DEFAULT_POLICY, batch=1)
