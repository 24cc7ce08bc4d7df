"""Egocentric observations: multi-scale windows around the progress vertex, turned towards the goal.

Why: a policy that sees the map and the tree *from the tree's progress vertex, facing the goal*
decides in a frame where "ahead", "left" and "behind" mean the same thing on every map, and at
several scales (1, 4 and 16 cells per pixel by default) it sees a corridor's walls and a trap's
opening alike. The same windows on a 32x32 and a 512x512 map make the policy transfer across sizes.

Each scale is a pyramid level of the obstacle grid (the blocked fraction of each block) and of the
blocks that hold a tree vertex, updated incrementally; a window pixel reads the level at the world point the
pixel's centre maps to. A query costs ``scales * size**2`` lookups in compiled code.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from planners import OccupancyGrid, Problem

EGO_VECTOR = ("goal_distance", "log_goal_distance", "iteration_fraction", "stuck", "log_tree_size",
              "anchor_is_start", "anchor_to_start", "progress")


@nb.njit(cache=True)
def _window(levels_obs, levels_tree, layout, ax, ay, ux, uy, size, out):
    """Fill out[2k], out[2k+1] with the obstacle / tree windows of pyramid level k (see ``build_pyramid``)."""
    half = size / 2.0
    vx, vy = -uy, ux
    for k in range(layout.shape[0]):
        off, H, W, f = layout[k, 0], layout[k, 1], layout[k, 2], layout[k, 3]
        lo = levels_obs[off:off + H * W].reshape((H, W))
        lt = levels_tree[off:off + H * W].reshape((H, W))
        inv = 1.0 / f
        exact = (f & (f - 1)) == 0  # a power of two: x * (1 / f) is exactly x / f, and a multiply is cheap
        for i in range(size):
            dy = (i + 0.5 - half) * f
            for j in range(size):
                dx = (j + 0.5 - half) * f
                # pixel (i, j): dx ahead (towards the goal), dy to the left
                x = ax + dx * ux + dy * vx
                y = ay + dx * uy + dy * vy
                c = int(math.floor(x * inv if exact else x / f))
                r = int(math.floor(y * inv if exact else y / f))
                if r < 0 or r >= H or c < 0 or c >= W:
                    out[2 * k, i, j] = 255
                    out[2 * k + 1, i, j] = 0
                else:
                    out[2 * k, i, j] = lo[r, c]
                    out[2 * k + 1, i, j] = 255 if lt[r, c] > 0 else 0


@nb.njit(cache=True)
def observe_windows(levels_obs, levels_tree, layout, size, res, origin, step, anchor, anchor_is_start, start, goal,
                    num_vertices, iteration, last_progress, max_iterations, local, vector):
    """Window (into ``local``) and vector features (into ``vector``) at ``anchor``; see ``EGO_VECTOR``.

    Points are world coordinates; ``origin`` is the world point of the grid's corner (a ROS map's).
    """
    dx = goal[0] - anchor[0]
    dy = goal[1] - anchor[1]
    n = math.sqrt(dx * dx + dy * dy)
    ux, uy = (1.0, 0.0) if n < 1e-12 else (dx / n, dy / n)
    _window(levels_obs, levels_tree, layout, (anchor[0] - origin[0]) / res, (anchor[1] - origin[1]) / res, ux, uy,
            size, local)
    dg = n / step
    d0 = math.sqrt((goal[0] - start[0]) ** 2 + (goal[1] - start[1]) ** 2) / step
    ds = math.sqrt((anchor[0] - start[0]) ** 2 + (anchor[1] - start[1]) ** 2) / step
    vector[0] = min(dg / 100.0, 1.0)
    vector[1] = math.log1p(dg) / math.log1p(1000.0)
    vector[2] = min(iteration / max_iterations, 1.0)
    vector[3] = min((iteration - last_progress) / 200.0, 1.0)
    vector[4] = min(math.log1p(num_vertices) / math.log1p(max_iterations + 2.0), 1.0)
    vector[5] = 1.0 if anchor_is_start else 0.0
    vector[6] = min(ds / 100.0, 1.0)
    vector[7] = max(-1.0, min(1.0, 1.0 - dg / max(d0, 1e-9)))
    return ux, uy


@nb.njit(cache=True, inline="always")
def _fill_level(obstacles, f, out):
    """``out``: blocked fraction (0-255) of each f x f block; blocks overhanging the map count the outside as blocked.

    ``obstacles`` holds 0/1. Rows are summed a block row at a time over whole map rows (contiguous,
    vectorised adds), then a running sum along that row gives each block's count as one difference:
    no per-cell division or scatter, and no per-block loop.
    """
    H, W = obstacles.shape
    if f == 1:
        for r in range(H):
            for c in range(W):
                out[r, c] = 255 if obstacles[r, c] else 0
        return
    rows, cols = out.shape
    # 0-255 level of k blocked cells out of f * f, rounded half to even as np.round
    level = np.empty(f * f + 1, dtype=np.uint8)
    for k in range(f * f + 1):
        level[k] = np.uint8(round(255.0 * k / (f * f)))
    acc = np.empty(W, dtype=np.int32)
    run = np.empty(cols * f + 1, dtype=np.int32)
    run[0] = 0
    for i in range(rows):
        r0 = i * f
        r1 = min(r0 + f, H)
        acc[:] = f - (r1 - r0)  # rows of the block below the map count as blocked
        for r in range(r0, r1):
            for c in range(W):
                acc[c] += obstacles[r, c]
        s = 0
        for c in range(W):
            s += acc[c]
            run[c + 1] = s
        for c in range(W, cols * f):  # columns right of the map, blocked
            s += f
            run[c + 1] = s
        for j in range(cols):
            out[i, j] = level[run[(j + 1) * f] - run[j * f]]


@nb.njit(cache=True)
def build_pyramid(obstacles, factors):
    """The obstacle pyramid of a 0/1 grid, flat: ``(layout, levels_obs, levels_tree)``.

    Level k (``factors[k]`` cells per block) is ``rows x cols`` at ``levels[off:off + rows * cols]``
    with ``layout[k] = (off, rows, cols, factors[k])``. One flat array per pyramid, not a tuple of
    levels, so that building it is one compiled call and the levels box into Python as one array.
    ``levels_tree`` (1: the block holds a vertex) starts empty.
    """
    H, W = obstacles.shape
    layout = np.empty((factors.shape[0], 4), dtype=np.int64)
    total = 0
    for k in range(factors.shape[0]):
        f = factors[k]
        layout[k, 0] = total
        layout[k, 1] = -(-H // f)
        layout[k, 2] = -(-W // f)
        layout[k, 3] = f
        total += layout[k, 1] * layout[k, 2]
    levels = np.empty(total, dtype=np.uint8)
    for k in range(factors.shape[0]):
        off, rows, cols = layout[k, 0], layout[k, 1], layout[k, 2]
        _fill_level(obstacles, factors[k], levels[off:off + rows * cols].reshape((rows, cols)))
    return layout, levels, np.zeros(total, dtype=np.uint8)


@nb.njit(cache=True)
def add_vertices(levels_tree, layout, V, res, origin):
    """Mark the pyramid blocks (every level) that hold one of the vertices ``V``.

    ``V`` holds world points; cells are ``res`` wide, counted from the grid's corner ``origin``.
    """
    for n in range(V.shape[0]):
        x = (V[n, 0] - origin[0]) / res
        y = (V[n, 1] - origin[1]) / res
        for k in range(layout.shape[0]):
            off, H, W, f = layout[k, 0], layout[k, 1], layout[k, 2], layout[k, 3]
            r = int(y / f)
            c = int(x / f)
            if 0 <= r < H and 0 <= c < W:
                levels_tree[off + r * W + c] = 1


class EgocentricView:
    """Builds egocentric windows and vector features for one 2-D grid problem.

    Args:
        problem: An ``OccupancyGrid`` problem.
        step_size: The planner's step; distances in the vector features are in steps.
        scales: Cells per window pixel at each level.
        size: Window side in pixels (even).
        max_iterations: Normalises the iteration count.
    """

    def __init__(self, problem: Problem, step_size: float, scales=(1, 4, 16), size: int = 16,
                 max_iterations: int = 20000) -> None:
        grid = problem.world
        if not isinstance(grid, OccupancyGrid):
            raise TypeError("egocentric observations need an OccupancyGrid problem")
        self.problem, self.step = problem, float(step_size)
        self.res = grid.resolution
        self.origin = np.ascontiguousarray(grid.origin, dtype=np.float64)
        self.size = int(size)
        self.max_iterations = max_iterations
        self.factors = np.asarray(scales, dtype=np.int64)
        self.layout, self.levels_obs, self.levels_tree = build_pyramid(grid.kernel.grid, self.factors)
        self.start = np.ascontiguousarray(problem.start[:2], dtype=np.float64)
        self.goal = np.ascontiguousarray(problem.goal[:2], dtype=np.float64)
        self.seen = 0
        self.best_distance = math.inf
        self.last_progress = 0

    @property
    def channels(self) -> int:
        return 2 * len(self.factors)

    def update(self, vertices: np.ndarray, num_vertices: int, best_distance: float, iteration: int) -> None:
        """Count the vertices added since the last call; note when the progress vertex improved."""
        if num_vertices > self.seen:
            add_vertices(self.levels_tree, self.layout, vertices[self.seen:num_vertices], self.res, self.origin)
            self.seen = num_vertices
        if best_distance < self.best_distance - 1e-9:
            self.best_distance = best_distance
            self.last_progress = iteration

    def frame(self, anchor: np.ndarray) -> tuple[float, float]:
        """Unit vector from ``anchor`` to the goal (x axis of the egocentric frame)."""
        d = self.problem.goal[:2] - anchor[:2]
        n = float(np.hypot(d[0], d[1]))
        return (1.0, 0.0) if n < 1e-12 else (float(d[0] / n), float(d[1] / n))

    def observe(self, anchor: np.ndarray, anchor_index: int, num_vertices: int, iteration: int) -> dict:
        """``{"local": (2 * scales, size, size) uint8, "vector": (8,) float32}`` at ``anchor``."""
        local = np.empty((self.channels, self.size, self.size), dtype=np.uint8)
        vector = np.empty(len(EGO_VECTOR), dtype=np.float32)
        observe_windows(self.levels_obs, self.levels_tree, self.layout, self.size, self.res, self.origin, self.step,
                 np.ascontiguousarray(anchor[:2], dtype=np.float64), anchor_index == 0, self.start, self.goal,
                 num_vertices, iteration, self.last_progress, self.max_iterations, local, vector)
        return {"local": local, "vector": vector}
