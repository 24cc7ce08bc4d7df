"""The route encoder's field computed only when a query needs it: RRT follows the straight line first.

On an open map the straight-line follower (the route sampler without its encoder, ``shipped_ablation``) reaches the
goal in about as many iterations as the encoder, and the encoder's pass over a map it has not seen costs as much as
hundreds of its iterations. ``LazyRouteSampler`` starts RRT on the straight-line field and computes the encoder's
field only if the run has not solved within a budget of iterations that grows with the map's area, as the pass's
cost does (rent, then buy: ``after`` iterations per step-sized square of the map, 0.35), at least ``floor`` and at
most ``cap`` iterations whatever the area (500 and 1,000: a pass has a fixed cost besides the one that grows with
the area, and each straight-line iteration grows dearer with the tree, so the switch comes at 1,000 on every map of
more than 2,857 step-sized squares, 214 x 214 cells at step 4); from then on it is the route sampler on the
encoder's field, following the tree grown so far. So an easy query costs what the ablation costs, and a winding one
the ablation's budget, the encoder's pass and the encoder's iterations from the tree already there. A second switch,
off by default, computes the field once the straight line's tree has come no closer to the goal for ``stall``
iterations: where the straight line is lost on a large map, it stops paying rent long before the budget runs out.
Each was chosen on the validation maps by time to solution (``scripts/experiments/lazy_route_rule.py``: the
geometric mean of the median times over validation maps of 32 to 512 cells, 32 to 1024 for the other planners'
caps); with ``goal_in_sight=False`` (below), ``after=0`` with ``floor=0`` (or ``cap=0``) is the route sampler and
``after=inf`` with ``cap=inf`` (and no stall) its ablation, run for run.

Both phases draw inside RRT's compiled loop: the loop runs up to the switch on the straight-line field, the encoder
runs, and the loop goes on on the encoder's field, so a fused run is the run drawn through ``draw``, bit for bit.
RRT-Connect takes ``LazyConnectSampler``: both trees grow by the planner's own uniform sampling (inside its compiled
loop) until ``connect_after`` iterations per step-sized square (at least ``connect_floor``), then follow the route
field's two fields (``BidirectionalRouteSampler``). The roadmaps take ``LazyCorridorSampler``: uniform samples until
``roadmap_after`` per step-sized square (at least ``roadmap_floor``), then the field's corridor. RRT* and Informed
RRT* take ``LazyConvergingSampler``: RRT's lazy rule to the first solution (the straight line, then the encoder's field
at RRT's switch), then the route field's corridor inside the informed set, computing the fields it still lacks at its
first draw after the first solution.

Before either phase, RRT asks whether it needs one: where the straight motion from the start to the goal is free (the
planner's own motion check, one call), the goal is in sight, and RRT draws the goal itself (``GoalBiasedSampler(1.0)``'s
draws, in the same compiled loop as the classical samplers) for as many iterations as steps along that line, plus one:
each extends the tree a step along the free line, so the run solves in the fewest iterations there are, with no field
and no set-up beyond the check. A run that has not solved by then (a step the motion check refuses where the whole line
passed) goes on with the straight line's phase from the tree grown so far. ``goal_in_sight=False`` leaves this out.
"""

from __future__ import annotations

import copy
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
from learning.samplers.route_rules import (
    CONVERGING_SETTINGS,
    BidirectionalRouteSampler,
    ConvergingRouteSampler,
    CorridorSampler,
    route_rrtstar_loop,
)
from planners import OccupancyGrid
from planners.base.fileio import InputError, short_repr
from planners.base.planner import Planner
from planners.base.samplers import FAMILY_BIDIRECTIONAL, FAMILY_OPTIMIZING, FAMILY_ROADMAP, FAMILY_TREE, SamplerBase
from planners.fused import (
    B_STOP,
    CHUNK,
    FusedConnect,
    FusedRRT,
    classical_connect_loop,
    classical_rrt_loop,
    classical_state,
    fuse_connect,
    fuse_rrt,
    fuse_rrtstar,
    rrt_loop,
)

#: The planner families whose rule here differs from the route sampler's: RRT and RRT* (the straight line first),
#: RRT-Connect and the roadmaps (their uniform sampling first).
LAZY_FAMILIES = (FAMILY_TREE, FAMILY_BIDIRECTIONAL, FAMILY_ROADMAP, FAMILY_OPTIMIZING)

