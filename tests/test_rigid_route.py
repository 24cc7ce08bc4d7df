"""The learned 6-DoF route sampler: its features, its file, its draws, its registry name and its training."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from learning.models.rigid_orientation import OrientationNet, load_orientation_net, save_orientation_net
from learning.models.shipped import SHIPPED_RIGID_ORIENTATION
from learning.samplers.registry import make_sampler
from learning.samplers.rigid_route import (
    FOLLOW_BATCH,
    SHIPPED_RIGID_ROADMAP,
    SHIPPED_RIGID_SETTINGS,
    RigidRouteSampler,
    rotation_chain,
)
from learning.training.rigid import RigidTrainConfig, augment, train_rigid_orientation
from planners.base.fileio import InputError
from planners.guidance.rigid_orientation import (
    CLASS_PERMUTATIONS,
    ORIENTATION_CLASSES,
    class_rotations,
    euler_from_matrices,
    occupancy_grid,
    route_patches,
)
from planners.worlds.rigid3d import RigidBodyWorld, box_body, rotation_matrix
from planners.worlds.rigid_scenes import rigid_scene


@pytest.fixture(scope="module")
def slot_scene():
    return rigid_scene("slot", 12345)  # a training seed


def test_angles_from_matrices_invert_the_bodys_rotation_and_classes_are_the_boxs_symmetry():
    rng = np.random.default_rng(0)
    angles = rng.uniform(-np.pi, np.pi, (100, 3))
    R = np.array([rotation_matrix(*a) for a in angles])
    back = np.array([rotation_matrix(*a) for a in euler_from_matrices(R)])
    assert np.abs(back - R).max() < 1e-12
    rots = class_rotations()
    assert rots.shape == (6, 4, 3, 3) and np.allclose(np.linalg.det(rots), 1.0)
    body = box_body(10, 5, 2.5)
    for c, (a, b) in enumerate(ORIENTATION_CLASSES):
        pts = [np.round(body @ r.T, 9) for r in rots[c]]  # the four rotations place the same point set
        assert all({tuple(p) for p in q} == {tuple(p) for p in pts[0]} for q in pts)
        extent = np.ptp(pts[0], axis=0)
        assert extent[a] == 10 and extent[b] == 5
    assert sorted(map(tuple, CLASS_PERMUTATIONS)) == sorted(set(map(tuple, CLASS_PERMUTATIONS)))


def test_occupancy_is_the_exact_covered_share_and_outside_counts_as_covered():
    world = RigidBodyWorld([[2.0, 0.0, 0.0, 3.5, 4.0, 4.0]], box_body(1, 0.5, 0.25), low=(0, 0, 0), high=(8, 4, 4),
                           delta=0.05)
    g = occupancy_grid(world)
    assert g.shape == (8, 4, 4)
    assert np.allclose(g[:, 0, 0], [0, 0, 1, 0.5, 0, 0, 0, 0])
    p = route_patches(g, np.array([[0.5, 0.5, 0.5]]), world.low3, half=2)
    assert p.shape == (1, 5, 5, 5) and p[0, 0].min() == 1.0 and p[0, 2, 2, 2] == 0.0


def test_augmentation_moves_classes_with_the_axes():
    rng = np.random.default_rng(1)
    P = rng.random((40, 5, 5, 5)).astype(np.float32)
    D = rng.standard_normal((40, 3)).astype(np.float32)
    Y = np.eye(6, dtype=np.float32)[rng.integers(6, size=40)]
    P2, D2, Y2 = augment(P, D, Y, np.random.default_rng(2))
    assert np.allclose(np.sort(np.abs(D2), axis=1), np.sort(np.abs(D), axis=1))
    assert np.allclose(Y2.sum(axis=1), 1) and np.allclose(np.sort(P2.ravel()), np.sort(P.ravel()))


def test_the_shipped_model_is_small_and_loads_as_weights_only(tmp_path):
    assert SHIPPED_RIGID_ORIENTATION.stat().st_size < 1_000_000
    blob = torch.load(SHIPPED_RIGID_ORIENTATION, map_location="cpu", weights_only=True)
    assert blob["config"]["kind"] == "rigid_orientation"
    net = load_orientation_net(SHIPPED_RIGID_ORIENTATION)
    path = tmp_path / "m.pt"
    save_orientation_net(net, path)
    again = load_orientation_net(path)
    assert all(torch.equal(a, b) for a, b in zip(net.state_dict().values(), again.state_dict().values(), strict=True))
    torch.save({"config": {"kind": "other"}, "state": {}}, path)
    with pytest.raises(InputError, match="kind"):
        load_orientation_net(path)


def test_draws_are_valid_shaped_seeded_and_batch_invariant(slot_scene):
    s = make_sampler("rigid_route").bind(slot_scene)
    assert s.uniform_share == SHIPPED_RIGID_SETTINGS["uniform_share"]
    a = s.draw(np.random.default_rng(3), 64, None)
    b = s.draw(np.random.default_rng(3), 64, None)
    rng = np.random.default_rng(3)
    c = np.concatenate([s.draw(rng, 20, None), s.draw(rng, 44, None)])
    assert a.shape == (64, 6) and np.array_equal(a, b) and np.allclose(a, c)
    low, high = slot_scene.world.bounds
    assert np.all(a >= low) and np.all(a <= high)
    assert s.probs.shape == (len(s.route), 6) and np.allclose(s.probs.sum(axis=1), 1)
    # the goal share draws the goal; everything else is the route or uniform
    only_goal = RigidRouteSampler(s.net, goal_share=1.0).bind(slot_scene).draw(np.random.default_rng(0), 5, None)
    assert np.allclose(only_goal, slot_scene.goal)
    # every learned orientation is an axis-aligned one when no noise is added
    exact = RigidRouteSampler(s.net, route_fraction=1.0, uniform_share=0.0, angle_noise=0.0, goal_share=0.0)
    q = exact.bind(slot_scene).draw(np.random.default_rng(4), 32, None)
    R = np.array([rotation_matrix(*x[3:]) for x in q])
    assert np.allclose(np.abs(R).max(axis=1), 1.0)


def test_a_uniform_ramp_turns_the_route_samples_to_uniform_angles_as_the_query_goes_on(slot_scene):
    net = make_sampler("rigid_route").net
    kw = dict(route_fraction=1.0, uniform_share=0.0, angle_noise=0.0, goal_share=0.0)

    ramp = RigidRouteSampler(net, uniform_ramp=1000, **kw).bind(slot_scene)
    rng = np.random.default_rng(6)
    q = np.concatenate([ramp.draw(rng, 700, None), ramp.draw(rng, 1300, None)])  # batches: the count runs on
    off_axis = np.array([not np.allclose(np.abs(rotation_matrix(*x[3:])).max(axis=1), 1.0) for x in q])
    assert off_axis[1000:].all()  # past the ramp every route sample takes uniform angles
    early, late = off_axis[:250].mean(), off_axis[750:1000].mean()  # about k / 1000 on the way
    assert early < 0.3 < 0.6 < late
    # without the ramp the same stream keeps the model's classes; its positions are the same
    plain = RigidRouteSampler(net, **kw).bind(slot_scene).draw(np.random.default_rng(6), 2000, None)
    assert np.array_equal(plain[:, :3], q[:, :3])
    assert all(np.allclose(np.abs(rotation_matrix(*x[3:])).max(axis=1), 1.0) for x in plain)
    # seeded and batch invariant; a new query (bind) starts the count again
    again = RigidRouteSampler(net, uniform_ramp=1000, **kw).bind(slot_scene).draw(np.random.default_rng(6), 2000, None)
    assert np.array_equal(again, q)
    assert np.array_equal(ramp.bind(slot_scene).draw(np.random.default_rng(6), 2000, None), q)
    # a roadmap keeps every sample it draws: it never ramps
    assert RigidRouteSampler(net, uniform_ramp=1000, **kw).for_planner("roadmap").uniform_ramp == 0.0
    assert make_sampler("rigid_route", uniform_ramp=50).uniform_ramp == 50.0
    with pytest.raises(InputError, match="uniform_ramp"):
        RigidRouteSampler(net, uniform_ramp=-1)
    with pytest.raises(InputError, match="roadmap uniform_ramp"):
        RigidRouteSampler(net, roadmap={"uniform_ramp": -1})


def test_uniform_first_draws_uniform_states_before_the_route_and_the_route_then_starts_its_own_count(slot_scene):
    net = make_sampler("rigid_route").net
    kw = dict(route_fraction=1.0, uniform_share=0.0, angle_noise=0.0, goal_share=0.0, uniform_ramp=300)
    lazy = RigidRouteSampler(net, uniform_first=500, **kw).bind(slot_scene)
    assert not lazy.routed  # the route waits for the first sample after the uniform ones
    rng = np.random.default_rng(7)
    head = np.concatenate([lazy.draw(rng, 200, None), lazy.draw(rng, 300, None)])
    assert not lazy.routed
    low, high = slot_scene.world.bounds
    assert ((head >= low) & (head < high)).all()
    off_axis = np.array([not np.allclose(np.abs(rotation_matrix(*x[3:])).max(axis=1), 1.0) for x in head])
    assert off_axis.all()  # uniform angles, not the model's classes
    tail = lazy.draw(rng, 1000, None)
    assert lazy.routed
    # from sample 500 on, the draws are the route sampler's from its first sample (its ramp counted from there):
    # the same stream's rows after the first 500, drawn by the sampler without uniform states first
    burnt = np.random.default_rng(7)
    burnt.random((500, 13 + slot_scene.dim))
    eager = RigidRouteSampler(net, **kw).bind(slot_scene)
    assert eager.routed
    assert np.array_equal(eager.draw(burnt, 1000, None), tail)
    # seeded, batch invariant across the switch
    again = RigidRouteSampler(net, uniform_first=500, **kw).bind(slot_scene).draw(np.random.default_rng(7), 1500, None)
    assert np.array_equal(again, np.concatenate([head, tail]))
    # a roadmap keeps every sample: it draws the route from its first; the registry takes it; bad values are refused
    assert RigidRouteSampler(net, uniform_first=500, **kw).for_planner("roadmap").uniform_first == 0.0
    assert make_sampler("rigid_route", uniform_first=50).uniform_first == 50.0
    with pytest.raises(InputError, match="uniform_first"):
        RigidRouteSampler(net, uniform_first=float("inf"))
    with pytest.raises(InputError, match="roadmap uniform_first"):
        RigidRouteSampler(net, roadmap={"uniform_first": -1})

def test_a_stall_window_runs_the_ramp_only_while_the_trees_stand_still_on_the_route(slot_scene):
    from types import SimpleNamespace

    net = make_sampler("rigid_route").net
    kw = dict(route_fraction=1.0, uniform_share=0.0, angle_noise=0.0, goal_share=0.0, uniform_ramp=1000)

    def off_axis(q):
        return np.array([not np.allclose(np.abs(rotation_matrix(*x[3:])).max(axis=1), 1.0) for x in q])

    # trees that never move (no view: nothing reached): the ramp starts after the window and then runs as before
    still = RigidRouteSampler(net, stall_window=500, **kw).bind(slot_scene)
    rng = np.random.default_rng(8)
    q = np.concatenate([still.draw(rng, 250, None) for _ in range(10)])
    assert not off_axis(q[:500]).any()  # the classes until the window has passed
    assert off_axis(q[1500:]).all()  # a ramp of 1,000 samples from sample 500 on
    # a start tree that moves along the route by more than a route voxel at every refill keeps the classes
    moving = RigidRouteSampler(net, stall_window=500, **kw).bind(slot_scene)
    route, rng, tree, drawn = moving.route, np.random.default_rng(8), [slot_scene.start], []
    for i in range(10):
        view = SimpleNamespace(vertices=np.array(tree), num_vertices=len(tree), goal_tree=None)
        drawn.append(moving.draw(rng, 250, view))
        reach = route[min(len(route) - 1, (i + 1) * max(1, len(route) // 10))]
        tree.append(np.concatenate([reach, slot_scene.start[3:]]))
    assert not off_axis(np.concatenate(drawn)[:2000]).any()
    # 0 is the plain ramp; a roadmap ignores it; the registry takes it; bad values are refused
    plain = RigidRouteSampler(net, **kw).bind(slot_scene).draw(np.random.default_rng(8), 2500, None)
    assert off_axis(plain[1000:]).all() and not np.array_equal(plain, q)
    assert RigidRouteSampler(net, stall_window=500, **kw).for_planner("roadmap").stall_window == 0.0
    assert make_sampler("rigid_route", stall_window=50).stall_window == 50.0
    with pytest.raises(InputError, match="stall_window"):
        RigidRouteSampler(net, stall_window=-1)


def test_follow_draws_the_route_samples_in_windows_about_the_trees_reach(slot_scene):
    from types import SimpleNamespace

    net = make_sampler("rigid_route").net
    kw = dict(route_fraction=1.0, uniform_share=0.0, angle_noise=0.0, goal_share=0.0, spread=0.0, follow=2.0)
    world = slot_scene.world

    def arcs(sampler, q):  # each sample's arc position: its nearest route point's, within a segment of its own
        near = ((q[:, None, :3] - sampler.route[None]) ** 2).sum(axis=2).argmin(axis=1)
        return sampler.arc[near]

    # no tree seen yet: every route sample within the window about the start (a draw returns at most FOLLOW_BATCH)
    s = RigidRouteSampler(net, **kw).bind(slot_scene)
    span, total = 2.0 * world.radius, s.arc[-1]
    assert span < total / 2  # the window is a part of the route
    span += np.diff(s.arc).max()  # a sample's nearest route point may lie a segment beyond it
    q = s.draw(np.random.default_rng(3), 500, None)
    assert len(q) == FOLLOW_BATCH
    assert arcs(s, q).max() <= span + 1e-9
    # a start tree that reached the route's middle, and a goal tree: half the samples about each tree's reach
    mid = s.route[int(np.searchsorted(s.arc, total / 2))]
    tree = np.array([slot_scene.start, np.concatenate([mid, slot_scene.start[3:]])])
    # the start tree's vertex at the middle is seen in two steps: a jump beyond the window does not count at once
    view = SimpleNamespace(vertices=tree[:1], num_vertices=1, goal_tree=slot_scene.goal[None])
    s.draw(np.random.default_rng(4), 64, view)
    far = SimpleNamespace(vertices=tree, num_vertices=2, goal_tree=slot_scene.goal[None])
    a = arcs(s, s.draw(np.random.default_rng(5), 64, far))
    assert s._reach[0] == 0.0  # the jump was not taken
    assert ((a <= span + 1e-9) | (a >= total - span - 1e-9)).all() and (a <= span).any() and (a > total / 2).any()
    # reached in steps within the window, it counts
    steps = [s.route[int(np.searchsorted(s.arc, x))]
             for x in np.arange(0.5 * world.radius, total / 2, 0.5 * world.radius)]
    for k in range(len(steps)):
        near = np.array([np.concatenate([p, slot_scene.start[3:]]) for p in steps[:k + 1]])
        s.draw(np.random.default_rng(6), 64, SimpleNamespace(vertices=np.concatenate([tree, near]), num_vertices=0,
                                                           goal_tree=slot_scene.goal[None]))
    assert s._reach[0] >= total / 2 - world.radius
    a = arcs(s, s.draw(np.random.default_rng(7), 64, SimpleNamespace(vertices=np.concatenate([tree, near]),
                                                                     num_vertices=0, goal_tree=slot_scene.goal[None])))
    start_side = np.abs(a - s._reach[0]) <= span + 1e-9
    goal_side = a >= total - span - 1e-9
    assert (start_side | goal_side).all() and start_side.any() and goal_side.any()
    # follow_share: that share of the route samples in the windows, the rest along the whole route
    half = RigidRouteSampler(net, **kw, follow_share=0.5).bind(slot_scene)
    a = arcs(half, np.concatenate([half.draw(np.random.default_rng(9), 64, None) for _ in range(8)]))
    assert 0.35 < (a <= span).mean() < 0.8 and (a > total / 2).any()
    one = RigidRouteSampler(net, **kw, follow_share=1.0).bind(slot_scene)
    assert np.array_equal(one.draw(np.random.default_rng(3), 64, None),
                          RigidRouteSampler(net, **kw).bind(slot_scene).draw(np.random.default_rng(3), 64, None))
    with pytest.raises(InputError, match="follow_share"):
        RigidRouteSampler(net, follow=2, follow_share=1.5)
    # 0 draws along the whole route; a roadmap ignores it; the registry takes it; bad values are refused
    whole = RigidRouteSampler(net, **{**kw, "follow": 0.0}).bind(slot_scene)
    assert arcs(whole, whole.draw(np.random.default_rng(3), 500, None)).max() > total / 2
    assert RigidRouteSampler(net, **kw).for_planner("roadmap").follow == 0.0
    assert make_sampler("rigid_route", follow=4).follow == 4.0 and "follow=4" in repr(make_sampler("rigid_route",
                                                                                                     follow=4))
    with pytest.raises(InputError, match="follow"):
        RigidRouteSampler(net, follow=-1)
    # the draws follow the trees, and a seeded run is the same run
    from planners import RRTConnect

    runs = [RRTConnect(slot_scene, sampler=make_sampler("rigid_route", follow=2), seed=4).solve(max_iterations=2000)
            for _ in range(2)]
    assert runs[0].solved and runs[0].iterations == runs[1].iterations and np.array_equal(runs[0].path, runs[1].path)


@pytest.mark.parametrize("settings", [{}, {"symmetry": "random"}, {"symmetry": "chain_start", "uniform_share": 0.0},
                                      {"passage_weight": 0.0, "min_confidence": 0.6},
                                      {"uniform_ramp": 100.0, "goal_share": 0.2}])
def test_the_compiled_follow_draw_makes_the_numpy_draws_samples(slot_scene, settings):
    # with follow_share 0 every route sample is drawn along the whole route, as without follow: the compiled draw
    # (planners.guidance.route_draws) then gives the numpy draw's samples from the same rows, to the last bits of
    # the logarithm, arcsine and arctangent, which the C library computes there and numpy's vector code here
    net = make_sampler("rigid_route").net
    compiled = RigidRouteSampler(net, **settings, follow=2.0, follow_share=0.0).bind(slot_scene)
    plain = RigidRouteSampler(net, **settings).bind(slot_scene)
    for seed in range(4):
        a = compiled.draw(np.random.default_rng(seed), 64, None)
        b = plain.draw(np.random.default_rng(seed), 64, None)
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)
    assert compiled._drawn == plain._drawn == 256


def test_the_trees_reach_along_the_route_is_the_nearest_route_points_within_the_window():
    from hypothesis import given, settings
    from hypothesis import strategies as st

    from planners.guidance.route_draws import route_reach

    route = np.cumsum(np.r_[[[0.0, 0.0, 0.0]], np.tile([[1.0, 0.0, 0.0]], (9, 1)), np.tile([[0.0, 1.0, 0.0]], (10, 1))],
                      axis=0)
    arc = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(route, axis=0), axis=1))]

    def reference(states, seen, reach, side, span, follow):  # the numpy watch the kernel replaces
        best = max if side == 0 else min
        for lo in range(seen, len(states), 256):
            first, last = 0, len(route)
            if follow:
                if side == 0:
                    last = max(1, int(np.searchsorted(arc, reach + span, "right")))
                else:
                    first = min(last - 1, int(np.searchsorted(arc, reach - span)))
            d2 = ((states[lo:lo + 256, None, :3] - route[None, first:last]) ** 2).sum(axis=2)
            near = first + d2.argmin(axis=1)
            if follow:
                near = near[d2.min(axis=1) <= span ** 2]
            if len(near):
                reach = best(reach, float(best(arc[near])))
        return reach

    @settings(max_examples=60, deadline=None)
    @given(st.integers(0, 2 ** 32 - 1), st.integers(0, 600), st.sampled_from([0, 1]), st.floats(0.5, 8.0),
           st.booleans())
    def check(seed, n, side, span, follow):
        rng = np.random.default_rng(seed)
        states = np.c_[rng.uniform(-2, 12, (n, 2)), rng.uniform(-1, 1, (n, 1)), rng.uniform(-3, 3, (n, 3))]
        seen = int(rng.integers(0, n + 1))
        reach = 0.0 if side == 0 else float(arc[-1])
        assert route_reach(states, seen, route, arc, reach, side, span, follow) == \
            reference(states, seen, reach, side, span, follow)

    check()


def test_the_registry_name_plans_with_rrt_connect(slot_scene):
    from learning.evaluation.rigid import run_one

    row = run_one(slot_scene, "RRTConnect", "rigid_route", 0, max_iterations=300)
    again = run_one(slot_scene, "RRTConnect", "rigid_route", 0, max_iterations=300)
    assert row.iterations == again.iterations and row.solved == again.solved and row.iterations <= 300
    with pytest.raises(InputError, match="takes no parameter"):
        make_sampler("rigid_route", colour=1)



def test_a_roadmap_takes_its_own_validated_rule_and_a_users_setting_holds_for_every_planner(slot_scene):
    from planners import PRM, RRT, RRTConnect

    s = make_sampler("rigid_route")
    tree = (SHIPPED_RIGID_SETTINGS["symmetry"], SHIPPED_RIGID_SETTINGS["route_fraction"])
    assert (s.symmetry, s.route_fraction) == tree
    for family in ("tree", "bidirectional", "optimizing"):
        assert s.for_planner(family) is s
    r = s.for_planner("roadmap")
    assert r is not s and all(getattr(r, k) == v for k, v in SHIPPED_RIGID_ROADMAP.items() if k != "uniform_ramp")
    assert r.uniform_ramp == 0.0 and s.uniform_ramp == SHIPPED_RIGID_SETTINGS["uniform_ramp"]  # a roadmap never ramps
    assert (s.symmetry, s.route_fraction) == tree  # the trees' rule unchanged
    assert (s.uniform_share, s.angle_noise) == (SHIPPED_RIGID_SETTINGS["uniform_share"],
                                                SHIPPED_RIGID_SETTINGS["angle_noise"])
    # the planners ask for it when handed the sampler
    assert PRM(slot_scene, sampler=s, seed=0).sampler.symmetry == SHIPPED_RIGID_ROADMAP["symmetry"]
    assert RRT(slot_scene, sampler=s, seed=0).sampler.symmetry == SHIPPED_RIGID_SETTINGS["symmetry"]
    assert RRTConnect(slot_scene, sampler=s, seed=0).sampler.route_fraction == SHIPPED_RIGID_SETTINGS["route_fraction"]
    # a setting the user gives holds for a roadmap too; the one not given is the roadmap's own
    mine = make_sampler("rigid_route", symmetry="random").for_planner("roadmap")
    assert (mine.symmetry, mine.route_fraction) == ("random", SHIPPED_RIGID_ROADMAP["route_fraction"])
    mine = make_sampler("rigid_route", route_fraction=0.5, symmetry="ends", angle_noise=0.2).for_planner("roadmap")
    assert (mine.symmetry, mine.route_fraction, mine.angle_noise) == ("ends", 0.5, 0.2)
    assert mine.uniform_share == SHIPPED_RIGID_ROADMAP["uniform_share"]
    # the roadmap's unturned axis-aligned rotations: every route sample of a class at one of its four rotations
    q = PRM(slot_scene, sampler=make_sampler("rigid_route", goal_share=0.0), seed=0).sampler.draw(
        np.random.default_rng(5), 64, None)
    assert np.allclose(np.abs(np.array([rotation_matrix(*x[3:]) for x in q])).max(axis=1), 1.0)
    assert make_sampler("rigid_route_ablation").for_planner("roadmap").route_fraction == 0.75  # its own, tuned
    # the ablation's route positions are the learned sampler's, a tree's and a roadmap's, and a weight the user
    # gives holds for both
    abl = make_sampler("rigid_route_ablation")
    assert abl.passage_weight == s.passage_weight == SHIPPED_RIGID_SETTINGS["passage_weight"]
    assert abl.for_planner("roadmap").passage_weight == r.passage_weight == SHIPPED_RIGID_ROADMAP["passage_weight"]
    mine = make_sampler("rigid_route_ablation", passage_weight=2.0)
    assert mine.passage_weight == mine.for_planner("roadmap").passage_weight == 2.0
    with pytest.raises(InputError, match="no setting colour"):
        RigidRouteSampler(s.net, roadmap={"colour": 1})
    with pytest.raises(InputError, match="roadmap symmetry"):
        RigidRouteSampler(s.net, roadmap={"symmetry": "spiral"})
    with pytest.raises(InputError, match="roadmap route_fraction"):
        RigidRouteSampler(s.net, roadmap={"route_fraction": 1.5})
    with pytest.raises(InputError, match="roadmap angle_noise"):
        RigidRouteSampler(s.net, roadmap={"angle_noise": -0.1})
    with pytest.raises(InputError, match="roadmap uniform_share must be 1"):
        RigidRouteSampler(None, uniform_share=1.0, roadmap={"uniform_share": 0.0})


def test_the_rotation_chain_keeps_each_point_nearest_the_one_before_from_its_nearer_end():
    rots = class_rotations()
    rng = np.random.default_rng(0)
    classes = rng.integers(6, size=30)
    ends = rots[[2, 5], [1, 3]]  # a start and a goal orientation
    arc = np.cumsum(rng.random(30))
    arc -= arc[0]
    half = arc <= arc[-1] / 2
    for start_only in (False, True):
        chain = rotation_chain(rots, classes, ends, arc, start_only=start_only)
        forward = half | start_only
        for i in range(30):
            cand = rots[classes[i]]
            assert any(np.allclose(chain[i], c) for c in cand)  # one of its class's four
            if forward[i]:
                before = ends[0] if i == 0 else chain[i - 1]
            else:
                before = ends[1] if i == 29 else chain[i + 1]
            assert np.allclose(chain[i], cand[np.einsum("sij,ij->s", cand, before).argmax()])
    # one class all along: the walk never turns, and starts at the class's rotation nearest the start's
    same = rotation_chain(rots, np.full(30, 4), ends, arc, start_only=True)
    first = rots[4][np.einsum("sij,ij->s", rots[4], ends[0]).argmax()]
    assert np.allclose(same, same[0]) and np.allclose(same[0], first)

@pytest.mark.parametrize("label", ["solution", "window"])
def test_training_is_reproducible_on_a_tiny_set(label):
    torch.set_num_threads(1)
    config = RigidTrainConfig(scenes_per_family=1, families=("slot", "shelves"), epochs=1, held_out=0.0, label=label)
    net1, log1 = train_rigid_orientation(config)
    net2, log2 = train_rigid_orientation(config)
    assert isinstance(net1, OrientationNet) and log1["examples"] == log2["examples"] > 0
    assert all(torch.equal(a, b) for a, b in zip(net1.state_dict().values(), net2.state_dict().values(), strict=True))


def test_solution_labels_are_one_hot_and_name_the_class_the_solution_holds(slot_scene):
    from learning.references.rigid_expert import solve_reference
    from learning.training.rigid import collect_rigid_examples
    from planners.guidance.rigid_orientation import nearest_class, solution_classes
    from planners.worlds.mesh import rotation_matrices

    ex = collect_rigid_examples(RigidTrainConfig(scenes_per_family=1, families=("slot",), label="solution"))
    assert len(ex.labels) > 0 and np.array_equal(ex.labels.sum(axis=1), np.ones(len(ex.labels)))
    # at a state of the solution the label is that state's own class
    states = solve_reference(slot_scene)[0]
    assert states is not None
    y = solution_classes(states[::7], states)
    assert np.array_equal(y.argmax(axis=1), nearest_class(rotation_matrices(states[::7, 3:]))[0])


def test_window_labels_keep_the_classes_that_fit_along_the_whole_window():
    from learning.training.rigid import window_labels

    pts = np.stack([np.arange(10.0), np.zeros(10), np.zeros(10)], axis=1)
    fit = np.ones((10, 6))
    fit[5, 1:] = 0  # a passage at x = 5 that only class 0 passes
    y = window_labels(pts, fit, 2.0)
    assert np.array_equal(y[3:8], np.tile(np.eye(6)[0], (5, 1)))  # within 2 of the passage: class 0 only
    assert np.all(y[:3] == 1) and np.all(y[8:] == 1)
    none = window_labels(pts, np.zeros((10, 6)) + np.eye(6)[np.arange(10) % 6], 1.0)
    assert np.allclose(none[4], [0, 0, 0, 1 / 3, 1 / 3, 1 / 3])  # no class throughout: the window's mean


def test_centring_moves_route_points_across_the_route_to_more_clearance(slot_scene):
    from planners.guidance.workspace_route import centre_route, voxel_route

    world = slot_scene.world
    route = voxel_route(world, slot_scene.start, slot_scene.goal)
    moved = centre_route(world, route, 2)
    assert moved.shape == route.shape and np.array_equal(moved[[0, -1]], route[[0, -1]])
    assert np.array_equal(centre_route(world, route, 0), route)

    def clearance(p):
        gap = np.maximum(np.maximum(world.boxes[None, :, :3] - p[:, None], p[:, None] - world.boxes[None, :, 3:]), 0)
        return np.minimum(np.linalg.norm(gap, axis=2).min(axis=1),
                          np.minimum(p - world.low3, world.high3 - p).min(axis=1))

    assert np.all(clearance(moved) >= clearance(route) - 1e-12) and np.any(clearance(moved) > clearance(route))
    s = make_sampler("rigid_route", centre=0).bind(slot_scene)
    assert np.array_equal(s.route, route) and make_sampler("rigid_route").centre == SHIPPED_RIGID_SETTINGS["centre"]


def test_the_training_script_writes_weights_and_recipe_and_the_comparison_takes_sampler_params(tmp_path, capsys):
    import json
    import runpy
    import sys

    from scripts import evaluate_rigid

    argv = sys.argv
    try:
        sys.argv = ["train_rigid.py", "--scenes-per-family", "1", "--families", "slot", "--epochs", "1",
                    "--out", str(tmp_path / "run")]
        with pytest.raises(SystemExit) as done:
            runpy.run_path("scripts/train_rigid.py", run_name="__main__")
    finally:
        sys.argv = argv
    assert done.value.code == 0
    meta = json.loads((tmp_path / "run" / "rigid_route.json").read_text())
    assert meta["recipe"]["families"] == ["slot"] and meta["recipe"]["label"] == "solution"
    load_orientation_net(tmp_path / "run" / "rigid_route.pt")
    assert evaluate_rigid.main(["--sampler-params", "[1]", "--out", str(tmp_path / "e")]) == 2
    assert evaluate_rigid.main(["--sampler-params", "{", "--out", str(tmp_path / "e")]) == 2
    assert "sampler-params" in capsys.readouterr().err
    assert evaluate_rigid.main(["--first-scene", "-1", "--out", str(tmp_path / "e")]) == 2
    assert evaluate_rigid.main(["--first-scene", "2", "--mesh", "--part", "test", "--out", str(tmp_path / "e")]) == 2
    assert "--first-scene" in capsys.readouterr().err
    # names and the output place are refused before the scenes are made (nothing printed of them, nothing written)
    assert evaluate_rigid.main(["--samplers", "nosuch", "--out", str(tmp_path / "e")]) == 2
    assert evaluate_rigid.main(["--planners", "XX", "--out", str(tmp_path / "e")]) == 2
    assert evaluate_rigid.main(["--out", str(tmp_path / "e.png")]) == 2
    out = capsys.readouterr()
    assert "unknown sampler 'nosuch'" in out.err and "'XX'" in out.err and "give a folder" in out.err
    assert "scenes" not in out.out and not (tmp_path / "e").exists() and not (tmp_path / "e.png").exists()
    # a part from a later scene on: the runs name those scenes
    assert evaluate_rigid.main(["--families", "slot", "--scenes", "1", "--first-scene", "16", "--planners", "RRT",
                                "--samplers", "uniform", "--max-iterations", "20", "--out", str(tmp_path / "f")]) == 0
    assert [r["scene"] for r in json.loads((tmp_path / "f" / "rows.json").read_text())] == ["slot-200016"]
    assert "from its scene 16 on" in (tmp_path / "f" / "summary.md").read_text()


def test_a_passage_weight_crowds_route_positions_where_the_route_is_tight_and_zero_leaves_the_draws_as_they_were():
    from planners.worlds.rigid_scenes import rigid_scene

    problem = rigid_scene("slot", 200_000)
    kw = {"route_fraction": 1.0, "goal_share": 0.0, "follow": 0.0}  # along the whole route
    plain = make_sampler("rigid_route", passage_weight=0.0, **kw).bind(problem)
    tight = make_sampler("rigid_route", passage_weight=16.0, **kw).bind(problem)
    shipped = make_sampler("rigid_route", **kw).bind(problem)  # the trees' default on a box world: the same weight
    assert shipped.passage_weight == SHIPPED_RIGID_SETTINGS["passage_weight"] == 16.0
    assert np.array_equal(shipped.draw(np.random.default_rng(2), 300, None),
                          tight.draw(np.random.default_rng(2), 300, None))
    # the draws' own weighting: segment lengths times 1 + weight x the patch's solid share, so the tight segments
    # (the slot's wall) hold a larger part of the route as drawn than of its length
    seg = np.diff(tight.arc)
    drawn = np.diff(tight.warc) / tight.warc[-1]
    assert np.all(drawn >= 0) and np.isclose(drawn.sum(), 1.0) and np.array_equal(plain.warc, plain.arc)
    wall = problem.world.boxes[:, 0].min(), problem.world.boxes[:, 3].max()  # the wall across x, with its slot
    mid = 0.5 * (tight.route[:-1, 0] + tight.route[1:, 0])
    near = (mid > wall[0] - 5) & (mid < wall[1] + 5)
    assert near.any() and drawn[near].sum() > seg[near].sum() / seg.sum() + 0.1
    # and the positions follow it: more of them near the wall than without the weight
    q = tight.draw(np.random.default_rng(3), 2000, None)[:, 0]
    p = plain.draw(np.random.default_rng(3), 2000, None)[:, 0]
    assert np.mean((q > wall[0] - 5) & (q < wall[1] + 5)) > np.mean((p > wall[0] - 5) & (p < wall[1] + 5))
    # the ablation computes the same occupancy without a model, so its positions crowd the same way
    abl = make_sampler("rigid_route_ablation", passage_weight=16.0, follow=0.0).bind(problem)
    assert abl.net is None and np.allclose(abl.warc, tight.warc)
    with pytest.raises(InputError, match="passage_weight"):
        make_sampler("rigid_route", passage_weight=-1.0)


def test_the_own_ablation_draws_the_learned_samplers_positions_with_uniform_angles_and_needs_no_model():
    from planners.worlds.rigid_scenes import rigid_scene

    problem = rigid_scene("slot", 200_000)
    learned, ablation = make_sampler("rigid_route"), make_sampler("rigid_route_ablation")
    assert ablation.net is None and ablation.uniform_share == 1.0 and ablation.centre == learned.centre
    learned, ablation = learned.bind(problem), ablation.bind(problem)
    a = learned.draw(np.random.default_rng(3), 400, None)
    b = ablation.draw(np.random.default_rng(3), 400, None)
    assert np.array_equal(a[:, :3], b[:, :3])  # the same stream: the same positions, goal draws included
    assert not np.array_equal(a[:, 3:], b[:, 3:])  # the angles differ: the model's against uniform ones
    with pytest.raises(InputError, match="uniform_share must be 1"):
        RigidRouteSampler(None, uniform_share=0.5)


def test_nearest_class_names_the_axis_aligned_rotation_and_solution_labels_follow_the_nearest_state():
    from planners.guidance.rigid_orientation import nearest_class, small_rotations, solution_classes

    rots = class_rotations()
    cls, sym = nearest_class(rots.reshape(-1, 3, 3))
    assert np.array_equal(cls, np.repeat(np.arange(6), 4)) and np.array_equal(sym, np.tile(np.arange(4), 6))
    turned = small_rotations(np.full((24, 3), 0.2)) @ rots.reshape(-1, 3, 3)
    assert np.array_equal(nearest_class(turned)[0], cls)
    # a solution that holds class 2 up to x = 5 and class 4 after: each point takes the class of the nearest state
    states = np.zeros((11, 6))
    states[:, 0] = np.arange(11.0)
    states[:6, 3:] = euler_from_matrices(rots[2, 1])
    states[6:, 3:] = euler_from_matrices(rots[4, 3])
    y = solution_classes(np.array([[0.2, 0.0, 0.0], [4.9, 1.0, 0.0], [9.0, -1.0, 2.0]]), states)
    assert np.array_equal(y.argmax(axis=1), [2, 2, 4]) and np.array_equal(y.sum(axis=1), [1, 1, 1])


def test_the_ends_rule_takes_the_class_rotation_nearest_the_nearer_ends_orientation(slot_scene):
    from planners.guidance.rigid_orientation import nearest_class
    from planners.worlds.mesh import rotation_matrices

    net = make_sampler("rigid_route").net
    s = RigidRouteSampler(net, route_fraction=1.0, uniform_share=0.0, angle_noise=0.0, goal_share=0.0,
                          symmetry="ends").bind(slot_scene)
    q = s.draw(np.random.default_rng(5), 64, None)
    R = rotation_matrices(q[:, 3:])
    cls, sym = nearest_class(R)
    ends = rotation_matrices(np.stack([slot_scene.start[3:], slot_scene.goal[3:]]))
    near_goal = (np.linalg.norm(q[:, :3] - slot_scene.goal[:3], axis=1)
                 < np.linalg.norm(q[:, :3] - slot_scene.start[:3], axis=1))
    rots = class_rotations()
    best = np.einsum("nsij,nij->ns", rots[cls], ends[near_goal.astype(int)]).argmax(axis=1)
    # the sample's end is judged at its route point, not its noisy position: compare where they agree clearly
    far = np.abs(np.linalg.norm(q[:, :3] - slot_scene.goal[:3], axis=1)
                 - np.linalg.norm(q[:, :3] - slot_scene.start[:3], axis=1)) > 5.0
    assert far.sum() > 20 and np.array_equal(sym[far], best[far])
    with pytest.raises(InputError, match="symmetry"):
        RigidRouteSampler(net, symmetry="nearest")


def test_min_confidence_gives_uniform_angles_where_the_model_is_unsure_and_is_checked(slot_scene):
    net = make_sampler("rigid_route").net
    kw = dict(route_fraction=1.0, uniform_share=0.0, angle_noise=0.0, goal_share=0.0)
    sure = RigidRouteSampler(net, **kw).bind(slot_scene)
    never = RigidRouteSampler(net, min_confidence=1.0, **kw).bind(slot_scene)
    a, b = (s.draw(np.random.default_rng(5), 200, None) for s in (sure, never))
    assert np.array_equal(a[:, :3], b[:, :3])  # the same positions: only the angles differ
    axis_aligned = [np.allclose(np.abs(rotation_matrix(*x[3:])).max(axis=1), 1.0) for x in b]
    assert not any(axis_aligned) and sure.sure.all() and not never.sure.any()
    # a gate between the route points' confidences keeps the model's class exactly where it is sure
    c = float(np.median(sure.probs.max(axis=1)))
    gated = RigidRouteSampler(net, min_confidence=c, **kw).bind(slot_scene)
    g = gated.draw(np.random.default_rng(5), 200, None)
    assert np.array_equal(gated.sure, sure.probs.max(axis=1) >= c) and 0 < gated.sure.sum() < len(gated.sure)
    kept = np.all(np.isclose(g, a), axis=1)
    assert kept.any() and not kept.all()
    with pytest.raises(InputError, match="min_confidence"):
        RigidRouteSampler(net, min_confidence=1.5)
    assert make_sampler("rigid_route", min_confidence=c).min_confidence == c


def test_the_clearance_open_test_keeps_passage_points_and_drops_most_open_ones():
    from learning.training.rigid import collect_rigid_examples

    base = dict(scenes_per_family=1, families=("slot",), label="solution")
    by_label = collect_rigid_examples(RigidTrainConfig(**base))
    by_clearance = collect_rigid_examples(RigidTrainConfig(**base, open_test="clearance"))
    assert np.all(by_label.fits == 1)  # a one-hot label names one class: every point is kept
    assert len(by_clearance.labels) < len(by_label.labels)
    assert by_clearance.fits.min() >= 1 and by_clearance.fits.max() <= 6
    assert np.allclose(by_clearance.labels.sum(axis=1), 1)
    with pytest.raises(InputError, match="open_test"):
        RigidTrainConfig(open_test="walls").check()


def test_the_route_benchmark_times_every_piece_of_a_bind_and_checks_its_arguments(capsys, tmp_path, monkeypatch):
    from conftest import load_script

    from learning.evaluation.rigid_speed import PIECES, setup_times

    rows = setup_times([rigid_scene("slot", 300_000)], repeats=1)
    assert len(rows) == 1 and all(rows[0][p] > 0 for p in PIECES) and rows[0]["route points"] > 2
    bench = load_script("benchmark_rigid_route")
    assert bench.main(["--part", "validation", "--families", "shelves", "--scenes", "1", "--repeats", "1"]) == 0
    out = capsys.readouterr().out
    assert "| shelves | 1 |" in out and "bind (ms)" in out
    assert bench.main(["--scenes", "0"]) == 2
    assert bench.main(["--part", "tuning", "--families", "elbow"]) == 2
    assert "test-only" in capsys.readouterr().err
    monkeypatch.delenv("SAMPLERGYM_OMPLAPP_DIR", raising=False)
    assert bench.main(["--problems", "cubicles"]) == 2 and "goes with --omplapp" in capsys.readouterr().err
    assert bench.main(["--omplapp"]) == 2 and "SAMPLERGYM_OMPLAPP_DIR" in capsys.readouterr().err
    assert bench.main(["--omplapp", str(tmp_path)]) == 2 and "no OMPL.app problems" in capsys.readouterr().err


def test_min_route_confidence_gives_the_whole_query_uniform_angles_below_the_routes_peak(slot_scene):
    net = make_sampler("rigid_route").net
    kw = dict(route_fraction=1.0, uniform_share=0.0, angle_noise=0.0, goal_share=0.0)
    plain = RigidRouteSampler(net, **kw).bind(slot_scene)
    peak = float(plain.probs.max())
    below = RigidRouteSampler(net, min_route_confidence=peak, **kw).bind(slot_scene)  # the peak itself passes
    above = RigidRouteSampler(net, min_route_confidence=min(1.0, np.nextafter(peak, 2.0)), **kw).bind(slot_scene)
    a, b, c = (s.draw(np.random.default_rng(6), 100, None) for s in (plain, below, above))
    assert np.array_equal(a, b) and below.sure.all() and not above.sure.any()
    assert np.array_equal(a[:, :3], c[:, :3]) and not np.isclose(a[:, 3:], c[:, 3:]).all(axis=1).any()
    with pytest.raises(InputError, match="min_route_confidence"):
        RigidRouteSampler(net, min_route_confidence=-0.1)


def test_the_patch_size_is_part_of_the_recipe_and_reaches_the_model():
    torch.set_num_threads(1)
    config = RigidTrainConfig(scenes_per_family=1, families=("slot",), epochs=1, held_out=0.0, half=4)
    net, log = train_rigid_orientation(config)
    assert net.half == 4 and log["examples"] > 0
    with pytest.raises(InputError, match="half"):
        RigidTrainConfig(half=40).check()
    with pytest.raises(InputError, match="half"):
        RigidTrainConfig(half=1).check()


def test_the_training_scripts_refuse_an_unusable_output_place_before_training(tmp_path, capsys):
    from conftest import load_script

    (tmp_path / "file").write_text("x")
    train_rigid, sb3 = load_script("train_rigid"), load_script("sb3_defaults")
    assert train_rigid.main(["--out", str(tmp_path / "file" / "run")]) == 2
    assert train_rigid.main(["--out", str(tmp_path / "run"), "--export", str(tmp_path / "file" / "w.pt")]) == 2
    with pytest.raises(SystemExit) as done:
        sb3.main(["--out", str(tmp_path / "file" / "models")])
    assert done.value.code == 2
    err = capsys.readouterr().err
    assert err.count("is a file, so nothing can be created below it") == 3 and not (tmp_path / "run").exists()
