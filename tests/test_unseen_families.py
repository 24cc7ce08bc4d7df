"""The unseen test families: deterministic, valid queries with a wide route, solvable by plain RRT."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from planners import GoalBiasedSampler, make_planner
from planners.maps import generators
from planners.maps.gridsearch import connected, shortest_path_length
from planners.maps.unseen import (
    ROUTE_CLEARANCE,
    UNSEEN_FAMILIES,
    UNSEEN_MIN_SIZE,
    UNSEEN_SEED0,
    clearance_map,
    generate_unseen,
    unseen_families,
)


def _cells(problem) -> tuple[tuple[int, int], tuple[int, int]]:
    grid = problem.world
    return grid.cell_of(problem.start), grid.cell_of(problem.goal)


def _check_valid(problem, size: int) -> None:
    """Start and goal free, connected, far enough apart, and joined by a route wider than one RRT step."""
    obs = problem.world.obstacles
    assert obs.shape == (size, size) and obs.dtype == np.bool_
    s, g = _cells(problem)
    assert not obs[s] and not obs[g]
    assert connected(obs, s, g)
    length = shortest_path_length(problem.world, problem.start, problem.goal)
    assert length == pytest.approx(problem.reference_length)
    assert length >= 0.5 * size
    assert np.hypot(*(problem.start - problem.goal)) > problem.goal_tolerance
    # the wide route, checked independently of clearance_map: grow the obstacles (the map edge a wall) by a
    # square of the clearance and ask scipy whether start and goal share a 4-connected free component
    r = max(1, int(ROUTE_CLEARANCE * size / 128 + 0.5))
    grown = ndimage.binary_dilation(obs, structure=np.ones((2 * r + 1, 2 * r + 1), bool), border_value=1)
    labels, _ = ndimage.label(~grown)
    assert labels[s] > 0 and labels[s] == labels[g]


def test_the_families_are_listed_and_named_apart_from_the_training_ones():
    assert unseen_families() == UNSEEN_FAMILIES
    assert len(UNSEEN_FAMILIES) >= 2
    assert not set(UNSEEN_FAMILIES) & set(generators.FAMILIES)


def test_the_seed_range_lies_above_every_other_split():
    others = (generators.TRAIN_SEEDS[1], generators.VALIDATION_SEED0, generators.TUNING_SEED0,
              generators.TEST_SEED0, generators.SHIFTED_SEED0)
    # each split takes consecutive seeds from its start; a million apart keeps every set of any use apart
    assert all(UNSEEN_SEED0 - s >= 1_000_000 for s in others)


@pytest.mark.parametrize("family", UNSEEN_FAMILIES)
def test_the_same_seed_gives_the_same_problem_and_another_seed_another(family):
    a, b = generate_unseen(family, UNSEEN_SEED0, 96), generate_unseen(family, UNSEEN_SEED0, 96)
    assert np.array_equal(a.world.obstacles, b.world.obstacles)
    assert np.array_equal(a.start, b.start) and np.array_equal(a.goal, b.goal)
    assert a.reference_length == b.reference_length and a.name == b.name == f"{family}-96-{UNSEEN_SEED0}"
    c = generate_unseen(family, UNSEEN_SEED0 + 1, 96)
    assert not np.array_equal(a.world.obstacles, c.world.obstacles)
    d = generate_unseen(family, np.random.default_rng(UNSEEN_SEED0), 96)
    assert d.name == f"{family}-96" and np.array_equal(d.world.obstacles, a.world.obstacles)


@pytest.mark.parametrize("family", UNSEEN_FAMILIES)
@pytest.mark.parametrize("size", [UNSEEN_MIN_SIZE, 128, 256])
def test_problems_are_valid_at_every_size(family, size):
    for i in range(3):
        _check_valid(generate_unseen(family, UNSEEN_SEED0 + i, size), size)


@settings(max_examples=20, deadline=None)
@given(family=st.sampled_from(UNSEEN_FAMILIES), seed=st.integers(0, 2**32),
       size=st.integers(UNSEEN_MIN_SIZE, 160), tolerance=st.sampled_from([1.0, 2.5, 4.0]))
def test_any_seed_and_size_give_a_valid_problem(family, seed, size, tolerance):
    p = generate_unseen(family, seed, size, goal_tolerance=tolerance)
    assert p.goal_tolerance == tolerance
    _check_valid(p, size)


def test_clearance_map_grows_obstacles_and_the_edge_by_a_square():
    obs = np.zeros((9, 9), dtype=bool)
    obs[4, 4] = True
    grown = clearance_map(obs, 1)
    expected = np.ones((9, 9), dtype=bool)
    expected[1:-1, 1:-1] = False  # the edge grows inwards by one
    expected[3:6, 3:6] = True
    assert np.array_equal(grown, expected)
    assert np.array_equal(clearance_map(obs, 0), obs)


@pytest.mark.parametrize("family", UNSEEN_FAMILIES)
def test_goal_biased_rrt_solves_every_family_at_step_4(family):
    for i in range(2):
        p = generate_unseen(family, UNSEEN_SEED0 + i, 128)
        result = make_planner("RRT", p, extension_step=4.0, sampler=GoalBiasedSampler(0.05), seed=0).solve(
            max_iterations=20000)
        assert result.solved, f"{p.name}: goal-biased RRT did not reach the goal in 20000 iterations"


@pytest.mark.parametrize(("kwargs", "error", "match"), [
    ({"family": "forest"}, ValueError, "unknown unseen map family 'forest'"),
    ({"size": UNSEEN_MIN_SIZE - 1}, ValueError, f"size must be an integer >= {UNSEEN_MIN_SIZE}"),
    ({"size": 96.0}, ValueError, "size must be"),
    ({"seed": -1}, ValueError, "seed must be a non-negative"),
    ({"seed": True}, TypeError, "seed must be an int"),
    ({"seed": "1"}, TypeError, "seed must be an int"),
    ({"goal_tolerance": 0.0}, ValueError, "goal_tolerance must be a positive finite number"),
    ({"goal_tolerance": float("nan")}, ValueError, "goal_tolerance"),
    ({"goal_tolerance": "4"}, ValueError, "goal_tolerance"),
])
def test_bad_arguments_are_named(kwargs, error, match):
    args = {"family": "spiral", "seed": 0, "size": 96, **kwargs}
    family, seed, size = args.pop("family"), args.pop("seed"), args.pop("size")
    with pytest.raises(error, match=match):
        generate_unseen(family, seed, size, **args)
