"""The 6-DoF privileged expert: samples along a solution that long runs found before the run."""

from __future__ import annotations

import numpy as np
import pytest

import learning.references.rigid_expert as rigid_expert
from learning.evaluation.rigid import run_one, target_rows
from learning.references.rigid_expert import RigidExpertSampler, query_key
from learning.samplers.registry import REFERENCES, make_sampler
from planners.base.fileio import InputError
from planners.maps.generators import generate
from planners.worlds.rigid_scenes import rigid_scene


@pytest.fixture(scope="module")
def slot_scene():
    return rigid_scene("slot", 12345)  # a training seed


def test_draws_are_seeded_batch_invariant_in_bounds_and_lie_on_the_solution(slot_scene):
    s = make_sampler("rigid_expert").bind(slot_scene)
    assert s.solved_reference and s.reference_iterations > 0 and s.states.shape[1] == 6
    a = s.draw(np.random.default_rng(3), 64, None)
    rng = np.random.default_rng(3)
    c = np.concatenate([s.draw(rng, 20, None), s.draw(rng, 44, None)])
    assert a.shape == (64, 6) and np.allclose(a, c)
    low, high = slot_scene.world.bounds
    assert np.all(a >= low) and np.all(a <= high)
    # without noise, uniform share or goal share every sample is a state of the solution, and those are free
    exact = RigidExpertSampler(uniform_share=0.0, goal_share=0.0, angle_noise=0.0, spread=0.0).bind(slot_scene)
    q = exact.draw(np.random.default_rng(4), 50, None)
    d = np.abs(q[:, None, :] - exact.states[None, :, :]).max(axis=2).min(axis=1)
    assert d.max() < 1e-9
    assert all(slot_scene.world.is_valid(x) for x in q)
    # the solution joins the query's start and goal
    assert np.allclose(exact.states[0], slot_scene.start) and np.allclose(exact.states[-1], slot_scene.goal)
    only_goal = RigidExpertSampler(goal_share=1.0).bind(slot_scene).draw(np.random.default_rng(0), 5, None)
    assert np.allclose(only_goal, slot_scene.goal)


def test_the_long_runs_are_kept_per_query_and_a_query_they_miss_samples_uniformly(slot_scene, monkeypatch):
    calls = []
    real = rigid_expert.solve_reference

    def counting(problem, attempts, budget):
        calls.append(budget)
        return real(problem, attempts, budget)

    monkeypatch.setattr(rigid_expert, "solve_reference", counting)
    monkeypatch.setattr(rigid_expert, "SOLUTIONS", type(rigid_expert.SOLUTIONS)())
    RigidExpertSampler(attempts=1, budget=3).bind(slot_scene)
    missed = RigidExpertSampler(attempts=1, budget=3).bind(slot_scene)
    assert calls == [3] and not missed.solved_reference and missed.states is None
    pts = missed.draw(np.random.default_rng(1), 200, None)
    uniform = RigidExpertSampler(attempts=1, budget=3, goal_share=0.0).bind(slot_scene)
    assert np.allclose(uniform.draw(np.random.default_rng(1), 10, None)[:, :3].std(axis=0) > 0, True)
    assert pts.shape == (200, 6)
    # another query of the same world is another key
    other = slot_scene.with_query(slot_scene.goal, slot_scene.start)
    assert query_key(other, 1, 3) != query_key(slot_scene, 1, 3)


def test_it_is_a_reference_not_a_competitor_and_refuses_what_it_cannot_plan(slot_scene):
    assert "rigid_expert" in REFERENCES
    row = run_one(slot_scene, "RRTConnect", "rigid_expert", 0)
    again = run_one(slot_scene, "RRTConnect", "rigid_expert", 0)
    assert row.solved and (row.iterations, row.solved) == (again.iterations, again.solved)
    cells = [{"family": "slot", "planner": "RRTConnect", "sampler": name, "runs": 2, "solved": 2, "success": 1.0,
              "median_iterations": its, "median_checks": 0.0, "median_time": 1.0}
             for name, its in [("uniform", 900.0), ("rigid_route_ablation", 300.0), ("rigid_route", 200.0),
                               ("rigid_expert", 50.0)]]
    assert [t["sampler"] for t in target_rows(cells)] == ["rigid_route"]
    with pytest.raises(InputError, match="6-DoF box and mesh worlds"):
        RigidExpertSampler().bind(generate("forest", 0, size=32))
    with pytest.raises(InputError, match="attempts"):
        RigidExpertSampler(attempts=0)
    with pytest.raises(InputError, match="at most 16"):
        RigidExpertSampler(attempts=17)


