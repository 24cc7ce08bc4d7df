"""scripts/plan.py: headless planning on a picture map writes a figure and a GIF; bad input writes nothing."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
from conftest import REPO, fine_check_path
from PIL import Image

from planners.workflow import load_map, plan_on_image

SCRIPT = REPO / "scripts" / "plan.py"


@pytest.fixture(scope="module")
def map_png(tmp_path_factory):
    """A 96x64 drawing: black walls on white, a wall with a door, anti-aliased gray pixels."""
    img = np.full((64, 96), 255, dtype=np.uint8)
    img[:, 46:50] = 0
    img[28:34, 46:50] = 255  # the door
    img[10:20, 10:25] = 30
    img[40:55, 65:80] = 100
    img[40:55, 64] = 200  # light anti-aliasing: free at the default threshold
    path = tmp_path_factory.mktemp("maps") / "floor.png"
    Image.fromarray(img).convert("RGB").save(path)
    return path


def run(*args, env_extra=None):
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env.update(env_extra or {})
    return subprocess.run([sys.executable, str(SCRIPT), *map(str, args)], capture_output=True, text=True,
                          timeout=120, env=env, cwd=REPO)


def test_headless_run_writes_figure_and_gif(map_png, tmp_path):
    out = tmp_path / "out"
    p = run(map_png, "--start", 5.5, 30.5, "--goal", 90.5, 40.5, "--out", out, "--headless", "--frames", 12)
    assert p.returncode == 0, p.stderr
    for key in ("iterations:", "collision checks:", "time:", "path length:", "smoothed"):
        assert key in p.stdout
    with Image.open(out / "plan.png") as im:
        assert im.format == "PNG" and min(im.size) > 100
    with Image.open(out / "plan.gif") as im:
        assert im.format == "GIF" and im.n_frames >= 3 and max(im.size) <= 520
    assert sorted(f.name for f in out.iterdir()) == ["plan.gif", "plan.png"]  # no temporary files left


def test_options_and_no_gif(map_png, tmp_path):
    out = tmp_path / "o"
    p = run(map_png, "--start", 5.5, 30.5, "--goal", 90.5, 40.5, "--out", out, "--headless", "--planner", "rrt",
            "--sampler", "goal-bias", "--goal-bias", 0.2, "--metric", "chebyshev", "--step", 6, "--tolerance", 2,
            "--no-smooth", "--no-gif", "--seed", 3)
    assert p.returncode == 0, p.stderr
    assert "smoothed" not in p.stdout and "metric chebyshev" in p.stdout
    assert sorted(f.name for f in out.iterdir()) == ["plan.png"]


@pytest.mark.parametrize("args, message", [
    (["missing.png", "--start", 5, 5, "--goal", 90, 40], "missing.png"),
    (["{map}", "--start", 47, 5, "--goal", 90, 40], "start (47, 5)"),
    (["{map}", "--start", 5, 5, "--goal", 500, 40], "goal (500, 40)"),
    (["{map}"], "no --start/--goal given"),
    (["{map}", "--start", 5, 5], "give both --start and --goal"),
    (["{bad}", "--start", 5, 5, "--goal", 90, 40], "cannot read"),
    (["{map}", "--start", 5, 5, "--goal", 90, 40, "--planner", "obprm", "--sampler", "uniform"], "own sampler"),
])
def test_bad_input_gives_a_clear_error_and_no_output(map_png, tmp_path, args, message):
    bad = tmp_path / "notes.png"
    bad.write_text("not an image")
    out = tmp_path / "out"
    args = [str(a).format(map=map_png, bad=bad) for a in args]
    p = run(*args, "--out", out, "--headless")
    assert p.returncode == 2
    assert message in p.stderr, p.stderr
    assert "Traceback" not in p.stderr
    assert not out.exists()


@pytest.mark.parametrize("planner", ["rrt-connect", "prm", "lazy-prm", "obprm", "rrtstar", "informed-rrtstar"])
def test_plan_on_image_library(map_png, planner):
    grid = load_map(map_png)
    out = plan_on_image(grid, (5.5, 30.5), (90.5, 40.5), planner=planner, metric="euclidean", step=8,
                        max_iterations=3000, seed=1)
    assert out.result.solved
    assert fine_check_path(grid, out.path, spacing=0.05) and fine_check_path(grid, out.smoothed, spacing=0.05)
    assert out.smoothed_length <= out.length + 1e-9
    assert out.history[-1][0] == out.result.iterations


def test_map_kinds(tmp_path):
    obs = np.zeros((20, 30), dtype=bool)
    obs[5:15, 12] = True
    np.save(tmp_path / "m.npy", obs)
    assert np.array_equal(load_map(tmp_path / "m.npy").obstacles, obs)
    (tmp_path / "m.map").write_text("type octile\nheight 2\nwidth 3\nmap\n..@\n.@.\n")
    assert load_map(tmp_path / "m.map").obstacles.tolist() == [[False, False, True], [False, True, False]]
    with pytest.raises(ValueError, match="unknown kind"):
        (tmp_path / "m.txt").write_text("x")
        load_map(tmp_path / "m.txt")
