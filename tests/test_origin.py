"""Maps whose corner is not at (0, 0), as every ROS map_server map: guidance, the learned sampler, the
ablation, the follower, the expert and the environments' observations see a translated map as the same map.

Each is run on a generated map and on the same grid with ``origin`` moved; what each sees must agree
(observations equal, world points translated), and planning must cost the same.
"""

from __future__ import annotations

import numpy as np
import pytest

from envs.observation import GridObservation
from learning import ConstantGuidedSampler, PolicySampler, RouteSampler
from learning.models.shipped import SHIPPED_POLICY
from learning.references.expert import CorridorSampler, ExpertSampler, GeodesicExpert
from planners import RRT, OccupancyGrid, Problem
from planners.base.planner import TreeView
from planners.guidance.frontier import Frontier
from planners.guidance.guided import GuidedSampling
from planners.maps.generators import TEST_SEED0, generate

SHIPPED = SHIPPED_POLICY
ORIGIN = np.array([-64.0, -32.0])


def _moved(p: Problem, origin=ORIGIN) -> Problem:
    g = p.world
    return Problem(OccupancyGrid(g.obstacles, g.resolution, origin=origin), start=p.start + origin,
                   goal=p.goal + origin, goal_tolerance=p.goal_tolerance)


@pytest.fixture(scope="module")
def pair():
    a = generate("bugtrap", TEST_SEED0 + 4, 96)
    b = _moved(a)
    planner = RRT(a, step_size=4.0, seed=0)
    planner.solve(max_iterations=250)
    va = planner.view()
    vb = TreeView(problem=b, vertices=va.vertices + ORIGIN, parents=va.parents, num_vertices=va.num_vertices,
                  best_vertex=va.best_vertex, best_distance=va.best_distance, best_cost=va.best_cost,
                  iteration=va.iteration)
    assert va.num_vertices > 50
    return (a, va), (b, vb)


def test_guided_observation_and_frontier_are_translation_invariant(pair):
    (a, va), (b, vb) = pair
    ga, gb = GuidedSampling(a, 4.0), GuidedSampling(b, 4.0)
    for g, v in ((ga, va), (gb, vb)):
        g.update(v)
    oa, ob = ga.observe(va), gb.observe(vb)
    assert oa["local"][1].any() and np.array_equal(oa["local"], ob["local"])
    assert np.array_equal(oa["vector"], ob["vector"])
    fa, fb = Frontier(a, 4.0), Frontier(b, 4.0)
    fa.update(va.vertices, va.num_vertices)
    fb.update(vb.vertices, vb.num_vertices)
    assert len(fa) == len(fb) > 0
    sa, sb = fa.sample(np.random.default_rng(1), 16), fb.sample(np.random.default_rng(1), 16)
    assert np.allclose(sa + ORIGIN, sb, atol=1e-9)
    assert all(b.world.cell_of(q) == a.world.cell_of(q - ORIGIN) for q in sb)


def test_policy_draws_are_translation_invariant(pair):
    (a, va), (b, vb) = pair
    out = []
    for p, v in ((a, va), (b, vb)):
        sampler = PolicySampler.load(SHIPPED, fuse=False).bind(p)
        batch = sampler.draw(np.random.default_rng(3), 8, v)
        out.append((sampler.last_observation(), batch))
    (obs_a, ba), (obs_b, bb) = out
    assert np.array_equal(obs_a["local"], obs_b["local"]) and np.array_equal(obs_a["vector"], obs_b["vector"])
    assert np.array_equal(ba.anchored, bb.anchored)
    world = ba.anchored == 0  # world points move with the map; goal-frame offsets do not
    assert np.allclose(ba.points[world] + ORIGIN, bb.points[world], atol=1e-9)
    assert np.allclose(ba.points[~world], bb.points[~world])


def test_expert_and_grid_observation_are_translation_invariant(pair):
    (a, va), (b, vb) = pair
    ea, eb = GeodesicExpert(a, 4.0), GeodesicExpert(b, 4.0)
    ea.update(va.vertices, va.num_vertices)
    eb.update(vb.vertices, vb.num_vertices)
    assert np.allclose(ea.target() + ORIGIN, eb.target())

    class _Planner:  # what GridObservation reads of a planner
        def __init__(self, view):
            self._view = view

        def view(self):
            return self._view

    obs = []
    for p, v in ((a, va), (b, vb)):
        o = GridObservation(64, 48, 1)
        o.reset(p, 20000)
        o.update(_Planner(v))
        obs.append(o.build(_Planner(v)))
    for key in obs[0]:
        assert np.array_equal(obs[0][key], obs[1][key]), key
    assert obs[0]["local"][1].any()


@pytest.mark.parametrize("make", [lambda: PolicySampler.load(SHIPPED), lambda: ConstantGuidedSampler(0.8),
                                  lambda: ExpertSampler(4.0), lambda: RouteSampler(None),
                                  lambda: CorridorSampler(0.3, RouteSampler(None))],
                         ids=["policy", "constant", "expert", "follower", "corridor"])
def test_planning_costs_the_same_on_a_translated_map(make):
    its = {0: [], 1: []}
    for i, family in enumerate(("bugtrap", "maze", "narrow_passage", "rooms") * 2):
        a = generate(family, TEST_SEED0 + 10 + i, 96)
        for k, p in enumerate((a, _moved(a, np.array([-50.0, 17.5])))):
            r = RRT(p, step_size=4.0, sampler=make(), seed=i).solve(max_iterations=20000)
            assert r.solved and np.allclose(r.path[0], p.start)
            its[k].append(r.iterations)
    ratio = np.median(its[1]) / np.median(its[0])
    assert 0.8 < ratio < 1.25, its
