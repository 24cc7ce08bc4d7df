"""Bring your own sampler: any SB3 model trained on a SamplerGym env plans in every tree planner.

A planner with ``SB3Sampler`` and a rollout of the same model in the env, on the same query and planner
seed, are the same run; a model file is loaded without unpickling; ``evaluate.py --sampler`` ranks a
user's model and a user's Sampler factory beside the baselines.
"""

from __future__ import annotations

import base64
import json
import os
import pickle
import zipfile
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import torch
from conftest import fine_check_path, load_script
from gymnasium.utils import seeding
from stable_baselines3 import DQN, PPO, SAC

import envs
from learning import SB3Sampler
from planners import RRT, OccupancyGrid, RRTConnect, RRTStar
from planners.base.fileio import InputError
from planners.maps.generators import generate

gym.register_envs(envs)
REPO = Path(__file__).resolve().parents[1]

# (env id, env kwargs, algorithm): every action mode an SB3 algorithm can drive, 2-D and 6-DoF
# SB3's default CNN costs about 2.5 ms per sample on 64x64 and 48x48 images: the tests use its smallest
# input (36x36) and short episodes, and fit every model briefly (the weights only need to be fixed)
SMALL = {"observation": "image", "obs_size": 36, "local_size": 36, "max_iterations": 300}
CASES = [
    ("SamplerGym/RRT-Forest-v2", {"action_mode": "bias", **SMALL}, PPO),
    ("SamplerGym/RRT-Forest-v2", {"action_mode": "relative", **SMALL}, SAC),
    ("SamplerGym/RRT-Rooms-v2", {"action_mode": "guided", **SMALL}, DQN),
    ("SamplerGym/RRT-RigidBody-v1", {"action_mode": "bias", "max_iterations": 300}, PPO),
]
FOREST = {"action_mode": "bias", **SMALL}


@pytest.fixture(autouse=True)
def _one_torch_thread():
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(threads)


def _train(env_id: str, kwargs: dict, algo, steps: int = 64):
    env = gym.make(env_id, **kwargs)
    policy = "MultiInputPolicy" if isinstance(env.observation_space, gym.spaces.Dict) else "MlpPolicy"
    # off-policy models take no gradient step (learning_starts = steps): their CNN updates take minutes
    extra = {"n_steps": 32, "batch_size": 32} if algo is PPO else {"buffer_size": 500, "learning_starts": steps}
    return env, algo(policy, env, seed=0, verbose=0, **extra).learn(steps)


@pytest.fixture(scope="module")
def ppo_forest(tmp_path_factory):
    """A PPO model trained briefly on RRT-Forest-v2 with goal-bias actions, and its saved file."""
    env, model = _train("SamplerGym/RRT-Forest-v2", FOREST, PPO)
    path = tmp_path_factory.mktemp("user") / "user_ppo.zip"
    model.save(path)
    return model, path


@pytest.mark.parametrize(("env_id", "kwargs", "algo"), CASES, ids=lambda c: getattr(c, "__name__", str(c)))
def test_a_planner_run_is_the_env_rollout(env_id, kwargs, algo, tmp_path):
    env, model = _train(env_id, kwargs, algo)
    path = tmp_path / "model.zip"
    model.save(path)
    base = env.unwrapped
    for k in range(2):
        problem = base.source(np.random.default_rng(k))
        obs, _ = env.reset(seed=k, options={"problem": problem})
        done = False
        while not done:
            obs, _, terminated, truncated, info = env.step(model.predict(obs, deterministic=True)[0])
            done = terminated or truncated
        # the env seeds its planner with the first draw of its np_random (no map drawn: the problem is given)
        seed = int(seeding.np_random(k)[0].integers(2**63))
        for m in (model, path):
            planner = RRT(problem, step_size=base.step_size, sampler=SB3Sampler(m, env_id, **kwargs), seed=seed)
            r = planner.solve(max_iterations=base.max_iterations)
            assert (r.iterations, r.solved) == (info["iterations"], info["solved"])
            assert np.array_equal(planner.view().vertices, base.planner.view().vertices)


