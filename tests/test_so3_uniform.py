"""The uniform-rotation probe (scripts/experiments/so3_uniform.py): its rotations and its sampler."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import load_script

from planners import Problem
from planners.worlds.rigid3d import rotation_matrix, thin_wall_scene

pytestmark = pytest.mark.experiments


def test_its_rotations_are_uniform_and_written_on_both_covers():
    so3 = load_script("experiments/so3_uniform")
    so3.check_conversion()
    a = so3.haar_euler(np.random.default_rng(3), 40000)
    assert np.all((a >= -math.pi) & (a < math.pi))
    # uniform over rotations: tx's density on the double cover is |cos tx| / 4 (uniform angles: 1 / (2 pi)), so
    # a quarter turn either side of 0 holds sin(pi / 4) / 2 of the draws (uniform angles: 1/4) and the quarter
    # turns about +-pi/2 hold 1 - sin(pi / 4) (uniform angles: 1/2)
    near_zero = np.mean(np.abs(a[:, 0]) < math.pi / 4)
    near_quarter = np.mean(np.abs(np.abs(a[:, 0]) - math.pi / 2) < math.pi / 4)
    assert abs(near_zero - math.sin(math.pi / 4) / 2) < 0.01 and abs(near_quarter - (1 - math.sin(math.pi / 4))) < 0.01
    assert np.array_equal(a, so3.haar_euler(np.random.default_rng(3), 40000))  # seeded


def test_its_sampler_keeps_the_box_and_the_goal_share():
    so3 = load_script("experiments/so3_uniform")
    p = thin_wall_scene(hole=4.0)
    p = Problem(p.world, p.start, p.goal, goal_tolerance=1.0)
    s = so3.HaarSampler(0.25).bind(p)
    x = s.draw(np.random.default_rng(0), 4000, None)
    low, high = p.world.bounds
    assert x.shape == (4000, 6) and np.all((x >= low) & (x <= high))
    at_goal = np.all(x == p.goal, axis=1).mean()
    assert 0.22 < at_goal < 0.28
    R = rotation_matrix(*x[~np.all(x == p.goal, axis=1)][0, 3:])
    assert np.allclose(R @ R.T, np.eye(3))


def test_it_refuses_bad_counts():
    so3 = load_script("experiments/so3_uniform")
    with pytest.raises(SystemExit):
        so3.main(["--scenes", "0"])
