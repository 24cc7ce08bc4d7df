"""The guided action space: egocentric sample cells around the tree's progress, or the frontier.

An action is one of ``N_ACTIONS`` classes:

* ``0 .. N_EGO - 1``: a cell of a log-polar grid (16 directions x 11 rings out to 24 steps) in the
  frame that points from the tree vertex nearest the goal towards the goal. The sample is a uniform
  point of that cell, kept as an offset (``ANCHOR_GOAL``) so the planner resolves it against the
  progress vertex current when the sample is used: a batch keeps following the tree.
* ``FRONTIER``: a point in a frontier cell of the tree (see ``planners.guidance.frontier``), cells nearer the goal
  preferred.

Whatever the class, a ``uniform_floor`` share of samples is uniform over the map, so probabilistic
completeness is never lost. The environment's ``guided`` action mode (``GuidedSampling``) and the
learned ``PolicySampler`` share this geometry and its compiled builders and draws, so training and
inference observe and draw samples identically.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from planners import Problem, SampleBatch, TreeView
from planners.guidance.egocentric import EgocentricView
from planners.guidance.frontier import NO_COST, Frontier, cdf_search, frontier_cdf, update_frontier

ANGLES = 16
RINGS = (0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0, 24.0)  # in steps
SCALES = (0.25, 1.0, 4.0)  # egocentric window scales, in steps per pixel
WINDOW = 16  # egocentric window side, in pixels
FRONTIER_TAU = 1.0  # frontier goal preference, in cells
N_EGO = ANGLES * (len(RINGS) - 1)
FRONTIER = N_EGO
N_ACTIONS = N_EGO + 1
_RINGS = np.asarray(RINGS)


@nb.njit(cache=True, inline="always")
def _ego_offset(c, ur, ua, rings, angles, step, pts, anch, k):
    """Row ``k`` := a uniform point of egocentric cell ``c`` (ring ``c // angles``), a goal-frame offset."""
    ring = c // angles
    r = (rings[ring] + ur * (rings[ring + 1] - rings[ring])) * step
    a = (c % angles + ua) * (2.0 * math.pi / angles)
    pts[k, 0] = r * math.cos(a)
    pts[k, 1] = r * math.sin(a)
    anch[k] = 2  # ANCHOR_GOAL


@nb.njit(cache=True)
def _fill_samples(classes, u, uni, front, low, high, step, rings, angles, floor, pts, anch):
    """Turn classes into samples: egocentric cells (goal-frame offsets), frontier points, uniform floor.

    ``u`` holds 3 uniforms per sample, ``uni`` 2 more for the uniform fallback, ``front`` the frontier
    points drawn for this batch (fewer than needed when the frontier is empty).
    """
    n_ego = angles * (rings.shape[0] - 1)
    for k in range(classes.shape[0]):
        c = classes[k]
        if u[k, 2] < floor or (c >= n_ego and k >= front.shape[0]):
            pts[k, 0] = low[0] + (high[0] - low[0]) * uni[k, 0]
            pts[k, 1] = low[1] + (high[1] - low[1]) * uni[k, 1]
            anch[k] = 0
        elif c >= n_ego:
            pts[k, 0] = front[k, 0]
            pts[k, 1] = front[k, 1]
            anch[k] = 0
        else:
            _ego_offset(c, u[k, 0], u[k, 1], rings, angles, step, pts, anch, k)


@nb.njit(cache=True)
def fill_from_cdf(cdf, acc, u, low, high, step, floor, frontier, fstate, X, n, fcdf, pts, anch):
    """Draw a class per row of ``u`` from the class CDF ``cdf`` (total ``acc``) and turn it into a sample.

    ``u`` holds 6 uniforms per sample: class, ring position, angle position, floor test, and two for
    a uniform or frontier point. ``frontier`` is ``(world, counts, cell, W, goal, free, covered, pos,
    cells, dist, tau)`` of a ``Frontier`` and ``fstate`` its ``[vertices seen, cell count]``: it is
    brought up to date with the tree's vertices ``X[:n]`` only when a sample falls in the frontier
    class, which spares the visibility checks while the policy samples around the tree's progress.
    ``fcdf`` is scratch for the frontier cells' weights, as long as the frontier can grow.
    """
    world, counts, cell, fW, fgoal, free, cov, fpos, front, fdist, tau = frontier
    n_ego = ANGLES * (_RINGS.shape[0] - 1)
    facc = -1.0
    for k in range(u.shape[0]):
        c = cdf_search(cdf, cdf.shape[0], u[k, 0] * acc)
        if c >= n_ego and u[k, 3] >= floor and facc < 0.0:
            if n > fstate[0]:
                fstate[1] = update_frontier(world, counts, X[fstate[0]:n], cell, fgoal, free, cov, fpos, front,
                                            fdist, fstate[1], NO_COST)
                fstate[0] = n
            facc = frontier_cdf(front, fstate[1], fdist, tau, fcdf)
        if u[k, 3] < floor or (c >= n_ego and fstate[1] == 0):
            pts[k, 0] = low[0] + (high[0] - low[0]) * u[k, 4]
            pts[k, 1] = low[1] + (high[1] - low[1]) * u[k, 5]
            anch[k] = 0
        elif c >= n_ego:
            f = front[cdf_search(fcdf, fstate[1], u[k, 1] * facc)]
            pts[k, 0] = world.params[1] + (f % fW + u[k, 4]) * cell  # the grid's corner: a ROS map's origin
            pts[k, 1] = world.params[2] + (f // fW + u[k, 5]) * cell
            anch[k] = 0
        else:
            _ego_offset(c, u[k, 1], u[k, 2], _RINGS, ANGLES, step, pts, anch, k)


def ego_class(dx: float, dy: float, step: float) -> int:
    """Class of an offset given in the goal frame (world units); beyond the last ring -> last ring."""
    r = math.hypot(dx, dy) / step
    ring = min(len(RINGS) - 2, int(np.searchsorted(_RINGS, r, side="right")) - 1)
    a = math.atan2(dy, dx) % (2 * math.pi)
    return ring * ANGLES + int(a / (2 * math.pi) * ANGLES) % ANGLES


def scale_cells(step: float, resolution: float, scales=SCALES) -> tuple[int, ...]:
    """Grid cells per window pixel at each scale (scales are in steps per pixel); at least one."""
    return tuple(max(1, int(round(s * step / resolution))) for s in scales)


class GuidedSampling:
    """Egocentric observation, frontier and action geometry for one 2-D grid problem.

    Args:
        problem: An ``OccupancyGrid`` problem.
        step_size: The planner's step (rings and window scales are in steps).
        scales: Egocentric window scales, in steps per pixel.
        size: Window side in pixels.
        max_iterations: Normalises the iteration feature.
        tau: Frontier goal preference (cells).
        uniform_floor: Share of uniform samples whatever the class.
    """

    def __init__(self, problem: Problem, step_size: float, *, scales=SCALES, size: int = WINDOW,
                 max_iterations: int = 20000, tau: float = FRONTIER_TAU, uniform_floor: float = 0.05) -> None:
        self.problem, self.step = problem, float(step_size)
        cells = scale_cells(self.step, problem.world.resolution, scales)
        self.ego = EgocentricView(problem, self.step, scales=cells, size=size, max_iterations=max_iterations)
        self.frontier = Frontier(problem, self.step, tau)
        self.uniform_floor = float(uniform_floor)
        self.low, self.high = (np.asarray(b, dtype=np.float64) for b in problem.world.bounds)

    def update(self, view: TreeView) -> None:
        self.ego.update(view.vertices, view.num_vertices, view.best_distance, view.iteration)
        self.frontier.update(view.vertices, view.num_vertices)

    def stuck(self, view: TreeView) -> int:
        """Iterations since the progress vertex last came closer to the goal."""
        return view.iteration - self.ego.last_progress

    def observe(self, view: TreeView) -> dict[str, np.ndarray]:
        anchor = view.vertices[view.best_vertex]
        return self.ego.observe(anchor, view.best_vertex, view.num_vertices, view.iteration)

    def classify(self, view: TreeView, target: np.ndarray) -> int:
        """The egocentric class containing world point ``target``."""
        anchor = view.vertices[view.best_vertex]
        ux, uy = self.ego.frame(anchor)
        d = np.asarray(target[:2]) - anchor[:2]
        return ego_class(d[0] * ux + d[1] * uy, -d[0] * uy + d[1] * ux, self.step)

    def samples(self, classes: np.ndarray, rng: np.random.Generator) -> SampleBatch:
        """One sample per class (a fixed number of random draws per sample, whatever its class)."""
        classes = np.ascontiguousarray(classes, dtype=np.int64).reshape(-1)
        m = len(classes)
        u = rng.random((m, 3))
        uni = rng.random((m, 2))
        front = self.frontier.sample(rng, m)
        pts = np.empty((m, 2))
        anch = np.empty(m, dtype=np.int8)
        _fill_samples(classes, u, uni, front, self.low, self.high, self.step, _RINGS, ANGLES, self.uniform_floor,
                      pts, anch)
        return SampleBatch(pts, anch)
