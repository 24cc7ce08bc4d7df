"""Restarts by Luby's sequence (planners.algorithms.restarts): the sequence, the attempts, the budgets, the result."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import fine_check_path
from hypothesis import given, settings
from hypothesis import strategies as st

from planners import GoalBiasedSampler, OccupancyGrid, Problem, luby, make_planner, solve_with_restarts
from planners.algorithms.restarts import attempt_seed


@pytest.fixture(scope="module")
def wall():
    """A wall with one gap far from the straight line: RRT-Connect needs a few hundred iterations."""
    obs = np.zeros((60, 60), bool)
    obs[:, 29:31] = True
    obs[52:55, 29:31] = False
    g = OccupancyGrid(obs)
    return Problem(g, (5.5, 10.5), (55.5, 10.5), goal_tolerance=1.5)


def test_the_sequence_is_lubys():
    assert [luby(i) for i in range(1, 32)] == [1, 1, 2, 1, 1, 2, 4, 1, 1, 2, 1, 1, 2, 4, 8,
                                               1, 1, 2, 1, 1, 2, 4, 1, 1, 2, 1, 1, 2, 4, 8, 16]
    with pytest.raises(ValueError):
        luby(0)


@given(st.integers(1, 2**20))
@settings(max_examples=200, deadline=None)
def test_each_block_of_the_sequence_ends_at_its_power_of_two(i):
    # the first 2^k - 1 terms sum to k 2^(k-1), and term 2^k - 1 is 2^(k-1): the sequence's defining recursion
    k = i.bit_length()
    if i == (1 << k) - 1:
        assert luby(i) == 1 << (k - 1)
    else:
        assert luby(i) == luby(i - (1 << (k - 1)) + 1)


def test_attempts_are_fresh_planners_on_seeds_from_the_run(wall):
    plain = make_planner("RRTConnect", wall, seed=attempt_seed(3, 1), step_size=2.0).solve(max_iterations=20000)
    assert plain.solved
    once = solve_with_restarts("RRTConnect", wall, seed=3, unit=20000, max_iterations=20000, step_size=2.0)
    assert once.restarts == 0 and once.seed == 3 and once.iterations == plain.iterations
    assert np.array_equal(once.path, plain.path)
    cut = solve_with_restarts("RRTConnect", wall, seed=3, unit=5, max_iterations=20000, step_size=2.0)
    assert cut.solved and cut.restarts > 0 and cut.stop_reason == "solved"
    assert fine_check_path(wall.world, cut.path)
    # the totals are the attempts' own, replayed by hand
    total = checks = 0
    for a in range(1, cut.restarts + 2):
        r = make_planner("RRTConnect", wall, seed=attempt_seed(3, a), step_size=2.0).solve(max_iterations=5 * luby(a))
        total, checks = total + r.iterations, checks + r.collision_checks
        assert r.solved == (a == cut.restarts + 1)
    assert cut.iterations == total and cut.collision_checks == checks
    assert cut.first_solution_iteration == total - r.iterations + r.first_solution_iteration
    again = solve_with_restarts("RRTConnect", wall, seed=3, unit=5, max_iterations=20000, step_size=2.0)
    assert again.iterations == cut.iterations and np.array_equal(again.path, cut.path)


def test_a_sampler_is_bound_again_for_each_attempt(wall):
    spec = GoalBiasedSampler(0.2)
    r = solve_with_restarts("RRT", wall, seed=1, unit=10, max_iterations=50000, sampler=spec, step_size=2.0)
    total = 0
    for a in range(1, r.restarts + 2):
        total += make_planner("RRT", wall, seed=attempt_seed(1, a), sampler=GoalBiasedSampler(0.2),
                              step_size=2.0).solve(max_iterations=10 * luby(a)).iterations
    assert r.solved and total == r.iterations


def test_the_budgets_hold_over_all_attempts(wall):
    r = solve_with_restarts("RRTConnect", wall, seed=0, unit=1, max_iterations=7, step_size=2.0)
    assert not r.solved and r.iterations == 7 and r.stop_reason == "max_iterations" and r.restarts >= 3
    t = solve_with_restarts("RRTConnect", wall, seed=0, unit=1, time_limit=0.05, step_size=0.05)
    assert t.stop_reason in ("time_limit", "solved")


def test_bad_arguments_are_refused_by_name(wall):
    with pytest.raises(ValueError, match="anytime"):
        solve_with_restarts("RRTstar", wall, seed=0, unit=10, max_iterations=10)
    with pytest.raises(ValueError, match="unit"):
        solve_with_restarts("RRT", wall, seed=0, unit=0, max_iterations=10)
    with pytest.raises(ValueError, match="max_iterations or time_limit"):
        solve_with_restarts("RRT", wall, seed=0, unit=10)
    with pytest.raises(ValueError, match="time_limit"):
        solve_with_restarts("RRT", wall, seed=0, unit=10, time_limit=-1.0)
