"""``SamplerGym/RigidOrientation-v1``: the 6-DoF route sampler's orientation choice as an environment, and the
shipped orientation model's examples collected through it."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from envs import ORIENTATION_ENV_ID, Lesson, NoLessons, RigidOrientationEnv, witness_teacher
from planners.base.fileio import InputError
from planners.guidance.rigid_orientation import N_CLASSES, path_points, route_observation, solution_classes
from planners.guidance.workspace_route import voxel_route
from planners.worlds.rigid_scenes import scene_with_witness


def _episode(env, options=None, policy=None):
    obs, info = env.reset(options=options)
    seen, rewards, done = [], [], False
    while not done:
        seen.append((obs, info))
        action = info["expert_action"] if policy is None else policy(obs, info)
        obs, reward, done, truncated, info = env.step(action)
        rewards.append(reward)
        assert not truncated
    return seen, rewards, info


def test_the_environment_passes_gymnasiums_and_sb3s_checkers():
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = gym.make(ORIENTATION_ENV_ID, families=["slot"])
    check_env(env.unwrapped, skip_render_check=True)
    sb3_check_env(gym.make(ORIENTATION_ENV_ID, families=["slot"]), warn=False)


def test_an_episode_steps_through_the_scenes_route_and_witness_points_with_the_witness_classes():
    env = RigidOrientationEnv(families=["slot"])
    seen, rewards, last = _episode(env, {"family": "slot", "scene_seed": 123})
    problem, witness = scene_with_witness("slot", 123)
    route = voxel_route(problem.world, problem.start, problem.goal)
    points = np.concatenate([route, path_points(witness.path)])
    assert len(seen) == len(points) == last["points"] and "label" not in last
    patches = np.concatenate([route_observation(problem.world, pts)[0] for pts in (route, path_points(witness.path))])
    assert all(np.array_equal(obs["patch"], p) for (obs, _), p in zip(seen, patches, strict=True))
    # the expert's action is the witness path's class, rewarded 1; another class 0
    labels = np.array([info["label"] for _, info in seen])
    assert labels.shape == (len(points), N_CLASSES) and (labels.sum(axis=1) == 1).all()
    assert rewards == [1.0] * len(points)
    _, wrong, _ = _episode(env, {"family": "slot", "scene_seed": 123},
                           policy=lambda obs, info: (info["expert_action"] + 1) % N_CLASSES)
    assert wrong == [0.0] * len(points)


def test_the_same_seed_draws_the_same_episodes_and_another_seed_another_scene():
    a, b = RigidOrientationEnv(families=["slot", "duct"]), RigidOrientationEnv(families=["slot", "duct"])
    scenes = []
    for env in (a, b):
        obs, info = env.reset(seed=5)
        scenes.append((info["scene"], info["points"], obs["patch"].copy()))
        obs, info = env.reset()
        scenes.append((info["scene"], info["points"], obs["patch"].copy()))
    assert scenes[0][:2] == scenes[2][:2] and scenes[1][:2] == scenes[3][:2]
    assert np.array_equal(scenes[0][2], scenes[2][2])
    assert scenes[0][0] != scenes[1][0]


def test_a_teacher_decides_the_points_labels_and_which_scenes_count():
    def only_the_route(problem, route, witness, rng):
        labels = np.zeros((len(route), N_CLASSES))
        labels[:, 0], labels[:, 3] = 3.0, 1.0  # a soft label: the reward is the class's share
        keep = rng.random(len(route)) < 0.5
        return [Lesson(route, labels, np.full(len(route), 2), keep)]

    env = RigidOrientationEnv(families=["slot"], teacher=only_the_route)
    seen, rewards, _ = _episode(env, {"family": "slot", "scene_seed": 7, "teacher_seed": 11})
    again, _, _ = _episode(env, {"family": "slot", "scene_seed": 7, "teacher_seed": 11})
    assert 0 < len(seen) == len(again) and rewards == [0.75] * len(seen)
    assert all(info["fits"] == 2 for _, info in seen)
    with pytest.raises(NoLessons) as unlabelled:
        RigidOrientationEnv(families=["slot"], teacher=lambda *a: None).reset(
            options={"family": "slot", "scene_seed": 7})
    assert not unlabelled.value.labelled and "slot-7" in str(unlabelled.value)
    def nothing_kept(problem, route, witness, rng):
        return [Lesson(route, np.ones((len(route), N_CLASSES)), np.ones(len(route)), np.zeros(len(route), bool))]

    with pytest.raises(NoLessons) as empty:
        RigidOrientationEnv(families=["slot"], teacher=nothing_kept).reset(options={"family": "slot",
                                                                                    "scene_seed": 7})
    assert empty.value.labelled


def test_bad_arguments_are_refused_with_what_was_expected():
    with pytest.raises(InputError, match="test-only|choose one or more"):
        RigidOrientationEnv(families=["hatch"])
    with pytest.raises(InputError, match="part must be"):
        RigidOrientationEnv(part="holdout")
    env = RigidOrientationEnv(families=["slot"])
    with pytest.raises(InputError, match="'family'"):
        env.reset(options={"family": "duct", "scene_seed": 3})
    env.reset(options={"family": "slot", "scene_seed": 3})
    with pytest.raises(InputError, match="orientation class"):
        env.step(N_CLASSES)
    assert RigidOrientationEnv(part="test", families=["hatch"]).reset(seed=0)[1]["scene"].startswith("hatch-")


def test_the_training_examples_are_the_environments_observations_and_the_teachers_labels():
    from learning.training.rigid import RigidTrainConfig, collect_rigid_examples, recipe_teacher

    config = RigidTrainConfig(scenes_per_family=1, families=("slot",), label="window", poses=2)
    ex = collect_rigid_examples(config)
    seed = int(np.random.default_rng(config.seed).integers(0, 100_000))
    problem, witness = scene_with_witness("slot", seed)
    assert ex.names == [problem.name] and len(ex.patches) == len(ex.labels) == len(ex.scene) > 0
    env = RigidOrientationEnv(families=["slot"], teacher=recipe_teacher(config))
    seen, _, _ = _episode(env, {"family": "slot", "scene_seed": seed, "teacher_seed": [config.seed, seed, 0]})
    assert np.array_equal(ex.patches, np.stack([obs["patch"] for obs, _ in seen]))
    assert np.array_equal(ex.labels, np.stack([info["label"] for _, info in seen]).astype(np.float32))
    other = collect_rigid_examples(config)
    assert all(np.array_equal(getattr(ex, k), getattr(other, k)) for k in ("patches", "directions", "labels", "fits"))


def test_the_witness_teacher_labels_the_class_the_witness_takes():
    problem, witness = scene_with_witness("duct", 40)
    route = voxel_route(problem.world, problem.start, problem.goal)
    lessons = witness_teacher(problem, route, witness, np.random.default_rng(0))
    assert [len(x.points) for x in lessons] == [len(route), len(path_points(witness.path))]
    # at the witness path's own vertices the label is the class of the vertex's orientation
    from planners.guidance.rigid_orientation import nearest_class
    from planners.worlds.mesh import rotation_matrices

    own, _ = nearest_class(rotation_matrices(witness.path[:, 3:]))
    vertex_labels = solution_classes(witness.path[:, :3], witness.path).argmax(axis=1)
    assert np.array_equal(vertex_labels, own)


def test_ppo_with_sb3s_defaults_trains_on_it():
    from stable_baselines3 import PPO

    env = gym.make(ORIENTATION_ENV_ID, families=["slot"])
    model = PPO("MultiInputPolicy", env, n_steps=64, batch_size=32, n_epochs=1, seed=0, device="cpu")
    model.learn(128)
    obs, _ = env.reset(seed=1)
    action, _ = model.predict(obs, deterministic=True)
    assert env.action_space.contains(int(action))
