"""The route field with every planner family: the ``for_planner`` hook, RRT-Connect's view, and the field's rules."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from conftest import random_walled_problem
from hypothesis import given, settings
from hypothesis import strategies as st

import envs  # noqa: F401 - registers the environments
from learning.evaluation.every_planner import Setup, run_setup
from learning.evaluation.protocol import MOVINGAI_MAPS, Protocol, movingai_queries
from learning.samplers.registry import make_sampler
from learning.samplers.route import RouteSampler
from learning.samplers.route_rules import (
    CORRIDOR_START_FIELD,
    BidirectionalRouteSampler,
    ConvergingRouteSampler,
    CorridorSampler,
    WalkField,
    corridor_cells,
    corridor_stages,
    query_cells,
    reversed_query,
    route_chain,
    route_sums,
    sight_chain,
    walk_field_steps,
    walk_field_to_start,
    walled_between,
    whole_walk,
)
from planners import OccupancyGrid, Problem, TreeView, UniformSampler, make_planner
from planners.base.fileio import InputError
from planners.base.samplers import PLANNER_FAMILIES, TREE_GOAL, TREE_START, SamplerBase
from planners.guidance.follow import last_in_sight, path_field, walk_field, walk_path
from planners.maps.gridsearch import distance_field


def wall_problem(size: int = 32) -> Problem:
    """A small map split by a wall with one gap near its bottom, start and goal on either side."""
    obs = np.zeros((size, size), dtype=bool)
    obs[:, size // 2 - 1:size // 2 + 1] = True
    obs[2:5, size // 2 - 1:size // 2 + 1] = False
    return Problem(OccupancyGrid(obs), (4.5, size - 4.5), (size - 4.5, size - 4.5), goal_tolerance=2.0, name="wall")


class Recorder(UniformSampler):
    """Uniform sampling that records the family it was told."""

    told: list = []

    def for_planner(self, family):
        Recorder.told.append(family)
        return self


FAMILY_OF = {"RRT": "tree", "RRTConnect": "bidirectional", "PRM": "roadmap", "LazyPRM": "roadmap",
             "OBPRM": "roadmap", "RRTstar": "optimizing", "InformedRRTstar": "optimizing"}


@pytest.mark.parametrize("planner", sorted(FAMILY_OF))
def test_every_planner_tells_the_sampler_its_family(planner):
    Recorder.told = []
    make_planner(planner, wall_problem(), sampler=Recorder(), seed=0)
    assert Recorder.told == [FAMILY_OF[planner]] and FAMILY_OF[planner] in PLANNER_FAMILIES


def test_a_for_planner_hook_that_returns_no_sampler_is_refused_by_name():
    class Broken(UniformSampler):
        def for_planner(self, family):
            return "nothing"

    with pytest.raises(TypeError, match="Broken.for_planner"):
        make_planner("RRT", wall_problem(), sampler=Broken(), seed=0)


def test_rrt_connect_tells_which_tree_the_next_sample_extends():
    seen = []

    class Watcher(UniformSampler):
        def draw(self, rng, n, view):
            seen.append((view.iteration, view.tree, None if view.goal_tree is None else len(view.goal_tree)))
            return self._uniform(rng.random((1, 2)))

    planner = make_planner("RRTConnect", wall_problem(), sampler=Watcher(), seed=3, step_size=2.0)
    planner.solve(max_iterations=6)
    assert [t for _, t, _ in seen] == [TREE_START, TREE_GOAL] * 3
    assert all(it == i for i, (it, _, _) in enumerate(seen)) and seen[0][2] == 1
    assert make_planner("RRT", wall_problem(), seed=0).view().goal_tree is None


@pytest.mark.parametrize("name", ["route_ablation", "exact_route"])
@pytest.mark.parametrize("planner, rule", [("RRT", RouteSampler), ("RRTConnect", BidirectionalRouteSampler),
                                           ("PRM", CorridorSampler), ("LazyPRM", CorridorSampler),
                                           ("RRTstar", ConvergingRouteSampler)])
def test_one_sampler_takes_each_planners_rule_and_solves_the_same_way_twice(name, planner, rule):
    p = wall_problem()
    results = []
    for _ in range(2):
        solver = make_planner(planner, p, sampler=make_sampler(name, step_size=2.0), seed=5, extension_step=2.0)
        assert isinstance(solver.sampler, rule)
        r = solver.solve(max_iterations=400 if planner == "RRTstar" else 3000)
        assert r.solved and p.world.path_valid(r.path)
        results.append((r.iterations, r.collision_checks, r.cost))
    assert results[0] == results[1]


def test_the_learned_field_serves_rrt_connect_and_prm():
    from planners.maps.generators import VALIDATION_SEED0, generate

    p = generate("rooms", VALIDATION_SEED0 + 7, 64, goal_tolerance=4.0)
    for planner in ("RRTConnect", "PRM"):
        r = make_planner(planner, p, sampler=make_sampler("route"), seed=0, extension_step=4.0).solve(
            max_iterations=5000)
        assert r.solved and p.world.path_valid(r.path)


def test_the_exact_corridor_holds_the_shortest_route_and_nothing_longer():
    p = wall_problem()
    to_goal = distance_field(p.world.obstacles, p.world.cell_of(p.goal))
    to_start = distance_field(p.world.obstacles, p.world.cell_of(p.start))
    cells = corridor_cells(to_goal, to_start, 0.0, width=1e-9)  # sums along two routes differ by rounding
    total = (to_goal + to_start).ravel()
    assert len(cells) and np.allclose(total[cells], np.nanmin(np.where(np.isfinite(total), total, np.nan)))
    gap = np.ravel_multi_index((4, 15), p.world.obstacles.shape)  # every shortest route passes the gap's top cell
    assert gap in cells
    assert len(corridor_cells(np.full((2, 2), np.inf), np.full((2, 2), np.inf), 0.3)) == 0


def test_the_routes_length_is_what_the_fields_say_not_a_dip_in_their_sum():
    p = wall_problem()
    to_goal = distance_field(p.world.obstacles, p.world.cell_of(p.goal))
    to_start = distance_field(p.world.obstacles, p.world.cell_of(p.start))
    shortest = to_goal[p.world.cell_of(p.start)]
    cells, sums, length = route_sums(to_goal, to_start, query_cells(p))
    assert length == pytest.approx(shortest) and sums.min() == pytest.approx(shortest)  # one number, exact
    exact = corridor_cells(to_goal, to_start, 0.0)
    off = np.setdiff1d(cells, exact)
    near = off[np.argmin(to_start.ravel()[off])]  # a cell off the shortest routes, near the start
    assert to_start.ravel()[near] < 0.5 * shortest
    dipped = to_goal.copy()
    dipped.ravel()[near] = 0.0  # a learned field can call a cell off the route close to the goal
    _, sums, length = route_sums(dipped, to_start, query_cells(p))
    assert sums.min() < 0.5 * shortest and length == pytest.approx(shortest)
    assert len(route_sums(np.full((2, 2), np.inf), np.zeros((2, 2)), ((0, 0), (1, 1)))[0]) == 0
    cells, counts, starts = corridor_stages(np.full((2, 2), np.inf), np.zeros((2, 2)), ((0, 0), (1, 1)), 0.3, 1.0, 4.0)
    assert len(cells) == 0 and list(counts) == [0] and list(starts) == [0]  # no reachable cell: an empty corridor


class DippedExact(SamplerBase):
    """The exact route sampler whose field to the goal calls one cell ``near`` the goal: a learned field's dip."""

    def __init__(self, near: int) -> None:
        self.exact, self.near = make_sampler("exact_route", step_size=2.0), near
        self.net, self.step_size = None, 2.0

    def cost_to_go(self, problem):
        f = self.exact.cost_to_go(problem)
        if problem.goal[0] > problem.start[0]:  # the field to the goal, not the pass with start and goal swapped
            f.field.ravel()[self.near] = 0.0
        return f

    def bind(self, problem):
        bound = self.exact.bind(problem)  # RRT*'s rule follows it to a first solution
        bound.field = self.cost_to_go(problem).field
        return bound

    def draw(self, rng, n, view):
        raise NotImplementedError("only its field is read")


