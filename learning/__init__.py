"""Learned samplers: imitation + PPO training of guided sampling policies and ``PolicySampler``.

``ConstantGuidedSampler`` is the ablation: the policy's action classes with a constant distribution.
``SB3Sampler`` turns any Stable-Baselines3 model trained on a SamplerGym environment into a sampler.
``RouteSampler`` follows a learned cost-to-go field (``learning.route``); ``RouteSampler(None)`` is the
straight-line follower, the strongest sampler without learning in the comparison.
"""

from learning.ablation import ConstantGuidedSampler
from learning.policy_sampler import PolicySampler
from learning.route import RouteSampler
from learning.sb3_sampler import SB3Sampler

__all__ = ["ConstantGuidedSampler", "PolicySampler", "RouteSampler", "SB3Sampler"]
