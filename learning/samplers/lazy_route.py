"""The route encoder's field computed only when a query needs it: RRT follows the straight line first.

On an open map the straight-line follower (the route sampler without its encoder, ``shipped_ablation``) reaches
the goal in about as many iterations as the encoder, and the encoder's pass over a map it has not seen costs as
much as hundreds of its iterations. ``LazyRouteSampler`` starts RRT on the straight-line field and computes the
encoder's field only if the run has not solved within a budget of iterations that grows with the map's area, as the
pass's cost does (rent, then buy: ``after`` iterations per step-sized square of the map; on the CPU a pass costs
about as much as 0.7 of them); from then on it is the route sampler on the encoder's field, following the tree grown
so far. So an easy query costs what the ablation costs, and a winding one the ablation's budget, the encoder's pass
and the encoder's iterations from the tree already there. A second switch, off by default, computes the field once
the straight line's tree has come no closer to the goal for ``stall`` iterations: where the straight line is lost
on a large map, it stops paying rent long before the budget runs out. Both were chosen on the validation maps by
time to solution (``scripts/experiments/lazy_route_rule.py``: the geometric mean of the median times over
validation maps of 128, 256 and 512 cells); ``after=0`` is the route sampler and ``after=inf`` (with no stall) its
ablation, run for run.

Both phases draw inside RRT's compiled loop: the loop runs up to the switch on the straight-line field, the encoder
runs, and the loop goes on on the encoder's field, so a fused run is the run drawn through ``draw``, bit for bit.
Other planner families take the route sampler's own rule for them (``RouteSampler.for_planner``), which needs the
field from the start.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from learning.samplers.route import (
    ABLATION_SETTINGS,
    R_CLOSER,
    SHIPPED_SETTINGS,
    RouteSampler,
    route_draw,
    route_rrt_loop,
)
from planners import OccupancyGrid
from planners.base.fileio import InputError, short_repr
from planners.base.planner import Planner
from planners.base.samplers import FAMILY_TREE, SamplerBase
from planners.fused import B_COUNT, B_POS, B_STOP, FusedRRT, fuse_rrt, rrt_loop

#: The switch, chosen on the validation maps by time to solution (``scripts/experiments/lazy_route_rule.py``): the
#: encoder's field is computed once the straight line has not solved within this many iterations per step-sized
#: square of the map.
SHIPPED_AFTER = 0.7
#: The stall switch, chosen with ``after`` (off): the field is computed once the straight line's tree has come no
#: closer to the goal for this many iterations. On the validation maps ``stall=200`` came within 3.05% of the chosen
#: pair's objective, outside the rule's 3%, and cut the median time on the 512-cell maze, bugtrap and rooms maps from
#: 41-107 ms to 31-36 ms: an option for large maps.
SHIPPED_STALL = math.inf
#: What ``LazyRouteSampler`` adds to ``RouteSampler``'s attributes (left out of ``eager``).
LAZY_ATTRIBUTES = ("after", "stall", "straight", "switched", "switch_at")


@nb.njit(cache=True)
def stall_draw(state, X, n, best_vertex, best_distance, iteration, rng, pts, anchored):
    """``route_draw`` on the straight line's state, ending RRT's loop where the tree has stalled ``stall`` iterations.

    ``state`` is (the straight line's ``RouteSampler`` state, the loop's counters, ``stall``): the draw sets the
    counters' ``B_STOP`` once the tree has come no closer to the goal for ``stall`` iterations (``R_CLOSER``, which
    the draw itself keeps), and the loop ends before using its sample (``planners.fused``).
    """
    straight, counters, stall = state
    route_draw(straight, X, n, best_vertex, best_distance, iteration, rng, pts, anchored)
    if iteration - straight[7][R_CLOSER] >= stall:
        counters[B_STOP] = 1


@nb.njit(cache=True)
def stall_rrt_loop(budget, state, buffers, rng, loop):
    """RRT's compiled loop drawing from ``stall_draw`` (``planners.fused``)."""
    return rrt_loop(budget, stall_draw, state, buffers, rng, loop)


