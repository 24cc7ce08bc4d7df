"""``samplergym``: a module name a user's project does not shadow registers the environments on import."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

SCRIPT = textwrap.dedent("""
    import gymnasium as gym
    import numpy as np

    env = gym.make("samplergym:SamplerGym/RRT-Forest-v2", max_iterations=20)
    obs, info = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    env.step(env.action_space.sample())
    import envs  # the project's own envs/ is still the project's
    assert envs.MINE == "yes", envs
    import samplergym
    print("ok", type(env.unwrapped).__module__, samplergym.SamplerEnv.__name__)
""")


def _run(cwd: Path, code: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    return subprocess.run([sys.executable, "-c", code], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=300)


def test_gym_make_with_the_module_prefix_beside_a_projects_own_envs(tmp_path):
    (tmp_path / "envs").mkdir()
    (tmp_path / "envs" / "__init__.py").write_text('MINE = "yes"\n')
    proc = _run(tmp_path, SCRIPT)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["ok", "samplergym.envs.sampler_env", "SamplerEnv"]
    # without the prefix, a fresh process has not registered anything: the prefix is what imports it
    proc = _run(tmp_path, 'import gymnasium as gym\ngym.make("SamplerGym/RRT-Forest-v2")')
    assert proc.returncode != 0 and "SamplerGym" in proc.stderr


def test_samplergym_is_envs_when_nothing_shadows_it(tmp_path):
    code = textwrap.dedent("""
        import gymnasium as gym
        env = gym.make("samplergym:SamplerGym/RRT-Maze-v2")
        import envs, samplergym
        assert samplergym.envs is envs and type(env.unwrapped) is envs.SamplerEnv
        assert samplergym.make_planner.__module__ == "planners.base.registry"
        print("ok")
    """)
    proc = _run(tmp_path, code)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["ok"]


def test_sb3_sampler_plans_beside_a_projects_own_envs(tmp_path):
    """``learning`` reaches the environments as ``samplergym.envs``: a user's ``envs/`` does not break SB3Sampler."""
    (tmp_path / "envs").mkdir()
    (tmp_path / "envs" / "__init__.py").write_text('MINE = "yes"\n')
    code = textwrap.dedent("""
        import gymnasium as gym
        import numpy as np
        import torch
        from stable_baselines3 import PPO

        from learning import SB3Sampler
        from learning.extractor import EgocentricExtractor  # the path SB3 checkpoints name the extractor by
        from planners import RRT
        import samplergym

        torch.set_num_threads(1)
        kwargs = {"action_mode": "bias", "obs_size": 36, "local_size": 36, "max_iterations": 50}
        env = gym.make("samplergym:SamplerGym/RRT-Forest-v2", **kwargs)
        model = PPO("MultiInputPolicy", env, seed=0, device="cpu")
        model.save("user_ppo.zip")
        problem = env.unwrapped.source(np.random.default_rng(0))
        runs = []
        for m in (model, "user_ppo.zip"):
            sampler = SB3Sampler(m, "samplergym:SamplerGym/RRT-Forest-v2", **kwargs)
            assert isinstance(sampler, samplergym.EnvSampler) and samplergym.SB3Sampler is SB3Sampler
            planner = RRT(problem, step_size=4.0, sampler=sampler, seed=0)
            r = planner.solve(max_iterations=40)
            runs.append((r.iterations, planner.view().num_vertices))
        assert runs[0] == runs[1] and runs[0][1] > 1, runs
        import envs
        assert envs.MINE == "yes", envs
        print("ok", type(sampler.env).__module__, EgocentricExtractor.__module__)
    """)
    proc = _run(tmp_path, code)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["ok", "samplergym.envs.sampler_env", "learning.models.extractor"]


def test_sample_problem_gives_the_query_an_episode_of_that_seed_plans():
    import gymnasium as gym
    import numpy as np
    import pytest

    from planners.base.fileio import InputError

    env = gym.make("samplergym:SamplerGym/RRT-Forest-v2")
    problem = env.unwrapped.sample_problem(7)
    env.reset(seed=7)
    episode = env.unwrapped.problem
    assert np.array_equal(problem.start, episode.start) and np.array_equal(problem.goal, episode.goal)
    assert np.array_equal(problem.world.obstacles, episode.world.obstacles)
    again = env.unwrapped.sample_problem(np.random.default_rng(7))
    assert np.array_equal(again.start, problem.start)
    with pytest.raises(InputError, match="seed must be a non-negative integer"):
        env.unwrapped.sample_problem(-1)


def test_the_docs_make_environments_with_the_prefix_and_draw_queries_with_the_public_method():
    for page in [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]:
        text = page.read_text(encoding="utf-8")
        assert "\nimport envs\n" not in text and "gym.register_envs(envs)" not in text, page
        assert ".unwrapped.source(" not in text, page
