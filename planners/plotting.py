"""Figures and animations of maps, trees, roadmaps and paths (matplotlib, headless).

Imported on demand only (``import planners`` never loads matplotlib). Uses the object-oriented API
with an Agg canvas, never pyplot, so it works without a display and in worker processes. Maps are
drawn in world coordinates with y growing downwards, as in images and MovingAI maps.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from collections.abc import Iterable
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.patches import Circle as CirclePatch
from matplotlib.patches import Rectangle as RectPatch

from planners.grid import OccupancyGrid
from planners.planner import Planner, PlannerData, PlanResult
from planners.problem import Problem
from planners.shapes import Circle, GeometricWorld

TREE_COLORS = ("#4a90d9", "#e8a33d")  # start tree, goal tree (RRT-Connect)
PATH_COLOR = "#d62728"


def new_figure(size: tuple[float, float] = (6.0, 6.0), dpi: int = 100) -> Figure:
    """A Figure with an Agg canvas attached (no pyplot, no display needed)."""
    fig = Figure(figsize=size, dpi=dpi)
    FigureCanvasAgg(fig)
    return fig


def draw_world(ax, world) -> None:
    """Draw obstacles of an ``OccupancyGrid`` or ``GeometricWorld``; y grows downwards."""
    if isinstance(world, OccupancyGrid):
        w, h = world.bounds[1]
        ax.imshow(world.obstacles, cmap="gray_r", vmin=0, vmax=1.4, origin="upper", extent=(0, w, h, 0),
                  interpolation="nearest")
    elif isinstance(world, GeometricWorld):
        w, h = world.width, world.height
        ax.add_patch(RectPatch((0, 0), w, h, fill=False, edgecolor="black", linewidth=1.0))
        for ob in world.obstacles:
            if isinstance(ob, Circle):
                ax.add_patch(CirclePatch((ob.x, ob.y), ob.r, color="0.3"))
            else:
                ax.add_patch(RectPatch((ob.x0, ob.y0), ob.x1 - ob.x0, ob.y1 - ob.y0, color="0.3"))
    else:
        raise TypeError(f"cannot draw a {type(world).__name__} in 2-D")
    ax.set_xlim(0, w)
    ax.set_ylim(h, 0)
    ax.set_aspect("equal")


def draw_problem(ax, problem: Problem) -> None:
    """World, start (green), goal (red) and the goal region (dashed)."""
    draw_world(ax, problem.world)
    ax.add_patch(CirclePatch(tuple(problem.goal[:2]), problem.goal_tolerance, fill=False, linestyle="--",
                             edgecolor=PATH_COLOR, linewidth=1.0, zorder=4))
    ax.plot(*problem.start[:2], "o", color="#2ca02c", markersize=7, zorder=5)
    ax.plot(*problem.goal[:2], "*", color=PATH_COLOR, markersize=11, zorder=5)


def graph_segments(data: PlannerData) -> np.ndarray:
    """(m, 2, 2) line segments of a planner graph's edges."""
    V = data.vertices[:, :2]
    return np.stack([V[data.edges[:, 0]], V[data.edges[:, 1]]], axis=1) if len(data.edges) else np.empty((0, 2, 2))


def draw_graph(ax, data: PlannerData, *, linewidth: float = 0.5, show_vertices: bool | None = None) -> list:
    """Tree or roadmap edges as line collections (one colour per tree tag); returns the artists."""
    artists = []
    tags = data.tags[data.edges[:, 1]] if len(data.edges) else np.empty(0, dtype=np.int64)
    seg = graph_segments(data)
    for t in np.unique(tags) if len(tags) else [0]:
        lc = LineCollection(seg[tags == t] if len(tags) else seg, colors=TREE_COLORS[int(t) % 2 if t >= 0 else 0],
                            linewidths=linewidth, zorder=2)
        ax.add_collection(lc)
        artists.append(lc)
    if show_vertices is None:
        show_vertices = len(data.vertices) <= 5000
    if show_vertices and len(data.vertices):
        artists.append(ax.scatter(data.vertices[:, 0], data.vertices[:, 1], s=2, color=TREE_COLORS[0], zorder=3))
    return artists


def draw_path(ax, path, **kw):
    """A solution path as a thick polyline."""
    path = np.asarray(path)
    style = dict(color=PATH_COLOR, linewidth=2.2, zorder=6) | kw
    return ax.plot(path[:, 0], path[:, 1], **style)[0]


def plot(problem: Problem, planner: Planner | None = None, result: PlanResult | None = None, *, ax=None,
         title: str | None = None, show_vertices: bool | None = None) -> Figure:
    """One call that draws the problem, the planner's graph and the solution path."""
    if ax is None:
        fig = new_figure()
        ax = fig.add_subplot(1, 1, 1)
    else:
        fig = ax.figure
    if result is None and planner is not None:
        result = planner.result()
    draw_problem(ax, problem)
    if planner is not None:
        draw_graph(ax, planner.planner_data(), show_vertices=show_vertices)
    if result is not None and result.solved:
        draw_path(ax, result.path)
    if title is None and planner is not None:
        outcome = f"cost {result.cost:.1f}" if result.solved else "not solved"
        title = f"{planner.name}: {result.iterations} iterations, {outcome}"
    if title:
        ax.set_title(title)
    return fig


