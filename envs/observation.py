"""Observations of a planning episode: what an agent sees of the map, the tree, start and goal.

An observation builder has ``space``, ``reset(problem, max_iterations, guide)`` (once per query),
``update(planner)`` (after every iteration) and ``build(planner)`` (the observation). ``guide`` is
the episode's ``planners.guidance.GuidedSampling`` when the env makes one (egocentric observations,
guided actions), else None. ``make_observation`` builds one by kind from ``OBSERVATIONS``: to add
an observation type, write its class here and add it to that table; ``SamplerEnv(observation=...)``
and ``EnvSampler`` then accept it.

Building an observation must not dominate a step, so everything static (obstacle views, start and
goal marks) is computed once per map in ``reset`` and the tree channels are updated incrementally
from the vertices added since the last step.
"""

from __future__ import annotations

import math

import numpy as np
from gymnasium import spaces

from planners import OccupancyGrid, Planner, Problem
from planners.base.fileio import InputError, check_int
from planners.guidance import EGO_VECTOR, SCALES, WINDOW, GuidedSampling

CHANNELS = ("obstacles", "tree", "start", "goal")
VECTOR_FEATURES = (
    "start_x", "start_y", "goal_x", "goal_y", "anchor_x", "anchor_y", "to_goal_x", "to_goal_y",
    "anchor_distance", "iteration_fraction", "tree_size",
)
#: What a bidirectional planner's (RRT-Connect's) observation adds: the goal tree's channel, and the
#: goal tree's anchor (its vertex nearest the start), its distance to the start over the map diagonal,
#: and whose turn it is (+1: the next sample extends the goal tree; -1: the start tree).
GOAL_TREE_CHANNEL = "goal_tree"
TWO_TREE_FEATURES = ("goal_anchor_x", "goal_anchor_y", "goal_anchor_distance", "turn")


class _GoalTreeAnchor:
    """The goal tree's vertex nearest the start, kept up to date from the vertices added since the last call."""

    def __init__(self, problem: Problem) -> None:
        self.problem = problem
        self.seen = 0
        self.state = np.asarray(problem.goal, dtype=np.float64)
        self.distance = problem.distance(problem.goal, problem.start)

    def update(self, view) -> np.ndarray:
        """The goal tree's states added since the last call (none where the view has no goal tree)."""
        tree = view.goal_tree
        n = 0 if tree is None else len(tree)
        if n <= self.seen:
            return np.empty((0, self.problem.dim))
        new = tree[self.seen:n]
        for q in new:
            d = self.problem.distance(q, self.problem.start)
            if d < self.distance:
                self.state, self.distance = np.array(q, dtype=np.float64), d
        self.seen = n
        return new