#: Every switch below is chosen on the validation maps by time to solution (``scripts/experiments/lazy_route_rule.py``,
#: one switch at a time with the others as chosen before it, on maps of 32 to 512 cells, ``--maps 32 32 32 16 8``, 2
#: seeds: 1,200 runs a candidate; the candidates' order turning from one query to the next). Each comment gives the
#: geometric means of the median times in ms and, in brackets, how often 1,000 paired bootstrap resamples of the runs
#: give the same choice (``--bootstrap``): most choices are near-ties. The RRT switch: the encoder's field is
#: computed once the straight line has not solved within this many iterations per step-sized square of the map
#: (``--after 0.35 0.7 1.4 inf``: 0.838, 0.841, 0.849, 0.857; 91%).
SHIPPED_AFTER = 0.35
#: The stall switch (off): the field is computed once the straight line's tree has come no closer to the goal for
#: this many iterations (``--stall 10 25 50 100 200 inf``, on 8 8 8 4 2 maps: 2.574 to 1.038 ms for the stalls, 0.822
#: for none; 100%).
SHIPPED_STALL = math.inf
#: The most straight-line iterations before the switch, whatever the map's area (``cap``; inf: none;
#: ``--cap 500 1000 2000 4000 inf``: 0.860, 0.831, 0.882, 0.912, 0.907; 57%): the straight line's iterations grow
#: dearer as its tree grows, so on a large winding map the area's budget alone (5,735 iterations at 512 cells) costs
#: several passes.
SHIPPED_CAP = 1000.0
#: RRT-Connect's switch (``connect_after``; ``--planner RRTConnect``): both trees grow by uniform sampling until this
#: many iterations per step-sized square of the map, then follow the route field's two fields (0.05 to inf: 0.801,
#: 0.822, 0.797, 0.696, 0.614, 0.611, 0.612; 59%, 1.4 in 38%; never switching is within 3%: on these maps the fields
#: are a late safety net). Asked again once the goal tree's field came off the walk (one pass for both trees), floor
#: 2,000: 0.876, 0.876, 0.855, 0.759, 0.672, 0.667, 0.680 (0.7 in 67%, 1.4 in 32%).
SHIPPED_CONNECT_AFTER = 0.7
#: The roadmaps' switch (``roadmap_after``: PRM, Lazy-PRM, OB-PRM; ``--planner PRM``): uniform samples until this
#: many per step-sized square of the map, then the route field's corridor (0.05 to inf: 0.529, 0.529, 0.537, 0.529,
#: 0.515, 0.524, 0.521; 0.05 is the smallest within 3% of the lowest; 55%).
SHIPPED_ROADMAP_AFTER = 0.05
#: The fewest iterations (RRT, RRT-Connect) or samples (the roadmaps) before each planner's switch, whatever the
#: map's area (``floor``, ``connect_floor``, ``roadmap_floor``; 0: none): a pass has a fixed cost besides the one that
#: grows with the area, which on a small map the area's budget does not cover (``--floor``): RRT 0, 250, 500, 1000:
#: 1.175, 0.913, 0.870, 0.846 (500, within 3% of 1,000; 63%); RRT-Connect 0, 500, 1000, 2000, 4000: 1.088, 0.832,
#: 0.735, 0.635, 0.626 (2,000; 62%; with one pass for both trees, 0 to 2,000: 1.264, 1.038, 0.911, 0.813, 98%); PRM,
#: asked again once the corridor began with a chain along the route, 0, 250, 500, 1000: 0.835, 0.469, 0.449, 0.447
#: ms (500, within 3% of 1,000; 98% of the resamples; before the chain, with 2000 among them, 0.989, 0.567, 0.545,
#: 0.540, 0.527 chose 1,000). The larger the floor, the fewer runs reach the field: on these maps the classical phase
#: alone is nearly as fast, and the field is a late safety net.
SHIPPED_FLOOR = 500.0
SHIPPED_CONNECT_FLOOR = 2000.0
SHIPPED_ROADMAP_FLOOR = 500.0
#: The most iterations (RRT-Connect) or samples (the roadmaps) before each planner's switch, whatever the map's area
#: (``connect_cap``, ``roadmap_cap``; inf: none), as ``cap`` is RRT's. Chosen by the same rule on validation maps of
#: 32 to 1024 cells (``lazy_route_rule.py --cap inf 1000 2000 4000 8000 --sizes 32 64 128 256 512 1024 --maps 8 8 8
#: 4 2 1``, with connect_after 1.4 and roadmap_after 0.35): none. RRT-Connect's geometric means run 0.714 ms without
#: a cap against 0.735 to 1.587 with one (100%; at 1024 cells uniform RRT-Connect solves every validation query in a
#: few milliseconds, where its two passes cost about 140); PRM's candidates ran the same runs (the same 6 of 310
#: switching), 0.601 to 0.618. So on a map of more than 28,571 step-sized squares (676 x 676 cells at step 4)
#: RRT-Connect's switch lies past 20,000 iterations: there it is uniform RRT-Connect.
SHIPPED_CONNECT_CAP = math.inf
SHIPPED_ROADMAP_CAP = math.inf
#: After the roadmaps' switch the corridor's chain along the route is drawn twice: with its own links, then with links
#: no longer than the radius of a disc that holds this many of the roadmap's vertices on average
#: (``LazyCorridorSampler.link_bound``, ``CorridorSampler.second_chain``). A roadmap connects a new vertex to its
#: nearest ones (10 by default), so on a roadmap that the uniform phase left in pieces the first chain's long links
#: are seldom tried and a single chain falls apart; on one whose pieces are large the first chain connects it alone.
#: Chosen on the validation maps by time to solution (``scripts/experiments/lazy_chain_links.py``: the switch forced
#: at 150 and at 400 samples on 12 validation maps of each family at 256 and 512 cells, the 20 and 7 that reach it;
#: pooled geometric means for 1 / 3 / 8 / no second chain: 17.63 / 17.53 / 17.51 / 18.81 ms): every bound within 3%
#: of the best, so the smallest. A new point of the second chain then has one vertex nearer than the point before on
#: average, which is among its 10 nearest but for about one link in ten million (a Poisson count of mean 1 reaching
#: 10).
LINK_VERTICES = 1.0
#: The switch of a sampler that never switches: the largest iteration there is.
NEVER = int(np.iinfo(np.int64).max)
#: What ``LazyRouteSampler`` adds to ``RouteSampler``'s attributes (left out of ``eager``).
LAZY_ATTRIBUTES = ("after", "cap", "floor", "stall", "connect_after", "roadmap_after", "connect_floor",
                   "roadmap_floor", "connect_cap", "roadmap_cap", "straight", "switched", "switch_at", "goal_in_sight",
                   "in_sight_until")


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
    squared: the encoder reads ``A`` times its ``step ** 2`` cells, so its pass grows with ``A``), at least ``floor``
    and at most ``cap`` (the cap wins).
    Before it, samples are the ablation's (``RouteSampler(None, **ABLATION_SETTINGS)``, the straight line's own tuned
    settings); at it, unless the run has solved, the encoder's field is computed (``forward_passes`` and
    ``reused_seconds`` as the route sampler's; 0 for a run that never switches) and the route sampler's rule goes on
    from the tree grown so far: its progress vertex is that tree's vertex of lowest predicted cost-to-go.

    Args:
        net: The trained encoder, as for ``RouteSampler``.
        after: The switch in iterations per step-sized square of the map (>= 0; ``inf`` with ``cap`` ``inf``: never).
        cap: The switch at the latest at this iteration, whatever the map's area (>= 0; ``inf``: no cap).
        floor: The switch at the earliest at this iteration, whatever the map's area (>= 0; 0: none).
        connect_after, roadmap_after, connect_floor, roadmap_floor, connect_cap, roadmap_cap: RRT-Connect's and
            the roadmaps' switches (``LazyConnectSampler``, ``LazyCorridorSampler``), as ``after``, ``floor`` and
            ``cap`` are RRT's.
        goal_in_sight: With RRT, draw the goal itself first where the start sees it (the module's docstring);
            False: the straight line's phase from the first iteration (with ``after`` and ``cap`` inf, the ablation
            run for run).
        kwargs: ``RouteSampler``'s (its settings once the field is computed; default the shipped ones). ``batch``
            must be 1, the validated setting, so that the switch falls on one iteration whatever the loop.
    """

    def __init__(self, net, *, after: float = SHIPPED_AFTER, cap: float = SHIPPED_CAP, stall: float = SHIPPED_STALL,
                 connect_after: float = SHIPPED_CONNECT_AFTER, roadmap_after: float = SHIPPED_ROADMAP_AFTER,
                 floor: float = SHIPPED_FLOOR, connect_floor: float = SHIPPED_CONNECT_FLOOR,
                 roadmap_floor: float = SHIPPED_ROADMAP_FLOOR, connect_cap: float = SHIPPED_CONNECT_CAP,
                 roadmap_cap: float = SHIPPED_ROADMAP_CAP, goal_in_sight: bool = True, **kwargs) -> None:
        if net is None:
            raise InputError("LazyRouteSampler needs an encoder (its straight-line phase is the ablation; for the "
                             "ablation alone use RouteSampler(None) or make_sampler('route_ablation'))")
        per_square = "iterations per step-sized square of the map, >= 0"
        for name, value, low, expected in (
                ("after", after, 0, f"{per_square} (inf, with cap=inf: never compute the field)"),
                *((n, v, 0, "the most iterations before the switch, >= 0 (inf: no cap)")
                  for n, v in (("cap", cap), ("connect_cap", connect_cap), ("roadmap_cap", roadmap_cap))),
                *((n, v, 0, "the fewest iterations before the switch, >= 0 (0: none)")
                  for n, v in (("floor", floor), ("connect_floor", connect_floor), ("roadmap_floor", roadmap_floor))),
                *((n, v, 0, f"{per_square} (inf: never compute the field)")
                  for n, v in (("connect_after", connect_after), ("roadmap_after", roadmap_after))),
                ("stall", stall, 1, "iterations without coming closer to the goal, >= 1 (inf: never switch on a "
                                    "stall)")):
            if isinstance(value, bool) or not isinstance(value, int | float | np.floating) or not value >= low:
                raise InputError(f"{name} = {short_repr(value)}: expected {expected}")
        if not isinstance(goal_in_sight, bool | np.bool_):
            raise InputError(f"goal_in_sight = {short_repr(goal_in_sight)}: expected True or False")
        if kwargs.get("batch", 1) != 1:
            raise InputError(f"batch = {short_repr(kwargs['batch'])}: LazyRouteSampler draws one sample at a time "
                             f"(batch 1)")
        settings = {**SHIPPED_SETTINGS, **kwargs}
        super().__init__(net, **settings)
        self.after, self.cap, self.stall = float(after), float(cap), float(stall)
        self.connect_after, self.roadmap_after = float(connect_after), float(roadmap_after)
        self.floor, self.connect_floor, self.roadmap_floor = float(floor), float(connect_floor), float(roadmap_floor)
        self.connect_cap, self.roadmap_cap = float(connect_cap), float(roadmap_cap)
        self.straight = RouteSampler(None, step_size=self.step_size, **ABLATION_SETTINGS)
        self.switched, self.switch_at = False, 0
        self.goal_in_sight, self.in_sight_until = bool(goal_in_sight), 0

    def at_step(self, step_size: float) -> LazyRouteSampler:
        """``RouteSampler.at_step``, for both phases."""
        out = super().at_step(step_size)
        if out is not self:
            out.straight = self.straight.at_step(step_size)
        return out

    def eager(self) -> RouteSampler:
        """The route sampler this one becomes once its field is computed (same encoder, settings and cache)."""
        out = object.__new__(RouteSampler)
        attributes = self.__dict__.copy()  # (dropping the lazy ones: a fifth of a dict comprehension's time)
        for name in LAZY_ATTRIBUTES:
            attributes.pop(name, None)
        out.__dict__.update(attributes)
        return out

    def for_planner(self, family: str) -> SamplerBase:
        """This sampler's rule for a planner ``family``: itself for RRT, a lazy rule for the others.

        ``LazyConvergingSampler`` for RRT* and Informed RRT* (this sampler to the first solution, at RRT's switch),
        ``LazyConnectSampler`` for RRT-Connect, ``LazyCorridorSampler`` for the roadmaps; the route sampler's rule
        for a family it does not know (``rule_for``).
        """
        if family == FAMILY_TREE:
            return self
        if family == FAMILY_OPTIMIZING:  # the straight line first: RRT*'s loop to its first solution takes its state
            return LazyConvergingSampler(self._copy_with(goal_in_sight=False))
        if family == FAMILY_BIDIRECTIONAL:
            return LazyConnectSampler(self.eager(), self.connect_after, self.connect_floor, self.connect_cap)
        if family == FAMILY_ROADMAP:
            return LazyCorridorSampler(self.eager(), self.roadmap_after, self.roadmap_floor, self.roadmap_cap)
        return self.eager().for_planner(family)

    def _setup(self) -> None:
        self.check_query(self.problem)  # a map the encoder refuses is refused at bind, not at the switch
        grid = self.problem.world
        self.forward_passes, self.reused_seconds, self.switched = 0, 0.0, False
        self.switch_at = switch_iteration(self.after, grid, self.step_size, self.floor, self.cap)
        self.in_sight_until = self._in_sight() if self.goal_in_sight else 0
        self._state = None if self.in_sight_until else self.straight.bind(self.problem).draw_state

    def _in_sight(self) -> int:
        """The iteration the goal-in-sight phase ends at (0: the start does not see the goal): the steps along the
        free line from the start to the goal, plus one.
        """
        p = self.problem
        if not p.world.check_motion(p.start, p.goal):
            return 0
        (sx, sy), (gx, gy) = p.start.tolist(), p.goal.tolist()
        return math.ceil(math.hypot(gx - sx, gy - sy) / self.step_size) + 1  # a grid's metric is Euclidean

    def leave_sight(self) -> None:
        """End the goal-in-sight phase: the straight line's phase goes on from the tree grown so far (a no-op after)."""
        if self.in_sight_until:
            self.in_sight_until = 0
            if not self.switched:
                self._state = self.straight.bind(self.problem).draw_state

    def switch(self) -> None:
        """Compute the encoder's field for the bound query and follow it from here (once; a no-op after)."""
        if not self.switched:
            self.in_sight_until = 0
            super()._setup()
            self.switched = True

    def draw(self, rng, n, view):
        if self.in_sight_until:
            if view.iteration < self.in_sight_until:
                # a whole batch of GoalBiasedSampler(1.0)'s uniforms, as the fused loop draws them, the rows past the
                # phase's end dropped, as it drops them
                u = rng.random((min(n, CHUNK), self.problem.dim + 1))
                rows = min(len(u), self.in_sight_until - view.iteration)
                return np.repeat(np.asarray(self.problem.goal, dtype=np.float64)[None], rows, axis=0)
            self.leave_sight()
        if not self.switched and view.iteration >= self.switch_at:
            self.switch()
        pts = super().draw(rng, n, view)
        if not self.switched and view.iteration - self._state[7][R_CLOSER] >= self.stall:
            self.switch()  # stalled: the straight line's sample is dropped, as the fused loop drops it
            pts = super().draw(rng, n, view)
        return pts

    def fuse(self, planner: Planner) -> SwitchLoop | FusedRRT | None:
        """RRT's loop with both phases' draws compiled in, the switch between them (None for other planners); with the
        goal in sight, the classical loop drawing the goal first (``GoalInSight``).
        """
        if self.in_sight_until:
            state = classical_state(self.low, self.high, self.problem.goal, 1.0, True)
            fused = fuse_rrt(planner, classical_rrt_loop, state, CHUNK)
            return None if fused is None else SwitchLoop(GoalInSight(self), fused)
        if self.switched or math.isinf(self.stall):  # no stall switch: the route sampler's own loop to the switch
            fused = fuse_rrt(planner, route_rrt_loop, self._state, self.batch)
            return fused if fused is None or self.switched else SwitchLoop(self, fused)
        fused = fuse_rrt(planner, stall_rrt_loop, None, self.batch)
        if fused is None:
            return None
        fused.state = (self._state, fused.counters, self.stall)
        return SwitchLoop(self, fused)

    def switch_loop(self, planner: Planner) -> FusedRRT:
        """Switch (``switch``) and give RRT's loop, or RRT*'s to its first solution, on the encoder's field
        (``SwitchLoop``).
        """
        self.switch()
        if planner.fusable_loop == "rrtstar":
            return fuse_rrtstar(planner, route_rrtstar_loop, self._state, self.batch)
        return fuse_rrt(planner, route_rrt_loop, self._state, self.batch)

    def __repr__(self) -> str:
        return (f"LazyRouteSampler(after={self.after:g}, cap={self.cap:g}, floor={self.floor:g}, stall={self.stall:g}, "
                f"goal_in_sight={self.goal_in_sight}, {super().__repr__()[len('RouteSampler('):]}")


class GoalInSight:
    """A lazy route sampler's goal-in-sight phase as ``SwitchLoop`` sees a phase: its end (``switch_at``), whether it
    has ended (``switched``), and the loop that follows it (``switch_loop``: the straight line's, ``fuse``).
    """

    __slots__ = ("lazy",)

    def __init__(self, lazy: LazyRouteSampler) -> None:
        self.lazy = lazy

    @property
    def switched(self) -> bool:
        return not self.lazy.in_sight_until

    @property
    def switch_at(self) -> int:
        return self.lazy.in_sight_until

    def switch_loop(self, planner: Planner):
        self.lazy.leave_sight()
        return self.lazy.fuse(planner)


def switch_iteration(after: float, grid: OccupancyGrid, step: float, floor: float = 0.0,
                     cap: float = math.inf) -> int:
    """``ceil(after * A)`` on a map of ``A`` step-sized squares, at least ``ceil(floor)`` and at most ``ceil(cap)``
    (the cap wins); an infinite switch is never (the largest int64).
    """
    def up(v: float) -> int:
        return NEVER if math.isinf(v) else math.ceil(v)

    return min(max(up(after * grid.height * grid.width * (grid.resolution / step) ** 2), up(floor)), up(cap))


class LazyRule(SamplerBase):
    """What the lazy rules for other planners share: uniform sampling, then the route field's rule for the planner.

    Until ``switch_at`` (``switch_iteration(after, ...)``, at least ``floor``, at most ``cap``) the planner's uniform
    sampling; from it the route sampler's rule for the planner (``rule_type``), bound once.
    """

    #: The route field's rule this one switches to.
    rule_type: type = SamplerBase

    def __init__(self, route: RouteSampler, after: float, floor: float = 0.0, cap: float = math.inf) -> None:
        self.route, self.after, self.floor, self.cap = route, float(after), float(floor), float(cap)

    def _setup(self) -> None:
        self.route.check_query(self.problem)  # refused at bind, not at the switch
        self.switch_at = switch_iteration(self.after, self.problem.world, self.route.step_size, self.floor, self.cap)
        self.rule = None

    @property
    def switched(self) -> bool:
        """Whether the fields have been computed."""
        return self.rule is not None

    @property
    def forward_passes(self) -> int:
        """The encoder's passes this query took (0 before the switch, the rule's after)."""
        return 0 if self.rule is None else self.rule.forward_passes

    @property
    def reused_seconds(self) -> float:
        """Encoder seconds of fields taken from a cache (see ``RouteSampler``)."""
        return 0.0 if self.rule is None else self.rule.reused_seconds

    def switch(self) -> SamplerBase:
        """Compute the fields for the bound query and follow the route field's rule from here (once)."""
        if self.rule is None:
            self.rule = self.rule_type(self.route).bind(self.problem)
        return self.rule

    def switch_loop(self, planner: Planner):
        """Switch (``switch``) and give the rule's own fused loop (``SwitchLoop``)."""
        return self.switch().fuse(planner)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.route!r}, after={self.after:g}, floor={self.floor:g}, cap={self.cap:g})"


