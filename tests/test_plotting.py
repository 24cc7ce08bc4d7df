"""Figures and animations: headless, atomic writes, pixels where the path is."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from planners import PRM, RRT, Circle, GeometricWorld, OccupancyGrid, Problem, Rectangle, RRTConnect
from planners.plotting import PATH_COLOR, figure_to_array, plot, save_figure, save_gif


@pytest.fixture(scope="module")
def solved():
    obs = np.zeros((40, 40), bool)
    obs[10:30, 18:22] = True
    p = Problem(OccupancyGrid(obs), (5.5, 20.5), (35.5, 20.5), goal_tolerance=1.0)
    planner = RRTConnect(p, step_size=3.0, seed=0)
    planner.solve(max_iterations=5000)
    return p, planner


def test_plot_and_save_png(solved, tmp_path):
    p, planner = solved
    fig = plot(p, planner)
    out = save_figure(fig, tmp_path / "sub" / "fig.png")
    with Image.open(out) as img:
        assert img.format == "PNG" and img.size[0] > 200
    assert [f.name for f in out.parent.iterdir()] == ["fig.png"]  # no temp file left behind


def test_path_pixels_are_drawn(solved):
    p, planner = solved
    rgb = np.array([int(PATH_COLOR[i:i + 2], 16) for i in (1, 3, 5)])
    with_path = figure_to_array(plot(p, planner))
    without = figure_to_array(plot(p))
    assert with_path.dtype == np.uint8 and with_path.ndim == 3 and with_path.shape[2] == 3
    near = lambda img: (np.abs(img.astype(int) - rgb).sum(axis=2) < 40).sum()  # noqa: E731
    assert near(with_path) > near(without) + 200


def test_geometric_world_and_roadmap(tmp_path):
    w = GeometricWorld(50, 30, [Circle(25, 15, 6), Rectangle(5, 20, 15, 25)])
    p = Problem(w, (2, 2), (48, 28), goal_tolerance=1.0)
    planner = PRM(p, seed=1)
    planner.solve(max_iterations=2000)
    assert save_figure(plot(p, planner), tmp_path / "g.svg").read_text().startswith("<?xml")


def test_gif_has_frames_and_failures_leave_nothing(tmp_path, solved):
    p, _ = solved
    frames = [figure_to_array(plot(p, title=f"frame {i}")) for i in range(3)]  # identical frames get merged
    out = save_gif(frames, tmp_path / "a.gif", fps=5)
    with Image.open(out) as img:
        assert img.n_frames == 3

    def broken():
        yield frames[0]
        raise RuntimeError("renderer crashed")

    with pytest.raises(RuntimeError, match="crashed"):
        save_gif(broken(), tmp_path / "b.gif")
    assert sorted(f.name for f in tmp_path.iterdir()) == ["a.gif"]


def test_animate_planner(tmp_path):
    from planners.plotting import animate_planner

    obs = np.zeros((30, 30), bool)
    p = Problem(OccupancyGrid(obs), (2.5, 2.5), (27.5, 27.5), goal_tolerance=2.0)
    out = animate_planner(RRT(p, step_size=3.0, seed=0), tmp_path / "rrt.gif", every=2, fps=4)
    with Image.open(out) as img:
        assert img.n_frames > 4


def test_import_planners_does_not_load_heavy_modules():
    code = ("import sys, planners; heavy = [m for m in ('matplotlib', 'torch', 'gymnasium', 'ompl') "
            "if m in sys.modules]; assert not heavy, heavy")
    subprocess.run([sys.executable, "-c", code], check=True)
