"""The classical samplers' draws, compiled: uniform sampling and goal bias inside the planners' loops.

``UniformSampler`` and ``GoalBiasedSampler`` (``planners.base.samplers``) draw here when a planner has a compiled
loop (``planners.fused``) and the install has chosen it (``draw_classical_in_loops``), value for value what their
``draw`` gives through Python (``next_double`` is ``Generator.random()``), so a fused run is the drawn run and only
the time differs: the learned samplers draw inside the loops, and so must the classical ones they are compared with
on the clock.

One draw serves both samplers, so each planner's loop compiles once for them. Its ``state`` is ``(low, high, goal, p,
biased)``: the sampling box, the goal state, the goal probability and whether a sample first draws the uniform that
chooses the goal (``GoalBiasedSampler``, whatever its ``p``) or not (``UniformSampler``).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from planners.kernels.bitgen import next_double
from planners.kernels.fused import connect_loop, rrt_loop, rrtstar_loop


def classical_state(low, high, goal, p: float, biased: bool) -> tuple:
    """The draw's ``state``: contiguous float64 arrays, ``p`` a float and ``biased`` a bool (one compiled type)."""
    return (np.ascontiguousarray(low, dtype=np.float64), np.ascontiguousarray(high, dtype=np.float64),
            np.ascontiguousarray(goal, dtype=np.float64), float(p), bool(biased))


@nb.njit(cache=True)
def classical_fill(state, X, n, best_vertex, best_distance, iteration, rng, pts, anchored):
    """``UniformSampler.draw`` (``Generator.random((m, dim))`` row by row over the box) or, with ``biased``,
    ``GoalBiasedSampler.draw`` (``dim + 1`` uniforms a sample, the first choosing the goal with probability ``p``).
    """
    low, high, goal, p, biased = state
    for k in range(pts.shape[0]):
        u0 = next_double(rng) if biased else 1.0
        for j in range(pts.shape[1]):
            pts[k, j] = low[j] + (high[j] - low[j]) * next_double(rng)
        if u0 < p:
            for j in range(pts.shape[1]):
                pts[k, j] = goal[j]


@nb.njit(cache=True)
def classical_rrt_loop(budget, state, buffers, rng, loop):
    """RRT's compiled loop drawing from ``classical_fill`` (``planners.fused``)."""
    return rrt_loop(budget, classical_fill, state, buffers, rng, loop)


@nb.njit(cache=True)
def classical_connect_loop(budget, state_a, state_b, buffers, rng, loop):
    """RRT-Connect's compiled loop drawing from ``classical_fill`` for both trees."""
    return connect_loop(budget, classical_fill, state_a, state_b, buffers, rng, loop)


@nb.njit(cache=True)
def classical_rrtstar_loop(budget, state, buffers, rng, loop):
    """RRT*'s compiled loop drawing from ``classical_fill`` up to its first solution."""
    return rrtstar_loop(budget, classical_fill, state, buffers, rng, loop)
