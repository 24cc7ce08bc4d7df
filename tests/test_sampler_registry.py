"""The sampler registry (``learning.samplers.registry``) and the validated defaults it hands out."""

from __future__ import annotations

import json

import pytest
from hypothesis import given
from hypothesis import strategies as st

import learning
from learning.models.shipped import SHIPPED_POLICY_BATCH
from learning.samplers.registry import (
    REFERENCES,
    ModelCache,
    SamplerSpec,
    make_sampler,
    parse_user_sampler,
    sampler_names,
)
from learning.samplers.route import FOLLOWER_SETTINGS, SHIPPED_SETTINGS, RouteSampler, shipped_sampler
from planners import RRT, GoalBiasedSampler, Sampler, UniformSampler
from planners.base.fileio import InputError
from planners.maps.generators import TEST_SEED0, generate


def test_every_registered_name_builds_a_sampler_and_the_references_are_marked():
    assert set(sampler_names()) == {"uniform", "goal_bias", "informed", "follower", "route", "route_lazy",
                                    "route_ablation", "policy",
                                    "policy_ablation", "expert", "exact_route", "gaussian", "bridge_test",
                                    "obstacle_based", "rigid_workspace_route", "rigid_route", "rigid_route_ablation",
                                    "rigid_expert"}
    assert set(REFERENCES) == {"expert", "exact_route", "rigid_expert"}
    for name in sampler_names():
        assert isinstance(make_sampler(name), Sampler), name
    assert learning.sampler_names() == sampler_names() and learning.make_sampler is make_sampler


def test_parameters_reach_the_sampler_and_bad_ones_are_refused_by_name():
    assert isinstance(make_sampler("uniform"), UniformSampler)
    gb = make_sampler("goal_bias", bias=0.2)
    assert isinstance(gb, GoalBiasedSampler) and gb.p == 0.2
    assert make_sampler("policy_ablation", frontier=0.3, batch=2).frontier == 0.3
    assert make_sampler("policy", batch=1).batch == 1
    with pytest.raises(InputError, match="unknown sampler 'nope'.*goal_bias"):
        make_sampler("nope")
    with pytest.raises(InputError, match="takes no parameter colour"):
        make_sampler("goal_bias", colour=1)


def test_defaults_are_the_validated_settings():
    shipped = RouteSampler.load()
    assert all(getattr(shipped, k) == v for k, v in SHIPPED_SETTINGS.items())
    assert repr(shipped) == repr(shipped_sampler()) == repr(make_sampler("route"))
    assert repr(RouteSampler(shipped.net)) == repr(shipped)
    assert learning.PolicySampler.load().batch == SHIPPED_POLICY_BATCH == make_sampler("policy").batch
    # the comparison's follower keeps the settings it was measured at
    follower = make_sampler("follower")
    assert follower.net is None
    assert (follower.lookahead, follower.stuck, follower.tau, follower.ripple) == (1.0, 4, 1.0, 0.0)
    assert FOLLOWER_SETTINGS == {"lookahead": 1.0, "stuck": 4, "tau": 1.0, "ripple": 0.0, "ripple_growth": 0.0,
                                 "sight": False, "widen": "off"}
    assert follower.widen == "off" and shipped.widen == "stalled" == make_sampler("route_ablation").widen


def test_the_follower_plans_as_the_route_sampler_at_its_settings():
    p = generate("bugtrap", TEST_SEED0, 64, goal_tolerance=4.0)
    runs = [RRT(p, step_size=4.0, sampler=s, seed=3).solve(max_iterations=3000)
            for s in (make_sampler("follower"), RouteSampler(None, **FOLLOWER_SETTINGS))]
    assert runs[0].iterations == runs[1].iterations and runs[0].solved == runs[1].solved


@given(name=st.sampled_from(["uniform", "goal_bias", "policy_ablation"]),
       value=st.floats(0.0, 1.0, allow_nan=False))