def stages_and_cells(bound):
    """The stage of each of ``bound``'s first 2,000 draws, and the cells drawn in each."""
    pts = bound.draw(np.random.default_rng(3), 2000, None)
    stage = np.searchsorted(bound.starts, np.arange(2000), side="right") - 1
    cells = np.floor(pts[:, 1]).astype(int) * 32 + np.floor(pts[:, 0]).astype(int)
    return stage, cells


def test_the_corridor_widens_from_a_dip_to_the_route_then_to_every_cell():
    p = wall_problem()
    assert p.goal[0] > p.start[0]
    exact = CorridorSampler(make_sampler("exact_route", step_size=2.0), 0.0, 0.0, None).bind(p)
    to_start = distance_field(p.world.obstacles, p.world.cell_of(p.start)).ravel()
    off = np.setdiff1d(np.flatnonzero(np.isfinite(to_start)), exact.cells[:exact.counts[0]])
    near = off[np.argmin(to_start[off])]
    narrow = CorridorSampler(DippedExact(near), 0.0, 0.0, None).bind(p)
    assert narrow.counts[0] < exact.counts[0] / 4  # the dip shrinks the first corridor
    assert len(narrow.counts) == 1 and len(narrow.starts) == 1  # and without ``fill`` it stays
    wide = CorridorSampler(DippedExact(near), 0.0, 0.0, 1.0).bind(p)
    assert wide.counts[0] == narrow.counts[0] and np.array_equal(wide.cells[:wide.counts[0]],
                                                                  narrow.cells[:narrow.counts[0]])
    assert set(wide.cells[:wide.counts[1]]) >= set(exact.cells[:exact.counts[0]])  # stage 1: the route's corridor
    assert wide.counts[-1] == len(wide.cells) == np.isfinite(to_start).sum()  # the last: every reachable cell
    assert np.all(np.diff(wide.counts) > 0)
    assert np.array_equal(np.diff(wide.starts), np.ceil(wide.counts[:-1] / 2.0 ** 2))  # one draw per 2x2 cells
    stage, cells = stages_and_cells(wide)
    for j in range(len(wide.counts)):
        assert np.isin(cells[stage == j], wide.cells[:wide.counts[j]]).all()
    assert (stage == len(wide.counts) - 1).any()


def test_a_corridor_about_a_route_of_length_zero_widens_to_every_cell():
    p = wall_problem()
    here = p.with_query((4.5, 27.5), (4.6, 27.4))  # start and goal in one cell
    bound = CorridorSampler(make_sampler("exact_route", step_size=2.0), 0.3, 0.3, 1.0).bind(here)
    assert bound.counts[-1] == len(bound.cells) == np.isfinite(distance_field(p.world.obstacles, (27, 4))).sum()
    assert np.all(np.diff(bound.counts) > 0)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), cut=st.integers(1, 199))
def test_a_widening_corridors_stream_does_not_depend_on_batch_sizes(seed, cut):
    p = wall_problem()
    one = CorridorSampler(make_sampler("route_ablation", step_size=2.0), 0.0, 0.3, 0.5).bind(p)
    two = CorridorSampler(make_sampler("route_ablation", step_size=2.0), 0.0, 0.3, 0.5).bind(p)
    assert len(one.starts) > 1 and one.starts[1] < 200  # the draws cross a stage
    a = one.draw(np.random.default_rng(seed), 200, None)
    rng = np.random.default_rng(seed)
    b = np.concatenate([two.draw(rng, cut, None), two.draw(rng, 200 - cut, None)])
    assert np.array_equal(a, b)


@pytest.mark.parametrize("fill", [0, -1.0, math.inf, math.nan, True, "4"])
def test_a_corridor_refuses_a_fill_that_is_not_a_positive_number(fill):
    with pytest.raises(InputError, match="fill"):
        CorridorSampler(make_sampler("route"), 0.3, 0.3, fill)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), margin=st.sampled_from([0.0, 0.3, 1.0]))
def test_corridor_samples_lie_in_corridor_cells_without_a_floor(seed, margin):
    p = wall_problem()
    bound = CorridorSampler(make_sampler("exact_route", step_size=2.0), margin, 0.0).bind(p)
    pts = bound.draw(np.random.default_rng(seed), 64, None)
    rows, cols = np.floor(pts[:, 1]).astype(int), np.floor(pts[:, 0]).astype(int)
    assert np.isin(rows * 32 + cols, bound.cells).all()
    again = CorridorSampler(make_sampler("exact_route", step_size=2.0), margin, 0.0).bind(p)
    assert np.array_equal(again.draw(np.random.default_rng(seed), 64, None), pts)  # seeded: the same samples


