"""Figures and animations of maps, trees, roadmaps and paths (matplotlib, headless).

Imported on demand only (``import planners`` never loads matplotlib). Uses the object-oriented API
with an Agg canvas, never pyplot, so it works without a display, in threads and in worker processes.
Worlds are drawn in world coordinates over their true extent (a grid's origin and resolution), y
growing downwards as in images and MovingAI maps, or upwards for grids with ``y_up`` (ROS maps).
Every file is written atomically (``planners.base.fileio.atomic_path``): rendered to a hidden temporary
file beside the target, then moved into place, so an exception or a crash never leaves a
half-written file.
"""

from __future__ import annotations

import itertools
import os
import shutil
import subprocess
from collections.abc import Iterable, Iterator
from contextlib import suppress
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.colors import ListedColormap, to_rgba_array
from matplotlib.figure import Figure
from matplotlib.patches import Circle as CirclePatch
from matplotlib.patches import Polygon
from matplotlib.patches import Rectangle as RectanglePatch

from planners.base.fileio import atomic_path, check_int
from planners.base.planner import Planner, PlannerData, PlanResult
from planners.base.problem import Problem
from planners.worlds.grid import OccupancyGrid
from planners.worlds.shapes import Circle, GeometricWorld

OBSTACLE_COLOR = "#3a3a3a"
#: The zone an inflated map (``OccupancyGrid.inflate``, a robot radius) adds around the map's own walls.
INFLATED_COLOR = "#c8c2d6"
#: The outline drawn around the map's own walls on inflated maps.
WALL_OUTLINE_COLOR = "#000000"
#: Cell colours of ``map_levels``: free, inflated zone, wall.
LEVEL_COLORS = ("white", INFLATED_COLOR, OBSTACLE_COLOR)
START_COLOR = "#2ca02c"
GOAL_COLOR = "#d62728"
PATH_COLOR = "#e6007e"
#: The raw (unsmoothed) path, drawn thin under the smoothed one.
RAW_PATH_COLOR = "#7a0045"
#: Edge and vertex colours by ``PlannerData.tags``: start tree (and roadmaps), goal tree.
TREE_COLORS = ("#4a90d9", "#f29e38")
#: Above this many vertices ``draw_graph`` leaves out the vertex dots unless asked for them.
MAX_VERTEX_DOTS = 5000


def new_figure(size: tuple[float, float] = (6.0, 6.0), dpi: float = 100, layout: str | None = "constrained") -> Figure:
    """A Figure with an Agg canvas attached (no pyplot, no display needed)."""
    fig = Figure(figsize=size, dpi=dpi, layout=layout)
    FigureCanvasAgg(fig)
    return fig


def world_extent(world) -> tuple[float, float]:
    """Width and height of the world in world units."""
    x0, x1, y0, y1 = world_box(world)
    return x1 - x0, y1 - y0


def world_box(world) -> tuple[float, float, float, float]:
    """``(x0, x1, y0, y1)``: the world's bounds (a grid's origin to origin + size * resolution)."""
    if not isinstance(world, (OccupancyGrid, GeometricWorld)):
        raise TypeError(f"cannot draw a {type(world).__name__}: expected an OccupancyGrid or GeometricWorld")
    lo, hi = world.bounds
    return float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])


def y_up(world) -> bool:
    """True if the world is shown with y growing upwards (grids flagged ``y_up``, as ROS maps)."""
    return bool(getattr(world, "y_up", False))


def image_extent(world) -> tuple[float, float, float, float]:
    """``imshow`` extent of an image whose row 0 is drawn at the top of the world's view.

    Use with ``origin="upper"`` and an image from ``display_rows``.
    """
    x0, x1, y0, y1 = world_box(world)
    return (x0, x1, y0, y1) if y_up(world) else (x0, x1, y1, y0)


def display_rows(world, image: np.ndarray) -> np.ndarray:
    """Rows of a per-cell image (row index growing with y) reordered top to bottom as shown."""
    return image[::-1] if y_up(world) else image


def world_to_pixels(world, points, size: tuple[int, int]) -> np.ndarray:
    """(k, 2) world points as pixel coordinates of a (W, H) = ``size`` image of the world as shown."""
    x0, x1, y0, y1 = world_box(world)
    pts = np.asarray(points, dtype=np.float64)[:, :2]
    px = (pts[:, 0] - x0) * (size[0] / (x1 - x0))
    py = ((y1 - pts[:, 1]) if y_up(world) else (pts[:, 1] - y0)) * (size[1] / (y1 - y0))
    return np.stack([px, py], axis=1)