def test_a_spec_is_data_that_builds_its_sampler(name, value):
    params = {} if name == "uniform" else {"bias": value} if name == "goal_bias" else {"frontier": value}
    spec = SamplerSpec.of(name, **params)
    assert spec == SamplerSpec.of(name, **dict(reversed(list(params.items())))) and hash(spec) == hash(spec)
    assert json.loads(spec.to_json()) == {"name": name, "params": params}
    assert type(spec.build()) is type(make_sampler(name, **params))


def test_user_names_may_not_shadow_registered_samplers():
    assert parse_user_sampler("mine=my_module:make") == ("mine", "my_module:make")
    for arg in ("route=x:y", "follower=x:y", "policy=a.zip@SamplerGym/RRT-Forest-v2", "nospec"):
        with pytest.raises(InputError):
            parse_user_sampler(arg)


def test_a_spec_round_trips_through_json_and_a_model_cache_loads_each_file_once():
    spec = SamplerSpec.of("route", step_size=4.0)
    assert SamplerSpec.from_json(spec.to_json()) == spec and spec.param("step_size") == 4.0
    assert spec.param("path") is None and spec.param("colour", "x") == "x"  # the factory's default, or the given one
    assert SamplerSpec.of("goal_bias").param("bias") == make_sampler("goal_bias").p
    models = ModelCache()
    a, b = spec.build(models), spec.build(models)
    assert a is not b and a.net is b.net and len(models.routes) == 1  # a new sampler per run, one network
    assert repr(a) == repr(make_sampler("route"))
    policy = SamplerSpec.of("policy", batch=2)
    assert policy.build(models) is policy.build(models) and policy.build(models).batch == 2
    assert len(models.policies) == 1


def test_a_users_sampler_is_a_spec_too(tmp_path, monkeypatch):
    (tmp_path / "my_factory.py").write_text("from planners import UniformSampler\n\ndef make():\n"
                                            "    return UniformSampler()\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    spec = SamplerSpec.user("mine", "my_factory:make")
    assert json.loads(spec.to_json()) == {"name": "user", "params": {"name": "mine", "spec": "my_factory:make"}}
    models = ModelCache()
    assert isinstance(spec.build(), UniformSampler) and spec.build(models) is spec.build(models)


@pytest.mark.parametrize("name, params, message", [
    ("route", {"step_size": float("inf")}, "step_size = inf, expected a finite number"),
    ("policy", {"batch": float("inf")}, "batch = inf, expected an integer from 1 to 4096"),
    ("policy", {"batch": 10**9}, "batch = 1000000000, expected an integer from 1 to 4096"),
    ("policy", {"step_size": float("nan")}, "step_size = nan, expected a finite number"),
    ("policy_ablation", {"step_size": float("inf")}, "step_size = inf"),
    ("policy_ablation", {"batch": 10**9}, "from 1 to 4096"),
])
def test_non_finite_or_unbounded_parameters_are_refused_when_the_sampler_is_made(name, params, message):
    with pytest.raises(InputError, match=message):
        make_sampler(name, **params)


@pytest.mark.parametrize("name", ["route_ablation", "follower", "policy", "policy_ablation", "expert"])
def test_a_step_past_the_map_is_refused_at_bind_not_a_memory_error(name):
    problem = generate("forest", TEST_SEED0, 64)
    sampler = make_sampler(name, step_size=1e9)
    if hasattr(sampler, "at_step"):  # it takes the planner's step when bound: its own is never used
        planner = RRT(problem, step_size=4.0, sampler=sampler, seed=0)
        assert planner.sampler.step_size == 4.0 and planner.solve(max_iterations=10).iterations == 10
        return
    with pytest.raises(InputError, match=r"step_size = 1000000000.0 on a map whose diagonal is 90.5"):
        RRT(problem, step_size=4.0, sampler=sampler, seed=0).solve(max_iterations=10)