class LazyConnectSampler(LazyRule):
    """RRT-Connect's lazy rule: both trees grow by uniform sampling, then follow the field once it is needed.

    Until iteration ``switch_at`` (``switch_iteration(after, ...)``) each sample is uniform over the map, drawn in
    the planner's batches inside its compiled loop; at it, unless the trees have met, the batch's samples past it are
    dropped, the route sampler's fields are computed and ``BidirectionalRouteSampler``'s rule goes on from the
    trees grown so far.

    Args:
        route: The route sampler whose rule each tree follows after the switch (``LazyRouteSampler.eager``).
        after: The switch in iterations per step-sized square of the map (inf: never).
    """

    rule_type = BidirectionalRouteSampler

    def _setup(self) -> None:
        super()._setup()
        # ``UniformSampler``'s compiled draw (``planners.fused.classical_connect_loop``): the box, no goal bias
        self.bounds = classical_state(self.low, self.high, self.problem.goal, 0.0, biased=False)

    def draw(self, rng, n, view):
        if self.rule is None and view.iteration >= self.switch_at:
            self.switch()
        if self.rule is not None:
            return self.rule.draw(rng, n, view)
        # a whole batch is drawn, as the fused loop draws it; the samples past the switch are dropped, as it drops them
        pts = self._uniform(rng.random((min(n, CHUNK), self.problem.dim)))
        return pts[:min(len(pts), self.switch_at - view.iteration)]

    def fuse(self, planner: Planner) -> SwitchLoop | FusedConnect | None:
        """RRT-Connect's loop with both phases' draws compiled in, the switch between them (None for others)."""
        if self.rule is not None:
            return self.rule.fuse(planner)
        fused = fuse_connect(planner, classical_connect_loop, self.bounds, self.bounds, (CHUNK, CHUNK))
        return None if fused is None else SwitchLoop(self, fused)


