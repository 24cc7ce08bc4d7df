"""Learned samplers: imitation + PPO training of guided sampling policies, and ``PolicySampler``."""

from learning.policy_sampler import PolicySampler

__all__ = ["PolicySampler"]
