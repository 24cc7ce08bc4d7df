"""The ablation that removes the learning: the policy's action classes drawn from a constant distribution."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import fine_check_path

from learning import evaluation as E
from learning.samplers.ablation import FRONTIER_GRID, ConstantGuidedSampler
from planners import RRT
from planners.base.fileio import InputError
from planners.maps.generators import generate
from planners.tools.benchmark import Run


def _run(family, query, split, planner, sampler, seed, its, spec="") -> Run:
    return Run(map=family, query=query, split=split, planner=planner, sampler=sampler, seed=seed, solved=True,
               iterations=its, lower_bound=1, candidates=its, collision_checks=its, wall_time=0.001,
               us_per_iteration=1.0, path_cost=1.0, forward_passes=0, vertices=its, sampler_spec=spec)


@pytest.mark.parametrize("family", ["forest", "bugtrap", "maze"])
def test_paths_are_valid_and_runs_seeded(family):
    problem = generate(family, 123, 64)
    runs = []
    for _ in range(2):
        planner = RRT(problem, step_size=4.0, sampler=ConstantGuidedSampler(0.7), seed=5)
        r = planner.solve(max_iterations=20000)
        runs.append((r.iterations, planner.view().vertices.copy()))
        assert r.solved and fine_check_path(problem.world, r.path)
        assert np.allclose(r.path[0], problem.start)
        assert np.linalg.norm(r.path[-1] - problem.goal) <= problem.goal_tolerance + 1e-9
    assert runs[0][0] == runs[1][0] and np.array_equal(runs[0][1], runs[1][1])


def test_the_frontier_probability_changes_the_run():
    problem = generate("rooms", 7, 64)
    its = {p: RRT(problem, step_size=4.0, sampler=ConstantGuidedSampler(p), seed=0).solve(20000).iterations
           for p in (0.3, 0.9)}
    assert its[0.3] != its[0.9]


@pytest.mark.parametrize("kwargs", [{"frontier": 1.5}, {"frontier": math.nan}, {"frontier": "0.5"},
                                    {"batch": 0}, {"batch": 2.0}, {"uniform_floor": -0.1}, {"step_size": 0}])
def test_bad_settings_are_refused_by_name(kwargs):
    with pytest.raises(InputError, match=next(iter(kwargs))):
        ConstantGuidedSampler(**kwargs)


def test_the_ablation_is_tuned_on_the_tuning_split_only():
    qs = E.generated_queries(["forest"], 64, n_test=2, n_tune=3)
    protocol = E.Protocol()
    tasks = E.constant_tuning_tasks(qs, "RRT", protocol, 8)
    assert {t.query.split for t in tasks} == {"tuning"} and len(tasks) == 3 * len(FRONTIER_GRID)
    assert {t.sampler_label for t in tasks} == {E.constant_sampler(p) for p in FRONTIER_GRID}
    # tuning runs where 0.5 is best; test runs where 0.9 would look best must not sway the choice
    runs = []
    for t in tasks:
        its = 10 if t.sampler.param("frontier") == 0.5 else 100
        runs.append(_run(t.query.family, str(t.query.key), "tuning", t.planner, t.sampler_label, t.seed, its,
                         t.sampler.to_json()))
    runs.append(_run("forest", "x", "test", "RRT", "constant=0.9", 0, 1, E.constant_spec(0.9, protocol, 8).to_json()))
    best = E.best_constant(runs)
    assert best == {("forest", "RRT"): 0.5}
    test = E.constant_test_tasks(qs, "RRT", protocol, 8, best, seeds=2)
    assert {t.sampler for t in test} == {E.constant_spec(0.5, protocol, 8)} and {t.sampler_label for t in test} == {
        E.CONSTANT} and {t.query.split for t in test} == {"test"} and len(test) == 4


def test_the_geodesic_frontier_reference_ranks_its_frontier_by_cost_to_go():
    """Its frontier weights are geodesic distances: never below the straight line, well above it in a trap."""
    from learning.references.expert import GeodesicFrontierSampler

    p = generate("bugtrap", 1_000_003, 128, goal_tolerance=4.0)
    planner = RRT(p, step_size=4.0, sampler=GeodesicFrontierSampler(0.7), seed=0)
    planner.solve(max_iterations=150)
    f = planner.sampler.guide.frontier  # the planner binds its own copy
    cells = f.front[:len(f)]
    centres = np.stack([(cells % f.W + 0.5) * f.cell, (cells // f.W + 0.5) * f.cell], 1)
    euclid = np.linalg.norm(centres - p.goal, axis=1) / f.cell
    assert len(cells) > 10
    assert np.all(f.dist[cells] >= euclid - 1.0)  # grid distances are octile, and measured from the centre cell
    assert np.max(f.dist[cells] - euclid) > 5.0  # somewhere the way round the trap is longer than the line
    r = RRT(p, step_size=4.0, sampler=GeodesicFrontierSampler(0.7), seed=1).solve(max_iterations=5000)
    assert r.solved and fine_check_path(p.world, r.path) and np.allclose(r.path[0], p.start)
    assert np.linalg.norm(r.path[-1] - p.goal) <= p.goal_tolerance + 1e-9


def test_the_corridor_reference_samples_near_shortest_paths_and_plans():
    """q=1: every sample lies in a free cell through which a path is at most 10% longer than the shortest."""
    from learning.references.expert import CorridorSampler
    from learning.samplers.route import RouteSampler
    from planners import UniformSampler
    from planners.maps.gridsearch import distance_field

    p = generate("maze", 1_000_004, 128, goal_tolerance=4.0)
    grid = p.world
    bound = CorridorSampler(1.0, UniformSampler()).bind(p)
    pts = bound.draw(np.random.default_rng(0), 2000, None)
    s, g = grid.cell_of(p.start), grid.cell_of(p.goal)
    through = distance_field(grid.obstacles, s) + distance_field(grid.obstacles, g)
    cells = np.array([grid.cell_of(q) for q in pts])
    assert np.all(through[cells[:, 0], cells[:, 1]] <= 1.1 * through[s] + 1e-9)
    assert len({tuple(c) for c in cells}) > 200  # spread over the corridor, not a few cells
    for q, base in ((0.3, RouteSampler(None)), (0.8, UniformSampler())):
        r = RRT(p, step_size=4.0, sampler=CorridorSampler(q, base), seed=2).solve(max_iterations=20000)
        assert r.solved and fine_check_path(p.world, r.path) and np.allclose(r.path[0], p.start)
        assert np.linalg.norm(r.path[-1] - p.goal) <= p.goal_tolerance + 1e-9
    with pytest.raises(ValueError, match="0 <= q <= 1"):
        CorridorSampler(1.5, UniformSampler())