class UnfusedBidirectional(BidirectionalRouteSampler):
    """The same rule drawn through ``draw`` once per iteration: what the fused loop must equal."""

    fuse = None


@pytest.mark.parametrize("name", ["route", "route_ablation", "exact_route"])
@pytest.mark.parametrize("family", ["narrow_passage", "bugtrap", "rooms"])
def test_rrt_connects_fused_loop_plans_the_same_runs_as_draw(name, family):
    from planners.maps.generators import VALIDATION_SEED0, generate

    p = generate(family, VALIDATION_SEED0 + 3, 96, goal_tolerance=4.0)
    route = make_sampler(name).at_step(4.0)
    runs = []
    for rule in (BidirectionalRouteSampler, UnfusedBidirectional):
        for seed in (0, 1):
            planner = make_planner("RRTConnect", p, sampler=rule(route), seed=seed, extension_step=4.0)
            assert (planner._fused is not None) == (rule is BidirectionalRouteSampler)
            r = planner.solve(max_iterations=20000)
            assert r.solved and p.world.path_valid(r.path)
            runs.append((r.iterations, r.collision_checks, r.candidates, r.num_vertices, r.cost, r.path.tobytes()))
    assert runs[:2] == runs[2:]


class UnfusedConverging(ConvergingRouteSampler):
    """RRT*'s rule drawn through ``draw`` once per iteration up to the first solution."""

    fuse = None


@pytest.mark.parametrize("name", ["route", "route_ablation"])
@pytest.mark.parametrize("planner", ["RRTstar", "InformedRRTstar"])
def test_rrtstars_loop_fused_to_its_first_solution_then_handed_back_plans_the_same_runs(name, planner):
    """Stopped at the first solution, and anytime past it (the loop hands the draws back to ``draw``)."""
    from planners.maps.generators import VALIDATION_SEED0, generate

    p = generate("rooms", VALIDATION_SEED0 + 2, 96, goal_tolerance=4.0)
    route = make_sampler(name).at_step(4.0)
    runs = []
    for rule in (ConvergingRouteSampler, UnfusedConverging):
        budget = 20000
        for first in (True, False):
            solver = make_planner(planner, p, sampler=rule(route), seed=1, extension_step=4.0,
                                  stop_on_first_solution=first)
            assert (solver._fused is not None) == (rule is ConvergingRouteSampler)
            r = solver.solve(max_iterations=budget)
            assert r.solved and (first or r.iterations == budget > r.first_solution_iteration)
            assert (solver._fused is None) == (not first or rule is UnfusedConverging)  # handed back past it
            runs.append((r.iterations, r.collision_checks, r.candidates, r.num_vertices, r.cost, r.path.tobytes()))
            budget = r.iterations + 200  # anytime: 200 iterations past the first solution
    assert runs[:2] == runs[2:]


@settings(max_examples=12, deadline=None)
@given(data=st.data())
def test_fused_and_drawn_rules_plan_the_same_runs_on_random_maps(data):
    """Random walls with random gaps, random ends and seeds: RRT-Connect's and RRT*'s fused loops equal ``draw``."""
    p = random_walled_problem(data, 40, wall=1, gap=3, tolerance=1.5)
    seed = data.draw(st.integers(0, 2**31 - 1))
    batch = data.draw(st.sampled_from([1, 2, 8]))  # above 1 a refill spans both trees' turns, or the first solution
    route = (make_sampler(data.draw(st.sampled_from(["route_ablation", "exact_route"])), step_size=2.0) if batch == 1
             else RouteSampler(None, step_size=2.0, batch=batch))
    for planner, rules in (("RRTConnect", (BidirectionalRouteSampler, UnfusedBidirectional)),
                           ("RRTstar", (ConvergingRouteSampler, UnfusedConverging))):
        runs = []
        for rule in rules:
            r = make_planner(planner, p, sampler=rule(route), seed=seed, extension_step=2.0).solve(max_iterations=600)
            runs.append((r.solved, r.iterations, r.collision_checks, r.candidates, r.num_vertices,
                         None if r.path is None else r.path.tobytes()))
        assert runs[0] == runs[1], planner


def test_rrt_connects_fused_run_in_pieces_is_the_run_in_one_piece():
    """Single steps, then solves in pieces of odd sizes across the trees' turns and refills: the one-solve run."""
    from planners.maps.generators import VALIDATION_SEED0, generate

    p = generate("bugtrap", VALIDATION_SEED0 + 1, 96, goal_tolerance=4.0)
    sampler = make_sampler("route_ablation")
    whole = make_planner("RRTConnect", p, sampler=sampler, seed=3, extension_step=4.0).solve(max_iterations=20000)
    planner = make_planner("RRTConnect", p, sampler=sampler, seed=3, extension_step=4.0)
    for _ in range(9):
        planner.step()
    for size in (3, 1, 20, 7):
        planner.solve(max_iterations=size)
    r = planner.solve(max_iterations=20000)
    assert whole.solved and whole.iterations > 40
    assert (r.iterations, r.collision_checks, r.path.tobytes()) == (whole.iterations, whole.collision_checks,
                                                                     whole.path.tobytes())


def test_the_goal_tree_follows_the_field_to_the_start():
    p = wall_problem()
    bound = BidirectionalRouteSampler(make_sampler("exact_route", step_size=2.0)).bind(p)
    view = TreeView(p, np.array([p.start]), None, 1, 0, math.dist(p.start, p.goal), math.inf, 1, tree=TREE_GOAL,
                    goal_tree=np.array([p.goal]))
    pts = np.concatenate([bound.draw(np.random.default_rng(s), 1, view) for s in range(40)])
    # the route to the start leaves the goal downwards, to the gap near row 3
    assert np.median(pts[:, 1]) < p.goal[1] - 2


