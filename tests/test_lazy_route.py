"""The lazy route sampler: the straight line first, the encoder's field only when the run has not solved in time."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import load_script, random_walled_problem
from hypothesis import given, settings
from hypothesis import strategies as st

from learning.samplers.lazy_route import (
    LINK_VERTICES,
    SHIPPED_AFTER,
    SHIPPED_CAP,
    SHIPPED_CONNECT_AFTER,
    SHIPPED_FLOOR,
    SHIPPED_ROADMAP_AFTER,
    LazyConnectSampler,
    LazyConvergingSampler,
    LazyCorridorSampler,
    LazyRouteSampler,
)
from learning.samplers.registry import make_sampler
from learning.samplers.route import RouteSampler
from learning.samplers.route_rules import (
    ConvergingRouteSampler,
    CorridorSampler,
    WalkField,
    query_cells,
    walk_field_steps,
)
from planners import OccupancyGrid, Problem, make_planner
from planners.base.fileio import InputError
from planners.maps.generators import VALIDATION_SEED0, generate


class Unfused(LazyRouteSampler):
    """The same sampler drawn through ``draw``, one Python call per iteration (no floor unless given, as ``_lazy``)."""

    fuse = None

    def __init__(self, net, **kwargs):
        super().__init__(net, **{"floor": 0, **kwargs})


def _lazy(**kwargs):
    """``make_sampler("route_lazy")`` with no floors unless given: these small maps switch where the area says."""
    return make_sampler("route_lazy", **{"floor": 0, "connect_floor": 0, "roadmap_floor": 0, **kwargs})


def _run(problem, sampler, seed, pieces=(), planner_name="RRT", budget=20000, **options):
    """One run solved after ``pieces`` (solves of those sizes): what must match, and the planner's bound sampler."""
    planner = make_planner(planner_name, problem, sampler=sampler, seed=seed, extension_step=4.0, **options)
    for size in pieces:
        planner.solve(max_iterations=size)
    r = planner.solve(max_iterations=budget - sum(pieces))
    key = (r.solved, r.iterations, r.collision_checks, r.candidates, r.num_vertices, r.first_solution_iteration,
           r.cost, None if r.path is None else r.path.tobytes())
    return key, planner.sampler


def _same(key, bound, other) -> bool:
    """The same run, and the field computed (or not) alike: a fused run that solves on the switch's iteration must
    not compute a field its drawn twin never needs."""
    return key == other[0] and bound.switched == other[1].switched and bound.forward_passes == other[1].forward_passes


@pytest.fixture(scope="module")
def lazy():
    return make_sampler("route_lazy")


@pytest.fixture(scope="module")
def maps():
    return [generate(f, VALIDATION_SEED0 + 3, 64, goal_tolerance=4.0) for f in ("maze", "bugtrap", "forest")]


def test_the_registry_builds_it_at_the_validated_switch(lazy):
    assert isinstance(lazy, LazyRouteSampler) and lazy.after == SHIPPED_AFTER
    assert make_sampler("route_lazy", after=1.5).after == 1.5


def test_switching_at_once_is_the_route_sampler_and_never_is_its_ablation(lazy, maps):
    route, ablation = make_sampler("route"), make_sampler("route_ablation")
    at_once, never = _lazy(after=0, goal_in_sight=False), _lazy(after=math.inf, cap=math.inf, goal_in_sight=False)
    for p in maps:
        for seed in (0, 1):
            assert _run(p, at_once, seed)[0] == _run(p, route, seed)[0]
            key, bound = _run(p, never, seed)
            assert key == _run(p, ablation, seed)[0]
            assert not bound.switched and bound.forward_passes == 0


def test_a_fused_run_is_the_drawn_run_and_a_run_in_pieces_is_one_solve(maps):
    """At a switch that falls inside some runs, the fused loop, ``draw`` and a solve in pieces plan alike."""
    after = 0.125  # a 64-cell map is 256 step squares: the switch at iteration 32
    fused, drawn = _lazy(after=after), None
    drawn = Unfused(fused.net, after=after)
    switched = kept = 0
    for p in maps:
        for seed in (0, 1, 2):
            key, bound = _run(p, fused, seed)
            assert _same(key, bound, _run(p, drawn, seed))
            assert key == _run(p, fused, seed, pieces=(1, 1, 5, 9, 2))[0]
            switched += bound.switched
            kept += not bound.switched
            assert bound.forward_passes == (bound.symmetry_passes if bound.switched else 0)
            if bound.switched:
                assert key[1] > bound.switch_at == 32
    assert switched and kept, "the maps must give runs on both sides of the switch"