def _atomic_target(path: str | os.PathLike) -> tuple[Path, Path]:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}-", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    return path, Path(tmp)


def _commit(tmp: Path, path: Path, ok: bool) -> None:
    if ok:
        os.replace(tmp, path)
    else:
        tmp.unlink(missing_ok=True)


def save_figure(fig: Figure, path: str | os.PathLike, dpi: int = 120) -> Path:
    """Write a figure (format from the suffix) atomically: a crash never leaves a partial file."""
    path, tmp = _atomic_target(path)
    ok = False
    try:
        fig.savefig(tmp, dpi=dpi, bbox_inches="tight", format=path.suffix.lstrip(".") or "png")
        ok = True
    finally:
        _commit(tmp, path, ok)
    return path


def figure_to_array(fig: Figure) -> np.ndarray:
    """The rendered figure as a uint8 (H, W, 3) array."""
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3].copy()


def save_gif(frames: Iterable[np.ndarray], path: str | os.PathLike, fps: float = 15) -> Path:
    """Write uint8 (H, W, 3) frames as an animated GIF, atomically."""
    from PIL import Image

    path, tmp = _atomic_target(path)
    ok = False
    try:
        images = [Image.fromarray(np.asarray(f, dtype=np.uint8)) for f in frames]
        if not images:
            raise ValueError("save_gif needs at least one frame")
        images[0].save(tmp, format="GIF", save_all=True, append_images=images[1:], duration=int(1000 / fps), loop=0)
        ok = True
    finally:
        _commit(tmp, path, ok)
    return path


def save_mp4(frames: Iterable[np.ndarray], path: str | os.PathLike, fps: float = 15) -> Path:
    """Write frames as an H.264 MP4 through ffmpeg (raises RuntimeError when ffmpeg is absent)."""
    ffmpeg = shutil.which("ffmpeg")
    if ffmpeg is None:
        raise RuntimeError("ffmpeg not found on PATH; install it or save a GIF instead")
    frames = [np.asarray(f, dtype=np.uint8) for f in frames]
    if not frames:
        raise ValueError("save_mp4 needs at least one frame")
    h, w = frames[0].shape[:2]
    h2, w2 = h - h % 2, w - w % 2  # yuv420p needs even sides
    path, tmp = _atomic_target(path)
    ok = False
    try:
        cmd = [ffmpeg, "-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{w2}x{h2}",
               "-r", str(fps), "-i", "-", "-pix_fmt", "yuv420p", "-vcodec", "libx264", "-f", "mp4", str(tmp)]
        data = b"".join(np.ascontiguousarray(f[:h2, :w2]).tobytes() for f in frames)
        subprocess.run(cmd, input=data, check=True)
        ok = True
    finally:
        _commit(tmp, path, ok)
    return path


class PlannerAnimator:
    """Frames of a planner as it grows: one Figure reused, only the edge collection's segments change."""

    def __init__(self, problem: Problem, size: tuple[float, float] = (5.0, 5.0), dpi: int = 80) -> None:
        self.fig = new_figure(size, dpi)
        self.ax = self.fig.add_axes((0, 0, 1, 1))
        self.ax.set_axis_off()
        draw_problem(self.ax, problem)
        self.edges = [LineCollection([], colors=c, linewidths=0.6, zorder=2) for c in TREE_COLORS]
        for lc in self.edges:
            self.ax.add_collection(lc)
        self.sample = self.ax.plot([], [], "x", color="black", markersize=6, zorder=7)[0]
        self.path = self.ax.plot([], [], color=PATH_COLOR, linewidth=2.2, zorder=6)[0]

    def frame(self, planner: Planner, sample: np.ndarray | None = None) -> np.ndarray:
        data = planner.planner_data()
        seg = graph_segments(data)
        tags = data.tags[data.edges[:, 1]] if len(data.edges) else np.empty(0, dtype=np.int64)
        for t, lc in enumerate(self.edges):
            lc.set_segments(seg[(tags % 2 if len(tags) else tags) == t] if len(seg) else [])
        if sample is not None:
            self.sample.set_data([sample[0]], [sample[1]])
        else:
            self.sample.set_data([], [])
        r = planner.result()
        if r.solved:
            self.path.set_data(r.path[:, 0], r.path[:, 1])
        else:
            self.path.set_data([], [])
        return figure_to_array(self.fig)


def animate_planner(planner: Planner, path: str | os.PathLike, *, every: int = 10, max_frames: int = 150,
                    fps: float = 15, max_iterations: int = 20000) -> Path:
    """Step ``planner`` until solved (or a cap), capturing a frame every ``every`` iterations.

    Writes a GIF, or an MP4 when ``path`` ends in ``.mp4``. The last frame shows the path.
    """
    anim = PlannerAnimator(planner.problem)
    frames = [anim.frame(planner)]
    step = None
    while not planner.solved and planner.iterations < max_iterations:
        step = planner.step()
        if planner.iterations % every == 0:
            if len(frames) >= max_frames:  # keep the animation bounded: sample frames more sparsely
                every *= 2
                frames = frames[::2]
            frames.append(anim.frame(planner, step.sample))
    frames += [anim.frame(planner)] * int(fps)  # hold the final picture for a second
    if str(path).endswith(".mp4"):
        return save_mp4(frames, path, fps)
    return save_gif(frames, path, fps)
