"""Learned samplers for the planners: the public API.

``make_sampler(name, **params)`` builds any registered sampler (``sampler_names()``): "uniform",
"goal_bias", "follower" (the straight-line follower, the strongest sampler without learning),
"route" (the shipped route encoder at its validated settings), "route_ablation", "policy" (the shipped
policy at its validated batch), "policy_ablation", and the privileged references "expert" and
"exact_route". ``PolicySampler.load()`` and ``RouteSampler.load()`` with no path read the shipped
models (package data, ``SHIPPED_POLICY`` and ``SHIPPED_ROUTE``). ``SB3Sampler`` turns any
Stable-Baselines3 model trained on a SamplerGym environment into a sampler; ``ConstantGuidedSampler``
is the policy's ablation (its action classes at a constant distribution).
"""

from learning.models.shipped import SHIPPED_POLICY, SHIPPED_ROUTE
from learning.samplers.ablation import ConstantGuidedSampler
from learning.samplers.policy import PolicySampler
from learning.samplers.registry import SamplerSpec, make_sampler, sampler_names, user_sampler
from learning.samplers.route import RouteSampler
from learning.samplers.sb3 import SB3Sampler

__all__ = ["SHIPPED_POLICY", "SHIPPED_ROUTE", "ConstantGuidedSampler", "PolicySampler", "RouteSampler", "SB3Sampler",
           "SamplerSpec", "make_sampler", "sampler_names", "user_sampler"]