@pytest.mark.parametrize("cls", [RRT, RRTStar, RRTConnect])
def test_every_tree_planner_takes_it(ppo_forest, cls):
    _, path = ppo_forest
    env = gym.make("SamplerGym/RRT-Forest-v2").unwrapped
    problem = env.source(np.random.default_rng(5))
    sampler = SB3Sampler(path, "SamplerGym/RRT-Forest-v2", **FOREST)
    kw = {"stop_on_first_solution": True} if cls is RRTStar else {}
    r = cls(problem, step_size=4.0, sampler=sampler, seed=0, **kw).solve(max_iterations=3000)
    assert r.solved
    assert np.allclose(r.path[0], problem.start)
    assert np.linalg.norm(r.path[-1] - problem.goal) <= problem.goal_tolerance + 1e-9
    assert fine_check_path(problem.world, r.path)


@pytest.mark.parametrize("env_id", sorted(envs.ENV_IDS))
def test_a_model_of_every_id_plans_in_every_tree_planner(env_id, monkeypatch):
    """A (untrained) SB3 default model of each registered id, 2-D and 6-DoF, drives RRT, RRT* and RRT-Connect."""
    from conftest import movingai_dir

    if env_id.endswith("MovingAI-v2"):
        if movingai_dir() is None:
            pytest.skip("MovingAI maps not found: set SAMPLERGYM_MOVINGAI_DIR or place them in ../shared/maps/movingai")
        monkeypatch.setenv("SAMPLERGYM_MOVINGAI_DIR", str(movingai_dir()))
    env = gym.make(env_id).unwrapped
    policy = "MultiInputPolicy" if isinstance(env.observation_space, gym.spaces.Dict) else "MlpPolicy"
    model = PPO(policy, env, seed=0)
    problem = env.source(np.random.default_rng(0))
    for cls in (RRT, RRTStar, RRTConnect):
        planner = cls(problem, step_size=env.step_size, sampler=SB3Sampler(model, env_id), seed=0)
        r = planner.solve(max_iterations=20)
        assert r.iterations == 20 or r.solved
        assert planner.view().num_vertices >= 1
        if r.solved and isinstance(problem.world, OccupancyGrid):  # the independent check is 2-D
            assert fine_check_path(problem.world, r.path)


def test_stochastic_actions_are_seeded_by_the_planner(ppo_forest):
    _, path = ppo_forest
    problem = gym.make("SamplerGym/RRT-Forest-v2").unwrapped.source(np.random.default_rng(1))
    sampler = SB3Sampler(path, "SamplerGym/RRT-Forest-v2", **FOREST, deterministic=False)

    def run(seed):
        planner = RRT(problem, step_size=4.0, sampler=sampler, seed=seed)
        planner.solve(max_iterations=100)
        return planner.view().vertices.copy()

    assert np.array_equal(run(3), run(3))
    assert not np.array_equal(run(3), run(4))


def test_a_pickled_call_in_the_model_file_does_not_run(ppo_forest, tmp_path):
    _, path = ppo_forest
    target = tmp_path / "pwned"

    class Mkdir:
        def __reduce__(self):
            return os.mkdir, (str(target),)

    with zipfile.ZipFile(path) as zf:
        entries = {n: zf.read(n) for n in zf.namelist()}
    data = json.loads(entries["data"])
    data["policy_kwargs"] = {":type:": "<class 'dict'>",
                             ":serialized:": base64.b64encode(pickle.dumps(Mkdir())).decode()}
    entries["data"] = json.dumps(data).encode()
    hostile = tmp_path / "hostile.zip"
    with zipfile.ZipFile(hostile, "w") as zf:
        for name, blob in entries.items():
            zf.writestr(name, blob)
    SB3Sampler(hostile, "SamplerGym/RRT-Forest-v2", **FOREST)
    assert not target.exists()


def test_a_model_for_another_env_is_refused_by_name(ppo_forest, tmp_path):
    model, path = ppo_forest
    with pytest.raises(InputError, match=r"user_ppo\.zip: its weights do not fit"):
        SB3Sampler(path, "SamplerGym/RRT-Forest-v2", **{**FOREST, "action_mode": "point"})
    with pytest.raises(InputError, match="trained on observations"):
        SB3Sampler(model, "SamplerGym/RRT-RigidBody-v1")
    with pytest.raises(InputError, match="not-an-id"):
        SB3Sampler(path, "SamplerGym/not-an-id")
    with pytest.raises(FileNotFoundError):
        SB3Sampler(tmp_path / "missing.zip", "SamplerGym/RRT-Forest-v2")


