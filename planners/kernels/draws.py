"""The classical samplers' draws, compiled: uniform sampling and goal bias inside the planners' loops.

``UniformSampler`` and ``GoalBiasedSampler`` (``planners.base.samplers``) draw here when a planner has a compiled
loop (``planners.fused``), value for value what their ``draw`` gives through Python (``next_double`` is
``Generator.random()``), so a fused run is the drawn run and only the time differs: the learned samplers draw inside
the loops, and so must the classical ones they are compared with on the clock.

A draw's ``state`` is ``(low, high, goal, p)``: the sampling box, the goal state and the goal probability (0 for
uniform sampling).
"""

from __future__ import annotations

import numba as nb

from planners.kernels.bitgen import next_double
from planners.kernels.fused import connect_loop, rrt_loop, rrtstar_loop


@nb.njit(cache=True)
def uniform_fill(state, X, n, best_vertex, best_distance, iteration, rng, pts, anchored):
    """``UniformSampler.draw``: ``Generator.random((m, dim))`` row by row, over the box ``state[0:2]``."""
    low, high, goal, p = state
    for k in range(pts.shape[0]):
        for j in range(pts.shape[1]):
            pts[k, j] = low[j] + (high[j] - low[j]) * next_double(rng)


@nb.njit(cache=True)
def goal_fill(state, X, n, best_vertex, best_distance, iteration, rng, pts, anchored):
    """``GoalBiasedSampler.draw``: ``dim + 1`` uniforms a sample, the first choosing the goal with probability ``p``."""
    low, high, goal, p = state
    for k in range(pts.shape[0]):
        u0 = next_double(rng)
        for j in range(pts.shape[1]):
            pts[k, j] = low[j] + (high[j] - low[j]) * next_double(rng)
        if u0 < p:
            for j in range(pts.shape[1]):
                pts[k, j] = goal[j]


@nb.njit(cache=True)
def uniform_rrt_loop(budget, state, buffers, rng, loop):
    """RRT's compiled loop drawing from ``uniform_fill`` (``planners.fused``)."""
    return rrt_loop(budget, uniform_fill, state, buffers, rng, loop)


@nb.njit(cache=True)
def goal_rrt_loop(budget, state, buffers, rng, loop):
    """RRT's compiled loop drawing from ``goal_fill``."""
    return rrt_loop(budget, goal_fill, state, buffers, rng, loop)


@nb.njit(cache=True)
def uniform_connect_loop(budget, state_a, state_b, buffers, rng, loop):
    """RRT-Connect's compiled loop drawing from ``uniform_fill`` for both trees."""
    return connect_loop(budget, uniform_fill, state_a, state_b, buffers, rng, loop)


@nb.njit(cache=True)
def goal_connect_loop(budget, state_a, state_b, buffers, rng, loop):
    """RRT-Connect's compiled loop drawing from ``goal_fill`` for both trees (the goal, as ``draw`` gives it)."""
    return connect_loop(budget, goal_fill, state_a, state_b, buffers, rng, loop)


@nb.njit(cache=True)
def uniform_rrtstar_loop(budget, state, buffers, rng, loop):
    """RRT*'s compiled loop drawing from ``uniform_fill`` up to its first solution."""
    return rrtstar_loop(budget, uniform_fill, state, buffers, rng, loop)


@nb.njit(cache=True)
def goal_rrtstar_loop(budget, state, buffers, rng, loop):
    """RRT*'s compiled loop drawing from ``goal_fill`` up to its first solution."""
    return rrtstar_loop(budget, goal_fill, state, buffers, rng, loop)