class GridObservation:
    """Dict observation for 2-D occupancy-grid problems.

    * ``image``: ``(4, size, size)`` uint8, the whole map resampled to a square (maps of any size or
      aspect; outside the map counts as obstacle): obstacle area fraction (so a one-cell door in a
      wall still shows as a lighter pixel), tree vertices, start, goal (discs of the goal radius).
    * ``local``: ``(4, local_size, local_size)`` uint8, the same channels at native resolution
      (``local_scale`` cells per pixel) in a window centred on the tree vertex nearest the goal, so
      narrow corridors survive on maps of any size.
    * ``vector``: ``(11,)`` float32 in [-1, 1]: start, goal and anchor vertex (map coordinates scaled to
      [-1, 1]), goal minus anchor over the map diagonal, anchor-goal distance over the diagonal,
      iteration fraction, log tree size over log of the iteration cap.

    ``two_trees=True`` (a bidirectional planner: RRT-Connect): both images get a fifth channel, the goal
    tree's vertices (``tree`` is the start tree's), the local window is centred on the anchor of the tree the
    next sample extends (the goal tree's anchor is its vertex nearest the start), and ``vector`` gets four
    more features (``TWO_TREE_FEATURES``): the goal tree's anchor, its distance to the start over the
    diagonal, and whose turn it is (+1 the goal tree's, -1 the start tree's).
    """

    def __init__(self, size: int = 64, local_size: int = 48, local_scale: int = 1, two_trees: bool = False) -> None:
        for label, v in (("obs_size", size), ("local_size", local_size), ("local_scale", local_scale)):
            check_int(v, label)
        if local_size % 2:
            raise InputError(f"local_size must be even, got {local_size}")
        self.size, self.local_size, self.local_scale = int(size), int(local_size), int(local_scale)
        self.two_trees = bool(two_trees)
        self.channels = CHANNELS + ((GOAL_TREE_CHANNEL,) if self.two_trees else ())
        self.features = VECTOR_FEATURES + (TWO_TREE_FEATURES if self.two_trees else ())

    @property
    def space(self) -> spaces.Dict:
        S, L, C = self.size, self.local_size, len(self.channels)
        return spaces.Dict({
            "image": spaces.Box(0, 255, (C, S, S), np.uint8),
            "local": spaces.Box(0, 255, (C, L, L), np.uint8),
            "vector": spaces.Box(-1.0, 1.0, (len(self.features),), np.float32),
        })

    def reset(self, problem: Problem, max_iterations: int, guide: GuidedSampling | None = None) -> None:
        grid = problem.world
        if not isinstance(grid, OccupancyGrid):
            raise TypeError("GridObservation needs an OccupancyGrid problem; use VectorObservation otherwise")
        self.problem = problem
        self.max_iterations = max_iterations
        H, W = grid.shape
        self.res = grid.resolution
        self.low, self.high = (np.asarray(b, dtype=np.float64) for b in grid.bounds)
        self.diag = float(np.linalg.norm(self.high - self.low))
        # global view: pad to a square of `side` cells, `cells_per_px` cells per pixel
        S = self.size
        side = max(H, W)
        self.cells_per_px = side / S
        obs = np.ones((side, side), dtype=np.float64)
        obs[:H, :W] = grid.obstacles
        self.image = np.zeros((len(self.channels), S, S), dtype=np.uint8)
        self.image[0] = np.round(255 * _area_fraction(obs, S)).astype(np.uint8)
        tol_px = problem.goal_tolerance / (self.res * self.cells_per_px)
        self.image[2] = _disc((S, S), self._px(problem.start), max(tol_px, 0.75))
        self.image[3] = _disc((S, S), self._px(problem.goal), max(tol_px, 0.75))
        # local view: full-resolution channels padded by half a window (and one pixel) of obstacle
        L, s = self.local_size, self.local_scale
        self.pad = L * s // 2 + s
        p = self.pad
        self.full = np.zeros((len(self.channels), H + 2 * p, W + 2 * p), dtype=np.uint8)
        self.full[0] = 255
        self.full[0, p:p + H, p:p + W] = np.where(grid.obstacles, 255, 0)
        tol_cells = problem.goal_tolerance / self.res
        self.full[2, p:p + H, p:p + W] = _disc((H, W), self._cells(problem.start), max(tol_cells, 0.75))
        self.full[3, p:p + H, p:p + W] = _disc((H, W), self._cells(problem.goal), max(tol_cells, 0.75))
        self.seen = 0
        self.goal_anchor = _GoalTreeAnchor(problem) if self.two_trees else None

    def _cells(self, q: np.ndarray) -> np.ndarray:
        """Continuous (x, y) cell coordinates of world points, counted from the grid's corner (a ROS map's origin)."""
        return (np.asarray(q)[..., :2] - self.low) / self.res

    def _px(self, q: np.ndarray) -> np.ndarray:
        """Continuous (x, y) pixel coordinates of a world point in the global view."""
        return (np.asarray(q)[..., :2] - self.low) / (self.res * self.cells_per_px)

    def update(self, planner: Planner) -> None:
        """Mark the vertices added since the last call (the goal tree's too, with ``two_trees``)."""
        view = planner.view()
        n = view.num_vertices
        if n > self.seen:
            self._mark(1, view.vertices[self.seen:n])
            self.seen = n
        if self.goal_anchor is not None:
            self._mark(4, self.goal_anchor.update(view))

    def _mark(self, channel: int, states: np.ndarray) -> None:
        if not len(states):
            return
        px = np.clip(self._px(states).astype(np.int64), 0, self.size - 1)
        self.image[channel, px[:, 1], px[:, 0]] = 255
        p = self.pad
        cells = self._cells(states).astype(np.int64)
        self.full[channel, cells[:, 1] + p, cells[:, 0] + p] = 255

    def build(self, planner: Planner) -> dict[str, np.ndarray]:
        view = planner.view()
        anchor = view.vertices[view.best_vertex]
        goal_turn = self.goal_anchor is not None and view.tree == 1
        L, s, p = self.local_size, self.local_scale, self.pad
        ac = self._cells(self.goal_anchor.state if goal_turn else anchor)
        r = int(ac[1]) + p - L * s // 2
        c = int(ac[0]) + p - L * s // 2
        crop = self.full[:, r:r + L * s, c:c + L * s]
        if s > 1:
            crop = crop.reshape(len(self.channels), L, s, L, s).max(axis=(2, 4))
        else:
            crop = crop.copy()
        return {"image": self.image.copy(), "local": crop, "vector": self.vector(view, anchor)}

    def vector(self, view, anchor: np.ndarray) -> np.ndarray:
        prob = self.problem
        span = self.high - self.low
        unit = lambda q: 2.0 * (np.asarray(q) - self.low) / span - 1.0  # noqa: E731
        v = np.empty(len(self.features), dtype=np.float32)
        v[0:2] = unit(prob.start)
        v[2:4] = unit(prob.goal)
        v[4:6] = unit(anchor)
        v[6:8] = (prob.goal - anchor) / self.diag
        v[8] = view.best_distance / self.diag
        v[9] = view.iteration / self.max_iterations
        v[10] = math.log1p(view.num_vertices) / math.log1p(self.max_iterations + 2)
        if self.goal_anchor is not None:
            v[11:13] = unit(self.goal_anchor.state)
            v[13] = self.goal_anchor.distance / self.diag
            v[14] = 1.0 if view.tree == 1 else -1.0
        return np.clip(v, -1.0, 1.0)