def test_the_goal_tree_reads_its_field_off_the_walk_to_the_goal_and_pays_no_second_pass():
    from planners.maps.generators import VALIDATION_SEED0, generate

    p = generate("rooms", VALIDATION_SEED0 + 7, 64, goal_tolerance=4.0)
    route = make_sampler("route").at_step(4.0)
    bound = BidirectionalRouteSampler(route).bind(p)
    assert isinstance(bound.to_start, WalkField) and bound.forward_passes == route.symmetry_passes
    blocked = np.asarray(p.world.obstacles, dtype=bool)
    (rs, cs), (rg, cg) = query_cells(p)
    W = blocked.shape[1]
    walk = np.empty(blocked.size + 2, np.int64)
    moves = walk_path(bound.to_goal.field, blocked, rs * W + cs, float(blocked.size), route.ripple,
                      route.ripple_growth, walk)
    if walk[moves - 1] != rg * W + cg:
        walk[moves], moves = rg * W + cg, moves + 1
    expected = np.where(blocked, np.inf, path_field(blocked, walk, moves) * p.world.resolution / 4.0)
    assert np.array_equal(bound.to_start.field, expected)  # in steps, to the start along the walk
    both = BidirectionalRouteSampler(route, goal_tree="pass").bind(p)
    assert not isinstance(both.to_start, WalkField) and both.forward_passes == 2 * route.symmetry_passes
    r = make_planner("RRTConnect", p, sampler=route, seed=0, extension_step=4.0).solve(max_iterations=5000)
    assert r.solved and p.world.path_valid(r.path)


def test_a_walk_that_ends_out_of_the_goals_sight_gives_its_field_as_far_as_it_went_or_none():
    """RRT-Connect's goal tree takes the walk's field as far as it went; RRT*'s corridor (no ``partial``) the pass."""
    p = wall_problem()
    blocked = np.asarray(p.world.obstacles, dtype=bool)
    to_goal = distance_field(blocked, p.world.cell_of(p.goal))
    pit = to_goal.copy()
    pit[:, :14] = np.where(blocked[:, :14], np.inf, 0.0)  # flat before the wall: the walk stops where it starts
    ends = query_cells(p)
    assert walk_field_to_start(pit, blocked, ends) is None
    assert walk_field_to_start(to_goal, blocked, ends) is not None
    (rs, cs), _ = ends
    start = np.array([rs * blocked.shape[1] + cs], dtype=np.int64)  # the walk: the start's cell alone
    assert np.array_equal(walk_field_to_start(pit, blocked, ends, partial=True), path_field(blocked, start, 1))

    class Pitted(RouteSampler):
        def _fields(self, grid):
            return pit.copy(), pit.copy()

    pitted = Pitted(None, step_size=2.0)
    bound = BidirectionalRouteSampler(pitted).bind(p)
    assert isinstance(bound.to_start, WalkField)  # no second pass: the field of the walk as far as it went
    walked = walk_field_to_start(pit, blocked, ends, pitted.ripple, pitted.ripple_growth, partial=True)
    assert np.array_equal(bound.to_start.field, np.where(blocked, np.inf, walked / 2.0))  # in steps of 2 cells
    W = blocked.shape[1]
    (rg, cg) = ends[1]
    assert np.isfinite(walked[rg, cg])  # from the goal a strict walk down it reaches the start
    assert walk_field(walked, blocked, rg * W + cg, float(blocked.size)) == start[0]
    starred = ConvergingRouteSampler(pitted, start_field="walk").bind(p)
    assert walk_field_steps(pitted, p, starred.first.field) is None  # the corridor would take the pass


@pytest.mark.parametrize("goal_tree", ["both", "", None, 1])
def test_an_unknown_goal_tree_field_is_refused_by_name(goal_tree):
    with pytest.raises(InputError, match="goal_tree = .*expected one of walk, pass"):
        BidirectionalRouteSampler(make_sampler("route_ablation"), goal_tree=goal_tree)


def test_after_a_solution_rrtstar_samples_stay_in_the_informed_set():
    p = wall_problem()
    bound = ConvergingRouteSampler(make_sampler("exact_route", step_size=2.0), 0.3, 0.3).bind(p)
    cost = 40.0
    view = TreeView(p, np.array([p.start]), np.array([-1]), 1, 0, 1.0, cost, 100)
    out = bound.draw(np.random.default_rng(0), 64, view)
    through = np.linalg.norm(out.points - p.start, axis=1) + np.linalg.norm(out.points - p.goal, axis=1)
    assert len(out.points) == 64 and (through <= cost + p.goal_tolerance + 2 * math.sqrt(2)).all()
    assert out.candidates.sum() >= 64


def test_after_a_solution_rrtstars_corridor_widens_by_stage_inside_the_informed_set():
    p = wall_problem()
    exact = CorridorSampler(make_sampler("exact_route", step_size=2.0), 0.0, 0.0, None).bind(p)
    to_start = distance_field(p.world.obstacles, p.world.cell_of(p.start)).ravel()
    off = np.setdiff1d(np.flatnonzero(np.isfinite(to_start)), exact.cells[:exact.counts[0]])
    bound = ConvergingRouteSampler(DippedExact(off[np.argmin(to_start[off])]), 0.0, 0.0, 1.0,
                                   start_field="pass").bind(p)  # the dip's corridor from both fields
    cost = 60.0  # an informed set that leaves some corridor cells out
    view = TreeView(p, np.array([p.start]), np.array([-1]), 1, 0, 1.0, cost, 100)
    rng = np.random.default_rng(5)
    pts = np.concatenate([bound.draw(rng, 64, view).points for _ in range(40)])
    assert len(bound.counts) > 2
    stage = np.searchsorted(bound.starts, np.arange(len(pts)), side="right") - 1
    cells = np.floor(pts[:, 1]).astype(int) * 32 + np.floor(pts[:, 0]).astype(int)
    rows, cols = np.divmod(bound.cells, 32)
    centres = np.stack([cols, rows], axis=1) + 0.5
    through = np.linalg.norm(centres - p.start, axis=1) + np.linalg.norm(centres - p.goal, axis=1)
    inside = bound.cells[through - math.sqrt(2.0) <= cost + p.goal_tolerance]  # within half a cell's diagonal
    assert 0 < len(inside) < len(bound.cells)
    for j in range(len(bound.counts)):
        mine = np.intersect1d(bound.cells[:bound.counts[j]], inside)  # floor 0: every sample from the corridor
        if len(mine):  # (a stage with no cell inside draws from the informed set)
            assert np.isin(cells[stage == j], mine).all()
    assert (stage == len(bound.counts) - 1).any()


def test_bad_corridor_settings_are_refused_by_name():
    with pytest.raises(InputError, match="margin"):
        CorridorSampler(make_sampler("route_ablation"), -1.0)
    with pytest.raises(InputError, match="floor"):
        CorridorSampler(make_sampler("route_ablation"), 0.3, 1.5)


