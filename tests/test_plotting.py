"""Figures and animations: headless, y downwards, pixels where the path is, atomic writes."""

from __future__ import annotations

import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from matplotlib.collections import LineCollection, PathCollection
from matplotlib.colors import to_rgba, to_rgba_array
from matplotlib.contour import ContourSet
from PIL import Image

from planners import (
    PRM,
    RRT,
    Circle,
    GeometricWorld,
    OccupancyGrid,
    PlannerData,
    Problem,
    Rectangle,
    RRTConnect,
)
from planners.viz import plotting
from planners.viz.plotting import (
    PATH_COLOR,
    TREE_COLORS,
    animate_planner,
    draw_graph,
    figure_to_array,
    new_figure,
    plot,
    save_figure,
    save_gif,
    save_mp4,
)


def _rgb(color: str) -> np.ndarray:
    return np.array(to_rgba(color)[:3]) * 255


def _near(img: np.ndarray, color: str, tol: float = 45) -> np.ndarray:
    """Mask of pixels within ``tol`` (sum of channel differences) of ``color``."""
    return np.abs(img.astype(float) - _rgb(color)).sum(axis=-1) < tol


def _pixel(fig, img: np.ndarray, world, x: float, y: float) -> np.ndarray:
    """The pixel showing world point (x, y), located from the axes box and the world size, y pointing down."""
    box = fig.axes[0].get_window_extent()
    w, h = world.bounds[1]
    return img[int(img.shape[0] - box.y1 + y / h * box.height), int(box.x0 + x / w * box.width)]


@pytest.fixture(scope="module")
def grid_problem() -> Problem:
    obs = np.zeros((40, 40), bool)
    obs[8:40, 18:22] = True  # a wall open at the top: the path must climb
    obs[2:8, 2:10] = True  # top-left block: tells up from down
    return Problem(OccupancyGrid(obs), (5.5, 30.5), (35.5, 30.5), goal_tolerance=1.5)


@pytest.fixture(scope="module")
def rrt(grid_problem):
    planner = RRT(grid_problem, step_size=3.0, seed=0)
    assert planner.solve(max_iterations=20000).solved
    return planner


@pytest.fixture(scope="module")
def connect(grid_problem):
    planner = RRTConnect(grid_problem, step_size=3.0, seed=0)
    assert planner.solve(max_iterations=20000).solved
    return planner


