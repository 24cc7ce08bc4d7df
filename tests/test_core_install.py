"""The core install (no test extras, so no scipy) plans in 2-D and in 6-DoF.

scipy is a test-only dependency; numba's matrix product and linear algebra need it, so any compiled
kernel that uses them breaks the core install. The check runs in a fresh interpreter where importing
scipy fails and numba's cache points at an empty directory, so every kernel is really compiled there.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

SCRIPT = textwrap.dedent("""
    import sys
    sys.modules["scipy"] = None  # "import scipy" now raises ImportError, as on a core install
    import numpy as np
    from planners import RRT, OccupancyGrid, Problem, GoalBiasedSampler
    from planners.worlds.rigid3d import thin_wall_scene

    grid = np.zeros((64, 64), bool)
    grid[20:44, 30:34] = True
    p2 = Problem(OccupancyGrid(grid), start=(5, 5), goal=(58, 58), goal_tolerance=4.0)
    r2 = RRT(p2, step_size=4.0, sampler=GoalBiasedSampler(0.05), seed=0).solve(max_iterations=20000)
    p6 = thin_wall_scene()
    r6 = RRT(p6, step_size=0.5, sampler=GoalBiasedSampler(0.05), seed=1).solve(max_iterations=20000)
    import envs, learning  # the other layers import without scipy too
    assert "scipy" not in {m.split(".")[0] for m, v in sys.modules.items() if v is not None}
    print("SOLVED", r2.solved, r6.solved)
""")


# Slow: it compiles RRT's kernels from nothing. CI's first step (.ci/run) checks the same on every build,
# more widely: a core install without scipy compiles every kernel (planners.compile) and runs the main job.
@pytest.mark.slow
def test_core_install_plans_without_scipy(tmp_path):
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba-cache"), "PYTHONPATH": str(REPO)}
    proc = subprocess.run([sys.executable, "-c", SCRIPT], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "SOLVED True True" in proc.stdout