def test_a_cap_brings_the_switch_forward_whatever_the_maps_area(maps):
    """``cap`` iterations at most before the switch: a cap of 32 on a 64-cell map is ``after`` = 0.125 there."""
    capped, by_area = _lazy(after=10.0, cap=32), _lazy(after=0.125)
    at_once = _lazy(cap=0)
    for p in maps:
        for seed in (0, 1):
            key, bound = _run(p, capped, seed)
            assert key == _run(p, by_area, seed)[0] and bound.switch_at == 32
            assert _run(p, at_once, seed)[0] == _run(p, _lazy(after=0), seed)[0]
    assert make_sampler("route_lazy").cap == SHIPPED_CAP and f"cap={SHIPPED_CAP:g}" in repr(make_sampler("route_lazy"))
    for bad in (-1, True, "8", math.nan):
        with pytest.raises(InputError, match="cap = "):
            make_sampler("route_lazy", cap=bad)


def test_a_floor_holds_each_switch_back_on_a_small_map(maps):
    """``floor`` (and each planner's own) iterations at least before the switch; the cap still wins for RRT."""
    p = maps[0]  # a 64-cell map: 256 step squares
    for planner_name, kwargs, at in (("RRT", {"after": 0.125, "floor": 100}, 100),
                                     ("RRT", {"after": 0.125, "floor": 100, "cap": 50}, 50),
                                     ("RRTConnect", {"connect_after": 0.125, "connect_floor": 100}, 100),
                                     ("PRM", {"roadmap_after": 0.125, "roadmap_floor": 100}, 100),
                                     ("RRTConnect", {"connect_after": 0.125}, 32),
                                     ("RRTConnect", {"connect_after": 0.125, "connect_floor": 100,
                                                     "connect_cap": 40}, 40),
                                     ("PRM", {"roadmap_after": 1.0, "roadmap_floor": 100, "roadmap_cap": 60}, 60)):
        sampler = _lazy(**kwargs)
        planner = make_planner(planner_name, p, sampler=sampler, seed=0, extension_step=4.0)
        planner.solve(max_iterations=1)
        assert planner.sampler.switch_at == at
    # RRT-Connect's floor past every run's end is uniform RRT-Connect, run for run
    never = _lazy(connect_after=0, connect_floor=10**6)
    for seed in (0, 1):
        key, bound = _connect(p, never, seed)
        assert key == _connect(p, make_sampler("uniform"), seed)[0] and not bound.switched
    assert f"floor={SHIPPED_FLOOR:g}" in repr(make_sampler("route_lazy"))
    for name in ("floor", "connect_floor", "roadmap_floor", "connect_cap", "roadmap_cap"):
        with pytest.raises(InputError, match=f"{name} = "):
            make_sampler("route_lazy", **{name: -1})
    # RRT-Connect's cap at 0 switches at once, as its switch at 0 does, run for run
    for seed in (0, 1):
        assert _connect(p, _lazy(connect_after=1.0, connect_cap=0), seed)[0] == \
            _connect(p, _lazy(connect_after=0), seed)[0]


def test_a_run_solved_on_the_switchs_iteration_computes_no_field(maps):
    """The switch falls just after the iteration that solves: neither the fused loop nor ``draw`` computes a field."""
    ablation = make_sampler("route_ablation")
    for p in maps:
        solved_at = _run(p, ablation, 0)[0][1]
        for planner_name, lazy in (("RRT", _lazy(after=solved_at / 256)),
                                   ("RRTConnect", _lazy(connect_after=solved_at / 256))):
            key, bound = _run(p, lazy, 0, planner_name=planner_name)
            if planner_name == "RRT":
                assert key[1] == solved_at == bound.switch_at  # the straight line solves on the last iteration before
            assert not bound.switched or key[1] > bound.switch_at


