"""Drawing inside a planner's compiled loop: the one way for a compiled sampler to fuse its draws with the planner.

A sampler whose draws are a numba function can run them inside RRT's compiled loop, so a solve
never returns to Python between batches (``Sampler.fuse`` in ``planners.base.samplers``). The
sampler provides three things:

1. a compiled ``draw(state, vertices, n, best_vertex, best_distance, iteration, rng, pts, anchored)``
   that fills ``pts`` (m, dim) with m samples and, where it anchors them, ``anchored`` (m,) with
   ``ANCHOR_*`` codes (it starts at zeros; a sampler that never anchors leaves it alone). The tree
   enters as ``vertices[:n]``, the vertex nearest the goal and its distance, and the planner's
   iteration; ``rng`` is the planner generator's address (``rng_address``), drawn from with
   ``next_double(rng)``, value for value what ``Generator.random()`` gives. ``state`` is anything
   numba can type (a tuple of arrays, a ``NamedTuple``): the sampler's per-query state.
2. a cached entry in its own module that hands that ``draw`` to the loop::

       @numba.njit(cache=True)
       def my_loop(budget, state, buffers, rng, loop):
           return rrt_loop(budget, my_draw, state, buffers, rng, loop)

   (numba compiles ``rrt_loop`` for ``my_draw``, with a direct call to it; the cache of ``my_loop``
   holds the whole loop and is renewed when the sampler's file changes);
3. ``fuse``: ``return fuse_rrt(planner, my_loop, state, batch)``.

The loop asks for ``min(batch, refill_size(k))`` samples at its ``k``-th refill, the planner's own
schedule, so a fused run draws exactly what the same sampler's ``draw`` method (called by the
planner with that many) would: fusing changes the speed, never the run. ``growing_floor`` is the
uniform share a guided sampler keeps, growing while the tree comes no closer to the goal.

A draw may end RRT's loop early: one whose state holds the loop's counters (``FusedRRT.counters``) and sets
``counters[B_STOP]`` ends the loop's call right after that refill, its samples left unused in the buffer; the
caller decides what the next call draws. A sampler that switches its rule mid-run (``learning.samplers.lazy_route``)
goes on with another loop there.

RRT-Connect (``fusable_loop = "connect"``) has its own loop, ``connect_loop(budget, draw, state_a, state_b,
buffers, rng, loop)``, entered the same way (``fuse_connect``). Its trees take turns, and each refill draws for
the tree whose turn it is, with ``draw``'s contract as above: the start tree as ``draw(state_a, ...)`` with its
vertices, its vertex nearest the goal and that distance; the goal tree as ``draw(state_b, ...)`` with its
vertices, 0 and its closest distance to the start (``nearest_distance``, which a sampler's ``draw`` calls too,
so both paths compute it alike). The iteration each sees is its own count of draws
(the planner's iteration // 2), so a tree-following draw treats each tree as RRT's tree towards the other's root.

RRT* (``fusable_loop = "rrtstar"``) runs a sampler's draws in its loop, ``rrtstar_loop``, up to its first solution
(``fuse_rrtstar``): at the first refill after it, the loop hands the draws back (``HAND_BACK``) and the planner
calls the sampler's ``draw`` from then on, its refill count carried over (``FusedRRT.refills``). So a sampler whose
rule changes once a solution exists (the route field's converging rule) fuses the part before it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from planners.kernels.bitgen import bitgen_address as rng_address
from planners.kernels.bitgen import next_double

# the classical samplers' compiled draws, for a sampler whose phase draws as ``UniformSampler`` or
# ``GoalBiasedSampler`` does (state: ``classical_state``, the box, the goal, the goal probability and whether a sample
# chooses the goal first)
from planners.kernels.draws import classical_connect_loop, classical_rrt_loop, classical_state
from planners.kernels.fused import (
    B_REFILLS,
    B_STOP,
    CHUNK,
    FIRST_REFILL,
    HAND_BACK,
    connect_loop,
    growing_floor,
    nearest_distance,
    refill_size,
    rrt_loop,
    rrtstar_loop,
)

if TYPE_CHECKING:
    from planners.base.planner import Planner

__all__ = ["B_STOP", "CHUNK", "FIRST_REFILL", "HAND_BACK", "FusedConnect", "FusedRRT", "classical_connect_loop",
           "classical_rrt_loop", "classical_state", "connect_loop", "fuse_connect", "fuse_rrt", "fuse_rrtstar",
           "growing_floor", "nearest_distance", "next_double", "refill_size", "rng_address", "rrt_loop", "rrtstar_loop"]


class FusedRRT:
    """The callable ``Sampler.fuse`` returns for RRT (and RRT* to its first solution): runs ``entry`` with ``state``.

    It owns the loop's sample buffer (``batch`` rows of ``dim``) and its counters (position, rows,
    refills so far), fresh for each planner (re)start, as the planner's own buffer is.
    """

    __slots__ = ("entry", "state", "buffers")

    def __init__(self, entry: Callable, state: Any, batch: int, dim: int) -> None:
        self.entry, self.state = entry, state
        self.buffers = (np.zeros(B_STOP + 1, dtype=np.int64), np.empty((batch, dim)), np.zeros(batch, dtype=np.int8))

    def __call__(self, planner: Planner, n: int) -> int:
        return self.entry(n, self.state, self.buffers, rng_address(planner.rng), planner.loop_args())

    @property
    def counters(self) -> np.ndarray:
        """The loop's counters (position, rows, refills, ``B_STOP``): for a draw that ends the loop."""
        return self.buffers[0]

    @property
    def refills(self) -> int:
        """Refills drawn so far: where the planner's own schedule goes on after the loop hands back."""
        return int(self.buffers[0][B_REFILLS])


