"""Plan on a picture: load an image (or MovingAI / numpy) map, plan, smooth, draw, animate.

The library side of ``scripts/plan.py``. ``plan_on_image`` validates everything (map file, start,
goal, planner options, output locations) before it plans and writes nothing until planning is done;
figures, animations and exported paths are written atomically (``planners.base.fileio``), so a bad input
or a crash never leaves a half-written file, and a failed write raises ``OutputError``. The
animation is replayed from the finished planner: vertex counts recorded while it ran select, frame
by frame, the vertices that existed then (trees and roadmaps store vertices in insertion order), so
recording costs almost nothing and huge trees never slow planning down; edges are subsampled and
frames capped so the file stays small whatever the tree size.

Matplotlib is imported only when a figure or animation is written.
"""

from __future__ import annotations

import json
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from planners.algorithms.smoothing import smooth as smooth_path
from planners.base.fileio import InputError, atomic_path, check_int, refuse_figure_name_for_folder
from planners.base.planner import Planner, PlannerData, PlanResult, compile_seconds
from planners.base.problem import Problem
from planners.base.registry import make_planner, one_step_size, planner_class
from planners.base.samplers import GoalBiasedSampler, Sampler, UniformSampler
from planners.kernels import raster
from planners.worlds.grid import OccupancyGrid

SAMPLERS = ("uniform", "goal-bias")
METRICS = ("euclidean", "manhattan", "chebyshev")
#: Planners the workflow gives a goal-biased sampler by default (the others: uniform).
GOAL_BIASED = ("RRT", "RRTstar")
#: Formats ``export_path`` writes, by suffix.
PATH_FORMATS = (".csv", ".json", ".npy")


class OutputError(OSError):
    """An output file could not be written (the message names it); nothing half-written is left."""

#: Edges drawn at most in the figure and per animation frame (a random, fixed subset beyond that).
MAX_FIGURE_EDGES = 400_000
MAX_FRAME_EDGES = 100_000
#: Above this many edges the figure rasterises the graph (``RASTER_PX`` pixels per side) instead of vector lines.
RASTER_EDGES = 20_000
RASTER_PX = 1200


def load_map(path: str | os.PathLike, threshold: float = 0.5, *, invert: bool = False,
             robot_radius: float = 0.0) -> OccupancyGrid:
    """An ``OccupancyGrid`` from an image, ROS ``map.yaml``, ``.map`` or ``.npy`` file (``OccupancyGrid.from_file``).

    ``robot_radius`` (map units) inflates the obstacles by a disc of that radius; 0 keeps the map.
    """
    if robot_radius:
        return OccupancyGrid.from_file(path, threshold, invert=invert, robot_radius=float(robot_radius))
    return OccupancyGrid.from_file(path, threshold, invert=invert)


def picture_planner(name: str, problem: Problem, *, sampler: str | Sampler | None = None, goal_bias: float = 0.05,
                    step_size: float | None = None, seed: int = 0, step: float | None = None) -> Planner:
    """A registered planner (``planners.base.registry``) with the picture workflow's sampler defaults.

    Args:
        name: A registered planner name (``planner_names()``; ``"rrt-connect"`` works too).
        problem: The problem.
        sampler: ``"uniform"``, ``"goal-bias"``, any ``Sampler`` (a learned ``PolicySampler``, say)
            or None: goal bias for RRT and RRT*, uniform for the others. Informed RRT* and OB-PRM
            bring their own sampler.
        goal_bias: Goal probability of the goal-biased sampler.
        step_size: The planner's step length (RRT family: extension length; PRM family: longest roadmap
            edge); None takes each planner's default.
        seed: Planner seed.
        step: Alias of ``step_size`` (not both).
    """
    cls = planner_class(name)
    step = one_step_size("picture_planner", step_size=step_size, step=step)
    if sampler is not None and not isinstance(sampler, Sampler) and sampler not in SAMPLERS:
        raise ValueError(f"unknown sampler {sampler!r}; choose from {', '.join(SAMPLERS)}")
    if cls.own_sampler:
        if sampler is not None:
            raise ValueError(f"planner {name!r} uses its own sampler; leave the sampler unset")
        if cls.name == "InformedRRTstar" and problem.metric != "euclidean":
            raise ValueError(f"informed-rrtstar needs the euclidean metric, got {problem.metric!r}")
        return make_planner(cls.name, problem, step_size=step, seed=seed)
    if sampler is None:
        sampler = "goal-bias" if cls.name in GOAL_BIASED else "uniform"
    if not isinstance(sampler, Sampler):
        sampler = GoalBiasedSampler(goal_bias) if sampler == "goal-bias" else UniformSampler()
    return make_planner(cls.name, problem, step_size=step, sampler=sampler, seed=seed)