@settings(max_examples=8, deadline=None)
@given(data=st.data())
def test_fused_and_drawn_lazy_runs_are_the_same_on_random_walled_maps(data):
    p = random_walled_problem(data, 64, wall=2, gap=5, tolerance=3.0)
    after = data.draw(st.sampled_from([0.0, 0.02, 0.1, 0.5, math.inf]))
    stall = data.draw(st.sampled_from([1, 3, 10, 40, math.inf]))
    cap = data.draw(st.sampled_from([0, 5, 40, SHIPPED_CAP, math.inf]))
    seed = data.draw(st.integers(0, 2**31 - 1))
    fused = _lazy(after=after, stall=stall, cap=cap)
    assert _same(*_run(p, fused, seed), _run(p, Unfused(fused.net, after=after, stall=stall, cap=cap), seed))


def test_a_stalled_straight_line_switches_to_the_field_fused_as_drawn(maps):
    """The stall switch: where the tree has come no closer for ``stall`` iterations, the field takes over."""
    fused = _lazy(after=math.inf, stall=8)
    drawn = Unfused(fused.net, after=math.inf, stall=8)
    switched = 0
    for p in maps:
        for seed in (0, 1, 2):
            key, bound = _run(p, fused, seed)
            assert _same(key, bound, _run(p, drawn, seed)) and _same(key, bound, _run(p, fused, seed, (1, 3, 8, 2)))
            switched += bound.switched
    assert switched, "the maze and the bugtrap stall the straight line for 8 iterations"


class UnfusedConnect(LazyConnectSampler):
    """RRT-Connect's lazy rule drawn through ``draw``, one Python call per iteration."""

    fuse = None


def _connect(problem, sampler, seed, pieces=()):
    return _run(problem, sampler, seed, pieces, "RRTConnect")


def test_rrt_connects_lazy_rule_is_uniform_then_the_route_rule_fused_as_drawn(maps):
    route, uniform = make_sampler("route"), make_sampler("uniform")
    at_once, never = _lazy(connect_after=0), _lazy(connect_after=math.inf)
    middle = _lazy(connect_after=0.05)  # 256 step squares: the switch at iteration 13
    switched = kept = 0
    for p in maps:
        for seed in (0, 1):
            assert _connect(p, at_once, seed)[0] == _connect(p, route, seed)[0]
            key, bound = _connect(p, never, seed)
            assert key == _connect(p, uniform, seed)[0] and not bound.switched and bound.forward_passes == 0
            key, bound = _connect(p, middle, seed)
            assert _same(key, bound, _connect(p, UnfusedConnect(middle.eager(), 0.05), seed))
            assert key == _connect(p, middle, seed, pieces=(1, 3, 12, 2))[0]
            switched += bound.switched
            kept += not bound.switched
            # one pass where the goal tree's field is read off the walk down the field to the goal, else two
            walked = bound.switched and isinstance(bound.rule.to_start, WalkField)
            assert bound.forward_passes == ((1 if walked else 2) if bound.switched else 0)
    assert switched and kept, "the maps must give runs on both sides of the switch"


@pytest.mark.parametrize("planner_name", ["PRM", "LazyPRM", "OBPRM"])
def test_a_roadmaps_lazy_rule_is_uniform_then_the_corridor(maps, planner_name):
    at_once = _lazy(roadmap_after=0)
    never = _lazy(roadmap_after=math.inf)
    middle = _lazy(roadmap_after=0.1)  # 256 step squares: the switch at sample 26
    switched = kept = 0
    for p in maps:
        for seed in (0, 1):
            assert _run(p, at_once, seed, planner_name=planner_name)[0] == \
                _run(p, make_sampler("route"), seed, planner_name=planner_name)[0]
            key, bound = _run(p, never, seed, planner_name=planner_name)
            assert key == _run(p, make_sampler("uniform"), seed, planner_name=planner_name)[0]
            assert not bound.switched and bound.forward_passes == 0
            key, bound = _run(p, middle, seed, planner_name=planner_name)
            assert key == _run(p, middle, seed, (1, 7, 30, 2), planner_name)[0]
            assert bound.forward_passes == (2 if bound.switched else 0)
            switched += bound.switched
            kept += not bound.switched
    assert switched and kept, "the maps must give runs on both sides of the switch"