class LazyCorridorSampler(LazyRule):
    """The roadmaps' lazy rule: uniform samples, then the route field's corridor (``CorridorSampler``) once needed.

    Until sample ``switch_at`` (``switch_iteration(after, ...)``) the samples are uniform over the map (a roadmap draws
    in batches through ``draw``: a batch stops at the switch); at it, unless the roadmap has connected the query, the
    route sampler's two fields are computed and the corridor's samples go on (its own stages, from its first draw),
    its chain along the route drawn twice: with its own links, then with links short enough for a roadmap of the
    vertices there to try them (``switch``).

    Args:
        route: The route sampler whose fields the corridor reads (``LazyRouteSampler.eager``).
        after: The switch in samples per step-sized square of the map (inf: never).
    """

    rule_type = CorridorSampler
    #: the roadmap's longest edge (``at_edge``), which the corridor's chain keeps to after the switch
    edge: float | None = None

    def at_edge(self, length: float | None) -> LazyCorridorSampler:
        """This rule for a roadmap whose edges are at most ``length`` long (``Sampler``; the corridor's ``at_edge``)."""
        out = copy.copy(self)
        out.edge = length
        return out

    def switch(self, vertices: int = 0) -> SamplerBase:
        """Compute the fields and follow the corridor from a roadmap of ``vertices`` other vertices (once).

        ``vertices``: the roadmap's vertices besides the query's start and goal (0: no bound from them).

        The corridor's chain is drawn first, each link in sight of the one before; a roadmap connects a new vertex to
        its nearest ones, so a link longer than the spacing of the vertices already there is seldom tried (the
        previous chain point is not among the nearest), and where the uniform phase left the roadmap in small pieces
        the chain falls apart into them. So after a switch the chain is drawn again with no link longer than
        ``link_bound(vertices)``, the radius of a disc that holds ``LINK_VERTICES`` of the roadmap's vertices on
        average (``CorridorSampler.second_chain``); a roadmap the first chain connects never reaches the second.
        """
        if self.rule is None:
            bound = self.link_bound(vertices)
            rule = CorridorSampler(self.route).at_edge(self.edge)
            self.rule = (rule if math.isinf(bound) else rule.second_chain(bound)).bind(self.problem)
        return self.rule

    def link_bound(self, vertices: int) -> float:
        """The radius of a disc holding ``LINK_VERTICES`` of ``vertices`` spread uniformly over the free space.

        inf for a roadmap of no vertices.
        """
        if vertices <= 0:
            return math.inf
        return math.sqrt(LINK_VERTICES * self.problem.world.free_volume() / (math.pi * vertices))

    def draw(self, rng, n, view):
        if self.rule is None and view.iteration >= self.switch_at:
            self.switch(view.num_vertices - 2)  # the roadmap's vertices besides the query's start and goal
        if self.rule is not None:
            return self.rule.draw(rng, n, view)
        return self._uniform(rng.random((min(n, self.switch_at - view.iteration), self.problem.dim)))