def test_bad_tightness_settings_are_refused_by_name():
    for tight in (-1.0, math.inf, math.nan, True, "8"):
        with pytest.raises(InputError, match="tight"):
            CorridorSampler(make_sampler("route_ablation"), 0.3, 0.3, 1.0, tight)


def test_tightness_marks_the_gap_in_a_wall_and_not_the_open():
    p = wall_problem()
    grid = p.world
    between = walled_between(grid, 2).reshape(grid.shape)
    assert between[3, 15:17].all()  # the gap's middle row: the wall two cells above and below
    assert not between[2, 15:17].any() and walled_between(grid, 3).reshape(grid.shape)[2:5, 15:17].all()
    assert not between[10:22, 4:12].any()  # the open half, no wall within two cells
    assert set(np.unique(between)) <= {0.0, 1.0}
    # outside the map counts as a wall: a cell in a corner is between walls, one on an edge's middle is not
    assert between[0, 0] == 1 and between[16, 0] == 0
    # asked for some cells, the same values as for the whole map
    some = np.random.default_rng(0).choice(grid.obstacles.size, 200, replace=False)
    assert np.array_equal(walled_between(grid, 2, some), between.ravel()[some])


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_a_tight_corridor_draws_more_often_in_the_passage_and_tight_zero_draws_every_cell_alike(seed):
    p = wall_problem()
    plain = CorridorSampler(make_sampler("exact_route", step_size=4.0), 0.3, 0.0, None, 0.0).bind(p)
    tight = CorridorSampler(make_sampler("exact_route", step_size=4.0), 0.3, 0.0, None, 8.0).bind(p)
    assert plain.cum is None and np.array_equal(plain.cells, tight.cells)
    # half a step is two cells: a cell weighs 9 where walls lie within two cells on two opposite sides, else 1
    weights = np.diff(np.concatenate([[0.0], tight.cum]))
    assert set(np.round(weights, 9)) <= {1.0, 9.0}
    middle = np.isin(tight.cells, [3 * 32 + 15, 3 * 32 + 16])
    assert middle.any() and np.all(weights[middle] == 9.0)
    # the draws follow the weights: the gap's middle row holds more of them than without
    share_plain, share_tight = middle.mean(), weights[middle].sum() / tight.cum[-1]
    assert share_tight > 1.5 * share_plain
    a, b = (s.draw(np.random.default_rng(seed), 4000, None) for s in (plain, tight))

    def in_middle(pts):
        return int(np.sum((pts[:, 0] >= 15) & (pts[:, 0] < 17) & (pts[:, 1] >= 3) & (pts[:, 1] < 4)))

    assert in_middle(b) > in_middle(a)
    assert abs(in_middle(b) - 4000 * share_tight) < 6 * math.sqrt(4000 * share_tight)


def test_the_reversed_query_swaps_start_and_goal():
    p = wall_problem()
    q = reversed_query(p)
    assert np.array_equal(q.start, p.goal) and np.array_equal(q.goal, p.start) and q.goal_tolerance == 2.0


def test_rrtstar_stops_at_its_first_solution_in_the_planner_rows():
    run = run_setup(Setup("uniform", "RRTstar", None), wall_problem(), 0, max_iterations=2000, step=2.0)
    assert run["solved"] and run["iterations"] < 2000  # stopped at its first solution


@pytest.mark.parametrize("planner", ["rrt-connect", "prm", "rrt*"])
def test_the_planning_env_serves_each_planner_and_passes_the_checkers(planner):
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = gym.make("SamplerGym/Planning-v1", planner=planner, source_kwargs={"size": 64}, max_iterations=40)
    check_env(env.unwrapped, skip_render_check=True)
    sb3_check_env(env.unwrapped, warn=False)


@pytest.mark.slow
@pytest.mark.parametrize("planner", ["rrt-connect", "prm", "rrt*"])
def test_sb3s_default_policy_trains_on_the_planning_env_for_each_planner(planner):
    from stable_baselines3 import PPO

    env = gym.make("SamplerGym/Planning-v1", planner=planner, source_kwargs={"size": 64}, max_iterations=40)
    # SB3's default policy for Dict observations takes the env as it is (a few updates, not a training run)
    PPO("MultiInputPolicy", env, n_steps=16, batch_size=16, n_epochs=1, seed=0, device="cpu").learn(16)


def test_a_roadmap_query_moves_the_corridor_and_later_queries_are_counted():
    from learning.evaluation.every_planner import later_queries
    from learning.evaluation.later_queries import other_queries

    p = wall_problem()
    pairs = other_queries(p, 2, seed=0)
    assert len(pairs) == 2 and all(p.world.path_valid(np.array([s, s])) for s, _ in pairs)
    planner = make_planner("PRM", p, sampler=make_sampler("exact_route", step_size=2.0), seed=0)
    planner.solve(max_iterations=3000)
    before = planner.sampler.cells
    s, g = pairs[0]
    r = planner.query(s, g, max_iterations=3000)
    assert r.solved and not np.array_equal(planner.sampler.cells, before)
    rows = later_queries({"wall": [p]}, [Setup("exact_route", "PRM", "exact_route", (("step_size", 2.0),))],
                         queries=2, seeds=(0,), max_iterations=3000)
    assert rows[0]["success"] == 1.0 and 0.0 <= rows[0]["served"] <= 1.0 and rows[0]["later"] >= 0


@pytest.mark.parametrize("start_field", ["pass", "walk"])
def test_a_roadmap_takes_both_fields_from_the_cache_on_a_second_run(start_field):
    from learning.samplers.route import FieldCache, shipped_sampler
    from planners.maps.generators import VALIDATION_SEED0, generate

    p = generate("maze", VALIDATION_SEED0 + 11, 64, goal_tolerance=4.0)
    cache = FieldCache()
    route = shipped_sampler(device="cpu")
    route.fields = cache
    sampler = route if start_field == CORRIDOR_START_FIELD else CorridorSampler(route, start_field=start_field)
    runs = [make_planner("PRM", p, sampler=sampler, seed=0) for _ in range(2)]
    assert cache.misses == 1 and cache.hits == 1  # bound: the field to the goal (the chain's), computed once
    assert np.array_equal(runs[0].sampler.cells, runs[1].sampler.cells)  # the corridor needs the field to the start
    passes = 2 if start_field == "pass" else 1  # a pass computed once too, or read off the walk (the default)
    assert (cache.misses, cache.hits) == (passes, passes)
    assert runs[0].sampler.reused_seconds == 0 and runs[1].sampler.reused_seconds > 0
    assert runs[1].sampler.forward_passes == passes


