"""Privileged samplers only the probes use, handed to the evaluation runner as tasks' samplers.

The runner builds any task's sampler with ``build(models)`` and records ``to_json()``; these are the
probes' own (``imitation_ceiling.py``), beside the registry's specs, so the evaluation has no branch for them.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

from learning.references.expert import CorridorSampler, GeodesicFrontierSampler
from learning.samplers.registry import ModelCache, SamplerSpec


@dataclass(frozen=True)
class Corridor:
    """This probe's sampler for the runner: ``CorridorSampler`` (share ``q``) around ``base``, a registry spec."""

    q: float
    base: SamplerSpec

    def build(self, models: ModelCache | None = None) -> CorridorSampler:
        return CorridorSampler(self.q, self.base.build(models))

    def to_json(self) -> str:
        return json.dumps({"name": "corridor", "params": {"q": self.q, "base": json.loads(self.base.to_json())}})


@dataclass(frozen=True)
class GeodesicFrontier:
    """This probe's sampler for the runner: the ablation with its frontier ranked by exact cost-to-go."""

    frontier: float
    step_size: float

    def build(self, models: ModelCache | None = None) -> GeodesicFrontierSampler:
        return GeodesicFrontierSampler(self.frontier, step_size=self.step_size)

    def to_json(self) -> str:
        return json.dumps({"name": "geodesic_frontier", "params": {"frontier": self.frontier,
                                                                   "step_size": self.step_size}})