@pytest.fixture
def fake_ffmpeg(tmp_path, monkeypatch):
    """An 'ffmpeg' on PATH that copies stdin to its output file (or fails when asked to)."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    script = bin_dir / "ffmpeg"
    script.write_text(
        f"#!{sys.executable}\n"
        "import os, sys\n"
        "if os.environ.get('FAKE_FFMPEG_FAIL'):\n"
        "    sys.exit('boom: no encoder')\n"
        "args = sys.argv[1:]\n"
        "data = sys.stdin.buffer.read()\n"
        "open(args[-1], 'wb').write(args[args.index('-s') + 1].encode() + b'|' + data)\n"
    )
    script.chmod(0o755)
    monkeypatch.setenv("PATH", str(bin_dir))
    return tmp_path / "out"


def test_plot_and_save_png(rrt, grid_problem, tmp_path):
    fig = plot(grid_problem, rrt)
    r = rrt.result()
    assert fig.axes[0].get_title() == f"RRT: {r.iterations} iterations, cost {r.cost:.1f}"
    out = save_figure(fig, tmp_path / "sub" / "fig.png", dpi=50)
    with Image.open(out) as img:
        assert img.format == "PNG"
        assert img.size == tuple(np.round(fig.get_size_inches() * 50).astype(int))
    assert [f.name for f in out.parent.iterdir()] == ["fig.png"]  # no temporary file left behind


@pytest.mark.parametrize("suffix, magic", [(".pdf", b"%PDF"), (".svg", b"<?xml")])
def test_save_vector_formats(grid_problem, tmp_path, suffix, magic):
    out = save_figure(plot(grid_problem), tmp_path / f"fig{suffix}")
    assert out.read_bytes().startswith(magic)


def test_unsolved_title_and_result_without_planner(grid_problem, rrt):
    planner = RRT(grid_problem, step_size=3.0, seed=0)
    planner.solve(max_iterations=2)
    assert plot(grid_problem, planner).axes[0].get_title() == "RRT: 2 iterations, not solved"
    r = rrt.result()
    assert plot(grid_problem, result=r).axes[0].get_title().startswith(f"RRT: {r.iterations} iterations, cost")


def test_path_pixels_are_drawn_where_the_path_is(rrt, grid_problem):
    fig = plot(grid_problem, rrt)
    img = figure_to_array(fig)
    w, h = fig.canvas.get_width_height()
    assert img.dtype == np.uint8 and img.shape == (h, w, 3)
    path = rrt.result().path
    seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
    s = np.concatenate([[0], np.cumsum(seg)])
    # points along the path, away from the start and goal markers drawn on top of it
    probes = [(np.interp(t, s, path[:, 0]), np.interp(t, s, path[:, 1])) for t in np.linspace(0.15, 0.85, 25) * s[-1]]
    on_path = [_near(_pixel(fig, img, grid_problem.world, x, y), PATH_COLOR) for x, y in probes]
    assert np.mean(on_path) > 0.9
    fig0 = plot(grid_problem)  # same picture without a planner: those pixels are not path-coloured
    img0 = figure_to_array(fig0)
    assert not any(_near(_pixel(fig0, img0, grid_problem.world, x, y), PATH_COLOR) for x, y in probes)


def test_y_grows_downwards_for_both_world_types():
    obs = np.zeros((40, 40), bool)
    obs[2:8, 2:10] = True
    geo = GeometricWorld(40, 30, [Circle(6, 5, 3), Rectangle(30, 25, 38, 28)])
    for world, (x, y) in ((OccupancyGrid(obs), (6, 5)), (geo, (6, 5))):
        ax = new_figure().add_subplot()
        plotting.draw_world(ax, world)
        fig = ax.figure
        img = figure_to_array(fig)
        w, h = world.bounds[1]
        assert ax.yaxis_inverted() and ax.get_xlim() == (0, w) and ax.get_ylim() == (h, 0)
        assert _near(_pixel(fig, img, world, x, y), plotting.OBSTACLE_COLOR)  # obstacle near the top is dark
        assert _near(_pixel(fig, img, world, x, h - y), "white")  # its mirror image is free
        assert img[: img.shape[0] // 2].mean() < img[img.shape[0] // 2 :].mean()  # more ink in the top half


def test_tree_edges_and_tags(connect, rrt):
    for planner, expected_tags in ((rrt, {0}), (connect, {0, 1})):
        data = planner.planner_data()
        ax = new_figure().add_subplot()
        lc = draw_graph(ax, data)
        segments = lc.get_segments()
        assert isinstance(lc, LineCollection) and len(segments) == len(data.edges)
        a, b = data.edges[-1]
        np.testing.assert_allclose(segments[-1], data.vertices[[a, b]])
        colors = lc.get_colors()
        tags = data.tags[data.edges[:, 1]]
        assert set(tags.tolist()) == expected_tags
        for t in expected_tags:  # one colour per tree
            np.testing.assert_allclose(colors[tags == t], np.tile(to_rgba(TREE_COLORS[t]), ((tags == t).sum(), 1)))


def test_roadmap_vertices_hidden_when_many():
    rng = np.random.default_rng(0)
    big = PlannerData(rng.uniform(1, 39, (6000, 2)), rng.integers(0, 6000, (9000, 2)), np.zeros(6000, np.int64))
    ax = new_figure().add_subplot()
    assert len(draw_graph(ax, big, color="black").get_segments()) == 9000
    assert not [c for c in ax.collections if isinstance(c, PathCollection)]
    np.testing.assert_allclose(ax.collections[0].get_colors(), to_rgba_array("black"))
    draw_graph(ax, big, show_vertices=True)
    dots = [c for c in ax.collections if isinstance(c, PathCollection)]
    assert len(dots) == 1 and len(dots[0].get_offsets()) == 6000
    small = PlannerData(big.vertices[:10], np.array([[0, 1], [1, 2]]), np.zeros(10, np.int64))
    ax = new_figure().add_subplot()
    draw_graph(ax, small)
    assert [len(c.get_offsets()) for c in ax.collections if isinstance(c, PathCollection)] == [10]


def test_prm_on_geometric_world(tmp_path):
    world = GeometricWorld(50, 30, [Circle(25, 15, 6), Rectangle(5, 20, 15, 25), Rectangle(35, 0, 38, 12)])
    p = Problem(world, (2, 2), (48, 28), goal_tolerance=1.0)  # the compiled metric (others: test_planners.py)
    planner = PRM(p, seed=1)
    planner.solve(max_iterations=2000)
    fig = plot(p, planner)
    w, h = fig.canvas.get_width_height()
    assert w > h  # the figure follows the world's shape
    with Image.open(save_figure(fig, tmp_path / "prm.png", dpi=40)) as img:
        assert img.size == (w * 40 // 100, h * 40 // 100)


def test_rendering_in_threads_matches_serial(grid_problem, rrt):
    serial = figure_to_array(plot(grid_problem, rrt))
    with ThreadPoolExecutor(2) as pool:
        images = list(pool.map(lambda _: figure_to_array(plot(grid_problem, rrt)), range(2)))
    for img in images:
        np.testing.assert_array_equal(img, serial)


def _frames(n: int) -> list[np.ndarray]:
    return [np.full((20, 30, 3), 40 * i, np.uint8) for i in range(n)]


def test_save_gif_writes_frames(tmp_path):
    out = save_gif(iter(_frames(3)), tmp_path / "a.gif", fps=5)
    with Image.open(out) as img:
        assert img.n_frames == 3 and img.size == (30, 20) and img.info["duration"] == 200
    assert [f.name for f in tmp_path.iterdir()] == ["a.gif"]


def test_failed_writes_leave_old_file_and_no_debris(tmp_path, grid_problem):
    target = save_gif(_frames(2), tmp_path / "a.gif")
    before = target.read_bytes()

    def broken():
        yield from _frames(2)
        raise RuntimeError("renderer crashed")

    with pytest.raises(RuntimeError, match="crashed"):
        save_gif(broken(), target)
    with pytest.raises(RuntimeError, match="crashed"):
        save_gif(broken(), tmp_path / "b.gif")
    with pytest.raises(ValueError, match="uint8"):
        save_gif([np.zeros((20, 30, 3))], tmp_path / "c.gif")
    with pytest.raises(ValueError, match="no frames"):
        save_gif([], tmp_path / "d.gif")

    fig = plot(grid_problem)

    def half_written(fname, **kw):
        with open(fname, "wb") as f:
            f.write(b"\x89PNG half")
        raise OSError("disk full")

    fig.savefig = half_written
    with pytest.raises(OSError, match="disk full"):
        save_figure(fig, tmp_path / "fig.png")
    assert target.read_bytes() == before
    assert [f.name for f in tmp_path.iterdir()] == ["a.gif"]


def test_save_mp4_needs_ffmpeg(tmp_path, monkeypatch):
    monkeypatch.setenv("PATH", str(tmp_path / "nowhere"))
    with pytest.raises(RuntimeError, match="ffmpeg"):
        save_mp4(_frames(2), tmp_path / "a.mp4")
    assert not list(tmp_path.iterdir())


def test_save_mp4_pipes_frames_to_ffmpeg(fake_ffmpeg, monkeypatch):
    frames = _frames(4)
    out = save_mp4(frames, fake_ffmpeg / "a.mp4", fps=10)
    assert out.read_bytes() == b"30x20|" + b"".join(f.tobytes() for f in frames)
    monkeypatch.setenv("FAKE_FFMPEG_FAIL", "1")
    with pytest.raises(RuntimeError, match="boom: no encoder"):
        save_mp4(frames * 50, fake_ffmpeg / "b.mp4")
    assert [f.name for f in fake_ffmpeg.iterdir()] == ["a.mp4"]


@pytest.mark.skipif(plotting.shutil.which("ffmpeg") is None, reason="ffmpeg not installed")
def test_save_mp4_with_real_ffmpeg(tmp_path):
    frames = [np.full((21, 31, 3), 50 * i, np.uint8) for i in range(5)]
    out = save_mp4(frames, tmp_path / "odd.mp4")  # odd sides are padded for yuv420p
    assert out.stat().st_size > 0 and out.read_bytes()[4:8] == b"ftyp"


def test_animate_planner_reuses_one_figure(grid_problem, tmp_path, monkeypatch):
    made = []
    monkeypatch.setattr(plotting, "new_figure", lambda *a, **k: made.append(1) or new_figure(*a, **k))
    planner = RRT(grid_problem, step_size=3.0, seed=0)
    planner.solve(max_iterations=10)  # a partly run planner continues from where it is
    out = animate_planner(planner, tmp_path / "rrt.gif", every=10, max_frames=500, fps=4)
    assert planner.solved and made == [1]
    with Image.open(out) as img:
        assert img.size == (400, 400) and img.n_frames > 4
        first = np.asarray(img.convert("RGB"))
        img.seek(img.n_frames - 1)
        last = np.asarray(img.convert("RGB"))
        assert img.info["duration"] >= 1000  # the final picture is held
    assert _near(last, PATH_COLOR, 60).sum() > 100 and not _near(first, PATH_COLOR, 60).any()


def test_animate_planner_frame_cap_and_mp4(grid_problem, fake_ffmpeg):
    planner = RRT(grid_problem, step_size=3.0, seed=0)
    out = animate_planner(planner, fake_ffmpeg / "rrt.mp4", every=1, max_frames=3, fps=4, dpi=20)
    assert planner.iterations == 2 and not planner.solved
    size, data = out.read_bytes().split(b"|", 1)
    frames = np.frombuffer(data, np.uint8).reshape(-1, 100, 100, 3)
    assert size == b"100x100" and len(frames) == 3 + 4  # the last frame is held for a second
    assert (frames[0] != frames[1]).any() and (frames[2:] == frames[2]).all()
    with pytest.raises(ValueError, match=".gif or .mp4"):
        animate_planner(planner, fake_ffmpeg / "rrt.avi")


def test_import_planners_does_not_load_matplotlib():
    code = "import sys, planners; loaded = {'matplotlib', 'PIL'} & set(sys.modules); assert not loaded, loaded"
    subprocess.run([sys.executable, "-c", code], check=True)


def _ros_like_grid() -> OccupancyGrid:
    """40 x 60 cells of 0.05 m from (-1, -2), y up; a block in the lowest rows, on the left."""
    obs = np.zeros((40, 60), bool)
    obs[0:8, 0:10] = True  # row 0 is the lowest y
    try:
        return OccupancyGrid(obs, 0.05, origin=(-1.0, -2.0), y_up=True)
    except TypeError:
        pytest.skip("OccupancyGrid(origin=..., y_up=...) is not in this tree yet (planners/worlds/grid.py)")


def test_a_grid_is_drawn_over_its_true_extent_with_y_up():
    grid = _ros_like_grid()
    ax = new_figure().add_subplot()
    plotting.draw_world(ax, grid)
    fig = ax.figure
    img = figure_to_array(fig)
    assert not ax.yaxis_inverted()
    np.testing.assert_allclose([*ax.get_xlim(), *ax.get_ylim()], [-1.0, 2.0, -2.0, 0.0])

    def at(x, y):  # the rendered pixel under world point (x, y), through the axes' own transform
        dx, dy = ax.transData.transform((x, y))
        return img[int(img.shape[0] - dy), int(dx)]

    assert _near(at(-0.8, -1.9), plotting.OBSTACLE_COLOR)  # the block, low left
    assert _near(at(-0.8, -0.1), "white")  # its mirror image is free
    assert img[img.shape[0] // 2:].mean() < img[: img.shape[0] // 2].mean()  # more ink in the bottom half
    np.testing.assert_allclose(plotting.world_to_pixels(grid, [[-1.0, -2.0], [2.0, 0.0]], (300, 200)),
                               [[0, 200], [300, 0]])


def test_plan_on_image_draws_a_y_up_map_the_right_way_up(tmp_path):
    from planners.tools.workflow import plan_on_image

    grid = _ros_like_grid()
    out = plan_on_image(grid, (-0.2, -1.8), (1.8, -0.2), planner="rrt-connect", seed=0, out_dir=tmp_path,
                        max_frames=5)
    assert out.result.solved
    with Image.open(tmp_path / "plan.gif") as im:
        frame = np.asarray(im.convert("RGB"))
    H = round(frame.shape[1] * 40 / 60)  # the map part, above the caption band
    dark = frame[:H].mean(axis=2) < 100
    assert dark[H - 5, 5] and not dark[5, 5]  # the block is at the bottom left, as in RViz


def test_gif_path_pixels_follow_the_resolution(tmp_path):
    from planners.tools.workflow import plan_on_image

    obs = np.zeros((30, 50), bool)
    obs[:, 24:26] = True
    obs[12:18, 24:26] = False
    grid = OccupancyGrid(obs, 2.0)  # 100 x 60 world units
    out = plan_on_image(grid, (5.0, 10.0), (95.0, 50.0), planner="rrt-connect", seed=0, smooth=False,
                        out_dir=tmp_path, gif_px=200, max_frames=3)
    with Image.open(tmp_path / "plan.gif") as im:
        im.seek(im.n_frames - 1)
        frame = np.asarray(im.convert("RGB")).astype(int)
    path = out.path
    s = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    probes = [(np.interp(t, s, path[:, 0]), np.interp(t, s, path[:, 1])) for t in np.linspace(0.2, 0.8, 15) * s[-1]]
    pink = np.array(to_rgba(PATH_COLOR)[:3]) * 255
    # 2 GIF pixels per world unit; the 2-pixel line is looked for in the 3 x 3 pixels around each probe
    hits = [(np.abs(frame[r - 1:r + 2, c - 1:c + 2] - pink).max(axis=2) < 60).any()
            for r, c in ((int(y * 2), int(x * 2)) for x, y in probes)]
    assert np.mean(hits) > 0.9



def test_save_animation_holds_the_last_frame_and_refuses_other_suffixes(tmp_path):
    frames = [np.full((8, 8, 3), v, dtype=np.uint8) for v in (0, 120, 240)]
    out = plotting.save_animation(iter(frames), tmp_path / "a.gif", fps=10, hold_s=1.0)
    with Image.open(out) as im:
        durations = []
        for i in range(im.n_frames):
            im.seek(i)
            durations.append(im.info["duration"])
    assert durations == [100, 100, 1100]  # identical trailing frames merge into one long frame
    with pytest.raises(ValueError, match=r"\.gif or \.mp4"):
        plotting.save_animation(frames, tmp_path / "a.png")
    assert not (tmp_path / "a.png").exists()


def _figure_texts(fig):
    """Every text in the figure: titles, tick labels, legend entries."""
    from matplotlib.text import Text

    return [t.get_text() for t in fig.findobj(Text)]


def test_inflated_map_shows_its_own_walls_outlined_and_the_zone_shaded():
    obs = np.zeros((40, 60), bool)
    obs[18:22, 28:32] = True  # a pillar
    grid = OccupancyGrid(obs).inflate(4.0)
    levels = plotting.map_levels(grid)
    assert np.array_equal(levels == 2, obs)  # the walls are the map's own
    assert np.array_equal(levels >= 1, grid.obstacles) and (levels == 1).sum() > 0  # the zone is the rest
    ax = new_figure((6, 4)).add_subplot()
    plotting.draw_world(ax, grid)
    img = figure_to_array(ax.figure)

    def at(x, y):
        dx, dy = ax.transData.transform((x, y))
        return img[int(img.shape[0] - dy), int(dx)]

    assert _near(at(30.0, 20.0), plotting.OBSTACLE_COLOR)  # inside the pillar
    assert _near(at(30.0, 15.5), plotting.INFLATED_COLOR)  # inside the zone, above it
    assert _near(at(10.0, 30.0), "white")  # free (the zone also lines the map's edge, 4 cells deep)
    assert any(isinstance(c, ContourSet) for c in ax.collections), "no outline drawn around the walls"
    # a map without a robot radius: obstacles as before, no zone, no outline
    plain = OccupancyGrid(obs)
    assert plotting.map_levels(plain).max() == 2 and not (plotting.map_levels(plain) == 1).any()
    ax = new_figure((6, 4)).add_subplot()
    plotting.draw_world(ax, plain)
    assert not any(isinstance(c, ContourSet) for c in ax.collections)


def test_plan_figure_has_a_legend_and_a_title_that_fits_a_tall_map(tmp_path, monkeypatch):
    from planners.tools.workflow import load_map, plan_on_image, write_figure

    obs = np.zeros((420, 60), bool)  # tall and narrow
    obs[200:204, 0:45] = True
    img = tmp_path / "tall.png"
    Image.fromarray(np.where(obs, 0, 255).astype(np.uint8)).save(img)
    grid = load_map(img, robot_radius=2.0)
    out = plan_on_image(grid, (10.5, 10.5), (10.5, 400.5), planner="rrt-connect", seed=0, gif=False)
    assert out.result.solved
    title = ("RRTConnect: a deliberately long title naming the planner, iterations, length and smoothed length "
             "that is wider than a narrow figure")
    captured = {}
    real_save = plotting.save_figure

    def keep(fig, path, **kw):
        captured["fig"] = fig
        return real_save(fig, path, **kw)

    monkeypatch.setattr(plotting, "save_figure", keep)
    write_figure(out, tmp_path / "plan.png", title=title)
    fig = captured["fig"]
    texts = _figure_texts(fig)
    for label in ("start tree", "goal tree", "raw path", "smoothed path", "start", "goal", "walls (the map's own)",
                  "robot radius zone (2)"):
        assert label in texts, f"legend misses {label!r}: {texts}"
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    ax = fig.axes[0]
    box = ax.title.get_window_extent(renderer)
    assert box.x0 >= 0 and box.x1 <= fig.bbox.width and box.y1 <= fig.bbox.height  # the whole title shows
    assert "\n" in ax.get_title()


def test_rows_in_messages_are_the_map_images_rows(tmp_path):
    """A ROS map's rows are flipped on loading; a message names the row of the image the user opens."""
    from planners.tools.workflow import plan_on_image

    grid = _ros_like_grid()
    r, c = np.argwhere(grid.obstacles)[0]
    q = grid.cell_center(r, c)
    image_row = grid.height - 1 - r
    with pytest.raises(ValueError, match=rf"start .* blocked cell \(row {image_row}, col {c} of the map image"):
        plan_on_image(grid, q, (1.8, -0.2))
    assert grid.image_row(r) == image_row and OccupancyGrid(grid.obstacles).image_row(r) == r
