"""Learned samplers: imitation + PPO training of guided sampling policies and ``PolicySampler``.

``SB3Sampler`` turns any Stable-Baselines3 model trained on a SamplerGym environment into a sampler.
"""

from learning.policy_sampler import PolicySampler
from learning.sb3_sampler import SB3Sampler

__all__ = ["PolicySampler", "SB3Sampler"]
