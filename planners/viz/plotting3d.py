"""3-D figures and animations of 6-DoF rigid-body problems (matplotlib, headless).

Imported on demand only. Like ``planners.viz.plotting`` it uses Figures with an Agg canvas, never pyplot,
and writes files atomically. Obstacles are drawn as translucent boxes; the body as the box spanned by
its points in its own frame (exactly the body for ``box_body``), turned and moved to each state, with
its points as dots. On a ``MeshWorld`` the environment and the robot are drawn as their triangles (at
most ``MAX_DRAWN_TRIANGLES`` of the environment and ``MAX_DRAWN_BODY_TRIANGLES`` of the robot, a seeded
choice where a mesh has more).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

from planners.base.fileio import check_int
from planners.base.planner import Planner
from planners.base.problem import Problem
from planners.kernels.space import interpolate
from planners.viz.plotting import (
    GOAL_COLOR,
    OBSTACLE_COLOR,
    PATH_COLOR,
    START_COLOR,
    TREE_COLORS,
    figure_to_array,
    new_figure,
    save_animation,
)
from planners.worlds.mesh import MeshWorld
from planners.worlds.rigid3d import RigidBodyWorld, rotation_matrix

#: Most environment triangles drawn (a seeded subset beyond), so a large scene still draws in seconds.
MAX_DRAWN_TRIANGLES = 6000
#: Most robot triangles drawn per pose.
MAX_DRAWN_BODY_TRIANGLES = 1500

BODY_COLOR = "#4a90d9"
# the six faces of a box, as indices into its corners (corner index = 4 * ix + 2 * iy + iz)
_FACES = ((0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5))


def _require_rigid(problem: Problem) -> RigidBodyWorld | MeshWorld:
    if not isinstance(problem, Problem):
        raise TypeError(f"problem must be a planners.Problem, got {type(problem).__name__}")
    if not isinstance(problem.world, (RigidBodyWorld, MeshWorld)):
        raise TypeError(f"plotting3d draws RigidBodyWorld and MeshWorld problems, got a "
                        f"{type(problem.world).__name__}; use planners.viz.plotting for 2-D worlds")
    return problem.world


def _triangles(vertices: np.ndarray, faces: np.ndarray, most: int) -> np.ndarray:
    """``(k, 3, 3)`` triangles, at most ``most`` of them (a seeded choice where there are more)."""
    if len(faces) > most:
        faces = faces[np.sort(np.random.default_rng(0).choice(len(faces), most, replace=False))]
    return vertices[faces]


def _box_corners(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    return np.array([[(lo, hi)[ix][0], (lo, hi)[iy][1], (lo, hi)[iz][2]]
                     for ix in (0, 1) for iy in (0, 1) for iz in (0, 1)])


def _box_faces(corners: np.ndarray) -> list[np.ndarray]:
    return [corners[list(f)] for f in _FACES]


def body_faces(world: RigidBodyWorld, q) -> list[np.ndarray]:
    """The six faces (4 x 3 arrays) of the body's bounding box (in its own frame) at state ``q``.

    On a ``MeshWorld``: the robot's triangles (3 x 3 arrays) at ``q``.
    """
    q = np.asarray(q, dtype=np.float64)
    if isinstance(world, MeshWorld):
        tris = _triangles(world.body_vertices, world.body_faces, MAX_DRAWN_BODY_TRIANGLES)
        return list(tris @ rotation_matrix(q[3], q[4], q[5]).T + q[:3])
    local = _box_corners(world.body.min(axis=0), world.body.max(axis=0))
    return _box_faces(local @ rotation_matrix(q[3], q[4], q[5]).T + q[:3])


def resample_path(path, problem: Problem, n: int) -> np.ndarray:
    """``n`` states evenly spaced by arc length (problem metric) along ``path``, shorter-arc angles."""
    path = np.asarray(path, dtype=np.float64).reshape(-1, problem.dim)
    if len(path) == 0:
        raise ValueError("path is empty")
    check_int(n, "n")
    if len(path) == 1 or n == 1:
        return np.repeat(path[:1], n, axis=0)
    seg = np.array([problem.distance(a, b) for a, b in zip(path[:-1], path[1:], strict=True)])
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    kind = problem.space[0]
    out = np.empty((n, problem.dim))
    for k, s in enumerate(np.linspace(0.0, cum[-1], n)):
        i = min(int(np.searchsorted(cum, s, side="right")) - 1, len(seg) - 1)
        t = (s - cum[i]) / seg[i] if seg[i] > 0 else 0.0
        interpolate(kind, path[i], path[i + 1], min(max(t, 0.0), 1.0), out[k])
    return out


def _setup_axes(fig: Figure, world: RigidBodyWorld, elev: float, azim: float):
    ax = fig.add_subplot(projection="3d")
    lo, hi = world.low3, world.high3
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(tuple(hi - lo))
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_zlabel("z")
    ax.view_init(elev=elev, azim=azim)
    return ax


def draw_obstacles(ax, world: RigidBodyWorld, alpha: float = 0.25) -> None:
    """The world's boxes as translucent solids (a mesh world's triangles)."""
    if isinstance(world, MeshWorld):
        tris = _triangles(world.env_vertices, world.env_faces, MAX_DRAWN_TRIANGLES)
        ax.add_collection3d(Poly3DCollection(list(tris), facecolors=OBSTACLE_COLOR, edgecolors="none",
                                             alpha=alpha))
        return
    faces = [f for b in world.boxes for f in _box_faces(_box_corners(b[:3], b[3:]))]
    if faces:
        ax.add_collection3d(Poly3DCollection(faces, facecolors=OBSTACLE_COLOR, edgecolors="#202020",
                                             linewidths=0.3, alpha=alpha))


def draw_body(ax, world: RigidBodyWorld, q, color: str = BODY_COLOR, alpha: float = 0.5, points: bool = True):
    """The body at state ``q``; returns ``(faces collection, points artist or None)`` (no points on a mesh world)."""
    mesh = isinstance(world, MeshWorld)
    poly = Poly3DCollection(body_faces(world, q), facecolors=color, edgecolors="none" if mesh else "black",
                            linewidths=0.4, alpha=alpha)
    ax.add_collection3d(poly)
    dots = None
    if points and not mesh:
        p = world.body_points(q)
        dots = ax.plot(p[:, 0], p[:, 1], p[:, 2], ".", color="black", markersize=2)[0]
    return poly, dots


def plot_scene(problem: Problem, path=None, *, ax=None, bodies: int = 6, title: str | None = None,
               size: tuple[float, float] = (6.0, 6.0), dpi: float = 100, elev: float = 25.0,
               azim: float = -60.0) -> Figure:
    """A 3-D figure of the problem: boxes, the body at start (green) and goal (red) and along ``path``.

    Args:
        problem: A ``RigidBodyWorld`` or ``MeshWorld`` problem.
        path: Optional ``(k, 6)`` states; the body origin's track is drawn, and the body at ``bodies``
            states evenly spaced along it (interpolated with shorter-arc angles).
        ax: A 3-D Axes to draw into; default a new Figure.
        bodies: Intermediate bodies drawn along the path.
        title: Axes title; default the problem's name.
        size: Figure size (inches) when a new Figure is made.
        dpi: Its resolution.
        elev: View elevation (degrees).
        azim: View azimuth (degrees).

    Returns:
        The Figure (no pyplot; save it with ``planners.viz.plotting.save_figure``).
    """
    world = _require_rigid(problem)
    if ax is None:
        fig = new_figure(size, dpi, layout=None)
        ax = _setup_axes(fig, world, elev, azim)
    draw_obstacles(ax, world)
    if path is not None:
        path = np.asarray(path, dtype=np.float64).reshape(-1, 6)
        if len(path):
            ax.plot(path[:, 0], path[:, 1], path[:, 2], "-", color=PATH_COLOR, linewidth=2.0)
            if bodies > 0 and len(path) > 1:
                for q in resample_path(path, problem, bodies + 2)[1:-1]:
                    draw_body(ax, world, q, color=PATH_COLOR, alpha=0.15, points=False)
    draw_body(ax, world, problem.start, color=START_COLOR, alpha=0.6)
    draw_body(ax, world, problem.goal, color=GOAL_COLOR, alpha=0.6)
    ax.set_title(problem.name if title is None else title)
    return ax.figure


def animate_rigid(problem: Problem, path, out_path: str | os.PathLike, *, fps: float = 15, frames: int | None = None,
                  size: tuple[float, float] = (5.0, 5.0), dpi: float = 80, elev: float = 25.0,
                  azim: float = -60.0) -> Path:
    """Write an animation of the body moving along ``path`` (``.gif``, or ``.mp4`` with ffmpeg).

    The path is resampled to ``frames`` states evenly spaced by arc length in the problem's metric
    (default: about two seconds per 10 units of path length, between 20 and 150 frames), with
    shorter-arc angle interpolation, so the body never spins the long way round. The final state is
    held for a second.

    Returns:
        The path written.
    """
    world = _require_rigid(problem)
    if Path(out_path).suffix.lower() not in (".gif", ".mp4"):  # before any drawing work
        raise ValueError(f"animations are written as .gif or .mp4 files, got {str(out_path)!r}")
    path = np.asarray(path, dtype=np.float64).reshape(-1, 6)
    if len(path) == 0:
        raise ValueError("path is empty")
    if frames is None:
        frames = int(np.clip(round(0.2 * fps * problem.path_length(path)), 20, 150))
    states = resample_path(path, problem, int(frames))
    fig = new_figure(size, dpi, layout=None)
    ax = _setup_axes(fig, world, elev, azim)
    fig.subplots_adjust(0, 0, 1, 1)
    plot_scene(problem, path, ax=ax, bodies=0, title="")
    poly, dots = draw_body(ax, world, states[0], color=BODY_COLOR, alpha=0.8)
    caption = ax.text2D(0.02, 0.97, "", transform=ax.transAxes, fontsize=9)

    def render() -> Iterator[np.ndarray]:
        for k, q in enumerate(states):
            poly.set_verts(body_faces(world, q))
            if dots is not None:
                p = world.body_points(q)
                dots.set_data_3d(p[:, 0], p[:, 1], p[:, 2])
            caption.set_text(f"{problem.name}  {k + 1}/{len(states)}")
            yield figure_to_array(fig)

    return save_animation(render(), out_path, fps)


class RigidPlannerAnimator:
    """Frames of a planner growing on a rigid-body problem, in one reused Figure (env rendering).

    Tree edges connect body-origin positions; the latest sample is drawn as a ghost body, the path
    (once solved) as a line.
    """

    def __init__(self, problem: Problem, size: tuple[float, float] | None = None, dpi: float = 80) -> None:
        self.world = _require_rigid(problem)
        self.fig = new_figure((5.0, 5.0) if size is None else size, dpi, layout=None)
        self.ax = _setup_axes(self.fig, self.world, 25.0, -60.0)
        self.fig.subplots_adjust(0, 0, 1, 1)
        plot_scene(problem, None, ax=self.ax, title="")
        self.edges = Line3DCollection([], colors=TREE_COLORS[0], linewidths=0.6)
        self.ax.add_collection3d(self.edges, autolim=False)
        self.sample = Poly3DCollection([], facecolors="black", alpha=0.15)
        self.ax.add_collection3d(self.sample, autolim=False)
        self.path = self.ax.plot([], [], [], "-", color=PATH_COLOR, linewidth=2.0)[0]
        self.caption = self.ax.text2D(0.02, 0.97, "", transform=self.ax.transAxes, fontsize=9)

    def frame(self, planner: Planner, sample: np.ndarray | None = None) -> np.ndarray:
        """The planner's current graph (and ``sample``, if given) as a uint8 (H, W, 3) array."""
        data = planner.planner_data()
        V = data.vertices
        e = data.edges
        self.edges.set_segments(np.stack([V[e[:, 0], :3], V[e[:, 1], :3]], axis=1) if len(e) else [])
        self.sample.set_verts(body_faces(self.world, sample) if sample is not None else [])
        r = planner.result()
        self.path.set_data_3d(r.path[:, 0], r.path[:, 1], r.path[:, 2])
        outcome = f", cost {r.cost:.1f}" if r.solved else ""
        self.caption.set_text(f"{planner.name}  iteration {r.iterations}{outcome}")
        return figure_to_array(self.fig)
