"""One planner registry: every planner by its own name, used by the env, workflow, evaluation and benchmark."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from conftest import fine_check_path

import envs
import planners
from planners import OccupancyGrid, Problem, make_planner, planner_names, register_planner
from planners.base.planner import Planner
from planners.base.registry import planner_class, planner_name_arg

gym.register_envs(envs)


def _problem() -> Problem:
    obstacles = np.zeros((40, 40), dtype=bool)
    obstacles[10:30, 18:22] = True
    return Problem(OccupancyGrid(obstacles), (5.5, 20.5), (34.5, 20.5), goal_tolerance=2.0)


def test_every_planner_is_registered_under_its_own_name():
    exported = {getattr(planners, n) for n in planners.__all__}
    classes = {c for c in exported if isinstance(c, type) and issubclass(c, Planner) and c is not Planner}
    assert {c.name for c in classes} == set(planner_names())
    assert len(set(planner_names())) == len(planner_names())
    for cls in classes:
        assert planner_class(cls.name) is cls
        assert cls.step_parameter in ("step_size", "max_edge_length")


@pytest.mark.parametrize("name", planner_names())
def test_every_name_builds_a_seeded_planner_that_solves(name):
    problem = _problem()
    runs = [make_planner(name, problem, step=3.0, seed=7).solve(max_iterations=5000) for _ in range(2)]
    assert runs[0].solved
    assert runs[0].iterations == runs[1].iterations and np.array_equal(runs[0].path, runs[1].path)
    path = runs[0].path
    assert np.allclose(path[0], problem.start) and problem.in_goal(path[-1])
    fine_check_path(problem.world, path)


@pytest.mark.parametrize("alias,name", [("rrt-connect", "RRTConnect"), ("rrtconnect", "RRTConnect"),
                                        ("lazy_prm", "LazyPRM"), ("RRTSTAR", "RRTstar"),
                                        ("informed-rrtstar", "InformedRRTstar"), ("ob-prm", "OBPRM")])
def test_aliases_ignore_case_dashes_and_underscores(alias, name):
    assert planner_class(alias).name == name
    assert planner_name_arg(alias) == name


def test_unknown_name_lists_the_valid_ones():
    with pytest.raises(ValueError, match="unknown planner 'RRT-Sharp'.*LazyPRM.*RRTConnect"):
        make_planner("RRT-Sharp", _problem())
    with pytest.raises(envs.sampler_env.InputError, match="planner: unknown planner"):
        gym.make("SamplerGym/Planning-v1", planner="RRT-Sharp")


def test_step_goes_to_each_planners_own_parameter():
    problem = _problem()
    assert make_planner("RRT", problem, step=3.0).step_size == 3.0
    assert make_planner("PRM", problem, step=3.0).max_edge_length == 3.0
    # an extension step is for planners that extend; a roadmap keeps its own edge length
    assert make_planner("PRM", problem, extension_step=3.0).max_edge_length is None
    assert make_planner("RRTConnect", problem, extension_step=3.0).step_size == 3.0
    with pytest.raises(ValueError, match="not both"):
        make_planner("RRT", problem, step=1.0, extension_step=1.0)


def test_a_name_is_taken_once():
    class Another(Planner):
        name = "rrt"  # the same key as RRT
        step_parameter = "step_size"

    with pytest.raises(ValueError, match="already taken by RRT"):
        register_planner(Another)


@pytest.mark.parametrize("name", ["RRTConnect", "LazyPRM", "RRTstar"])
def test_the_env_builds_registered_planners(name):
    env = gym.make("SamplerGym/Planning-v1", planner=name.lower(), max_iterations=50)
    env.reset(seed=0)
    assert env.unwrapped.planner.name == name
    env.step(env.action_space.sample())


@pytest.mark.parametrize("name", ["InformedRRTstar", "OBPRM"])
def test_the_env_refuses_planners_whose_sampler_is_their_algorithm(name):
    assert planner_class(name).own_sampler
    with pytest.raises(envs.sampler_env.InputError, match="brings its own sampler"):
        gym.make("SamplerGym/Planning-v1", planner=name)


@pytest.mark.parametrize("alias,name", [("RRTStar", "RRTstar"), ("RRT*", "RRTstar"), ("rrt-star", "RRTstar"),
                                        ("InformedRRTStar", "InformedRRTstar"), ("Informed RRT*", "InformedRRTstar")])
def test_one_canonical_spelling_and_the_class_name_as_alias(alias, name):
    assert planner_class(alias).name == name
    assert planner_name_arg(alias) == name
    assert planner_class(name).__name__ in ("RRTStar", "InformedRRTStar")


def test_step_size_is_the_one_step_name_and_its_aliases_never_conflict_silently():
    problem = _problem()
    assert make_planner("RRT", problem, step_size=3.0).step_size == 3.0
    assert make_planner("PRM", problem, step_size=3.0).max_edge_length == 3.0
    assert make_planner("PRM", problem, max_edge_length=2.5).max_edge_length == 2.5
    assert make_planner("RRT", problem, max_edge_length=2.5).step_size == 2.5  # an alias, whatever the planner
    for a, b in (("step_size", "step"), ("step", "max_edge_length"), ("step_size", "max_edge_length"),
                 ("step_size", "extension_step")):
        with pytest.raises(ValueError, match=rf"give one step length, not both {a}=1.0 and {b}=1.0"):
            make_planner("PRM", problem, **{a: 1.0, b: 1.0})


def test_the_picture_workflow_takes_step_size_and_step():
    from planners.tools.workflow import picture_planner

    problem = _problem()
    assert picture_planner("rrt", problem, step_size=2.0).step_size == 2.0
    assert picture_planner("rrt", problem, step=2.0).step_size == 2.0
    with pytest.raises(ValueError, match="picture_planner: give one step length"):
        picture_planner("rrt", problem, step_size=2.0, step=3.0)


@pytest.mark.parametrize("old", ["v0", "v1"])
def test_older_family_ids_name_their_version_2(old):
    """Versions 1 and 2 changed the default spaces; an older id is Gymnasium's DeprecatedEnv naming the -v2 id."""
    with pytest.raises(gym.error.DeprecatedEnv, match="SamplerGym/RRT-Forest-v2"):
        gym.make(f"SamplerGym/RRT-Forest-{old}")
