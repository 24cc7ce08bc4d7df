"""Learned samplers: imitation + PPO training of guided sampling policies and ``PolicySampler``.

``ConstantGuidedSampler`` is the ablation: the policy's action classes with a constant distribution.
``SB3Sampler`` turns any Stable-Baselines3 model trained on a SamplerGym environment into a sampler.
``RouteSampler`` follows a learned cost-to-go field (``learning.samplers.route``); ``RouteSampler(None)`` is the
straight-line follower, the strongest sampler without learning in the comparison.
"""

from learning.samplers.ablation import ConstantGuidedSampler
from learning.samplers.policy import PolicySampler
from learning.samplers.route import RouteSampler
from learning.samplers.sb3 import SB3Sampler

__all__ = ["ConstantGuidedSampler", "PolicySampler", "RouteSampler", "SB3Sampler"]