@pytest.mark.parametrize("start_field", ["pass", "walk"])
def test_rrtstar_pays_the_field_to_the_start_only_once_it_has_a_solution(start_field):
    """With the field to the start read off the walk, no second pass at all; with a pass, one once it has a solution."""
    from learning.samplers.route import FieldCache, shipped_sampler
    from planners.maps.generators import VALIDATION_SEED0, generate

    p = generate("rooms", VALIDATION_SEED0 + 7, 64, goal_tolerance=4.0)
    cache = FieldCache()
    route = shipped_sampler(device="cpu")
    route.fields = cache
    plain = shipped_sampler(device="cpu").at_step(4.0)  # no cache: the walk on this map reaches the goal's sight
    assert walk_field_steps(plain, p, plain.cost_to_go(p).field) is not None

    def rule():
        return ConvergingRouteSampler(route, start_field=start_field)

    first = make_planner("RRTstar", p, sampler=rule(), seed=0, stop_on_first_solution=True, step_size=4.0)
    r = first.solve(max_iterations=5000)
    assert r.solved and cache.misses == 1 and first.sampler.forward_passes == 1 and not first.sampler.built
    anytime = make_planner("RRTstar", p, sampler=rule(), seed=0, step_size=4.0)
    more = anytime.solve(max_iterations=r.iterations + 50)
    assert (more.first_solution_iteration, anytime.sampler.built) == (r.iterations, True)
    passes = 1 if start_field == "walk" else 2
    assert cache.misses == passes and anytime.sampler.forward_passes == passes and anytime.sampler.reused_seconds > 0


def test_rrtstar_takes_its_corridors_field_to_the_start_off_the_walk_by_default():
    assert ConvergingRouteSampler(make_sampler("route")).start_field == "walk"
    with pytest.raises(InputError, match="start_field = .*expected one of walk, pass"):
        ConvergingRouteSampler(make_sampler("route"), start_field="both")