def rooms_problem(side: int = 256, room: int = 32, door: int = 3) -> Problem:
    """A square of rooms, each wall of a room with one door, start and goal in opposite corner rooms."""
    obs = np.zeros((side, side), dtype=bool)
    for k in range(room, side, room):
        obs[k - 1:k + 1, :] = True
        obs[:, k - 1:k + 1] = True
    for r in range(0, side, room):
        for c in range(room, side, room):
            obs[r + room // 2:r + room // 2 + door, c - 1:c + 1] = False
            obs[c - 1:c + 1, r + room // 2:r + room // 2 + door] = False
    return Problem(OccupancyGrid(obs), (5.5, 5.5), (side - 5.5, side - 5.5), goal_tolerance=2.0, name="rooms")


def test_a_roadmaps_lazy_chain_after_the_switch_is_short_enough_to_connect():
    # a roadmap connects a new vertex to its nearest ones: after the switch the route's chain is drawn a second time
    # with links no longer than a disc holding LINK_VERTICES of the vertices there, so the chain connects the query
    # where the uniform phase left the roadmap in pieces (with the first chain alone, seed 2 took 402 samples after a
    # chain of 15)
    p = rooms_problem()
    first = CorridorSampler(make_sampler("route")).bind(p).links
    (rs, cs), _ = query_cells(p)
    switched = 0
    for seed in range(4):
        planner = make_planner("PRM", p, sampler=_lazy(roadmap_floor=200, roadmap_after=0), seed=seed)
        planner.solve(max_iterations=200)
        vertices = planner.view().num_vertices - 2
        result = planner.solve(max_iterations=20000)
        lazy = planner.sampler
        assert result.solved
        if not lazy.switched:
            continue
        switched += 1
        bound = math.sqrt(LINK_VERTICES * p.world.free_volume() / (math.pi * vertices))
        assert lazy.rule.edge is None and lazy.rule.second_link == pytest.approx(bound)
        links = lazy.rule.links
        assert np.array_equal(links[:len(first)], first) and len(links) > 2 * len(first)  # the long chain, then short
        second = [rs * 256 + cs, *links[len(first):]]
        for a, b in zip(second[:-1], second[1:], strict=True):
            assert math.hypot(a // 256 - b // 256, a % 256 - b % 256) <= bound
        assert result.iterations - 200 <= len(links) + 10
    assert switched >= 2, "the map must give runs that reach the switch"
    # a switch on a roadmap of no other vertices has no second chain: the route sampler's corridor
    assert LazyCorridorSampler(make_sampler("route"), 0.0).bind(p).switch(0).second_link is None


def test_other_planners_take_the_route_samplers_own_rules(lazy):
    assert lazy.for_planner("tree") is lazy
    connect = lazy.for_planner("bidirectional")
    assert isinstance(connect, LazyConnectSampler) and connect.after == lazy.connect_after == SHIPPED_CONNECT_AFTER
    assert isinstance(connect.route, RouteSampler) and connect.route.net is lazy.net
    roadmap = lazy.for_planner("roadmap")
    assert isinstance(roadmap, LazyCorridorSampler) and roadmap.after == lazy.roadmap_after == SHIPPED_ROADMAP_AFTER
    star = lazy.for_planner("optimizing")
    assert isinstance(star, LazyConvergingSampler) and isinstance(star, ConvergingRouteSampler)
    # RRT*'s loop to its first solution reads the straight line's state: no goal-in-sight phase before it
    assert type(star.route) is LazyRouteSampler and star.route.net is lazy.net and star.route.after == lazy.after
    assert lazy.goal_in_sight and not star.route.goal_in_sight
    eager = lazy.eager()
    assert type(eager) is RouteSampler and eager.net is lazy.net and not hasattr(eager, "after")
    assert not hasattr(eager, "goal_in_sight") and not hasattr(eager, "in_sight_until")
    p = generate("maze", VALIDATION_SEED0 + 3, 64, goal_tolerance=4.0)
    assert make_planner("RRTConnect", p, sampler=lazy, seed=0, extension_step=4.0).solve(20000).solved


class UnfusedStar(LazyRouteSampler):
    """The lazy sampler with RRT*'s rule drawn through ``draw`` (no floor unless given)."""

    def __init__(self, net, **kwargs):
        super().__init__(net, **{"floor": 0, **kwargs})

    def for_planner(self, family):
        rule = super().for_planner(family)
        if isinstance(rule, LazyConvergingSampler):
            rule.fuse = lambda planner: None
        return rule


def _star(problem, sampler, seed, pieces=(), first=False, planner_name="RRTstar"):
    """An RRT* run of 1,500 iterations, or to its first solution (``first``)."""
    return _run(problem, sampler, seed, pieces, planner_name, budget=1500, stop_on_first_solution=first)


def test_rrt_stars_lazy_rule_is_the_straight_line_then_the_field_then_the_corridor(maps):
    """RRT*'s lazy rule: at once, the route rule; never, the straight line to the first solution; between, the same
    run fused, drawn and in pieces, one pass where the run switched before its first solution and none where it did
    not, and the corridor's two fields once the run goes on for a shorter path."""
    route, ablation = make_sampler("route"), make_sampler("route_ablation")
    never = _lazy(after=math.inf, cap=math.inf)
    middle = _lazy(after=0.125)  # 256 step squares: the switch at iteration 32
    before = after = 0
    for p in maps:
        for seed in (0, 1):
            assert _star(p, _lazy(after=0), seed)[0] == _star(p, route, seed)[0]
            key, bound = _star(p, never, seed, first=True)
            assert key == _star(p, ablation, seed, first=True)[0]
            assert isinstance(bound, LazyConvergingSampler) and not bound.switched and bound.forward_passes == 0
            key, bound = _star(p, middle, seed, first=True)
            assert _same(key, bound, _star(p, UnfusedStar(middle.net, after=0.125), seed, first=True))
            assert key == _star(p, middle, seed, (1, 3, 12, 2), first=True)[0]
            assert bound.forward_passes == (bound.first.symmetry_passes if bound.switched else 0)
            assert bound.switched == (key[5] > bound.switch_at == 32)
            before += not bound.switched
            after += bound.switched
            key, bound = _star(p, middle, seed)  # on past the first solution: the corridor needs both fields
            assert _same(key, bound, _star(p, UnfusedStar(middle.net, after=0.125), seed))
            assert key == _star(p, middle, seed, (5, 40, 200))[0]
            # the field to the goal, and the field to the start read off the walk down it (else its own pass)
            walked = walk_field_steps(bound.route, p, bound.first.field) is not None
            assert bound.built and bound.forward_passes == (1 if walked else 2) * bound.first.symmetry_passes
            assert _star(p, middle, seed, planner_name="InformedRRTstar")[0] == \
                _star(p, UnfusedStar(middle.net, after=0.125), seed, planner_name="InformedRRTstar")[0]
    assert before and after, "the maps must give first solutions on both sides of the switch"


def test_at_a_new_step_both_phases_measure_in_it(lazy):
    moved = lazy.at_step(2.0)
    assert moved.step_size == 2.0 and moved.straight.step_size == 2.0 and lazy.step_size == 4.0


@pytest.mark.parametrize("bad", [{"after": -1.0}, {"after": "3"}, {"after": True}, {"after": math.nan},
                                 {"stall": 0}, {"stall": math.nan}, {"stall": "5"}, {"connect_after": -0.5},
                                 {"connect_after": None}, {"roadmap_after": -1}, {"roadmap_after": "1"}, {"batch": 2}])
def test_bad_settings_are_refused_by_name(lazy, bad):
    with pytest.raises(InputError, match=next(iter(bad))):
        LazyRouteSampler(lazy.net, **bad)
    with pytest.raises(InputError, match="needs an encoder"):
        LazyRouteSampler(None)


def test_a_map_the_encoder_refuses_is_refused_at_bind_not_at_the_switch(lazy, monkeypatch):
    monkeypatch.setenv("SAMPLERGYM_MAX_ROUTE_BLOCKS", "100")
    p = generate("forest", VALIDATION_SEED0, 64, goal_tolerance=4.0)
    with pytest.raises(InputError, match="SAMPLERGYM_MAX_ROUTE_BLOCKS"):
        make_planner("RRT", p, sampler=lazy, seed=0, step_size=4.0)
    for planner_name in ("RRT", "RRTstar", "RRTConnect"):  # at the planner's other step: the resampled map's size
        with pytest.raises(InputError, match=r"resampled to 43 x 43 cells.*Take a larger step"):
            make_planner(planner_name, p, sampler=lazy, seed=0, extension_step=6.0)


def test_a_bind_at_another_step_reads_the_maps_size_without_resampling_it(monkeypatch):
    """A lazy sampler that never switches pays no pass, and no resampling of the map either."""
    import planners.worlds.grid as grid_module

    calls = []
    real = grid_module.resample_obstacles
    monkeypatch.setattr("learning.samplers.route.resample_obstacles", lambda *a: calls.append(a) or real(*a))
    p = generate("forest", VALIDATION_SEED0, 64, goal_tolerance=4.0)
    for planner_name in ("RRT", "RRTConnect", "PRM"):
        planner = make_planner(planner_name, p, sampler=_lazy(after=math.inf, cap=math.inf, connect_after=math.inf,
                                                              roadmap_after=math.inf), seed=0, extension_step=6.0)
        assert planner.solve(max_iterations=2000).solved and not planner.sampler.switched
    assert not calls
    planner = make_planner("RRT", p, sampler=_lazy(after=0), seed=0, extension_step=6.0)
    planner.solve(max_iterations=1)
    assert len(calls) == 1 and planner.sampler.switched  # the pass reads the map resampled, once


@pytest.mark.experiments
def test_the_chain_links_rule_takes_the_smallest_bound_within_three_percent_and_restores_the_shipped_one(capsys):
    script = load_script("experiments/lazy_chain_links")
    assert script.choose({1.0: 10.25, 3.0: 10.0, math.inf: 11.0}) == 1.0
    assert script.choose({1.0: 10.4, 3.0: 10.0, 8.0: 10.2}) == 3.0
    assert script.main(["--sizes", "64", "--maps", "2", "--at", "5", "--repeat", "1", "--bounds", "1", "inf"]) == 0
    out = capsys.readouterr().out
    assert "switch at 5 samples:" in out and "chosen: " in out
    assert script.lazy_route.LINK_VERTICES == LINK_VERTICES  # the shipped bound again after the runs
    with pytest.raises(SystemExit):
        script.main(["--bounds", "0"])


@pytest.mark.experiments
def test_the_switchs_rule_takes_the_fastest_or_a_smaller_switch_within_three_percent(tmp_path, capsys):
    script = load_script("experiments/lazy_route_rule")
    inf = math.inf
    assert script.choose({(0.7, inf, inf): 3.05, (1.4, inf, inf): 3.0, (inf, inf, inf): 3.2}) == (0.7, inf, inf)
    assert script.choose({(0.7, inf, inf): 3.2, (inf, inf, inf): 3.0}) == (inf, inf, inf)
    assert script.choose({(0.7, 50.0, inf): 3.05, (0.35, inf, inf): 3.0, (inf, 25.0, inf): 3.5}) == (0.7, 50.0, inf)
    assert script.choose({(0.7, inf, 1000.0): 3.0, (0.7, inf, inf): 3.2}) == (0.7, inf, 1000.0)  # outside the tie
    assert script.choose({(0.7, inf, 1000.0): 3.0, (0.7, inf, inf): 3.05}) == (0.7, inf, inf)  # the larger cap
    assert script.choose({(1.4, inf, inf, 500.0): 3.0, (1.4, inf, inf, 0.0): 3.05}) == (1.4, inf, inf, 0.0)
    assert script.choose({(1.4, inf, inf, 500.0): 3.0, (1.4, inf, inf, 0.0): 3.2}) == (1.4, inf, inf, 500.0)
    # fewer cells whose median is not reached wins first, whatever the times
    assert script.choose({(1.4, inf, inf, 0.0): (1, 2.0), (1.4, inf, 1000.0, 0.0): (0, 3.0)}) == (1.4, inf, 1000.0, 0.0)
    # an unsolved run never solves: a cell half unsolved is not reached; the mean is over the cells that every
    # candidate with the fewest such cells reaches
    ran = {"ms": 1.0, "solved": False}
    runs = {"a": {"x": [{"ms": 5.0, "solved": True}] * 2, "y": [ran, {"ms": 4.0, "solved": True}]},
            "b": {"x": [{"ms": 2.0, "solved": True}] * 2, "y": [{"ms": 8.0, "solved": True}] * 2}}
    assert script.median_ms(runs["a"]["y"]) == inf and script.objective(runs) == {"a": (1, inf), "b": (0, 4.0)}
    # the paired bootstrap: a candidate faster on every run is chosen in every resample; shares sum to one
    fast = {(1.0, inf, inf, 0.0): {"x": [{"ms": 1.0 + i, "solved": True} for i in range(5)]},
            (2.0, inf, inf, 0.0): {"x": [{"ms": 2.0 + i, "solved": True} for i in range(5)]}}
    assert script.stability(fast, list(fast), 50) == {(1.0, inf, inf, 0.0): 1.0, (2.0, inf, inf, 0.0): 0.0}
    close = {(1.0, inf, inf, 0.0): {"x": [{"ms": m, "solved": True} for m in (1.0, 5.0, 2.0, 4.0, 3.0)]},
             (2.0, inf, inf, 0.0): {"x": [{"ms": m, "solved": True} for m in (5.0, 1.0, 4.0, 2.0, 3.0)]}}
    shares = script.stability(close, list(close), 200)
    assert abs(sum(shares.values()) - 1.0) < 1e-12 and 0.0 < shares[(1.0, inf, inf, 0.0)] < 1.0
    assert script.main(["--maps", "1", "0", "0", "--seeds", "1", "--after", "inf", "--stall", "20", "inf", "--out",
                        str(tmp_path / "rule"), "--bootstrap", "20"]) == 0
    out = capsys.readouterr().out
    assert "chosen: after = " in out and "stability: in 20 paired" in out
    assert (tmp_path / "rule" / "runs.json").is_file()
    with pytest.raises(SystemExit):
        script.main(["--after", "-1"])
    with pytest.raises(SystemExit):
        script.main(["--stall", "0"])
    with pytest.raises(SystemExit):
        script.main(["--bootstrap", "-1"])
    with pytest.raises(SystemExit):  # one --maps count per --sizes side
        script.main(["--sizes", "32", "64", "--maps", "1"])
    with pytest.raises(SystemExit):  # an output folder with something in it is refused before any run
        script.main(["--out", str(tmp_path)])


def _open_query(tolerance: float = 2.0):
    """A 64-cell map with one wall; the start sees the goal (the wall lies off the line between them)."""
    from planners import OccupancyGrid, Problem

    obs = np.zeros((64, 64), dtype=bool)
    obs[40:64, 30:33] = True
    return Problem(OccupancyGrid(obs), (4.5, 6.5), (58.5, 30.5), goal_tolerance=tolerance)


class ShortSight(LazyRouteSampler):
    """The goal-in-sight phase cut after two iterations, as where a step along the free line were refused."""

    def _in_sight(self) -> int:
        return min(super()._in_sight(), 2)


class ShortSightUnfused(ShortSight):
    fuse = None


def test_a_goal_in_sight_is_reached_in_the_fewest_iterations_with_no_field(lazy):
    p = _open_query()
    assert p.world.check_motion(p.start, p.goal)
    fewest = math.ceil((math.dist(p.start, p.goal) - p.goal_tolerance) / 4.0)
    drawn = Unfused(lazy.net)
    for seed in (0, 1, 2):
        key, bound = _run(p, lazy, seed)
        assert key[0] and key[1] == fewest and key[2] == fewest  # every iteration one step along the free line
        assert not bound.switched and bound.forward_passes == 0 and bound.draw_state is None
        assert _same(key, bound, _run(p, drawn, seed)) and key == _run(p, lazy, seed, pieces=(1, 2, 3))[0]
    # without it, the straight line's phase from the first iteration: the ablation, run for run
    never = _lazy(after=math.inf, cap=math.inf, goal_in_sight=False)
    key, bound = _run(p, never, 0)
    assert key == _run(p, make_sampler("route_ablation"), 0)[0] and bound.draw_state is not None


def test_a_goal_out_of_sight_changes_nothing(maps):
    for p in maps:
        assert not p.world.check_motion(p.start, p.goal)
        for seed in (0, 1):
            key, bound = _run(p, _lazy(after=0.125), seed)
            assert bound.in_sight_until == 0
            assert _same(key, bound, _run(p, _lazy(after=0.125, goal_in_sight=False), seed))


def test_a_sight_phase_that_ends_unsolved_goes_on_on_the_straight_line_fused_as_drawn(lazy):
    p = _open_query(tolerance=1.0)
    for seed in (0, 1):
        key, bound = _run(p, ShortSight(lazy.net), seed)
        assert key[0] and key[1] > 2 and bound.in_sight_until == 0 and bound.draw_state is not None
        assert _same(key, bound, _run(p, ShortSightUnfused(lazy.net), seed))
        assert key == _run(p, ShortSight(lazy.net), seed, pieces=(1, 1, 1, 4))[0]
    for bad in (1, "yes", 0.0):
        with pytest.raises(InputError, match="goal_in_sight = "):
            make_sampler("route_lazy", goal_in_sight=bad)
