"""The 6-DoF room probe (scripts/experiments/rigid_room.py): its samplers swap the expert's positions and angles."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import load_script

from planners.guidance.rigid_orientation import class_rotations, nearest_class
from planners.worlds.mesh import rotation_matrices
from planners.worlds.rigid_scenes import rigid_scene

pytestmark = pytest.mark.experiments


@pytest.fixture(scope="module")
def probe():
    return load_script("experiments/rigid_room")


@pytest.fixture(scope="module")
def slot_scene():
    return rigid_scene("slot", 12345)  # a training seed


def test_expert_positions_keep_the_positions_and_draw_uniform_angles(probe, slot_scene):
    s = probe.ExpertPositions(uniform_share=0.0, goal_share=0.0, angle_noise=0.0, spread=0.0).bind(slot_scene)
    q = s.draw(np.random.default_rng(2), 200, None)
    d = ((q[:, None, :3] - s.states[None, :, :3]) ** 2).sum(axis=2).min(axis=1)
    assert d.max() < 1e-18  # every position is a solution state's
    assert q[:, 3:].std(axis=0).min() > 1.0  # the angles are not the solution's: spread over [-pi, pi)


def test_snapped_angles_are_axis_aligned_and_every_rule_gives_one_of_the_solutions_classes(probe, slot_scene):
    states = probe.RigidExpertSampler().bind(slot_scene).states
    for rule in ("solution", "random", "ends", "chain"):
        s = probe.ExpertAngles(uniform_share=0.0, angle_noise=0.0, snap=True, symmetry=rule).bind(slot_scene)
        q = s.draw(np.random.default_rng(3), 100, None)
        turned = ~np.all(q == slot_scene.goal, axis=1)
        R = rotation_matrices(q[turned, 3:])
        assert np.allclose(np.abs(R).max(axis=1), 1.0), rule  # axis-aligned
        near = ((q[turned, None, :3] - states[None, :, :3]) ** 2).sum(axis=2).argmin(axis=1)
        assert np.array_equal(nearest_class(R)[0], nearest_class(rotation_matrices(states[near, 3:]))[0]), rule
    route = probe.make_sampler("rigid_route_ablation").bind(slot_scene).route
    chain = probe.chain_rotations(route, states, slot_scene)
    rots = class_rotations().reshape(-1, 3, 3)
    assert chain.shape == (len(route), 3, 3)
    assert all(any(np.allclose(c, r) for r in rots) for c in chain)


def test_the_cli_refuses_bad_arguments(probe):
    with pytest.raises(SystemExit):
        probe.main(["--scenes", "0"])
    with pytest.raises(SystemExit):
        probe.main(["--only", "nope"])
