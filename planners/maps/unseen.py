"""Seeded map families used for nothing but testing: layouts unlike every training generator.

``generate_unseen`` mirrors ``generators.generate``: a seeded ``Problem`` on a ``size x size``
``OccupancyGrid`` (resolution 1, origin 0), start and goal at free cell centres, 4-connected through
free cells, at least ``size / 2`` apart along the octile shortest path and further apart in a straight
line than the goal tolerance; ``reference_length`` is that octile shortest-path length. Every dimension
scales with ``size`` (numbers quoted are for ``size = 128``).

On top of that every map keeps a *wide route*: start and goal stay connected when every obstacle is
grown by ``ROUTE_CLEARANCE`` cells (a square of that radius, at 128), so each opening on that route is
at least ``2 * ROUTE_CLEARANCE + 1`` cells across, more than one extension step of 4: the map is
solvable by RRT at step 4 whatever the sampler. A map that misses this is redrawn.

The families (see ``docs/unseen-families.md`` for how they differ from the training ones):

- ``spiral``: concentric circular walls around the goal or the start, one opening in each, the
  openings far apart in angle and some corridors closed on one side by a radial spoke, so the route
  winds around the centre.
- ``warehouse``: long racks in parallel rows with aisles between them, staggered cross-aisles and
  pallets that turn some aisles into dead ends.
- ``baffles``: three to five parallel walls at a slant (20-70 degrees off the axes), each with one
  opening at alternating ends, so the route zigzags through openings in series.

All randomness comes from ``np.random.default_rng(seed)`` (or the generator passed in).
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from planners.base.fileio import check_int
from planners.base.problem import Problem
from planners.maps.generators import seeded_map
from planners.maps.gridsearch import distance_field, free_components
from planners.worlds.grid import OccupancyGrid

UNSEEN_FAMILIES = ("spiral", "warehouse", "baffles")

#: First seed of the unseen test maps; sets take consecutive seeds from here. Training (0-100,000),
#: validation (200,000), tuning (300,000), test (1,000,000) and shifted test maps (2,000,000) lie below.
UNSEEN_SEED0 = 3_000_000

#: Smallest map side: below it the rings, racks and openings would fall under a few cells.
UNSEEN_MIN_SIZE = 64

#: Cells (at size 128) by which every obstacle may grow without cutting the start from the goal.
ROUTE_CLEARANCE = 2

# a map that misses the wide route or a far enough start/goal pair is redrawn, at most this often
_MAP_TRIES = 16
# goals tried per map before the map is redrawn
_GOAL_TRIES = 8


def unseen_families() -> tuple[str, ...]:
    """The names ``generate_unseen`` accepts, in a fixed order."""
    return UNSEEN_FAMILIES


def _cells(size: int, cells: float, lo: int = 1) -> int:
    """``cells`` at size 128 scaled to ``size``, rounded half up, at least ``lo``."""
    return max(lo, int(cells * size / 128 + 0.5))


def _pick(rng: np.random.Generator, size: int, lo: float, hi: float, least: int = 1) -> int:
    """A uniform integer between ``lo`` and ``hi`` cells at size 128, both scaled to ``size``."""
    a = _cells(size, lo, least)
    return int(rng.integers(a, max(a, _cells(size, hi, least)) + 1))


def clearance_map(obstacles: np.ndarray, radius: int) -> np.ndarray:
    """``obstacles`` grown by a square of ``radius`` cells (the map edge counts as obstacle).

    A free cell of the result has a free ``(2 * radius + 1)``-cell square around it in ``obstacles``.
    """
    obs = np.asarray(obstacles, dtype=bool)
    padded = np.pad(obs, radius, constant_values=True)
    h, w = obs.shape
    grown = np.zeros_like(obs)
    for dr in range(2 * radius + 1):
        for dc in range(2 * radius + 1):
            grown |= padded[dr : dr + h, dc : dc + w]
    return grown


def _problem(rng: np.random.Generator, obs: np.ndarray, goal_mask: np.ndarray, start_mask: np.ndarray, *,
             goal_tolerance: float, name: str) -> Problem | None:
    """A problem on ``obs`` with a wide route, its goal in ``goal_mask`` and start in ``start_mask``; or None.

    Start and goal are drawn among the cells that stay free and connected to each other when the
    obstacles grow by the route clearance, so the route between them is wide; the start is then kept
    at least ``size / 2`` from the goal along the octile shortest path of the map itself.
    """
    size = obs.shape[0]
    labels = free_components(clearance_map(obs, _cells(size, ROUTE_CLEARANCE)))
    goals = np.argwhere(goal_mask & (labels >= 0))
    if not len(goals):
        return None
    for _ in range(_GOAL_TRIES):
        g = goals[rng.integers(len(goals))]
        rows, cols = np.nonzero(start_mask & (labels == labels[g[0], g[1]]))
        geo = distance_field(obs, (int(g[0]), int(g[1])))[rows, cols]
        ok = np.flatnonzero((geo >= 0.5 * size) & (np.hypot(rows - g[0], cols - g[1]) > goal_tolerance))
        if len(ok):
            i = ok[rng.integers(len(ok))]
            grid = OccupancyGrid(obs)
            return Problem(grid, start=grid.cell_center(rows[i], cols[i]), goal=grid.cell_center(g[0], g[1]),
                           goal_tolerance=goal_tolerance, name=name, reference_length=float(geo[i]))
    return None


def _centres(size: int) -> tuple[np.ndarray, np.ndarray]:
    """Row and column coordinates of the cell centres, as broadcastable (size, 1) and (1, size) arrays."""
    y, x = np.ogrid[0:size, 0:size]
    return y + 0.5, x + 0.5


def _turned(rng: np.random.Generator, *masks: np.ndarray) -> list[np.ndarray]:
    """``masks`` under one random symmetry of the square (the same for all)."""
    turns, flip = int(rng.integers(4)), bool(rng.integers(2))
    return [np.ascontiguousarray(np.rot90(m, turns)[:, ::-1] if flip else np.rot90(m, turns)) for m in masks]


def _spiral(rng: np.random.Generator, size: int, goal_tolerance: float, name: str) -> Problem | None:
    """Concentric circular walls, one opening each, the route winding from the centre out (or in)."""
    t = _pick(rng, size, 2, 3, 2)  # wall thickness
    gap = _pick(rng, size, 8, 11, 3)  # opening width, straight-sided
    lane = _pick(rng, size, 9, 13, 3)  # free band between two walls
    inner = _pick(rng, size, 9, 13, 3)  # free radius inside the innermost wall
    rings = max(2, int((0.5 * size - _cells(size, 6) - inner) // (t + lane)))
    outer = inner + rings * (t + lane) - lane  # outer edge of the outermost wall
    lo_c, hi_c = outer + _cells(size, 3), size - outer - _cells(size, 3)
    cy, cx = rng.uniform(lo_c, max(lo_c, hi_c), 2)
    y, x = _centres(size)
    dist = np.hypot(y - cy, x - cx)
    obs = np.zeros((size, size), dtype=bool)
    angle = rng.uniform(0, 2 * math.pi)
    for i in range(rings):
        r0 = inner + i * (t + lane)
        wall = (dist >= r0) & (dist < r0 + t)
        # the opening: cells within gap / 2 of the ray at ``angle`` (on its side of the centre)
        ux, uy = math.cos(angle), math.sin(angle)
        along = (x - cx) * ux + (y - cy) * uy
        across = np.abs(-(x - cx) * uy + (y - cy) * ux)
        obs |= wall & ~((along > 0) & (across < gap / 2))
        if i + 1 < rings and rng.random() < 0.5:
            # a spoke across the next lane just beside this opening: the route goes the long way round
            side = rng.choice([-1.0, 1.0])
            spoke_angle = angle + side * (gap + t) / (r0 + t)
            sx, sy = math.cos(spoke_angle), math.sin(spoke_angle)
            s_along = (x - cx) * sx + (y - cy) * sy
            s_across = np.abs(-(x - cx) * sy + (y - cy) * sx)
            obs |= (s_along > 0) & (s_across < t / 2 + 0.5) & (dist >= r0 + t) & (dist < r0 + t + lane)
        angle += rng.choice([-1.0, 1.0]) * rng.uniform(0.6 * math.pi, 1.4 * math.pi)
    margin = _cells(size, ROUTE_CLEARANCE) + 1
    centre = dist < inner - margin
    outside = dist > outer + margin
    goal, start = (centre, outside) if rng.integers(2) else (outside, centre)
    return _problem(rng, obs, goal, start, goal_tolerance=goal_tolerance, name=name)


def _warehouse(rng: np.random.Generator, size: int, goal_tolerance: float, name: str) -> Problem | None:
    """Rows of long racks with aisles, staggered cross-aisles and pallets closing off some aisles."""
    rack = _pick(rng, size, 3, 5, 2)  # rack depth (double-deep shelving)
    aisle = _pick(rng, size, 6, 9, 3)
    cross = _pick(rng, size, 6, 9, 3)  # cross-aisle width
    end_gap = _pick(rng, size, 6, 12, 3)  # aisle at the racks' open end
    against_wall = bool(rng.integers(2))  # racks run into the west wall, else leave an aisle there too
    c0, c1 = (0 if against_wall else end_gap), size - end_gap
    obs = np.zeros((size, size), dtype=bool)
    # drawn with the racks along the rows; turned below
    main = [int(rng.integers(c0 + cross, c1 - 2 * cross)) for _ in range(int(rng.integers(1, 3)))]
    r = aisle
    racks = []
    while r + rack + aisle <= size:
        obs[r : r + rack, c0:c1] = True
        racks.append(r)
        r += rack + aisle
    for r in racks:
        cuts = [c for c in main if rng.random() < 0.7]
        if rng.random() < 0.4:
            cuts.append(int(rng.integers(c0 + cross, c1 - 2 * cross)))
        for c in cuts:
            obs[r : r + rack, c : c + cross] = False
    for r in racks[:-1]:
        if rng.random() < 0.3:  # a pallet filling the aisle below this rack: dead ends on either side
            width = _pick(rng, size, 3, 6, 2)
            c = int(rng.integers(c0, c1 - width))
            obs[r + rack : r + rack + aisle, c : c + width] = True
    rows = np.broadcast_to(np.arange(size)[:, None], (size, size))
    goal, start = rows < size // 3, rows >= size - size // 3
    if rng.integers(2):
        goal, start = start, goal
    obs, goal, start = _turned(rng, obs, goal, start)
    return _problem(rng, obs, goal, start, goal_tolerance=goal_tolerance, name=name)


def _baffles(rng: np.random.Generator, size: int, goal_tolerance: float, name: str) -> Problem | None:
    """Parallel slanted walls across the map, one opening each at alternating ends."""
    count = int(rng.integers(3, 6))
    t = _pick(rng, size, 2, 3, 2)
    gap = _pick(rng, size, 8, 11, 3)
    theta = math.radians(rng.uniform(20, 70)) + 0.5 * math.pi * int(rng.integers(4))
    nx, ny = math.cos(theta), math.sin(theta)  # the walls' normal
    y, x = _centres(size)
    across = x * nx + y * ny  # coordinate along the normal
    along = -x * ny + y * nx  # coordinate along the walls
    lo, hi = float(across.min()), float(across.max())
    spacing = 0.6 * (hi - lo) / count
    obs = np.zeros((size, size), dtype=bool)
    end = int(rng.integers(2))
    places = []
    for i in range(count):
        d = lo + (hi - lo) * 0.2 + spacing * (i + 0.5) + rng.uniform(-0.15, 0.15) * spacing
        wall = np.abs(across - d) < t / 2
        u = along[wall]
        u_lo, u_hi = float(u.min()), float(u.max())
        reach = max(gap / 2 + 1, 0.3 * (u_hi - u_lo))
        offset = rng.uniform(gap / 2 + 1, reach)
        centre = u_lo + offset if (i + end) % 2 == 0 else u_hi - offset
        obs |= wall & (np.abs(along - centre) >= gap / 2)
        places.append(d)
    margin = _cells(size, 6)
    goal, start = across < places[0] - margin, across > places[-1] + margin
    if rng.integers(2):
        goal, start = start, goal
    return _problem(rng, obs, goal, start, goal_tolerance=goal_tolerance, name=name)


_FAMILIES = {"spiral": _spiral, "warehouse": _warehouse, "baffles": _baffles}


def generate_unseen(family: str, seed: int | np.random.Generator, size: int = 128, *,
                    goal_tolerance: float = 4.0) -> Problem:
    """A seeded problem of one unseen family; the same family, seed and size always give the same problem.

    Args:
        family: One of ``UNSEEN_FAMILIES``.
        seed: A non-negative int (named in the problem, ``f"{family}-{size}-{seed}"``; test sets take
            theirs from ``UNSEEN_SEED0``) or a ``np.random.Generator`` to draw from (the name is then
            ``f"{family}-{size}"``).
        size: Map side in cells, an integer >= ``UNSEEN_MIN_SIZE``.
        goal_tolerance: Goal radius (cells), a positive number.

    Raises:
        ValueError: For an unknown family, a size below ``UNSEEN_MIN_SIZE``, a negative seed or a non-positive
            goal tolerance.
        RuntimeError: If no map with a wide route and a far enough start/goal pair came up in
            ``_MAP_TRIES`` draws (a broken design, never seen on the sizes tested).
    """
    if not isinstance(family, str) or family not in _FAMILIES:
        raise ValueError(f"unknown unseen map family {family!r}; choose from {', '.join(UNSEEN_FAMILIES)}")
    size = check_int(size, "size", low=UNSEEN_MIN_SIZE)
    tol = goal_tolerance if isinstance(goal_tolerance, numbers.Real) and not isinstance(goal_tolerance, bool) else None
    if tol is None or not (math.isfinite(tol) and tol > 0):
        raise ValueError(f"goal_tolerance must be a positive finite number, got {goal_tolerance!r}")
    rng, name = seeded_map(seed, family, size)
    for _ in range(_MAP_TRIES):
        problem = _FAMILIES[family](rng, size, float(tol), name)
        if problem is not None:
            return problem
    raise RuntimeError(f"{name}: no map with a route {2 * _cells(size, ROUTE_CLEARANCE) + 1} cells wide between a "
                       f"start and goal half the map side apart came up in {_MAP_TRIES} draws")
