"""scripts/plan.py: headless planning on a picture map writes a figure and a GIF; bad input writes nothing."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
from conftest import REPO, fine_check_path
from PIL import Image

from learning.models.shipped import SHIPPED_POLICY
from planners.tools.workflow import load_map, picture_planner, plan_on_image

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
    (["{map}", "--start", 5, 5, "--goal", 90, 40, "--out", "{out}.png"], "like a file's; give a folder"),
    (["{scene}", "--start", 5, 5, "--goal", 90, 40], "is a 6-DoF problem (an OMPL.app .cfg or a box scene)"),
])
def test_bad_input_gives_a_clear_error_and_no_output(map_png, tmp_path, args, message):
    bad = tmp_path / "notes.png"
    bad.write_text("not an image")
    out = tmp_path / "out"
    from planners.worlds.rigid3d import WINDOW_SCENE

    args = [str(a).format(map=map_png, bad=bad, out=out, scene=WINDOW_SCENE) for a in args]
    p = run(*args, "--out", out, "--headless") if "--out" not in args else run(*args, "--headless")
    assert p.returncode == 2
    assert message in p.stderr, p.stderr
    assert "Traceback" not in p.stderr
    assert not out.exists() and not (tmp_path / "out.png").exists()


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


def gif_frames(path) -> int:
    with Image.open(path) as im:
        return im.n_frames


def test_a_short_run_gets_every_frame_asked_for(map_png, tmp_path):
    # 527 iterations: the recording used to be every 256 iterations, so the GIF had 4 growth frames
    out = tmp_path / "out"
    p = run(map_png, "--start", 5.5, 30.5, "--goal", 90.5, 40.5, "--planner", "rrt", "--step", 3, "--seed", 2,
            "--frames", 40, "--out", out, "--headless")
    assert p.returncode == 0, p.stderr
    assert "iterations:       527" in p.stdout
    assert gif_frames(out / "plan.gif") == 40 + 1  # growth frames, then the path


def test_recording_leaves_the_run_unchanged(map_png):
    grid = load_map(map_png)
    for planner, step in (("rrt", 3.0), ("lazy-prm", None), ("rrtstar", 6.0)):
        budget = 400 if planner == "rrtstar" else 100_000
        out = plan_on_image(grid, (5.5, 30.5), (90.5, 40.5), planner=planner, step=step, max_iterations=budget,
                            seed=2, max_frames=30)
        p = picture_planner(planner, out.problem, step=step, seed=2)
        r = p.solve(max_iterations=budget)
        assert (out.result.iterations, out.result.collision_checks, out.result.cost) == (
            r.iterations, r.collision_checks, r.cost)
        its = [h[0] for h in out.history]
        assert max(np.diff(its)) <= max(1, its[-1] // 60)  # records at most 1/(2 * frames) of the run apart


def test_policy_sampler_from_the_command_line(map_png, tmp_path):
    pytest.importorskip("torch")
    pytest.importorskip("stable_baselines3")
    out = tmp_path / "out"
    p = run(map_png, "--start", 5.5, 30.5, "--goal", 90.5, 40.5, "--planner", "rrt", "--sampler", "policy",
            "--out", out, "--headless", "--no-gif")
    assert p.returncode == 0, p.stderr
    assert "sampler policy shipped" in p.stdout
    p = run(map_png, "--start", 5.5, 30.5, "--goal", 90.5, 40.5, "--sampler", "policy", "--policy",
            tmp_path / "none.zip", "--out", out / "x", "--headless")
    assert p.returncode == 2 and "none.zip" in p.stderr and "Traceback" not in p.stderr
    assert not (out / "x").exists()


@pytest.mark.parametrize("sampler", ["follower", "route", "route_lazy"])
def test_registry_samplers_from_the_command_line(map_png, tmp_path, sampler):
    pytest.importorskip("torch")
    p = run(map_png, "--start", 5.5, 30.5, "--goal", 90.5, 40.5, "--planner", "rrt", "--sampler", sampler,
            "--out", tmp_path / "out", "--headless", "--no-gif")
    assert p.returncode in (0, 1), p.stderr
    assert f"sampler {sampler})" in p.stdout


@pytest.mark.parametrize("sampler", ["route", "route_lazy"])
def test_the_encoders_samplers_plan_at_its_step_where_the_maps_default_is_longer(tmp_path, sampler):
    """On a 300-cell map the default step is 2% of the diagonal (8.5 cells); the encoder was trained for 4."""
    pytest.importorskip("torch")
    grid = np.zeros((300, 300), dtype=bool)
    grid[100:200, 150] = True
    np.save(tmp_path / "open.npy", grid)
    p = run(tmp_path / "open.npy", "--start", 10.5, 150.5, "--goal", 290.5, 150.5, "--planner", "rrt", "--sampler",
            sampler, "--max-iterations", 50, "--out", tmp_path / "out", "--headless", "--no-gif")
    assert p.returncode in (0, 1), p.stderr
    assert "(step 4, seed 0," in p.stdout


def test_an_unknown_sampler_is_refused_before_the_map_is_read(tmp_path):
    pytest.importorskip("torch")
    p = run(tmp_path / "missing.png", "--start", 5, 5, "--goal", 9, 9, "--sampler", "nope", "--out", tmp_path / "o")
    assert p.returncode == 2 and "--sampler 'nope'" in p.stderr and "follower" in p.stderr
    assert "Traceback" not in p.stderr


def test_policy_sampler_plans_with_the_learned_policy(map_png):
    learning = pytest.importorskip("learning")
    sampler = learning.PolicySampler.load(SHIPPED_POLICY, step_size=3.0)
    out = plan_on_image(load_map(map_png), (5.5, 30.5), (90.5, 40.5), planner="rrt", sampler=sampler, step=3.0,
                        seed=0, smooth=False)
    assert out.result.solved
    assert type(out.planner.sampler).__name__ == "PolicySampler" and out.planner.sampler.forward_passes > 0


def test_plan_script_never_imports_learning(map_png, tmp_path):
    code = ("import sys; sys.path.insert(0, 'scripts'); import plan; "
            f"rc = plan.main([{str(map_png)!r}, '--start', '5.5', '30.5', '--goal', '90.5', '40.5', '--headless', "
            f"'--no-gif', '--out', {str(tmp_path / 'o')!r}]); "
            "assert rc == 0, rc; bad = {'learning', 'torch', 'stable_baselines3'} & set(sys.modules); "
            "assert not bad, bad")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=REPO)
    assert p.returncode == 0, p.stdout + p.stderr


@pytest.mark.parametrize("suffix", [".csv", ".json", ".npy"])
def test_save_path(map_png, tmp_path, suffix):
    dest = tmp_path / "paths" / f"route{suffix}"
    p = run(map_png, "--start", 5.5, 30.5, "--goal", 90.5, 40.5, "--out", tmp_path / "out", "--headless",
            "--no-gif", "--save-path", dest)
    assert p.returncode == 0, p.stderr
    assert f"wrote {dest}" in p.stdout
    if suffix == ".csv":
        lines = dest.read_text().splitlines()
        assert lines[0] == "x,y"
        path = np.array([[float(v) for v in line.split(",")] for line in lines[1:]])
    elif suffix == ".json":
        import json

        doc = json.loads(dest.read_text())
        assert doc["units"] == "px" and doc["y"] == "down" and doc["origin"] == [0.0, 0.0]
        assert doc["resolution"] == 1.0 and doc["smoothed"] is True and doc["map"] == str(map_png)
        path = np.array(doc["path"])
        assert doc["length"] == pytest.approx(np.linalg.norm(np.diff(path, axis=0), axis=1).sum())
    else:
        path = np.load(dest, allow_pickle=False)
    assert path.shape[1] == 2 and len(path) >= 2
    np.testing.assert_array_equal(path[0], [5.5, 30.5])
    assert np.hypot(*(path[-1] - [90.5, 40.5])) <= 1.2  # within the default tolerance (1% of the diagonal)
    assert fine_check_path(load_map(map_png), path, spacing=0.05)
    assert [f.name for f in dest.parent.iterdir()] == [dest.name]  # no temporary file left


def test_save_path_refuses_an_unknown_format_before_planning(map_png, tmp_path):
    p = run(map_png, "--start", 5.5, 30.5, "--goal", 90.5, 40.5, "--out", tmp_path / "out", "--headless",
            "--save-path", tmp_path / "route.txt")
    assert p.returncode == 2 and "route.txt" in p.stderr and ".csv, .json, .npy" in p.stderr
    assert "iterations" not in p.stdout and "Traceback" not in p.stderr
    assert sorted(tmp_path.iterdir()) == []


def test_an_unusable_output_location_is_its_own_error(map_png, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("keep me")
    for args in (["--out", blocker], ["--out", blocker / "sub"], ["--out", tmp_path / "o", "--save-path",
                                                                   blocker / "p.csv"]):
        p = run(map_png, "--start", 5.5, 30.5, "--goal", 90.5, 40.5, "--headless", *args)
        assert p.returncode == 3, (args, p.stdout, p.stderr)
        assert str(blocker) in p.stderr and "is a file" in p.stderr and "Traceback" not in p.stderr
    assert blocker.read_text() == "keep me" and sorted(f.name for f in tmp_path.iterdir()) == ["file"]


def test_a_write_failure_after_planning_is_exit_3_and_leaves_nothing_half_written(map_png, tmp_path):
    out = tmp_path / "out"
    (out / "plan.gif").mkdir(parents=True)  # the animation cannot replace a folder: found only when writing
    p = run(map_png, "--start", 5.5, 30.5, "--goal", 90.5, 40.5, "--out", out, "--headless")
    assert p.returncode == 3, p.stdout + p.stderr
    assert "plan.gif" in p.stderr and "written:" in p.stderr and "Traceback" not in p.stderr
    assert sorted(f.name for f in out.iterdir()) == ["plan.gif", "plan.png"]  # the figure, complete; no temp files
    assert (out / "plan.gif").is_dir()
    with Image.open(out / "plan.png") as im:
        im.load()


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="needs a POSIX user that permissions bind "
                    "(root writes anywhere)")
def test_a_read_only_output_folder_is_refused_before_planning(map_png, tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        p = run(map_png, "--start", 5.5, 30.5, "--goal", 90.5, 40.5, "--out", ro / "out", "--headless")
    finally:
        ro.chmod(0o700)
    assert p.returncode == 3 and "not writable" in p.stderr and "iterations" not in p.stdout
    assert list(ro.iterdir()) == []


def _needs_robot_radius():
    import inspect

    from planners import OccupancyGrid

    if "robot_radius" not in inspect.signature(OccupancyGrid.from_file).parameters:
        pytest.skip("OccupancyGrid.from_file(robot_radius=...) is not in this tree yet (planners/worlds/grid.py)")


def test_radius_keeps_the_path_a_radius_away_from_obstacles(map_png, tmp_path):
    _needs_robot_radius()
    dest = tmp_path / "p.npy"
    p = run(map_png, "--start", 5.5, 30.5, "--goal", 90.5, 40.5, "--radius", 1.5, "--out", tmp_path / "o",
            "--headless", "--no-gif", "--save-path", dest, "--max-iterations", 20000)
    assert p.returncode == 0, p.stdout + p.stderr
    assert "robot radius 1.5" in p.stdout
    path = np.load(dest)
    blocked = np.argwhere(load_map(map_png).obstacles)  # (row, col) of each blocked cell
    s = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    pts = np.stack([np.interp(t, s, path[:, k]) for k in (0, 1) for t in [np.linspace(0, s[-1], 2000)]], axis=1)
    # distance from each point to the nearest blocked cell (a closed unit square)
    dx = np.maximum(0, np.maximum(blocked[None, :, 1] - pts[:, None, 0], pts[:, None, 0] - blocked[None, :, 1] - 1))
    dy = np.maximum(0, np.maximum(blocked[None, :, 0] - pts[:, None, 1], pts[:, None, 1] - blocked[None, :, 0] - 1))
    assert np.hypot(dx, dy).min() >= 1.5 - 1e-9
    # the door is 6 cells tall: a robot of radius 3.5 cannot pass it
    p = run(map_png, "--start", 5.5, 30.5, "--goal", 90.5, 40.5, "--radius", 3.5, "--out", tmp_path / "o2",
            "--headless", "--no-gif", "--max-iterations", 3000)
    assert p.returncode == 1 and "solved:           False" in p.stdout, p.stdout + p.stderr


def test_a_ros_map_plans_in_metres_with_y_up(tmp_path):
    _needs_robot_radius()
    yaml = REPO / "tests" / "data" / "ros" / "turtlebot3_world" / "map.yaml"
    dest = tmp_path / "p.json"
    p = run(yaml, "--start", -1.9, -0.5, "--goal", 1.9, 0.5, "--radius", 0.1, "--out", tmp_path / "o", "--headless",
            "--frames", 8, "--save-path", dest)
    assert p.returncode == 0, p.stdout + p.stderr
    assert "start (-1.9, -0.5) -> goal (1.9, 0.5)" in p.stdout
    import json

    doc = json.loads(dest.read_text())
    assert (doc["units"], doc["frame"], doc["y"], doc["origin"], doc["resolution"]) == ("m", "map", "up",
                                                                                       [-10.0, -10.0], 0.05)
    path = np.array(doc["path"])
    np.testing.assert_array_equal(path[0], [-1.9, -0.5])
    grid = load_map(yaml, robot_radius=0.1)
    assert grid.path_valid(path)
    assert sorted(f.name for f in (tmp_path / "o").iterdir()) == ["plan.gif", "plan.png"]


def test_binding_the_sampler_is_timed_apart_from_planning(map_png):
    """A route encoder's pass happens when the sampler is bound: the sampler's time, not hidden before the clock."""
    from learning import make_sampler

    out = plan_on_image(map_png, (10, 40), (85, 40), planner="rrt", sampler=make_sampler("route"), step=4.0,
                        max_iterations=5000, seed=0)
    assert out.result.solved
    assert set(out.timings) >= {"load", "sampler", "plan"}
    assert out.timings["sampler"] > 0 and out.planner.sampler.forward_passes == 1


@pytest.mark.slow  # the planner's kernels compile from an empty cache (5 to 10 s)
def test_a_first_use_that_compiles_says_how_to_compile_ahead(map_png, tmp_path):
    hint = "python -m learning.compile compile the planners' and the learned samplers' kernels once, ahead"
    args = (map_png, "--start", 5.5, 30.5, "--goal", 90.5, 40.5, "--headless", "--no-gif", "--planner", "rrt")
    cold = run(*args, "--out", tmp_path / "a", env_extra={"NUMBA_CACHE_DIR": str(tmp_path / "cache")})
    assert cold.returncode == 0 and hint in cold.stdout, cold.stdout + cold.stderr
    warm = run(*args, "--out", tmp_path / "b", env_extra={"NUMBA_CACHE_DIR": str(tmp_path / "cache")})
    assert warm.returncode == 0 and hint not in warm.stdout, warm.stdout + warm.stderr