@pytest.mark.parametrize("kwargs", [{"observation": "egocentric"}, {"obs_size": 48}])
def test_a_model_of_other_observations_is_refused_up_front_naming_both(ppo_forest, kwargs):
    _, path = ppo_forest
    with pytest.raises(InputError, match=r"user_ppo\.zip: the model was trained on observations \{'image': "
                                         r"\(4, 36, 36\) uint8.*this environment gives .*env kwargs"):
        SB3Sampler(path, "SamplerGym/RRT-Forest-v2", **{**FOREST, **kwargs})


def _load_evaluate():
    return load_script("evaluate")


def test_the_worked_example_ranks_a_user_model_and_a_user_factory(ppo_forest, tmp_path, capsys):
    """README: train with SB3's defaults, save, compare with one command, read the table."""
    _, path = ppo_forest
    out = tmp_path / "evaluation"
    opts = "@action_mode=bias@observation=image@obs_size=36@local_size=36@max_iterations=300"
    rc = _load_evaluate().main([
        "--families", "forest", "--size", "64", "--maps", "2", "--tuning-maps", "2", "--seeds", "1",
        "--shifted-maps", "0", "--no-unseen", "--movingai-maps", "--other-planners", "none", "--processes", "1",
        "--max-iterations", "600",
        "--no-expert",
        "--sampler", f"mine={path}@SamplerGym/RRT-Forest-v2{opts}",
        "--sampler", f"mine_stochastic={path}@SamplerGym/RRT-Forest-v2{opts}@stochastic",
        "--sampler", "factory=planners.base.samplers:UniformSampler", "--out", str(out)])
    assert rc == 0
    printed = capsys.readouterr().out
    for col in ("mine_median", "mine/best_bias", "mine_stochastic_success", "factory_wall_ms"):
        assert col in printed
    runs = (out / "runs.csv").read_text().splitlines()
    for name in ("mine", "mine_stochastic", "factory"):
        assert sum(f",{name}," in line for line in runs) == 2  # 2 test maps x 1 seed
    # the factory is uniform sampling under another name: the same runs as the built-in uniform rows
    rows = [line.split(",") for line in runs[1:]]
    its = {s: sorted(r[7] for r in rows if r[4] == s and r[2] == "test") for s in ("factory", "uniform")}
    assert its["factory"] == its["uniform"]
    summary = (out / "summary.md").read_text()
    assert "User samplers: `mine`" in summary and "@stochastic" in summary


@pytest.mark.parametrize(("arg", "match"), [
    ("mine", "expected NAME=SPEC"),
    ("uniform=planners.base.samplers:UniformSampler", "taken"),
    ("mine=nowhere.zip@SamplerGym/RRT-Forest-v2", "nowhere.zip"),
    ("mine=planners.base.samplers:NoSuchSampler", "NoSuchSampler"),
    ("mine=planners.worlds.grid:OccupancyGrid", "not a Sampler|OccupancyGrid"),
])
def test_bad_sampler_specs_exit_2_naming_them(arg, match, capsys):
    with pytest.raises(SystemExit) as exc:
        _load_evaluate().parse_args(["--sampler", arg])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert any(part in err for part in match.split("|"))


def test_the_policy_acts_at_the_planning_thread_count_and_restores_the_callers(ppo_forest, monkeypatch):
    from learning.models.threads import planning_thread_count

    model, _ = ppo_forest
    seen = []
    sampler = SB3Sampler(model, "SamplerGym/RRT-Forest-v2", threads=2, **FOREST)
    act = sampler._act_now
    monkeypatch.setattr(sampler, "_act_now", lambda obs, rng: seen.append(torch.get_num_threads()) or act(obs, rng))
    torch.set_num_threads(1)
    RRT(generate("forest", 3, 64), step_size=4.0, sampler=sampler, seed=0).solve(max_iterations=20)
    assert set(seen) == {2} and torch.get_num_threads() == 1
    assert planning_thread_count() == 1
    with pytest.raises(InputError, match="threads = 0"):
        SB3Sampler(model, "SamplerGym/RRT-Forest-v2", threads=0, **FOREST)


@pytest.mark.parametrize(("env_id", "kwargs"), [("SamplerGym/RRT-Forest-v2", FOREST),
                                                ("SamplerGym/RRT-Rooms-v2", {"action_mode": "guided", **SMALL})],
                         ids=["gaussian", "categorical"])
