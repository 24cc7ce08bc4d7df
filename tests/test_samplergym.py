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

    env = gym.make("samplergym:SamplerGym/RRT-Forest-v0", max_iterations=20)
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
    proc = _run(tmp_path, 'import gymnasium as gym\ngym.make("SamplerGym/RRT-Forest-v0")')
    assert proc.returncode != 0 and "SamplerGym" in proc.stderr


def test_samplergym_is_envs_when_nothing_shadows_it(tmp_path):
    code = textwrap.dedent("""
        import gymnasium as gym
        env = gym.make("samplergym:SamplerGym/RRT-Maze-v0")
        import envs, samplergym
        assert samplergym.envs is envs and type(env.unwrapped) is envs.SamplerEnv
        assert samplergym.make_planner.__module__ == "planners.base.registry"
        print("ok")
    """)
    proc = _run(tmp_path, code)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["ok"]