class LazyConvergingSampler(ConvergingRouteSampler):
    """RRT*'s lazy rule: ``LazyRouteSampler``'s to the first solution, then the corridor inside the informed set.

    Up to the first solution the samples are the lazy route sampler's as RRT draws them: the straight line, and the
    encoder's field once the run has not solved by RRT's switch (``after``, ``floor``, ``cap``, ``stall``: RRT*'s
    iterations up to its first solution are RRT's with rewiring, so it takes RRT's switch). From the first solution
    on, ``ConvergingRouteSampler``'s corridor at its settings: at its first draw it computes the field to the goal,
    where the straight line solved without it, and reads the field to the start off the walk down it (a second pass
    where that walk ends out of the goal's sight). So a run that stops at its first solution before the switch pays no
    pass, and a run that goes on for a shorter path pays one (or two).

    Up to the first solution it draws inside RRT*'s compiled loop (``planners.fused.rrtstar_loop``) on either side of
    the switch (``SwitchLoop``); with a stall switch (off by default) it draws through ``draw``.

    Args:
        lazy: The lazy route sampler whose rule runs to the first solution and whose encoder makes the corridor.
        margin, floor, fill: As ``ConvergingRouteSampler``'s, after the first solution.
    """

    def __init__(self, lazy: LazyRouteSampler, margin: float = CONVERGING_SETTINGS["margin"],
                 floor: float = CONVERGING_SETTINGS["floor"],
                 fill: float | None = CONVERGING_SETTINGS["fill"]) -> None:
        super().__init__(lazy, margin, floor, fill)

    @property
    def switched(self) -> bool:
        """Whether the field to the goal has been computed (at the switch, or for the corridor)."""
        return self.first.switched

    @property
    def switch_at(self) -> int:
        """The iteration of the switch, as ``LazyRouteSampler``'s."""
        return self.first.switch_at

    def build_corridor(self) -> None:
        """``ConvergingRouteSampler.build_corridor``, computing the field to the goal first where the run lacks it."""
        if not self.built:
            self.first.switch()
        super().build_corridor()

    def fuse(self, planner: Planner) -> SwitchLoop | FusedRRT | None:
        """RRT*'s loop to the first solution with both phases' draws compiled in (None with a stall switch)."""
        if not math.isinf(self.first.stall):
            return None
        fused = super().fuse(planner)
        return fused if fused is None or self.first.switched else SwitchLoop(self.first, fused)