def test_where_rigid_route_follows_the_trees_the_expert_follows_them_along_its_solution(slot_scene):
    from types import SimpleNamespace

    from learning.samplers.rigid_route import SHIPPED_RIGID_SETTINGS

    kw = dict(uniform_share=0.0, goal_share=0.0, angle_noise=0.0, spread=0.0)
    s = RigidExpertSampler(**kw).bind(slot_scene)  # a box world's trees: rigid_route's follow
    assert s.follow == SHIPPED_RIGID_SETTINGS["follow"] > 0 and "follow=" in repr(s)
    span = s.follow * slot_scene.world.radius
    arc = s._arc

    def arcs(q):  # each sample's arc position along the solution: its state's
        return arc[np.abs(q[:, None, :] - s.states[None]).max(axis=2).argmin(axis=1)]

    q = s.draw(np.random.default_rng(3), 500, None)
    assert len(q) == 64 and arcs(q).max() <= span + 1e-9  # about the start, before any tree is seen
    # a start tree at the solution's middle, reached in steps, and a goal tree: half about each tree's reach
    mid = int(np.searchsorted(arc, arc[-1] / 2))
    steps = [s.states[int(np.searchsorted(arc, x))] for x in np.arange(0.5, arc[mid], 0.5 * span)]
    for k in range(1, len(steps) + 1):
        s.draw(np.random.default_rng(k), 64, SimpleNamespace(vertices=np.array(steps[:k]), goal_tree=None))
    assert s._reach[0] >= arc[mid] - span
    view = SimpleNamespace(vertices=np.array(steps), goal_tree=slot_scene.goal[None])
    a = arcs(s.draw(np.random.default_rng(9), 64, view))
    near_start, near_goal = np.abs(a - s._reach[0]) <= span + 1e-9, a >= arc[-1] - span - 1e-9
    assert (near_start | near_goal).all() and near_start.any() and near_goal.any()
    # 0 draws along the whole solution, as a roadmap does whatever it is given
    whole = RigidExpertSampler(**kw, follow=0.0).bind(slot_scene)
    assert arcs(whole.draw(np.random.default_rng(3), 500, None)).max() > arc[-1] / 2
    assert RigidExpertSampler(**kw).for_planner("roadmap").follow == 0.0
    assert make_sampler("rigid_expert", follow=4).follow == 4.0
    with pytest.raises(InputError, match="follow"):
        RigidExpertSampler(follow=-1.0)


def test_the_training_labels_long_runs_draw_along_the_whole_route_at_uniform_arc_length(slot_scene, monkeypatch):
    import learning.training.rigid as training

    seen = []
    monkeypatch.setattr(training, "solve_reference", lambda problem, **kw: seen.append(kw) or (None, 0.0, 0))
    with pytest.raises(RuntimeError, match="no training examples: none of the 1 scenes of slot"):
        training.collect_rigid_examples(training.RigidTrainConfig(scenes_per_family=1, families=("slot",)))
    assert seen == [{"settings": rigid_expert.LABEL_ABLATION}]
    # those settings: the ablation as it drew when the shipped model was trained, whatever it ships with now
    labels = make_sampler("rigid_route_ablation", **rigid_expert.LABEL_ABLATION).bind(slot_scene)
    assert labels.follow == 0.0 and np.array_equal(labels.warc, labels.arc)
    assert make_sampler("rigid_route_ablation").bind(slot_scene).follow > 0  # what it ships with on a box world