def set_world_view(ax, world) -> None:
    """Fit the axes to the world: equal aspect, y downwards (images) or upwards (``y_up``)."""
    x0, x1, y0, y1 = world_box(world)
    ax.set_xlim(x0, x1)
    ax.set_ylim((y0, y1) if y_up(world) else (y1, y0))
    ax.set_aspect("equal")


def map_levels(world: OccupancyGrid) -> np.ndarray:
    """Per cell (rows as stored): 0 free, 1 inflated zone (blocked only by a robot radius), 2 the map's own wall."""
    levels = world.obstacles.astype(np.uint8)
    levels[world.walls] = 2
    return levels


def pool_levels(levels: np.ndarray, max_px: int) -> np.ndarray:
    """``levels`` reduced to at most ``max_px`` per side by max-pooling (walls win, so thin walls survive)."""
    f = max(1, -(-max(levels.shape) // max_px))
    if f == 1:
        return levels
    H, W = levels.shape
    pad = np.zeros((-(-H // f) * f, -(-W // f) * f), dtype=levels.dtype)
    pad[:H, :W] = levels
    return pad.reshape(pad.shape[0] // f, f, pad.shape[1] // f, f).max(axis=(1, 3))


def draw_grid(ax, world: OccupancyGrid, max_px: int | None = None, *, zorder: float = 0) -> np.ndarray:
    """Draw a grid's walls (dark), inflated zone (shaded) and, on inflated maps, the walls' outline.

    Args:
        ax: Target axes (fitted to the world, see ``set_world_view``).
        world: The grid.
        max_px: Reduce the map to at most this many cells per side first (max-pooling); None: full size.
        zorder: Of the map image; the outline goes just above it.

    Returns:
        The drawn levels (rows as shown), for callers that paint into an image of their own.
    """
    levels = display_rows(world, map_levels(world) if max_px is None else pool_levels(map_levels(world), max_px))
    # rgba-stage antialiasing keeps one-cell walls visible (grey) when a big map is shrunk
    ax.imshow(levels, cmap=ListedColormap(LEVEL_COLORS), vmin=0, vmax=2, origin="upper", extent=image_extent(world),
              interpolation="auto", interpolation_stage="rgba", zorder=zorder)
    draw_wall_outline(ax, world, levels, zorder=zorder + 0.5)
    set_world_view(ax, world)
    return levels


def draw_wall_outline(ax, world: OccupancyGrid, levels: np.ndarray, *, zorder: float = 0.5) -> None:
    """Outline the map's own walls (``levels == 2``, rows as shown) where the map is inflated; else nothing."""
    if not (levels == 1).any():
        return
    x0, x1, bottom, top = image_extent(world)
    h, w = levels.shape
    # cell centres of the shown image: row 0 at the extent's top (origin="upper")
    dx, dy = (x1 - x0) / w, (bottom - top) / h
    xs = x0 + (np.arange(w) + 0.5) * dx
    ys = top + (np.arange(h) + 0.5) * dy
    walls = np.pad(levels == 2, 1).astype(np.float32)  # closed contours at the map's edge
    xs = np.concatenate([[xs[0] - dx], xs, [xs[-1] + dx]])
    ys = np.concatenate([[ys[0] - dy], ys, [ys[-1] + dy]])
    ax.contour(xs, ys, walls, levels=[0.5], colors=WALL_OUTLINE_COLOR, linewidths=0.7, zorder=zorder)
    set_world_view(ax, world)


def map_legend_handles(world, *, trees: tuple[str, ...] = (), raw_path: bool = False, smoothed_path: bool = False,
                       path: bool = False) -> list:
    """Legend entries for a plan figure: walls (and inflated zone), each tree, the paths, start and goal.

    Args:
        world: The world drawn (an inflated grid adds the inflated zone).
        trees: Labels of the graphs drawn, in ``TREE_COLORS`` order (e.g. ``("start tree", "goal tree")``).
        raw_path: The raw path is drawn thin beside a smoothed one.
        smoothed_path: The smoothed path is drawn.
        path: One path is drawn (unsmoothed).
    """
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    inflated = isinstance(world, OccupancyGrid) and world.inflation > 0
    handles = [Patch(facecolor=OBSTACLE_COLOR, edgecolor=WALL_OUTLINE_COLOR if inflated else "none",
                     label="walls (the map's own)" if inflated else "obstacles")]
    if inflated:
        handles.append(Patch(facecolor=INFLATED_COLOR, label=f"robot radius zone ({world.inflation:g})"))
    handles += [Line2D([], [], color=c, linewidth=1.5, label=t) for t, c in zip(trees, TREE_COLORS, strict=False)]
    if raw_path:
        handles.append(Line2D([], [], color=RAW_PATH_COLOR, linewidth=1.2, label="raw path"))
    if smoothed_path:
        handles.append(Line2D([], [], color=PATH_COLOR, linewidth=2.8, label="smoothed path"))
    if path:
        handles.append(Line2D([], [], color=PATH_COLOR, linewidth=2.8, label="path"))
    handles += [Line2D([], [], marker="o", linestyle="none", color=START_COLOR, markersize=8, label="start"),
                Line2D([], [], marker="*", linestyle="none", color=GOAL_COLOR, markersize=12, label="goal"),
                Line2D([], [], color=GOAL_COLOR, linestyle="--", linewidth=1.2, label="goal region")]
    return handles


def wrap_title(ax, title: str, fontsize: float | None = None) -> str:
    """``title`` broken into lines that fit the figure's width (so a narrow, tall map's title is not cut)."""
    import textwrap

    from matplotlib import rcParams
    from matplotlib.font_manager import FontProperties

    size = fontsize or FontProperties(size=rcParams["axes.titlesize"]).get_size_in_points()
    chars = max(12, int(ax.figure.get_figwidth() * 72 / (0.6 * size)))
    return "\n".join(textwrap.fill(line, chars) for line in title.splitlines())


def draw_world(ax, world: OccupancyGrid | GeometricWorld) -> None:
    """Draw a world's obstacles (dark) on white and fit the axes to it (see ``set_world_view``).

    Inflated grids show the map's own walls dark and outlined, the robot-radius zone shaded (``draw_grid``).
    """
    world_box(world)
    if isinstance(world, OccupancyGrid):
        draw_grid(ax, world)
    else:
        ax.set_facecolor("white")
        for ob in world.obstacles:
            if isinstance(ob, Circle):
                ax.add_patch(CirclePatch((ob.x, ob.y), ob.r, facecolor=OBSTACLE_COLOR, edgecolor="none", zorder=0))
            else:
                ax.add_patch(RectanglePatch((ob.x0, ob.y0), ob.x1 - ob.x0, ob.y1 - ob.y0, facecolor=OBSTACLE_COLOR,
                                            edgecolor="none", zorder=0))
    set_world_view(ax, world)


def goal_region_patch(problem: Problem):
    """The goal region's outline: the ball of radius goal_tolerance in the problem's metric."""
    (gx, gy), r = problem.goal[:2], problem.goal_tolerance
    style = dict(fill=False, linestyle="--", edgecolor=GOAL_COLOR, linewidth=1.2, zorder=4)
    if problem.metric == "chebyshev":
        return RectanglePatch((gx - r, gy - r), 2 * r, 2 * r, **style)
    if problem.metric == "manhattan":
        return Polygon([(gx + r, gy), (gx, gy + r), (gx - r, gy), (gx, gy - r)], closed=True, **style)
    return CirclePatch((gx, gy), r, **style)


def draw_problem(ax, problem: Problem) -> None:
    """The world, the start (green dot), the goal (red star) and the goal region (dashed)."""
    draw_world(ax, problem.world)
    ax.add_patch(goal_region_patch(problem))
    ax.plot(*problem.start[:2], "o", color=START_COLOR, markersize=8, markeredgecolor="white", zorder=7)
    ax.plot(*problem.goal[:2], "*", color=GOAL_COLOR, markersize=13, markeredgecolor="white", zorder=7)


def _tag_colors(tags: np.ndarray) -> np.ndarray:
    return to_rgba_array(TREE_COLORS)[np.asarray(tags, dtype=np.int64) % len(TREE_COLORS)]


def _edges(data: PlannerData) -> tuple[np.ndarray, np.ndarray]:
    """(m, 2, 2) edge segments and their (m, 4) colours (by the tag of each edge's second vertex)."""
    edges = np.asarray(data.edges, dtype=np.int64).reshape(-1, 2)
    segments = np.asarray(data.vertices, dtype=np.float64)[:, :2][edges]
    return segments, _tag_colors(np.asarray(data.tags)[edges[:, 1]])


def draw_graph(ax, data: PlannerData, *, color=None, linewidth: float | None = None,
               show_vertices: bool | None = None) -> LineCollection:
    """Draw a tree or roadmap: edges as one ``LineCollection``, vertices as optional dots.

    Args:
        ax: Target axes.
        data: ``Planner.planner_data()``; tag 0 (start tree, roadmaps) and tag 1 (RRT-Connect's goal
            tree) get the two ``TREE_COLORS``.
        color: One colour for everything instead of the colours by tag.
        linewidth: Edge width in points; None thins the lines of big graphs so their shape shows.
        show_vertices: Draw vertex dots; None draws them up to ``MAX_VERTEX_DOTS`` vertices.

    Returns:
        The edges' ``LineCollection``.
    """
    segments, colors = _edges(data)
    if linewidth is None:
        linewidth = float(np.clip(0.6 * np.sqrt(5000 / max(len(segments), 1)), 0.2, 0.6))
    lc = LineCollection(segments, colors=colors if color is None else color, linewidths=linewidth, zorder=2)
    ax.add_collection(lc)
    if show_vertices is None:
        show_vertices = len(data.vertices) <= MAX_VERTEX_DOTS
    if show_vertices and len(data.vertices):
        dots = dict(c=_tag_colors(data.tags)) if color is None else dict(color=color)
        ax.scatter(data.vertices[:, 0], data.vertices[:, 1], s=max(1.5, 8 * linewidth), linewidths=0, zorder=3, **dots)
    ax.autoscale_view()  # a no-op after draw_world, which fixes the view to the world
    return lc


def draw_path(ax, path, **kw):
    """A path as a thick polyline; ``kw`` overrides the ``Line2D`` style. Returns the line."""
    path = np.asarray(path, dtype=np.float64)
    if path.ndim != 2 or path.shape[1] < 2:
        raise ValueError(f"path must have shape (k, 2) or (k, dim), got {path.shape}")
    style = dict(color=PATH_COLOR, linewidth=2.8, solid_capstyle="round", solid_joinstyle="round", zorder=6) | kw
    return ax.plot(path[:, 0], path[:, 1], **style)[0]


def figure_size(world, longer: float = 6.0) -> tuple[float, float]:
    """Figure size in inches for ``world``: ``longer`` inches on its longer side, its aspect kept."""
    w, h = world_extent(world)
    return (longer, max(2.0, longer * h / w)) if w >= h else (max(2.0, longer * w / h), longer)


def plot(problem: Problem, planner: Planner | None = None, result: PlanResult | None = None, *, ax=None,
         title: str | None = None, show_vertices: bool | None = None) -> Figure:
    """Draw a problem with a planner's tree or roadmap and a solution path in one call.

    Args:
        problem: The problem (world, start, goal region).
        planner: Any planner; its ``planner_data()`` is drawn.
        result: The result whose path is drawn; defaults to ``planner.result()``.
        ax: Axes to draw into; None makes a new Figure (Agg canvas) sized to the world.
        title: Axes title; None gives "<planner>: <n> iterations, cost <c>" (or "not solved") when
            there is a planner or result, "" gives none.
        show_vertices: As in ``draw_graph``.

    Returns:
        The Figure drawn into.
    """
    if ax is None:
        ax = new_figure(figure_size(problem.world)).add_subplot()
    if result is None and planner is not None:
        result = planner.result()
    draw_problem(ax, problem)
    if planner is not None:
        draw_graph(ax, planner.planner_data(), show_vertices=show_vertices)
    if result is not None and result.solved:
        draw_path(ax, result.path)
    if title is None and result is not None:
        outcome = f"cost {result.cost:.1f}" if result.solved else "not solved"
        title = f"{planner.name if planner is not None else result.planner}: {result.iterations} iterations, {outcome}"
    if title:
        ax.set_title(title)
    return ax.figure


def save_figure(fig: Figure, path: str | os.PathLike, dpi: float = 150, **savefig_kw) -> Path:
    """Write a figure atomically; the format comes from the suffix (png, pdf, svg, ...).

    The image is ``fig.get_size_inches() * dpi`` pixels unless ``savefig_kw`` says otherwise
    (e.g. ``bbox_inches="tight"``). Returns the path written.
    """
    path = Path(path)
    fmt = path.suffix.lstrip(".").lower() or "png"
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format=fmt, **savefig_kw)
    return path


def figure_to_array(fig: Figure) -> np.ndarray:
    """Render a figure to a new uint8 (H, W, 3) RGB array."""
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3].copy()


def _checked_frames(frames: Iterable[np.ndarray]) -> Iterator[np.ndarray]:
    """The frames as C-contiguous uint8 (H, W, 3) arrays, all of the first frame's shape."""
    shape = None
    for i, f in enumerate(frames):
        f = np.asarray(f)
        if f.dtype != np.uint8 or f.ndim != 3 or f.shape[2] != 3:
            raise ValueError(f"frame {i} must be a uint8 (H, W, 3) array, got {f.dtype} {f.shape}")
        if shape is None:
            shape = f.shape
        elif f.shape != shape:
            raise ValueError(f"frame {i} has shape {f.shape}, the first frame {shape}")
        yield np.ascontiguousarray(f)
    if shape is None:
        raise ValueError("no frames to write")


def save_gif(frames: Iterable[np.ndarray], path: str | os.PathLike, fps: float = 10, loop: int = 0) -> Path:
    """Write uint8 (H, W, 3) frames as an animated GIF, atomically.

    Frames are consumed lazily (any iterable); identical consecutive frames merge into one longer
    frame. ``loop=0`` repeats forever. Returns the path written.
    """
    from PIL import Image

    if not fps > 0:
        raise ValueError(f"fps must be positive, got {fps}")
    images = (Image.fromarray(f) for f in _checked_frames(frames))
    with atomic_path(path) as tmp:
        first = next(images)
        first.save(tmp, format="GIF", save_all=True, append_images=images, duration=round(1000 / fps), loop=loop)
    return Path(path)


def save_mp4(frames: Iterable[np.ndarray], path: str | os.PathLike, fps: float = 15) -> Path:
    """Write uint8 (H, W, 3) frames as an H.264 MP4 by piping them to ffmpeg, atomically.

    Raises:
        RuntimeError: ffmpeg is not on PATH, or it failed.
    """
    ffmpeg = shutil.which("ffmpeg")
    if ffmpeg is None:
        raise RuntimeError("save_mp4 needs the ffmpeg executable on PATH (e.g. apt install ffmpeg); "
                           "save_gif needs nothing extra")
    if not fps > 0:
        raise ValueError(f"fps must be positive, got {fps}")
    it = _checked_frames(frames)
    first = next(it)
    h, w = first.shape[:2]
    with atomic_path(path) as tmp:
        # yuv420p (what players expect) needs even sides: pad by a pixel where needed
        cmd = [ffmpeg, "-hide_banner", "-loglevel", "error", "-y", "-f", "rawvideo", "-pix_fmt", "rgb24",
               "-s", f"{w}x{h}", "-framerate", f"{fps:g}", "-i", "-", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2",
               "-c:v", "libx264", "-pix_fmt", "yuv420p", "-f", "mp4", str(tmp)]
        proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        try:
            for f in itertools.chain([first], it):
                proc.stdin.write(f.tobytes())
        except BrokenPipeError:
            pass  # ffmpeg quit early; its exit status and stderr below say why
        except BaseException:
            proc.kill()  # a frame raised: stop ffmpeg, then the partial file is removed
            raise
        finally:
            with suppress(BrokenPipeError):  # unflushed frames are lost anyway if ffmpeg is gone
                proc.stdin.close()
            err = proc.stderr.read().decode(errors="replace").strip()
            proc.stderr.close()
            proc.wait()
        if proc.returncode != 0:
            raise RuntimeError(f"ffmpeg failed (exit {proc.returncode}): {err}")
    return Path(path)


def save_animation(frames: Iterable[np.ndarray], path: str | os.PathLike, fps: float = 15, *,
                   hold_s: float = 1.0) -> Path:
    """Write frames as ``.gif`` (Pillow) or ``.mp4`` (ffmpeg), by suffix, holding the last one ``hold_s`` seconds.

    The one writer behind every animation (``animate_planner``, ``plotting3d.animate_rigid``,
    ``envs.record_episode``). Frames are consumed lazily. Returns the path written.
    """
    suffix = Path(path).suffix.lower()
    if suffix not in (".gif", ".mp4"):
        raise ValueError(f"animations are written as .gif or .mp4 files, got {str(path)!r}")
    if not fps > 0:
        raise ValueError(f"fps must be positive, got {fps}")

    def held() -> Iterator[np.ndarray]:
        last = None
        for last in frames:
            yield last
        if last is not None:
            for _ in range(max(1, round(fps * hold_s))):
                yield last

    return (save_mp4 if suffix == ".mp4" else save_gif)(held(), path, fps)


def planner_animator(problem: Problem, size: tuple[float, float] | None = None, dpi: float = 80):
    """The frame renderer for ``problem``: ``PlannerAnimator`` (2-D) or ``plotting3d.RigidPlannerAnimator`` (6-DoF)."""
    if problem.dim == 6:
        from planners.viz.plotting3d import RigidPlannerAnimator

        return RigidPlannerAnimator(problem, size, dpi)
    if problem.dim != 2:
        raise ValueError(f"animations are drawn for 2-D and 6-DoF problems, got a {problem.dim}-D one")
    return PlannerAnimator(problem, size, dpi)


class PlannerAnimator:
    """Renders frames of a growing planner into one reused Figure.

    The problem is drawn once; each frame only replaces the edge collection's segments and colours,
    the last sample's marker, the path and a caption.

    Args:
        problem: The problem the planner solves.
        size: Figure size in inches.
        dpi: Pixels per inch of the frames.
    """

    def __init__(self, problem: Problem, size: tuple[float, float] | None = None, dpi: float = 80) -> None:
        self.fig = new_figure(size or figure_size(problem.world, 5.0), dpi, layout=None)
        self.ax = self.fig.add_axes((0, 0, 1, 1))
        self.ax.set_axis_off()
        draw_problem(self.ax, problem)
        self.edges = LineCollection([], linewidths=0.7, zorder=2)
        self.ax.add_collection(self.edges, autolim=False)
        self.sample = self.ax.plot([], [], "x", color="black", markersize=7, markeredgewidth=1.5, zorder=8)[0]
        self.path = draw_path(self.ax, np.empty((0, 2)))
        self.caption = self.ax.text(0.01, 0.99, "", transform=self.ax.transAxes, va="top", ha="left", fontsize=10,
                                    bbox=dict(facecolor="white", alpha=0.8, edgecolor="none"), zorder=9)

    def frame(self, planner: Planner, sample: np.ndarray | None = None) -> np.ndarray:
        """The planner's current graph (and ``sample``, if given) as a uint8 (H, W, 3) array."""
        segments, colors = _edges(planner.planner_data())
        self.edges.set_segments(segments)
        self.edges.set_color(colors)
        self.sample.set_data(([sample[0]], [sample[1]]) if sample is not None else ([], []))
        r = planner.result()
        self.path.set_data(r.path[:, 0], r.path[:, 1])  # empty until solved
        outcome = f", cost {r.cost:.1f}" if r.solved else ""
        self.caption.set_text(f"{planner.name}  iteration {r.iterations}{outcome}")
        return figure_to_array(self.fig)


def animate_planner(planner: Planner, path: str | os.PathLike, *, every: int = 10, max_frames: int = 200,
                    fps: float = 15, size: tuple[float, float] | None = None, dpi: float = 80) -> Path:
    """Step a planner, capturing a frame every ``every`` iterations, and write the animation.

    Starts from the planner's current state (fresh or partly run) and stops once it is solved or
    ``max_frames`` frames are captured (at most ``every * (max_frames - 1)`` iterations). Each frame
    marks the latest sample; the final frame, with the path if one was found, is held for a second.

    Args:
        planner: The planner to run; it is advanced in place.
        path: Output file: ``.gif`` (Pillow) or ``.mp4`` (needs ffmpeg).
        every: Iterations between frames.
        max_frames: Cap on captured frames, hence on iterations.
        fps: Frames per second.
        size: Figure size in inches; None fits the world in 5 inches.
        dpi: Pixels per inch of the frames.

    Returns:
        The path written.
    """
    if Path(path).suffix.lower() not in (".gif", ".mp4"):  # before any planning work
        raise ValueError(f"animations are written as .gif or .mp4 files, got {str(path)!r}")
    check_int(every, "every")
    check_int(max_frames, "max_frames")
    anim = planner_animator(planner.problem, size, dpi)

    def frames() -> Iterator[np.ndarray]:
        # a generator: frames are rendered as the writer consumes them, never all held as RGB
        frame = anim.frame(planner)
        yield frame
        for _ in range(max_frames - 1):
            if planner.solved:
                break
            for _ in range(every):
                step = planner.step()
                if step.solved:
                    break
            frame = anim.frame(planner, None if step.solved else step.sample)
            yield frame

    return save_animation(frames(), path, fps)