@dataclass
class PlanOutcome:
    """What ``plan_on_image`` returns.

    Attributes:
        problem: The problem planned.
        planner: The planner, in its final state.
        result: Its ``PlanResult``.
        path: The raw path ((0, 2) when unsolved).
        smoothed: The smoothed path, or None (smoothing off or unsolved).
        length: Raw path length in the problem's metric (inf when unsolved).
        smoothed_length: Smoothed path length (None when not smoothed).
        timings: Seconds per phase: ``load``, ``sampler`` (binding the sampler to the query: its per-query work,
            such as a route encoder's pass), ``plan``, ``smooth``, ``figure``, ``gif``.
        files: Files written.
        history: ``(iteration, vertices per tag)`` recorded while planning, for the animation.
    """

    problem: Problem
    planner: Planner
    result: PlanResult
    path: np.ndarray
    smoothed: np.ndarray | None
    length: float
    smoothed_length: float | None
    timings: dict[str, float] = field(default_factory=dict)
    files: list[Path] = field(default_factory=list)
    history: list[tuple[int, tuple[int, ...]]] = field(default_factory=list)


def solve_recording(planner: Planner, max_iterations: int | None, time_limit: float | None, *, frames: int = 60
                    ) -> tuple[PlanResult, list[tuple[int, tuple[int, ...]]]]:
    """``planner.solve(max_iterations, time_limit)`` in pieces, recording the vertex counts after each.

    Pieces are ``1 / (2 * frames)`` of the iterations done (1 to 16384), so however short the run,
    records lie at most ``1 / (2 * frames)`` of it apart and an animation can show ``frames`` growth
    steps (a run of n iterations makes about ``2 * frames * ln(n)`` records, a few thousand at most).
    A planner solved in pieces ends exactly as one solved in one call; the time limit excludes
    one-off compilation, as ``Planner.solve``'s.
    """
    if max_iterations is None and time_limit is None:
        raise ValueError("give max_iterations or time_limit (or both)")
    check_int(frames, "frames")
    history = [(planner.iterations, planner.vertex_counts())]
    t0, c0 = time.perf_counter(), compile_seconds()
    done = 0
    result = planner.result()
    reason = "solved" if planner.solved and not planner.anytime else "max_iterations"
    while reason != "solved":
        piece = int(min(max(1, planner.iterations // (2 * frames)), 16384))
        if max_iterations is not None:
            piece = min(piece, max_iterations - done)
            if piece <= 0:
                reason = "max_iterations"
                break
        left = None if time_limit is None else time_limit - (time.perf_counter() - t0 - (compile_seconds() - c0))
        if left is not None and left <= 0:
            reason = "time_limit"
            break
        before = planner.iterations
        result = planner.solve(max_iterations=piece, time_limit=left)
        done += planner.iterations - before
        history.append((planner.iterations, planner.vertex_counts()))
        if result.stop_reason in ("solved", "time_limit"):
            reason = result.stop_reason
    if result.stop_reason != reason:
        result = PlanResult(**{**result.__dict__, "stop_reason": reason})
    return result, history


def _subsample_edges(data: PlannerData, cap: int, seed: int = 0) -> PlannerData:
    """The same graph with at most ``cap`` edges (a fixed random subset)."""
    if len(data.edges) <= cap:
        return data
    keep = np.sort(np.random.default_rng(seed).choice(len(data.edges), cap, replace=False))
    return PlannerData(data.vertices, data.edges[keep], data.tags)


def _frame_indices(history: list, max_frames: int) -> list[int]:
    """Up to ``max_frames`` history entries, evenly spread in iterations, first and last included."""
    its = np.array([h[0] for h in history], dtype=np.float64)
    targets = np.linspace(its[0], its[-1], max(2, max_frames))
    picks = sorted({int(np.argmin(np.abs(its - t))) for t in targets} | {0, len(history) - 1})
    return picks


def _draw_map(ax, problem: Problem, max_px: int, markers: bool = True) -> None:
    """The world (a big grid pre-reduced to ``max_px`` per side) and, optionally, start, goal and goal region."""
    from planners.viz import plotting

    world = problem.world
    if isinstance(world, OccupancyGrid):
        plotting.draw_grid(ax, world, max_px)
    else:
        plotting.draw_world(ax, world)
    if markers:
        ax.add_patch(plotting.goal_region_patch(problem))
        ax.plot(*problem.start[:2], "o", color=plotting.START_COLOR, markersize=8, markeredgecolor="white", zorder=7)
        ax.plot(*problem.goal[:2], "*", color=plotting.GOAL_COLOR, markersize=13, markeredgecolor="white", zorder=7)


def _rgb(color) -> tuple[int, int, int]:
    from matplotlib.colors import to_rgb

    return tuple(int(round(255 * c)) for c in to_rgb(color))


def _edge_pixels(data: PlannerData, size: tuple[int, int], world) -> tuple[np.ndarray, np.ndarray]:
    """Edge endpoints in pixels of an image of ``size`` (W, H) of the world as shown, and an RGB colour each."""
    from planners.viz import plotting

    edges = np.asarray(data.edges, dtype=np.int64).reshape(-1, 2)
    V = plotting.world_to_pixels(world, np.asarray(data.vertices, dtype=np.float64).reshape(-1,
                                                                                            data.vertices.shape[-1]),
                          size)
    seg = V[edges].reshape(-1, 4)
    palette = np.array([_rgb(c) for c in plotting.TREE_COLORS])
    cols = palette[np.asarray(data.tags, dtype=np.int64)[edges[:, 1]] % len(palette)] if len(edges) else \
        np.zeros((0, 3), np.int64)
    return seg, cols


def _draw_edges(img: np.ndarray, seg: np.ndarray, cols: np.ndarray) -> None:
    """Draw 1-pixel segments into an (H, W, 3 or 4) uint8 array in place (compiled: fast for millions)."""
    raster.draw_segments(img, np.ascontiguousarray(seg, dtype=np.float64), np.ascontiguousarray(cols, dtype=np.uint8))


#: Narrowest plan figure in inches: a tall map's title and legend need the room.
MIN_FIGURE_WIDTH = 5.5


def write_figure(outcome: PlanOutcome, path: str | os.PathLike, *, title: str | None = None) -> Path:
    """The map, the final tree or roadmap, the raw path (thin) and the smoothed one (thick), atomically.

    The map's own walls are dark; on a map inflated by a robot radius (``OccupancyGrid.inflate``) the
    added zone is shaded and the walls are outlined. A legend under the map names the trees, paths,
    start and goal; the title wraps to the figure's width. Graphs of more than ``RASTER_EDGES`` edges
    are rasterised into an image layer (at ``RASTER_PX`` pixels per side) instead of drawn as vector
    lines, which keeps huge trees fast.
    """
    from planners.viz import plotting

    problem = outcome.problem
    world = problem.world
    w, h = plotting.world_extent(world)
    fw, fh = plotting.figure_size(world, 8.0)
    fig = plotting.new_figure((max(fw, MIN_FIGURE_WIDTH), fh + 1.0))  # + room for the legend
    ax = fig.add_subplot()
    data = _subsample_edges(outcome.planner.planner_data(), MAX_FIGURE_EDGES)
    if isinstance(world, OccupancyGrid) and (len(data.edges) > RASTER_EDGES or max(world.shape) > RASTER_PX):
        # one RGB image of map and graph: the cheapest thing for matplotlib to resample
        levels = plotting.display_rows(world, plotting.pool_levels(plotting.map_levels(world), RASTER_PX))
        rep = max(1, RASTER_PX // max(levels.shape))
        big = np.repeat(np.repeat(levels, rep, axis=0), rep, axis=1)
        palette = np.array([_rgb(c) for c in plotting.LEVEL_COLORS], np.uint8)
        rgb = palette[big]
        if len(data.edges) > RASTER_EDGES:
            _draw_edges(rgb, *_edge_pixels(data, (rgb.shape[1], rgb.shape[0]), world))
        else:
            plotting.draw_graph(ax, data)
        ax.imshow(rgb, origin="upper", extent=plotting.image_extent(world), interpolation="auto", zorder=0)
        plotting.draw_wall_outline(ax, world, levels, zorder=2.5)
        ax.add_patch(plotting.goal_region_patch(problem))
        ax.plot(*problem.start[:2], "o", color=plotting.START_COLOR, markersize=8, markeredgecolor="white", zorder=7)
        ax.plot(*problem.goal[:2], "*", color=plotting.GOAL_COLOR, markersize=13, markeredgecolor="white", zorder=7)
    else:
        _draw_map(ax, problem, RASTER_PX)
        if len(data.edges) > RASTER_EDGES:
            scale = RASTER_PX / max(w, h)
            size = (max(1, round(w * scale)), max(1, round(h * scale)))
            layer = np.zeros((size[1], size[0], 4), dtype=np.uint8)
            _draw_edges(layer, *_edge_pixels(data, size, world))
            ax.imshow(layer, origin="upper", extent=plotting.image_extent(world), interpolation="auto",
                      interpolation_stage="rgba", zorder=2)
            plotting.set_world_view(ax, world)
        else:
            plotting.draw_graph(ax, data)
    solved, smoothed = outcome.result.solved, outcome.result.solved and outcome.smoothed is not None
    if smoothed:
        plotting.draw_path(ax, outcome.path, linewidth=1.2, alpha=0.8, color=plotting.RAW_PATH_COLOR)
        plotting.draw_path(ax, outcome.smoothed)
    elif solved:
        plotting.draw_path(ax, outcome.path)
    if title is None:
        r = outcome.result
        if r.solved:
            title = f"{r.planner}: {r.iterations} iterations, length {outcome.length:.1f}"
            if outcome.smoothed_length is not None:
                title += f" (smoothed {outcome.smoothed_length:.1f})"
        else:
            title = f"{r.planner}: not solved after {r.iterations} iterations"
    ax.set_title(plotting.wrap_title(ax, title))
    handles = plotting.map_legend_handles(world, trees=_graph_labels(outcome.planner, data), raw_path=smoothed,
                                          smoothed_path=smoothed, path=solved and not smoothed)
    fig.legend(handles=handles, loc="outside lower center", ncols=min(4, len(handles)), frameon=False, fontsize=8)
    return plotting.save_figure(fig, path, pil_kwargs={"compress_level": 3})


def _graph_labels(planner: Planner, data: PlannerData) -> tuple[str, ...]:
    """Legend labels of the graphs by tag: a roadmap, one tree, or RRT-Connect's start and goal trees."""
    if planner.step_parameter == "max_edge_length":
        return ("roadmap",)
    if len(data.tags) and int(np.max(data.tags)) >= 1:
        return ("start tree", "goal tree")
    return ("tree",)


def _font(size: int):
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1 has only the fixed bitmap font
        return ImageFont.load_default()


def write_animation(outcome: PlanOutcome, path: str | os.PathLike, *, max_frames: int = 60, max_px: int = 480,
                    fps: float = 10, hold_s: float = 2.0) -> Path:
    """A GIF of the tree or roadmap growing, then the final path, written atomically.

    At most ``max_frames`` growth frames (evenly spread in iterations, from the recorded
    ``outcome.history``), at most ``max_px`` pixels per side, at most ``MAX_FRAME_EDGES`` edges
    (a fixed random subset), and the final frame held ``hold_s`` seconds. The map is rendered once;
    each frame only adds the edges that appeared since the previous one.
    """
    from PIL import Image, ImageDraw

    from planners.viz import plotting

    if Path(path).suffix.lower() != ".gif":
        raise ValueError(f"write_animation writes .gif files, got {str(path)!r}")
    check_int(max_frames, "max_frames", low=2)
    check_int(max_px, "max_px", low=32)
    if not fps > 0:
        raise ValueError(f"fps must be positive, got {fps}")
    problem, world = outcome.problem, outcome.problem.world
    w, h = plotting.world_extent(world)
    dpi = 100
    scale = max_px / max(w, h)
    fig = plotting.new_figure((max(0.32, w * scale / dpi), max(0.32, h * scale / dpi)), dpi, layout=None)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_axis_off()
    _draw_map(ax, problem, 2 * max_px, markers=False)
    base = plotting.figure_to_array(fig)
    _draw_map(ax, problem, 2 * max_px, markers=True)
    marked = plotting.figure_to_array(fig)
    on_top = np.any(marked != base, axis=2)  # start, goal and goal region stay above the tree
    H, W = base.shape[:2]

    # when does each edge appear: vertices are stored per tag in insertion order
    data = _subsample_edges(outcome.planner.planner_data(), MAX_FRAME_EDGES)
    history = outcome.history or [(outcome.result.iterations, outcome.planner.vertex_counts())]
    picks = _frame_indices(history, max_frames)
    counts = np.array([list(history[i][1]) for i in picks], dtype=np.int64)  # (frames, tags)
    tags = np.asarray(data.tags, dtype=np.int64)
    first = np.full(len(tags), len(picks) - 1, dtype=np.int64)
    for t in range(counts.shape[1]):
        idx = np.flatnonzero(tags == t)
        first[idx] = np.minimum(np.searchsorted(counts[:, t], np.arange(len(idx)), side="right"), len(picks) - 1)
    edges = np.asarray(data.edges, dtype=np.int64).reshape(-1, 2)
    seg, cols = _edge_pixels(data, (W, H), world)
    appear = np.maximum(first[edges[:, 0]], first[edges[:, 1]]) if len(edges) else np.zeros(0, np.int64)
    order = np.argsort(appear, kind="stable")
    bounds = np.searchsorted(appear[order], np.arange(len(picks) + 1), side="left")

    canvas = base.copy()
    font = _font(max(10, min(16, round(W / 32))))
    name = outcome.result.planner

    band = font.size + 8 if hasattr(font, "size") else 18

    def finish(text: str) -> Image.Image:
        # the caption goes in a band under the map, so it never hides the start or the goal
        arr = np.full((H + band, W, 3), 255, dtype=np.uint8)
        arr[:H] = canvas
        arr[:H][on_top] = marked[on_top]
        img = Image.fromarray(arr)
        ImageDraw.Draw(img).text((4, H + 3), text, fill=(0, 0, 0), font=font)
        return img

    frames = []
    for f, i in enumerate(picks):
        sel = order[bounds[f]:bounds[f + 1]]
        _draw_edges(canvas, seg[sel], cols[sel])
        its, c = history[i]
        frames.append(finish(f"{name}  iteration {its}  vertices {sum(c)}"))
    r = outcome.result
    if r.solved:
        final = outcome.smoothed if outcome.smoothed is not None else outcome.path
        px = plotting.world_to_pixels(world, final, (W, H))
        img = Image.fromarray(canvas)
        ImageDraw.Draw(img).line([tuple(p) for p in px.tolist()], fill=_rgb(plotting.PATH_COLOR),
                                 width=max(2, round(H / 160)), joint="curve")
        canvas = np.asarray(img).copy()
        length = outcome.smoothed_length if outcome.smoothed_length is not None else outcome.length
        frames.append(finish(f"{name}  solved: {r.iterations} iterations, length {length:.1f}"))
    else:
        frames.append(finish(f"{name}  not solved after {r.iterations} iterations"))
    # one palette for all frames (the last shows every colour): quantising is then cheap
    palette = frames[-1].quantize(colors=64, method=Image.Quantize.MEDIANCUT)
    indexed = [f.quantize(palette=palette, dither=Image.Dither.NONE) for f in frames]
    durations = [round(1000 / fps)] * (len(indexed) - 1) + [round(1000 * max(hold_s, 1 / fps))]
    with atomic_path(path) as tmp:
        indexed[0].save(tmp, format="GIF", save_all=True, append_images=indexed[1:], duration=durations, loop=0)
    return Path(path)


def path_units(grid: OccupancyGrid) -> dict:
    """How a path's coordinates on ``grid`` read: units, axis directions, origin and resolution."""
    ros = bool(grid.source) and Path(grid.source).suffix.lower() in (".yaml", ".yml")
    res = float(grid.resolution)
    units = "m" if ros else ("px" if res == 1.0 else f"world units ({res:g} per map pixel)")
    return {"units": units, "frame": "map" if ros else "image",
            "x": "right", "y": "up" if getattr(grid, "y_up", False) else "down",
            "origin": [float(v) for v in grid.bounds[0]], "resolution": res}


def check_path_file(path: str | os.PathLike) -> Path:
    """Refuse a path-export file name whose suffix ``export_path`` cannot write (before any planning)."""
    path = Path(path)
    if path.suffix.lower() not in PATH_FORMATS:
        raise InputError(f"path file {str(path)!r}: unknown format {path.suffix or '(no suffix)'!r}; "
                         f"use {', '.join(PATH_FORMATS)}")
    if path.is_dir():
        raise OutputError(f"cannot write the path to {str(path)!r}: it is a folder")
    check_output_dir(path.parent)
    return path


def check_output_dir(folder: str | os.PathLike) -> Path:
    """Raise ``OutputError`` now if files cannot be written into ``folder`` (created later if missing).

    A folder still to be made under a figure's name is an ``InputError`` (``refuse_figure_name_for_folder``).
    """
    folder = Path(folder)
    refuse_figure_name_for_folder(folder, "output folder")
    probe = folder
    while not probe.exists():  # the nearest existing ancestor is the one that must be a writable folder
        if probe.parent == probe:
            break
        probe = probe.parent
    if probe.exists() and not probe.is_dir():
        raise OutputError(f"cannot write into {str(folder)!r}: {str(probe)!r} is a file, not a folder")
    if probe.exists() and not os.access(probe, os.W_OK | os.X_OK):
        raise OutputError(f"cannot write into {str(folder)!r}: {str(probe)!r} is not writable")
    return folder


def export_path(path: np.ndarray, dest: str | os.PathLike, grid: OccupancyGrid, **meta) -> Path:
    """Write a (k, 2) path atomically: ``.csv`` (header ``x,y``), ``.json`` (with units and frame) or ``.npy``.

    Args:
        path: The states, in the map's world coordinates.
        dest: Target file; the suffix chooses the format.
        grid: The map, for the units and frame recorded in JSON.
        **meta: More JSON fields (planner, seed, length, ...).

    Raises:
        InputError: Unknown suffix.
        OutputError: The file cannot be written.
    """
    dest = check_path_file(dest)
    path = np.asarray(path, dtype=np.float64)[:, :2]
    suffix = dest.suffix.lower()
    try:
        with atomic_path(dest) as tmp:
            if suffix == ".npy":
                np.save(tmp, path, allow_pickle=False)
            elif suffix == ".csv":
                rows = "".join(f"{x!r},{y!r}\n" for x, y in path.tolist())
                tmp.write_text("x,y\n" + rows, encoding="utf-8")
            else:
                doc = {**path_units(grid), "map": grid.source, **meta, "path": path.tolist()}
                tmp.write_text(json.dumps(doc) + "\n", encoding="utf-8")
    except OSError as exc:
        raise OutputError(f"cannot write the path to {str(dest)!r}: {exc.strerror or exc}") from None
    return dest


def _write(what: str, dest: Path, writer):
    """Run a writer; an OS error becomes an ``OutputError`` naming the file."""
    try:
        return writer()
    except OSError as exc:
        raise OutputError(f"cannot write the {what} {str(dest)!r}: {exc.strerror or exc}") from None


def plan_on_image(map_source: str | os.PathLike | OccupancyGrid, start, goal, *, planner: str = "rrt-connect",
                  sampler: str | None = None, goal_bias: float = 0.05, metric: str = "euclidean",
                  step_size: float | None = None, tolerance: float | None = None,
                  max_iterations: int | None = 2_000_000, time_limit: float | None = None, seed: int = 0,
                  smooth: bool = True, threshold: float = 0.5, invert: bool = False,
                  out_dir: str | os.PathLike | None = None, gif: bool = True, max_frames: int = 60, gif_px: int = 480,
                  save_path: str | os.PathLike | None = None, step: float | None = None) -> PlanOutcome:
    """Plan from ``start`` to ``goal`` on a picture map; optionally write ``plan.png``, ``plan.gif``, the path.

    Coordinates are the map's world coordinates: for pictures, pixels with ``x`` to the right and
    ``y`` downwards, as image viewers show them (a pixel's centre is ``(col + 0.5, row + 0.5)``); for
    maps with a resolution and origin (ROS ``map.yaml``), those units and that frame.

    Args:
        map_source: An image, ``.map`` or ``.npy`` file (see ``load_map``), or a ready grid.
        start: ``(x, y)`` start.
        goal: ``(x, y)`` goal.
        planner: A registered planner name (``planners.planner_names()``; ``"rrt-connect"`` works too).
        sampler: One of ``SAMPLERS``, a ``Sampler``, or None (see ``picture_planner``).
        goal_bias: Goal probability of the goal-biased sampler.
        metric: One of ``METRICS``: path length, nearest neighbours and the goal region use it.
        step_size: Step size; None takes the planner's default. ``step`` is an alias (not both).
        tolerance: Goal radius; None is 1% of the map diagonal (at least one pixel).
        max_iterations: Iteration budget (None: only the time limit).
        time_limit: Seconds of planning (None: only the iteration budget).
        seed: Planner seed (and smoothing seed).
        smooth: Shortcut and simplify the path.
        threshold: Gray level in (0, 1) below which a pixel is an obstacle.
        invert: Light pixels are obstacles instead.
        out_dir: Where ``plan.png`` (and ``plan.gif``) go; None writes nothing.
        gif: Write the animation too.
        max_frames: Growth frames in the animation (fewer only if the run has fewer iterations).
        gif_px: Longest side of the animation in pixels.
        save_path: Where to export the final path (smoothed if smoothing is on): ``.csv``,
            ``.json`` or ``.npy`` (``export_path``); None exports nothing. Unsolved: nothing written.
        step: The same as ``step_size`` (give one of them).

    Raises:
        FileNotFoundError, ValueError: Bad map file, start, goal or option; nothing has been written.
        OutputError: An output cannot be written: raised before planning where the location is
            plainly unusable (a file where a folder must be, no write permission), else when the
            write fails; the files already written are listed in the message, none is half-written.
    """
    if metric not in METRICS:
        raise ValueError(f"unknown metric {metric!r}; choose from {', '.join(METRICS)}")
    step_size = one_step_size("plan_on_image", step_size=step_size, step=step)
    if max_iterations is None and time_limit is None:
        raise ValueError("give max_iterations or time_limit (or both)")
    if max_iterations is not None:
        check_int(max_iterations, "max_iterations")
    if time_limit is not None and not (math.isfinite(float(time_limit)) and float(time_limit) > 0):
        raise ValueError(f"time_limit must be a positive number of seconds, got {time_limit!r}")
    check_int(max_frames, "max_frames", low=2)
    if save_path is not None:
        check_path_file(save_path)
    if out_dir is not None:
        check_output_dir(out_dir)
    t0 = time.perf_counter()
    grid = map_source if isinstance(map_source, OccupancyGrid) else load_map(map_source, threshold, invert=invert)
    t_load = time.perf_counter() - t0
    if tolerance is None:
        w, h = grid.bounds[1] - grid.bounds[0]
        tolerance = max(grid.resolution, 0.01 * float(np.hypot(w, h)))
    where = f" on {grid.source}" if grid.source else ""
    for label, q in (("start", start), ("goal", goal)):
        try:
            q = np.asarray(q, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"{label} must be two numbers x y, got {q!r}") from None
        if q.shape != (2,):
            raise ValueError(f"{label} must be two numbers x y, got {q.tolist()!r}")
        why = grid.explain_invalid(q)
        if why:
            raise ValueError(f"{label} ({q[0]:g}, {q[1]:g}){where} is not a free position: it {why}")
    problem = Problem(grid, start, goal, goal_tolerance=tolerance, metric=metric,
                      name=Path(grid.source).name if grid.source else "map")
    t0 = time.perf_counter()  # binding the sampler is its per-query work (a route encoder's pass): timed apart
    p = picture_planner(planner, problem, sampler=sampler, goal_bias=goal_bias, step_size=step_size, seed=seed)
    t_sampler = time.perf_counter() - t0
    t0 = time.perf_counter()
    result, history = solve_recording(p, max_iterations, time_limit, frames=max_frames)
    t_plan = time.perf_counter() - t0
    path = np.asarray(result.path)
    length = problem.path_length(path) if result.solved else float("inf")
    smoothed, smoothed_length = None, None
    t0 = time.perf_counter()
    if smooth and result.solved and len(path) > 2:
        smoothed = smooth_path(path, problem, seed=seed)
        smoothed_length = problem.path_length(smoothed)
    elif smooth and result.solved:
        smoothed, smoothed_length = path.copy(), length
    t_smooth = time.perf_counter() - t0
    outcome = PlanOutcome(problem, p, result, path, smoothed, length, smoothed_length,
                          {"load": t_load, "sampler": t_sampler, "plan": t_plan, "smooth": t_smooth, "figure": 0.0,
                           "gif": 0.0},
                          [], history)
    try:
        if save_path is not None and result.solved:
            final = smoothed if smoothed is not None else path
            outcome.files.append(export_path(final, save_path, grid, planner=result.planner, seed=seed,
                                             length=problem.path_length(final), metric=metric,
                                             smoothed=smoothed is not None))
        if out_dir is not None:
            out = Path(out_dir)
            t0 = time.perf_counter()
            fig = out / "plan.png"
            outcome.files.append(_write("figure", fig, lambda: write_figure(outcome, fig)))
            outcome.timings["figure"] = time.perf_counter() - t0
            if gif:
                t0 = time.perf_counter()
                anim = out / "plan.gif"
                outcome.files.append(_write("animation", anim, lambda: write_animation(
                    outcome, anim, max_frames=max_frames, max_px=gif_px)))
                outcome.timings["gif"] = time.perf_counter() - t0
    except OutputError as exc:
        done = "; written: " + ", ".join(map(str, outcome.files)) if outcome.files else "; nothing was written"
        raise OutputError(f"{exc}{done}") from None
    return outcome