class VectorObservation:
    """Vector-only observation for worlds without an occupancy grid (geometric worlds, rigid bodies).

    ``(3 * f + 3,)`` float32 in [-1, 1], with ``f`` features per state (positions scaled to [-1, 1],
    angles as cos and sin): start, goal, anchor vertex; then anchor-goal distance over the sampling
    box diagonal, iteration fraction, log tree size. ``two_trees=True`` (RRT-Connect): ``(4 * f + 5,)``,
    the goal tree's anchor (its vertex nearest the start) and its distance to the start over the
    diagonal, and whose turn it is (+1 the goal tree's, -1 the start tree's) appended.
    """

    def __init__(self, dim: int, angle_dims: int = 0, two_trees: bool = False) -> None:
        self.dim, self.angle_dims = dim, angle_dims
        self.features = (dim - angle_dims) + 2 * angle_dims
        self.two_trees = bool(two_trees)

    @property
    def space(self) -> spaces.Box:
        n = 3 * self.features + 3 + ((self.features + 2) if self.two_trees else 0)
        return spaces.Box(-1.0, 1.0, (n,), np.float32)

    def reset(self, problem: Problem, max_iterations: int, guide: GuidedSampling | None = None) -> None:
        self.problem, self.max_iterations = problem, max_iterations
        self.low, self.high = (np.asarray(b, dtype=np.float64) for b in problem.world.bounds)
        self.diag = float(np.linalg.norm(self.high - self.low))
        self.goal_anchor = _GoalTreeAnchor(problem) if self.two_trees else None

    def update(self, planner: Planner) -> None:
        """Keep the goal tree's anchor (``two_trees``); nothing else accumulates."""
        if self.goal_anchor is not None:
            self.goal_anchor.update(planner.view())

    def _state(self, q: np.ndarray) -> np.ndarray:
        k = self.dim - self.angle_dims
        pos = 2.0 * (q[:k] - self.low[:k]) / (self.high[:k] - self.low[:k]) - 1.0
        ang = q[k:]
        return np.concatenate([pos, np.cos(ang), np.sin(ang)])

    def build(self, planner: Planner) -> np.ndarray:
        view = planner.view()
        anchor = view.vertices[view.best_vertex]
        parts = [
            self._state(self.problem.start), self._state(self.problem.goal), self._state(anchor),
            [view.best_distance / self.diag, view.iteration / self.max_iterations,
             math.log1p(view.num_vertices) / math.log1p(self.max_iterations + 2)],
        ]
        if self.goal_anchor is not None:
            parts += [self._state(self.goal_anchor.state),
                      [self.goal_anchor.distance / self.diag, 1.0 if view.tree == 1 else -1.0]]
        return np.clip(np.concatenate(parts), -1.0, 1.0).astype(np.float32)


