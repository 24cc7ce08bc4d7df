"""The ablation that removes the learning: the policy's action space with a constant distribution.

The learned sampler chooses, at each decision, one class of the guided action space (``planners.guidance.guided``):
a log-polar cell around the tree's progress vertex, in the frame pointing at the goal, or the tree's
frontier. ``ConstantGuidedSampler`` draws from the same classes, through the same geometry
(``GuidedSampling.samples``), with a fixed distribution and no network: the frontier with probability
``frontier``, otherwise the cell 1.5 to 2 steps straight ahead of the progress vertex; a
``uniform_floor`` share of samples is uniform, as for the policy. What the policy gains over the best
such constant is what learning adds; ``learning.evaluation`` tunes ``frontier`` on the tuning split
exactly as it tunes goal bias.
"""

from __future__ import annotations

import numpy as np

from planners import SamplerBase
from planners.base.fileio import InputError
from planners.base.samplers import check_sampler_params
from planners.guidance.guided import FRONTIER, GuidedSampling, ego_class

#: Frontier probabilities the comparison chooses from on the tuning split (0 is left out: always
#: straight ahead, it solved no narrow passage, maze or room within 20,000 iterations).
FRONTIER_GRID = (0.3, 0.5, 0.6, 0.7, 0.8, 0.9)


class ConstantGuidedSampler(SamplerBase):
    """Guided-action classes drawn from a constant distribution (see the module docstring).

    Args:
        frontier: Probability of the frontier class; the rest goes to the cell straight ahead.
        step_size: The planner's step (the cells' rings are in steps), as the policy's config has it.
        batch: Samples per draw, as many as the policy takes per decision; offsets are resolved against
            the progress vertex current when each sample is used.
        uniform_floor: Share of uniform samples whatever the class.
    """

    def __init__(self, frontier: float = 0.7, *, step_size: float = 4.0, batch: int = 8,
                 uniform_floor: float = 0.05) -> None:
        for name, v, lo, hi in (("frontier", frontier, 0.0, 1.0), ("uniform_floor", uniform_floor, 0.0, 1.0)):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not lo <= v <= hi:
                raise InputError(f"{name} must be a number in [{lo:g}, {hi:g}], got {v!r}")
        check_sampler_params("ConstantGuidedSampler", step_size=step_size, batch=batch)
        self.frontier, self.step_size, self.batch = float(frontier), float(step_size), batch
        self.uniform_floor = float(uniform_floor)

    def _setup(self) -> None:
        if self.problem.dim != 2 or not hasattr(self.problem.world, "obstacles"):
            raise InputError("ConstantGuidedSampler needs a 2-D occupancy-grid problem (the guided action space)")
        self.guide = GuidedSampling(self.problem, self.step_size, uniform_floor=self.uniform_floor)
        self.ahead = ego_class(1.5 * self.step_size, 0.0, self.step_size)

    def draw(self, rng, n, view):
        m = min(n, self.batch)
        self.guide.frontier.update(view.vertices, view.num_vertices)
        classes = np.where(rng.random(m) < self.frontier, FRONTIER, self.ahead)
        return self.guide.samples(classes, rng)

    def __repr__(self) -> str:
        return f"ConstantGuidedSampler(frontier={self.frontier:g})"
