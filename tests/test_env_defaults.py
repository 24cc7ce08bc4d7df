"""Every registered id works the way Gymnasium and Stable-Baselines3 users expect (issues 14.2, 14.3, 15.2)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from conftest import movingai_dir
from PIL import Image

import envs
from envs import ENV_IDS, SamplerEnv
from planners.base.fileio import InputError

gym.register_envs(envs)
MOVINGAI_ENV = "SAMPLERGYM_MOVINGAI_DIR"

ALL_IDS = sorted(ENV_IDS)


def _needs_movingai(env_id):
    if env_id.endswith("MovingAI-v2") and movingai_dir() is None:
        pytest.skip("MovingAI maps not found")


@pytest.fixture
def shared_cwd(monkeypatch):
    """Run from the repository, whose parent holds ``shared/`` when the MovingAI maps are present."""
    d = movingai_dir()
    if d is not None:
        monkeypatch.setenv(MOVINGAI_ENV, str(d))


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_sb3_default_policy_trains_on_every_id(env_id, shared_cwd):
    """SB3's default policy and extractor (NatureCNN for images) build and train on every id, no kwargs.

    Only the rollout size is shrunk (n_steps, batch_size) and one rollout of both envs with one update
    run, to keep the test fast; the policy class, its feature extractor and its preprocessing are SB3's
    defaults, which is what used to crash.
    """
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env

    _needs_movingai(env_id)
    venv = make_vec_env(env_id, n_envs=2, seed=0, env_kwargs={"max_iterations": 64})
    policy = "MlpPolicy" if isinstance(venv.observation_space, gym.spaces.Box) else "MultiInputPolicy"
    model = PPO(policy, venv, n_steps=64, batch_size=64, n_epochs=1, seed=0)
    if policy == "MultiInputPolicy":  # SB3's default CNN on every image key; the -v2 ids' windows are flattened
        from stable_baselines3.common.torch_layers import NatureCNN

        cnns = {k for k, m in model.policy.features_extractor.extractors.items() if isinstance(m, NatureCNN)}
        assert cnns == (set() if env_id.endswith("-v2") else {"image", "local"})
    before = [p.detach().clone() for p in model.policy.parameters()]
    model.learn(128)  # one rollout (64 steps of each of the 2 envs), then one update
    assert model.num_timesteps >= 128
    after = model.policy.parameters()
    assert any(not np.array_equal(a.numpy(), b.detach().numpy()) for a, b in zip(before, after, strict=True))
    venv.close()


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_gym_make_without_kwargs(env_id, shared_cwd):
    _needs_movingai(env_id)
    env = gym.make(env_id)
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    obs, *_ = env.step(env.action_space.sample())
    assert env.observation_space.contains(obs)
    env.close()


def test_files_id_defaults_to_the_shipped_sample_maps():
    paths = envs.sample_map_paths()
    assert len(paths) >= 2 and all(p.suffix == ".png" and p.is_file() for p in paths)
    env = gym.make("SamplerGym/RRT-Files-v2")
    names = {env.reset(seed=s)[0] is not None and env.unwrapped.problem.name for s in range(20)}
    assert names <= {p.name for p in paths} and len(names) >= 2


@pytest.mark.parametrize("kind", ["array", "png", "npy"])
def test_planning_id_plans_on_the_users_map(kind, tmp_path):
    obstacles = np.zeros((40, 48), bool)
    obstacles[5:35, 24] = True  # a wall with gaps at both ends
    if kind == "array":
        m = obstacles
    elif kind == "png":
        m = tmp_path / "mine.png"
        Image.fromarray(np.where(obstacles, 0, 255).astype(np.uint8)).save(m)
    else:
        m = tmp_path / "mine.npy"
        np.save(m, obstacles)
    env = gym.make("SamplerGym/Planning-v1", map=m, start=(4.5, 20.5), goal=(44.5, 20.5), max_iterations=3000,
                   action_mode="point")
    env.reset(seed=0)
    p = env.unwrapped.problem
    assert np.array_equal(p.world.obstacles, obstacles)
    assert np.array_equal(p.start, [4.5, 20.5]) and np.array_equal(p.goal, [44.5, 20.5])
    rng = np.random.default_rng(0)
    for _ in range(3000):
        _, _, term, trunc, info = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
        if term or trunc:
            break
    assert term and info["solved"]
    # random queries on the user's map without start / goal; map_source=array as well
    env = gym.make("SamplerGym/Planning-v1", map_source=obstacles)
    env.reset(seed=1)
    assert np.array_equal(env.unwrapped.problem.world.obstacles, obstacles)
    with pytest.raises(InputError, match="start and goal"):
        SamplerEnv(map=obstacles, start=(4.5, 20.5))
    with pytest.raises(InputError, match="start"):
        SamplerEnv(map=obstacles, start=(24.5, 20.5), goal=(44.5, 20.5))  # inside the wall


def test_movingai_dir_resolution(tmp_path, monkeypatch):
    """Argument > SAMPLERGYM_MOVINGAI_DIR > ../shared/maps/movingai from the working directory; not the source path."""
    from planners.maps import movingai as sources

    a, b = tmp_path / "a", tmp_path / "b"
    for d in (a, b):
        d.mkdir()
        (d / "x.map").write_text("type octile\nheight 1\nwidth 1\nmap\n.\n")
    # simulate a non-editable install: the module sits in site-packages, far from any shared/ folder
    monkeypatch.setattr(sources, "__file__",
                        str(tmp_path / "venv" / "lib" / "site-packages" / "planners" / "maps" / "movingai.py"))
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv(MOVINGAI_ENV, str(b))
    assert sources.movingai_dir() == b
    assert sources.movingai_dir(a) == a
    monkeypatch.delenv(MOVINGAI_ENV)
    with pytest.raises(InputError) as err:  # no ../shared beside tmp_path
        sources.movingai_dir()
    assert MOVINGAI_ENV in str(err.value) and "directory" in str(err.value)
    work = tmp_path / "proj" / "work"
    work.mkdir(parents=True)
    (tmp_path / "proj" / "shared" / "maps").mkdir(parents=True)
    (tmp_path / "proj" / "shared" / "maps" / "movingai").symlink_to(a)
    monkeypatch.chdir(work)
    assert sources.movingai_dir().resolve() == a.resolve()
    (tmp_path / "proj" / "shared" / "maps" / "movingai").unlink()
    assert sources.movingai_dir(required=False) is None  # the default folder may be absent...
    monkeypatch.setenv(MOVINGAI_ENV, str(tmp_path / "missing"))
    with pytest.raises(InputError, match=MOVINGAI_ENV):  # ...but a folder the user named must exist
        sources.movingai_dir(required=False)
    monkeypatch.delenv(MOVINGAI_ENV)
    with pytest.raises(InputError, match=MOVINGAI_ENV):
        gym.make("SamplerGym/RRT-MovingAI-v2", source_kwargs={"directory": str(tmp_path / "missing")})


def test_movingai_id_without_kwargs_uses_the_env_var(monkeypatch, tmp_path):
    d = movingai_dir()
    if d is None:
        pytest.skip("MovingAI maps not found")
    monkeypatch.chdir(tmp_path)  # no ../shared from here: only the variable can find the maps
    monkeypatch.setenv(MOVINGAI_ENV, str(d))
    env = gym.make("SamplerGym/RRT-MovingAI-v2")
    env.reset(seed=0)
    assert env.unwrapped.source.directory == d


@pytest.mark.parametrize("name, value", [
    ("checks_weight", float("nan")), ("checks_weight", -1.0), ("checks_weight", float("inf")),
    ("step_size", float("nan")), ("step_size", 0.0), ("uniform_floor", float("nan")), ("uniform_floor", 5.0),
    ("uniform_floor", -1.0), ("reach", float("nan")), ("shaping_gamma", float("nan")), ("shaping_gamma", 2.0),
    ("checks_weight", "0.1"), ("max_iterations", -5), ("max_iterations", True),
])
def test_bad_numeric_kwargs_are_refused_by_name(name, value):
    with pytest.raises(InputError, match=name):
        SamplerEnv("forest", reward="checks", **{name: value})


@pytest.mark.parametrize("action", ["3", None, 3.5, [1, 2], np.nan, True, "abc"])
def test_bad_guided_actions_name_the_action_and_space(action):
    env = SamplerEnv("forest", action_mode="guided", observation="egocentric")
    env.reset(seed=0)
    with pytest.raises(InputError, match=r"guided action.*Discrete\(177\)"):
        env.step(action)
    env.step(np.int64(3))  # the env is still usable


@pytest.mark.parametrize("action", ["3", None, "ab", [0.1], [[0.1, 0.2]], [np.nan, 0.0], [0.1, None]])
def test_bad_box_actions_name_the_action_and_space(action):
    env = SamplerEnv("forest", action_mode="point")
    env.reset(seed=0)
    with pytest.raises(InputError, match=r"action.*Box\(-1, 1, \(2,\)"):
        env.step(action)


@pytest.mark.parametrize("end", ["terminated", "truncated"])
def test_stepping_after_the_episode_ended_is_refused_alike(end):
    env = SamplerEnv("forest", max_iterations=5 if end == "truncated" else 2000, action_mode="bias")
    env.reset(seed=0)
    for _ in range(2000):
        _, _, term, trunc, _ = env.step(np.full(1, -0.8, np.float32))  # goal bias 0.1
        if term or trunc:
            break
    assert (term, trunc) == ((True, False) if end == "terminated" else (False, True))
    iterations = env.planner.iterations
    with pytest.raises(RuntimeError, match="call reset"):
        env.step(np.ones(1, np.float32))
    assert env.planner.iterations == iterations
    env.reset(seed=0)
    env.step(np.ones(1, np.float32))


# --- defaults that learn: every id's default action mode keeps a uniform floor -------------------------

TWO_D_IDS = [i for i in ALL_IDS if not i.endswith(("RigidBody-v1", "RigidScenes-v1"))]


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_every_ids_default_action_mode_explores(env_id, shared_cwd):
    _needs_movingai(env_id)
    env = gym.make(env_id).unwrapped
    assert env.new_action_sampler().explores, f"{env_id}: default action mode {env.action_mode!r} has no floor"
    assert not SamplerEnv(action_mode="point").new_action_sampler().explores
    assert not SamplerEnv(action_mode="mixture", uniform_floor=0.0).new_action_sampler().explores


def test_bias_mode_keeps_its_floor_at_full_bias():
    """A bias action of 1 (goal bias 1) still samples uniformly a uniform_floor share of the time."""
    env = SamplerEnv("forest", action_mode="bias", uniform_floor=0.2)
    env.reset(seed=3)
    at_goal = []
    for _ in range(400):
        *_, term, trunc, info = env.step(np.ones(1, np.float32))
        at_goal.append(bool(np.array_equal(info["sample"], env.problem.goal)))
        if term or trunc:
            env.reset()
    share = 1 - np.mean(at_goal)
    assert 0.12 < share < 0.3  # binomial(400, 0.2): far outside these bounds only by a bug


def _ppo_then_plan(env_id: str, learn_steps: int, **ppo_kwargs):
    """PPO with SB3's defaults (``ppo_kwargs`` only shrink the rollout) on ``env_id``'s defaults, then plan.

    The model plans through ``SB3Sampler(model, env_id)`` (its defaults) on a query of the
    id's family that training never saw, within 20,000 iterations.
    """
    import torch
    from stable_baselines3 import PPO

    from learning import SB3Sampler
    from planners import RRT

    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        env = gym.make(env_id)
        policy = "MultiInputPolicy" if isinstance(env.observation_space, gym.spaces.Dict) else "MlpPolicy"
        model = PPO(policy, env, seed=0, **ppo_kwargs).learn(learn_steps)
        base = env.unwrapped
        problem = base.source(np.random.default_rng(2**40 + 17))  # a seed outside the training stream
        sampler = SB3Sampler(model, env_id)
        result = RRT(problem, step_size=base.step_size, sampler=sampler, seed=5).solve(max_iterations=20_000)
    finally:
        torch.set_num_threads(threads)
    assert result.solved, f"{env_id}: not solved in {result.iterations} iterations"


def test_ppo_with_sb3_defaults_on_a_default_id_plans():
    """The fast representative: SB3's PPO on RRT-Forest-v2's defaults, a rollout shrunk to 128 steps."""
    _ppo_then_plan("SamplerGym/RRT-Forest-v2", 256, n_steps=128, batch_size=64, n_epochs=2)


@pytest.mark.slow
@pytest.mark.parametrize("env_id", TWO_D_IDS)
def test_ppo_with_sb3_defaults_on_every_2d_id_plans(env_id, shared_cwd):
    """PPO exactly as SB3 builds it (one 2,048-step rollout for 300 steps), then a held-out query."""
    _needs_movingai(env_id)
    _ppo_then_plan(env_id, 300)


def test_a_sampler_that_cannot_explore_warns_and_says_what_to_change():
    from stable_baselines3 import PPO

    from learning import SB3Sampler

    kw = {"action_mode": "point", "obs_size": 36, "local_size": 36}
    model = PPO("MultiInputPolicy", gym.make("SamplerGym/RRT-Forest-v2", **kw), n_steps=8, batch_size=8, seed=0)
    with pytest.warns(envs.NoExplorationWarning, match=r"action_mode='point'.*mixture.*deterministic=False"):
        SB3Sampler(model, "SamplerGym/RRT-Forest-v2", **kw)
    with pytest.warns(envs.NoExplorationWarning, match="uniform_floor=0"):
        SB3Sampler(PPO("MultiInputPolicy", gym.make("SamplerGym/RRT-Forest-v2", **{**kw, "action_mode": "mixture",
                                                                                   "uniform_floor": 0.0}),
                       n_steps=8, batch_size=8, seed=0),
                   "SamplerGym/RRT-Forest-v2", **{**kw, "action_mode": "mixture", "uniform_floor": 0.0})
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", envs.NoExplorationWarning)
        SB3Sampler(model, "SamplerGym/RRT-Forest-v2", deterministic=False, **kw)  # draws: explores
        envs.EnvSampler(SamplerEnv(**kw), lambda obs, rng: rng.uniform(-1, 1, 2), deterministic=False)
    with pytest.warns(envs.NoExplorationWarning, match="EnvSampler"):
        envs.EnvSampler(SamplerEnv(**kw), lambda obs, rng: np.zeros(2))


# --- the spec's max_episode_steps: truncation through Gymnasium's TimeLimit -----------------------------

@pytest.mark.parametrize("env_id, steps", [("SamplerGym/RRT-Forest-v2", 2000), ("SamplerGym/RRT-RigidBody-v1", 5000)])
def test_time_limit_follows_max_iterations(env_id, steps):
    from gymnasium.wrappers import TimeLimit

    env = gym.make(env_id)
    assert env.spec.max_episode_steps == steps
    env = gym.make(env_id, max_iterations=7, action_mode="bias")
    assert env.spec.max_episode_steps == 7
    wrapper = env
    while not isinstance(wrapper, TimeLimit):
        wrapper = wrapper.env
    assert wrapper._max_episode_steps == 7
    env.reset(seed=0)
    for i in range(7):
        _, _, term, trunc, _ = env.step(np.full(1, -1.0, np.float32))  # goal bias 0: not solved in 7
        assert not term and trunc == (i == 6)
    env.reset(seed=1)  # a new episode after truncation
    env.step(np.zeros(1, np.float32))


def test_registered_envs_pass_the_env_checkers():
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = gym.make("SamplerGym/RRT-Forest-v2", max_iterations=50)
    check_env(env.unwrapped, skip_render_check=True)
    sb3_check_env(env, warn=False)


def test_ppo_on_the_rigid_scenes_id_is_reproducible_and_plans_as_a_users_sampler(tmp_path):
    """``train_ppo_on(RIGID_ID, ...)`` (``sb3_defaults.py --rigid``): SB3's defaults on the 6-DoF scenes' vector
    observations, the same weights from the same seed, and the saved model plans a scene through
    ``user_sampler("MODEL.zip@ENV_ID")``, as the rigid comparison's ``--sampler`` runs it."""
    import torch

    from learning.samplers.registry import user_sampler
    from learning.sb3_defaults import RIGID_ID, train_ppo_on
    from planners import make_planner
    from planners.worlds.rigid_scenes import rigid_scene

    a = train_ppo_on(RIGID_ID, 64, 0, tmp_path / "a.zip")
    b = train_ppo_on(RIGID_ID, 64, 0, tmp_path / "b.zip")
    sa, sb = a.policy.state_dict(), b.policy.state_dict()
    assert all(torch.equal(sa[k], sb[k]) for k in sa)
    sampler = user_sampler(f"{tmp_path / 'a.zip'}@{RIGID_ID}")
    result = make_planner("RRT", rigid_scene("slot", 200_000), sampler=sampler, seed=0, extension_step=1.0).solve(50)
    assert result.iterations == 50 or result.solved


def test_the_family_ppo_is_sb3s_defaults_on_the_training_maps(tmp_path):
    """``train_default_ppo`` (``sb3_defaults.py --family``): exactly ``PPO("MultiInputPolicy", env, seed=seed)`` on the
    family id with its map seeds limited to the training range, saved where asked."""
    import torch
    from stable_baselines3 import PPO

    from learning.sb3_defaults import family_id, train_default_ppo
    from planners.maps.generators import TRAIN_SEEDS

    got = train_default_ppo("forest", 64, 3, tmp_path / "m.zip")
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        env = gym.make(family_id("forest"), source_kwargs={"seeds": np.arange(*TRAIN_SEEDS)})
        want = PPO("MultiInputPolicy", env, seed=3).learn(64)
    finally:
        torch.set_num_threads(threads)
    sg, sw = got.policy.state_dict(), want.policy.state_dict()
    assert all(torch.equal(sg[k], sw[k]) for k in sw) and (tmp_path / "m.zip").is_file()