def fuse_rrt(planner: Planner, entry: Callable, state: Any, batch: int) -> FusedRRT | None:
    """``entry`` (a cached wrapper of ``rrt_loop``, see the module) as ``planner``'s loop; None if it is not RRT's."""
    if planner.fusable_loop != "rrt":
        return None
    return FusedRRT(entry, state, int(batch), planner.problem.dim)


class FusedConnect:
    """The callable ``Sampler.fuse`` returns for RRT-Connect: runs ``entry`` on the planner's loop with both states.

    It owns the loop's sample buffer (the larger batch's rows), its counters (position, rows, refills so far, goal
    tree vertices seen) and the goal tree's closest distance to the start, fresh for each planner (re)start.
    """

    __slots__ = ("entry", "state_a", "state_b", "buffers")

    def __init__(self, entry: Callable, state_a: Any, state_b: Any, batches: tuple[int, int], dim: int) -> None:
        self.entry, self.state_a, self.state_b = entry, state_a, state_b
        rows = max(batches)
        self.buffers = (np.zeros(B_STOP + 1, dtype=np.int64), np.empty((rows, dim)), np.zeros(rows, dtype=np.int8),
                        np.full(1, np.inf), np.array(batches, dtype=np.int64))

    def __call__(self, planner: Planner, n: int) -> int:
        return self.entry(n, self.state_a, self.state_b, self.buffers, rng_address(planner.rng), planner.loop_args())

    @property
    def counters(self) -> np.ndarray:
        """The loop's counters, laid out as ``FusedRRT.counters`` (``B_SEEN_B`` added; its loop never stops early)."""
        return self.buffers[0]

    @property
    def refills(self) -> int:
        """Refills drawn so far, both trees' (``FusedRRT.refills``)."""
        return int(self.buffers[0][B_REFILLS])


def fuse_connect(planner: Planner, entry: Callable, state_a: Any, state_b: Any,
                 batches: tuple[int, int]) -> FusedConnect | None:
    """``entry`` (a cached wrapper of ``connect_loop``) as ``planner``'s loop; None if it is not RRT-Connect's.

    ``state_a`` and ``batches[0]`` serve the start tree's draws, ``state_b`` and ``batches[1]`` the goal tree's.
    """
    if planner.fusable_loop != "connect":
        return None
    return FusedConnect(entry, state_a, state_b, (int(batches[0]), int(batches[1])), planner.problem.dim)


def fuse_rrtstar(planner: Planner, entry: Callable, state: Any, batch: int) -> FusedRRT | None:
    """``entry`` (a wrapper of ``rrtstar_loop``) as ``planner``'s loop to its first solution; None if not RRT*'s."""
    if planner.fusable_loop != "rrtstar":
        return None
    return FusedRRT(entry, state, int(batch), planner.problem.dim)