class EgocentricObservation:
    """``Dict(local=(6, 16, 16) uint8, vector=(8,) float32)``: egocentric windows and vector features.

    Windows around the progress vertex at 1/4, 1 and 4 steps per pixel (obstacles and tree), turned
    towards the goal, and vector features (see ``planners.guidance.egocentric``); the same on maps of
    every size. The episode's ``GuidedSampling`` computes them, so ``reset`` needs it.

    ``flat=True`` (``observation="egocentric_flat"``): the windows flattened, ``local=(1536,) float32`` in
    [0, 1], which SB3's ``MultiInputPolicy`` feeds to its MLP (its CNN needs 36x36 images): a policy
    small enough to run at every planner iteration, trained with SB3's defaults.
    """

    def __init__(self, flat: bool = False) -> None:
        self.guide: GuidedSampling | None = None
        self.flat = bool(flat)

    @property
    def space(self) -> spaces.Dict:
        """Built when asked (a sampler's builder, made for each query, never asks: it costs a millisecond)."""
        shape = (2 * len(SCALES), WINDOW, WINDOW)
        return spaces.Dict({
            "local": (spaces.Box(0.0, 1.0, (math.prod(shape),), np.float32) if self.flat
                      else spaces.Box(0, 255, shape, np.uint8)),
            "vector": spaces.Box(-1.0, 1.0, (len(EGO_VECTOR),), np.float32),
        })

    def reset(self, problem: Problem, max_iterations: int, guide: GuidedSampling | None = None) -> None:
        if guide is None:
            raise ValueError("egocentric observations are computed by the episode's GuidedSampling: pass it as guide")
        self.guide = guide

    def update(self, planner: Planner) -> None:
        """Nothing: ``build`` brings the guide up to date from the same tree view it observes."""

    def build(self, planner: Planner) -> dict:
        view = planner.view()
        self.guide.update(view)
        obs = self.guide.observe(view)
        obs["vector"] = np.clip(obs["vector"], -1.0, 1.0)
        if self.flat:
            obs["local"] = obs["local"].reshape(-1).astype(np.float32) * np.float32(1.0 / 255.0)
        return obs


def _map_observation(dim: int, obs_size: int, local_size: int, local_scale: int, two_trees: bool):
    if dim == 2:
        return GridObservation(obs_size, local_size, local_scale, two_trees=two_trees)
    return VectorObservation(dim, angle_dims=3 if dim == 6 else 0, two_trees=two_trees)


def _egocentric(flat: bool):
    def make(dim: int, obs_size: int, local_size: int, local_scale: int, two_trees: bool):
        if two_trees:
            raise InputError("egocentric observations follow one tree's progress vertex; for RRT-Connect (two "
                             "trees) use observation='image', which shows both trees and whose turn it is")
        return EgocentricObservation(flat=flat)
    return make


#: Observation kinds by name: a factory ``(dim, obs_size, local_size, local_scale, two_trees) -> builder``.
#: ``image``: ``GridObservation`` on 2-D grids, ``VectorObservation`` otherwise. ``two_trees``: the
#: planner grows two trees (RRT-Connect); a kind that cannot show both refuses it.
OBSERVATIONS = {
    "image": _map_observation,
    "egocentric": _egocentric(flat=False),
    "egocentric_flat": _egocentric(flat=True),
}


def make_observation(kind: str, dim: int, *, obs_size: int = 64, local_size: int = 48, local_scale: int = 1,
                     two_trees: bool = False):
    """A fresh observation builder of ``kind`` (a key of ``OBSERVATIONS``) for ``dim``-D problems.

    ``two_trees``: for a bidirectional planner (RRT-Connect), whose goal tree the observation shows too.
    """
    if kind not in OBSERVATIONS:
        raise InputError(f"observation must be one of {tuple(OBSERVATIONS)}, got {kind!r}")
    return OBSERVATIONS[kind](dim, obs_size, local_size, local_scale, bool(two_trees))


def _area_fraction(obs: np.ndarray, S: int) -> np.ndarray:
    """Mean of a square (side x side) array over an S x S grid of equal pixels (any ratio)."""
    side = obs.shape[0]
    if side % S == 0:
        f = side // S
        return obs.reshape(S, f, S, f).mean(axis=(1, 3))
    # integral image over pixel bounds rounded to cells (each pixel covers at least one cell)
    ii = np.zeros((side + 1, side + 1))
    ii[1:, 1:] = obs.cumsum(0).cumsum(1)
    edges = np.floor(np.arange(S + 1) * side / S).astype(np.int64)
    lo = edges[:-1]
    hi = np.maximum(edges[1:], lo + 1)
    tot = ii[hi][:, hi] - ii[lo][:, hi] - ii[hi][:, lo] + ii[lo][:, lo]
    area = (hi - lo)[:, None] * (hi - lo)[None, :]
    return tot / area


def _disc(shape: tuple[int, int], center_xy: np.ndarray, radius: float) -> np.ndarray:
    """uint8 mask (255 inside) of a disc given in (x, y) pixel coordinates."""
    H, W = shape
    ys = np.arange(H) + 0.5
    xs = np.arange(W) + 0.5
    inside = (xs[None, :] - center_xy[0]) ** 2 + (ys[:, None] - center_xy[1]) ** 2 <= radius**2
    if not inside.any():
        c = np.clip(np.floor(center_xy).astype(int), 0, [W - 1, H - 1])
        inside[c[1], c[0]] = True
    return np.where(inside, 255, 0).astype(np.uint8)