def test_the_direct_actor_pass_takes_sb3s_actions(env_id, kwargs, monkeypatch):
    """``ActorPass`` (modules called directly, features reused) gives SB3's actions: the same runs, draw for draw."""
    env = gym.make(env_id, **kwargs)
    model = PPO("MultiInputPolicy", env, seed=0, device="cpu")
    base = env.unwrapped
    reference = {True: base.as_sampler(lambda obs, rng: model.predict(obs, deterministic=True)[0]),
                 False: SB3Sampler(model, env_id, deterministic=False, batch=1, **kwargs)}
    monkeypatch.setattr(reference[False], "_actor", None)  # SB3's own obs_to_tensor and get_distribution
    calls = []
    model.policy.features_extractor.extractors["image"].register_forward_hook(lambda *_: calls.append(1))
    for deterministic in (True, False):
        sampler = SB3Sampler(model, env_id, deterministic=deterministic, batch=1, **kwargs)
        assert sampler._actor is not None
        for k in range(3):
            problem = base.source(np.random.default_rng(k))
            runs = []
            for s in (sampler, reference[deterministic]):
                calls.clear()
                planner = RRT(problem, step_size=base.step_size, sampler=s, seed=k)
                r = planner.solve(max_iterations=150)
                runs.append((r.iterations, r.solved, planner.view().vertices.copy(), len(calls)))
            assert runs[0][:2] == runs[1][:2]
            assert np.array_equal(runs[0][2], runs[1][2])
            assert runs[1][3] == runs[1][0] > runs[0][3]  # SB3 runs the image CNN every draw; the pass reuses it


def test_a_policy_without_cnn_runs_in_numpy_and_takes_sb3s_actions(monkeypatch):
    """On a -v2 family id's defaults (flattened windows) ``MlpActor`` gives the actions of SB3's own pass."""
    env_id = "SamplerGym/RRT-Forest-v2"
    env = gym.make(env_id, max_iterations=300)
    model = PPO("MultiInputPolicy", env, seed=0, device="cpu")
    base = env.unwrapped
    for deterministic in (True, False):
        fast = SB3Sampler(model, env_id, deterministic=deterministic, max_iterations=300)
        slow = SB3Sampler(model, env_id, deterministic=deterministic, max_iterations=300)
        assert fast._mlp is not None
        monkeypatch.setattr(slow, "_mlp", None)
        for k in range(2):
            problem = base.source(np.random.default_rng(k))
            runs = []
            for s in (fast, slow):
                planner = RRT(problem, step_size=base.step_size, sampler=s, seed=k)
                r = planner.solve(max_iterations=100)
                runs.append((r.iterations, r.solved, planner.view().vertices.copy()))
            assert runs[0][:2] == runs[1][:2]
            assert np.array_equal(runs[0][2], runs[1][2])
    obs, _ = env.reset(seed=0)
    from learning.samplers.sb3 import MlpActor

    actor = MlpActor.of(model.policy)
    with torch.no_grad():
        logits = model.policy.get_distribution(model.policy.obs_to_tensor(obs)[0]).distribution.logits
    np.testing.assert_allclose(actor.head(obs) - actor.head(obs).max(), logits[0].numpy() - logits[0].numpy().max(),
                               atol=1e-5)
    assert actor.head({"local": obs["local"][:3], "vector": obs["vector"]}) is None  # a wrong shape: not this pass


def test_guided_draws_decide_once_per_batch():
    """A sampler drawing guided classes answers GUIDED_BATCH classes per observation; other modes refuse a batch."""
    from learning.samplers.sb3 import GUIDED_BATCH

    env_id = "SamplerGym/RRT-Forest-v2"
    model = PPO("MultiInputPolicy", gym.make(env_id, max_iterations=300), seed=0, device="cpu")
    sampler = SB3Sampler(model, env_id, max_iterations=300)
    assert sampler.batch == GUIDED_BATCH and not sampler.deterministic
    assert SB3Sampler(model, env_id, deterministic=True, max_iterations=300).batch == 1
    calls = []
    act_batch = sampler.act_batch
    sampler.act_batch = lambda obs, rng, k: calls.append(k) or act_batch(obs, rng, k)
    r = RRT(generate("forest", 3, 64), step_size=4.0, sampler=sampler, seed=0).solve(max_iterations=200)
    assert sum(calls) >= r.iterations > len(calls) and max(calls) <= GUIDED_BATCH
    with pytest.raises(InputError, match="batch=4 needs the guided action mode"):
        envs.EnvSampler(envs.SamplerEnv(action_mode="mixture"), lambda obs, rng: np.zeros(4), batch=4)