class SwitchLoop:
    """A planner's fused loop up to a lazy sampler's switch, then the fused loop of the rule it switches to.

    The rule's loop starts with buffers of its own, so what the first loop's buffer still holds is dropped: the
    samples of a uniform batch past the switch, or the sample a stalled draw ended the loop on (``B_STOP``), as the
    sampler's ``draw`` drops them. ``sampler.switch_loop(planner)`` switches and gives the rule's loop. Once the
    planner has a solution there is no switch: RRT*'s loop hands the draws back at its next refill (``HAND_BACK``),
    and ``refills`` counts both loops' for the planner's own schedule from there.
    """

    __slots__ = ("sampler", "fused", "before")

    def __init__(self, sampler: LazyRouteSampler | LazyRule | GoalInSight, fused: FusedRRT | FusedConnect) -> None:
        self.sampler, self.fused = sampler, fused
        self.before = 0  # the first loop's refills, once the rule's loop has taken over

    def __call__(self, planner: Planner, n: int) -> int:
        s, used = self.sampler, 0
        if not (s.switched or planner.solved):
            m = min(n, s.switch_at - planner.iterations)
            if m > 0:
                used = self.fused(planner, m)
                stopped = self.fused.counters[B_STOP]
                if not stopped and (used < m or used == n or planner.solved):  # solved, handed back, full or spent
                    return used
            self.before = self.fused.refills
            self.fused = s.switch_loop(planner)
        return used + self.fused(planner, n - used)

    @property
    def refills(self) -> int:
        """Refills drawn so far by both loops: where the planner's own schedule goes on after a hand-back."""
        return self.before + self.fused.refills