class LazyRouteSampler(RouteSampler):
    """``RouteSampler`` on the straight-line field until iteration ``switch_at``, then on the encoder's.

    ``switch_at`` is ``ceil(after * A)`` on a map of ``A`` step-sized squares (its cells over the cells of a step
    squared: the encoder reads ``A`` times its ``step ** 2`` cells, so its pass grows with ``A``). Before
    it, samples are the ablation's (``RouteSampler(None, **ABLATION_SETTINGS)``, the straight line's own tuned
    settings); at it, unless the run has solved, the encoder's field is computed (``forward_passes`` and
    ``reused_seconds`` as the route sampler's; 0 for a run that never switches) and the route sampler's rule goes on
    from the tree grown so far: its progress vertex is that tree's vertex of lowest predicted cost-to-go.

    Args:
        net: The trained encoder, as for ``RouteSampler``.
        after: The switch in iterations per step-sized square of the map (>= 0; ``inf``: never).
        kwargs: ``RouteSampler``'s (its settings once the field is computed; default the shipped ones). ``batch``
            must be 1, the validated setting, so that the switch falls on one iteration whatever the loop.
    """

    def __init__(self, net, *, after: float = SHIPPED_AFTER, stall: float = SHIPPED_STALL, **kwargs) -> None:
        if net is None:
            raise InputError("LazyRouteSampler needs an encoder (its straight-line phase is the ablation; for the "
                             "ablation alone use RouteSampler(None) or make_sampler('route_ablation'))")
        if isinstance(after, bool) or not isinstance(after, int | float | np.floating) or not after >= 0:
            raise InputError(f"after = {short_repr(after)}: expected iterations per step-sized square of the map, "
                             f">= 0 (inf: never compute the field)")
        if isinstance(stall, bool) or not isinstance(stall, int | float | np.floating) or not stall >= 1:
            raise InputError(f"stall = {short_repr(stall)}: expected iterations without coming closer to the goal, "
                             f">= 1 (inf: never switch on a stall)")
        if kwargs.get("batch", 1) != 1:
            raise InputError(f"batch = {short_repr(kwargs['batch'])}: LazyRouteSampler draws one sample at a time "
                             f"(batch 1)")
        settings = {**SHIPPED_SETTINGS, **kwargs}
        super().__init__(net, **settings)
        self.after, self.stall = float(after), float(stall)
        self.straight = RouteSampler(None, step_size=self.step_size, **ABLATION_SETTINGS)
        self.switched, self.switch_at = False, 0

    def at_step(self, step_size: float) -> LazyRouteSampler:
        """``RouteSampler.at_step``, for both phases."""
        out = super().at_step(step_size)
        if out is not self:
            out.straight = self.straight.at_step(step_size)
        return out

    def eager(self) -> RouteSampler:
        """The route sampler this one becomes once its field is computed (same encoder, settings and cache)."""
        out = object.__new__(RouteSampler)
        out.__dict__.update({k: v for k, v in self.__dict__.items() if k not in LAZY_ATTRIBUTES})
        return out

    def for_planner(self, family: str) -> SamplerBase:
        """This sampler for RRT (``"tree"``); the route sampler's rule for every other family (``rule_for``)."""
        return self if family == FAMILY_TREE else self.eager().for_planner(family)

    def _setup(self) -> None:
        grid = self.problem.world
        if not isinstance(grid, OccupancyGrid):
            raise InputError("LazyRouteSampler plans on OccupancyGrid problems")
        obstacles, _, _ = self._encoder_map(grid)
        self.net.check_size(obstacles.shape)  # a map the encoder refuses is refused at bind, not at the switch
        self.forward_passes, self.reused_seconds, self.switched = 0, 0.0, False
        self._state = self.straight.bind(self.problem).draw_state
        squares = grid.height * grid.width * (grid.resolution / self.step_size) ** 2
        self.switch_at = np.iinfo(np.int64).max if math.isinf(self.after) else math.ceil(self.after * squares)

    def switch(self) -> None:
        """Compute the encoder's field for the bound query and follow it from here (once; a no-op after)."""
        if not self.switched:
            super()._setup()
            self.switched = True

    def draw(self, rng, n, view):
        if not self.switched and view.iteration >= self.switch_at:
            self.switch()
        pts = super().draw(rng, n, view)
        if not self.switched and view.iteration - self._state[7][R_CLOSER] >= self.stall:
            self.switch()  # stalled: the straight line's sample is dropped, as the fused loop drops it
            pts = super().draw(rng, n, view)
        return pts

    def fuse(self, planner: Planner) -> LazyLoop | FusedRRT | None:
        """RRT's loop with both phases' draws compiled in, the switch between them (None for other planners)."""
        if self.switched or math.isinf(self.stall):  # no stall switch: the route sampler's own loop to the switch
            fused = fuse_rrt(planner, route_rrt_loop, self._state, self.batch)
            return fused if fused is None or self.switched else LazyLoop(self, fused)
        fused = fuse_rrt(planner, stall_rrt_loop, None, self.batch)
        if fused is None:
            return None
        fused.state = (self._state, fused.counters, self.stall)
        return LazyLoop(self, fused)

    def __repr__(self) -> str:
        return (f"LazyRouteSampler(after={self.after:g}, stall={self.stall:g}, "
                f"{super().__repr__()[len('RouteSampler('):]}")


class LazyLoop:
    """RRT's fused loop on the straight-line field up to the sampler's switch, then on the encoder's field."""

    __slots__ = ("sampler", "fused")

    def __init__(self, sampler: LazyRouteSampler, fused: FusedRRT) -> None:
        self.sampler, self.fused = sampler, fused

    def __call__(self, planner: Planner, n: int) -> int:
        s, used, counters = self.sampler, 0, self.fused.counters
        if not s.switched:
            m = min(n, s.switch_at - planner.iterations)
            if m > 0:
                used = self.fused(planner, m)
                if counters[B_STOP]:  # stalled: the straight line's sample in the buffer is dropped
                    counters[B_STOP], counters[B_POS] = 0, counters[B_COUNT]
                elif used < m or used == n:  # solved (or out of room) before the switch, or the call is spent
                    return used
            s.switch()
            self.fused.entry, self.fused.state = route_rrt_loop, s.draw_state
        return used + self.fused(planner, n - used)

    @property
    def refills(self) -> int:
        """Refills drawn so far (``FusedRRT.refills``)."""
        return self.fused.refills