def test_the_every_planner_script_prints_each_planners_rows_and_refuses_bad_counts(capsys):
    from conftest import load_script

    script = load_script("every_planner")
    with pytest.raises(SystemExit):
        script.main(["--n", "0"])
    assert "--n 0" in capsys.readouterr().err
    assert script.main(["--n", "1", "--seeds", "1", "--planners", "RRTConnect", "--max-iterations", "300"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 5 * 5 and {line.split()[2] for line in lines if line.startswith("forest ")} == {
        "uniform", "goal", "route", "route_ablation", "exact_route"}


@pytest.mark.parametrize("name", ["route", "route_ablation", "exact_route", "route_lazy", "policy"])
def test_a_2d_sampler_handed_a_6dof_body_names_the_world_and_the_sampler_that_fits(name):
    from learning.samplers.registry import make_sampler
    from planners import PRM, RRT, RRTConnect
    from planners.worlds.rigid3d import WINDOW_SCENE, load_scene

    problem = load_scene(WINDOW_SCENE)
    for planner in (RRT, RRTConnect, PRM):
        with pytest.raises(ValueError, match=r"2-D occupancy maps .*got a RigidBodyWorld; .*rigid_route"):
            planner(problem, sampler=make_sampler(name), seed=0).solve(max_iterations=5)


def in_sight(blocked: np.ndarray, a: int, b: int) -> bool:
    """Whether the centres of flat cells ``a`` and ``b`` see each other (the grid's segment test)."""
    return last_in_sight(blocked, np.array([a, b], dtype=np.int64), 2) == b


@settings(max_examples=15, deadline=None)
@given(data=st.data(), link=st.integers(1, 40))
def test_the_chain_is_the_walks_corners_each_in_sight_of_the_one_before(data, link):
    p = random_walled_problem(data, 40, wall=2, gap=3, tolerance=1.0)
    grid = p.world
    blocked = np.asarray(grid.obstacles, dtype=bool)
    exact = make_sampler("exact_route", step_size=1.0).bind(p)
    (rs, cs), (rg, cg) = query_cells(p)
    w = grid.width
    start, goal = rs * w + cs, rg * w + cg
    points, last = sight_chain(exact.field, blocked, start, link, 0.0, 0.0)
    assert exact.field.ravel()[last] == 0.0  # the exact field's walk reaches the goal's tolerance
    chain = [start] + points
    assert chain[-1] == last
    for a, b in zip(chain[:-1], chain[1:], strict=True):
        assert in_sight(blocked, a, b)
        # at most ``link`` moves of the walk apart: a move changes row or column by at most one
        assert max(abs(a // w - b // w), abs(a % w - b % w)) <= link
    # the chain the corridor draws leaves out the start's and the goal's own cells
    links = route_chain(exact.field, exact.field, blocked, ((rs, cs), (rg, cg)), link)
    if in_sight(blocked, last, goal):  # then the walk from the start is the whole chain
        assert list(links) == [c for c in points if c not in (start, goal)]
    else:
        assert list(links[:len(points)]) == [c for c in points if c not in (start, goal)]


def numpy_walled_between(blocked: np.ndarray, h: int, cells: np.ndarray) -> np.ndarray:
    """``walled_between`` written as whole-array steps over a padded map: the definition the compiled loop keeps."""
    padded = np.pad(blocked, h, constant_values=True)
    r, c = np.divmod(cells, blocked.shape[1])
    r, c = r + h, c + h
    out = np.zeros(len(cells), dtype=bool)
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
        ahead = np.zeros(len(cells), dtype=bool)
        behind = np.zeros(len(cells), dtype=bool)
        for k in range(1, h + 1):
            ahead |= padded[r + k * dr, c + k * dc]
            behind |= padded[r - k * dr, c - k * dc]
        out |= ahead & behind
    return out.astype(np.float64)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), h=st.integers(1, 6), rows=st.integers(1, 24), cols=st.integers(1, 24),
       density=st.floats(0.0, 0.6))
def test_walled_between_is_its_definition_on_random_maps(seed, h, rows, cols, density):
    rng = np.random.default_rng(seed)
    blocked = rng.random((rows, cols)) < density
    grid = OccupancyGrid(blocked)
    every = np.arange(blocked.size)
    assert np.array_equal(walled_between(grid, h), numpy_walled_between(blocked, h, every))
    some = rng.choice(blocked.size, min(blocked.size, 7), replace=False)
    assert np.array_equal(walled_between(grid, h, some), numpy_walled_between(blocked, h, some))


def python_sight_chain(field, blocked, cell, link, ripple, growth):
    """``sight_chain``'s corners found one by one in Python: the definition the compiled loop keeps."""
    visited = whole_walk(field, blocked, cell, ripple, growth)
    moves = len(visited)
    points, at = [], 0
    while at < moves - 1:
        end = min(moves, at + link + 1)
        corner = last_in_sight(blocked, visited[at:end], end - at)
        ahead = at + 1 + int(np.flatnonzero(visited[at + 1:end] == corner)[0]) if corner != visited[at] else at + 1
        points.append(int(visited[ahead]))
        at = ahead
    return points, int(visited[moves - 1])


@settings(max_examples=20, deadline=None)
@given(data=st.data(), link=st.integers(1, 80), ripple=st.sampled_from([0.0, 0.5, 2.0]))
def test_the_compiled_chain_is_the_python_chain(data, link, ripple):
    p = random_walled_problem(data, 40, wall=2, gap=3, tolerance=1.0)
    blocked = np.asarray(p.world.obstacles, dtype=bool)
    for name in ("exact_route", "route_ablation"):
        field = make_sampler(name, step_size=1.0).bind(p).field
        (rs, cs), _ = query_cells(p)
        start = rs * p.world.width + cs
        assert sight_chain(field, blocked, start, link, ripple, 0.1) == python_sight_chain(
            field, blocked, start, link, ripple, 0.1)


def test_where_the_walk_stops_short_the_chain_goes_on_from_the_goal_end():
    p = wall_problem()
    blocked = np.asarray(p.world.obstacles, dtype=bool)
    straight = make_sampler("route_ablation", step_size=2.0)
    to_goal, to_start = straight.bind(p).field, straight.bind(reversed_query(p)).field
    ends = query_cells(p)
    forward, last = sight_chain(to_goal, blocked, ends[0][0] * 32 + ends[0][1], 64, 0.0, 0.0)
    assert last != ends[1][0] * 32 + ends[1][1]  # the straight line's walk stops at the wall
    links = route_chain(to_goal, to_start, blocked, ends, 64)
    w = 32
    assert len(links) > len(forward)
    assert all(c % w < 15 for c in forward) and any(c % w > 16 for c in links[len(forward):])


def test_a_corridor_with_a_chain_draws_the_chain_first_then_the_corridor_and_prm_connects_along_it():
    p = wall_problem()
    route = make_sampler("exact_route", step_size=4.0)
    plain = CorridorSampler(route, 0.3, 0.3, 1.0, 8.0, 0.0).bind(p)
    chained = CorridorSampler(route, 0.3, 0.3, 1.0, 8.0, 64.0).bind(p)
    assert len(plain.links) == 0 and len(chained.links) >= 2  # the gap's two sides at least
    rng_a, rng_b = np.random.default_rng(5), np.random.default_rng(5)
    k = len(chained.links)
    a = chained.draw(rng_a, k + 50, None)
    assert len(a) == k  # the chain alone
    a, b = np.concatenate([a, chained.draw(rng_a, 50, None)]), plain.draw(rng_b, k + 50, None)
    cells = (b[:, 1].astype(int) * 32 + b[:, 0].astype(int))
    drawn = a[:k, 1].astype(int) * 32 + a[:k, 0].astype(int)
    assert np.array_equal(drawn, chained.links)  # each chain point in its cell, in order
    assert np.all(a[:k] % 1.0 == 0.5)  # at its centre, where the walk's sight test ran
    assert np.array_equal(a[k:], b[k:]) and len(cells) == k + 50  # then the corridor's draws, the stream unchanged
    r = make_planner("PRM", p, sampler=CorridorSampler(route, 0.3, 0.3, 1.0, 8.0, 64.0), seed=0).solve(
        max_iterations=2000)
    assert r.solved and r.iterations <= k
    assert "chain=64" in repr(chained) and "chain" not in repr(plain)


@pytest.mark.parametrize("chain", [-1.0, math.inf, math.nan, True, "4"])
def test_a_chain_that_is_not_a_finite_number_of_steps_is_refused(chain):
    with pytest.raises(InputError, match="chain"):
        CorridorSampler(make_sampler("route_ablation"), 0.3, 0.3, 1.0, 8.0, chain)


def test_a_chain_that_connects_the_roadmap_never_pays_the_field_to_the_start():
    from planners.maps.generators import VALIDATION_SEED0, generate

    p = generate("rooms", VALIDATION_SEED0 + 7, 64, goal_tolerance=4.0)
    bound = CorridorSampler(make_sampler("route", step_size=4.0), start_field="pass").bind(p)
    k = len(bound.links)
    assert k > 0 and not bound.built and bound.forward_passes == 1  # the field to the goal only
    rng = np.random.default_rng(0)
    chain = bound.draw(rng, 1000, None)
    assert len(chain) == k  # the chain alone, whatever the batch asked
    assert not bound.built and bound.forward_passes == 1
    after = bound.draw(rng, 10, None)
    assert len(after) == 10 and bound.built and bound.forward_passes == 2  # then the corridor, from both fields
    # the same samples as one whose corridor was built at bind, drawn in one batch: the stream is 4 uniforms a sample
    eager = CorridorSampler(make_sampler("route", step_size=4.0), start_field="pass").bind(p)
    eager.build_corridor()
    assert np.array_equal(eager.draw(np.random.default_rng(0), k + 10, None), np.concatenate([chain, after]))
    r = make_planner("PRM", p, sampler=make_sampler("route"), seed=0).solve(max_iterations=5000)
    assert r.solved and p.world.path_valid(r.path)


def test_a_corridor_may_read_its_field_to_the_start_off_the_walk_and_pay_no_second_pass():
    from planners.maps.generators import VALIDATION_SEED0, generate

    p = generate("rooms", VALIDATION_SEED0 + 7, 64, goal_tolerance=4.0)
    route = make_sampler("route", step_size=4.0)
    walked = CorridorSampler(route, start_field="walk").bind(p)
    passed = CorridorSampler(route, start_field="pass").bind(p)
    walked.build_corridor()
    passed.build_corridor()
    assert walked.forward_passes == 1 and passed.forward_passes == 2  # the walk's field costs no pass
    expected = walk_field_steps(route, p, walked._to_goal.field)
    assert expected is not None and np.array_equal(walked.field_to_start().field, expected)
    assert not np.array_equal(walked.field_to_start().field, passed.field_to_start().field)
    assert len(walked.cells) and walked.problem.world.obstacles.ravel()[walked.cells].sum() == 0
    r = make_planner("PRM", p, sampler=CorridorSampler(route, start_field="walk"), seed=0).solve(max_iterations=5000)
    assert r.solved and p.world.path_valid(r.path)
    with pytest.raises(InputError, match="start_field = 'both'"):
        CorridorSampler(route, start_field="both")


def test_where_the_walk_ends_out_of_the_goals_sight_a_walking_corridor_takes_the_pass(monkeypatch):
    import learning.samplers.route_rules as rules

    p = wall_problem()
    route = make_sampler("exact_route", step_size=4.0)
    monkeypatch.setattr(rules, "walk_field_steps", lambda *args, **kwargs: None)  # a walk that ends in a pit
    bound = CorridorSampler(route, start_field="walk").bind(p)
    bound.build_corridor()
    expected = route.cost_to_go(reversed_query(p)).field
    assert np.array_equal(bound.field_to_start().field, expected)


class EdgeRecorder(UniformSampler):
    """Uniform sampling that records the edge a roadmap told it (``at_edge``)."""

    told: list = []

    def at_edge(self, length):
        EdgeRecorder.told.append(length)
        return self


@pytest.mark.parametrize(("planner", "kwargs", "told"), [
    ("PRM", {}, [None]), ("PRM", {"max_edge_length": 3.0}, [3.0]), ("LazyPRM", {"max_edge_length": 5.0}, [5.0]),
    ("PRM", {"connection": "radius", "radius": 2.0, "max_edge_length": 5.0}, [2.0]),
    ("PRM", {"connection": "radius"}, [None]),  # PRM*'s radius shrinks as the roadmap grows: no limit known
    ("RRT", {}, []), ("RRTConnect", {}, [])])
def test_a_roadmap_tells_the_sampler_its_longest_edge(planner, kwargs, told):
    EdgeRecorder.told = []
    make_planner(planner, wall_problem(), sampler=EdgeRecorder(), seed=0, **kwargs)
    assert EdgeRecorder.told == told


@pytest.mark.parametrize("edge", [2.0, 3.0, 6.0])
def test_the_chain_keeps_to_the_roadmaps_longest_edge(edge):
    p = wall_problem()
    bound = CorridorSampler(make_sampler("exact_route", step_size=4.0)).at_edge(edge).bind(p)
    free = CorridorSampler(make_sampler("exact_route", step_size=4.0)).bind(p)
    (rs, cs), _ = query_cells(p)
    chain = [rs * 32 + cs, *bound.links]
    assert len(bound.links) > len(free.links) >= 2  # more links where each is shorter
    for a, b in zip(chain[:-1], chain[1:], strict=True):
        assert math.hypot(a // 32 - b // 32, a % 32 - b % 32) <= edge
    assert "edge=3" in repr(CorridorSampler(make_sampler("route_ablation")).at_edge(3.0))
    r = make_planner("PRM", p, sampler=make_sampler("exact_route", step_size=4.0), seed=0,
                     max_edge_length=edge).solve(max_iterations=5000)
    assert r.solved and r.iterations <= len(bound.links) + 1
    # below a cell's diagonal no link fits: no chain
    assert len(CorridorSampler(make_sampler("exact_route", step_size=4.0)).at_edge(1.0).bind(p).links) == 0


def test_a_second_chain_follows_the_first_with_shorter_links_and_refuses_a_length_that_is_not_one():
    p = wall_problem()
    route = make_sampler("exact_route", step_size=4.0)
    first = CorridorSampler(route).bind(p).links
    both = CorridorSampler(route).second_chain(2.0).bind(p)
    assert np.array_equal(both.links[:len(first)], first) and len(both.links) > 2 * len(first)
    (rs, cs), _ = query_cells(p)
    second = [rs * 32 + cs, *both.links[len(first):]]
    for a, b in zip(second[:-1], second[1:], strict=True):
        assert math.hypot(a // 32 - b // 32, a % 32 - b % 32) <= 2.0
    # no shorter than the first's links, or below a cell's diagonal: no second chain
    for length in (1e9, 1.0):
        assert np.array_equal(CorridorSampler(route).second_chain(length).bind(p).links, first)
    assert "second_link=2" in repr(CorridorSampler(route).second_chain(2.0))
    for bad in (0.0, -1.0, math.nan, math.inf, True, "2"):
        with pytest.raises(ValueError, match="second chain's longest link"):
            CorridorSampler(route).second_chain(bad)


def test_the_lazy_corridor_hands_the_roadmaps_edge_to_the_corridor_it_switches_to():
    p = wall_problem()
    lazy = make_sampler("route_lazy").for_planner("roadmap").at_edge(3.0).bind(p)
    assert lazy.switch().edge == 3.0


@pytest.mark.experiments
def test_the_rule_tuning_script_asks_the_corridors_field_to_the_start_on_the_movingai_tuning_split(movingai, capsys):
    from conftest import load_script

    script = load_script("experiments/tune_route_rules")
    maps = script.movingai_tuning_maps(str(movingai))
    assert set(maps) <= set(MOVINGAI_MAPS) and all(len(v) == Protocol().tuning_scenarios for v in maps.values())
    tests = {q.problem(str(movingai), 4.0).name for q in movingai_queries(
        str(movingai), list(maps), Protocol().scenarios, Protocol().tuning_scenarios, 4.0) if q.split == "test"}
    assert tests and not tests & {p.name for v in maps.values() for p in v}  # never a test scenario
    assert script.main(["--fields", "route", "--planners", "PRM", "--seeds", "1", "--margins", "0.3", "--floors",
                        "0.3", "--fills", "1", "--start-fields", "pass", "walk", "--movingai-tuning",
                        str(movingai)]) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("PRM")]
    assert len(rows) == 2 and "start pass" in rows[0] and "start walk" in rows[1]
    assert all(float(r.split("geomean")[1].split()[0]) >= 1 and "success" in r for r in rows)  # samples per query
