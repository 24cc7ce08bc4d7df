"""Seeded map generators for the five families the learning work uses.

Every generator takes an ``np.random.Generator`` and a map side ``size`` (>= 32; all dimensions scale
with it) and returns a ``Problem`` whose start and goal are free cell centres, connected (4-connected
free cells, which is what the continuous collision model allows), at least ``size / 2`` apart along
the shortest grid path, with ``reference_length`` set to that octile shortest-path length.
"""

from __future__ import annotations

import numpy as np

from planners.grid import OccupancyGrid
from planners.gridsearch import distance_field
from planners.problem import Problem

FAMILIES = ("forest", "narrow_passage", "bugtrap", "maze", "rooms")


def _scale(size: int, base: float) -> int:
    """``base`` cells at size 128, scaled linearly, at least 1."""
    return max(1, int(round(base * size / 128)))


def _orient(obs: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, int, bool, bool]:
    """A random one of the 8 symmetries of the square; returns it with its parameters."""
    k = int(rng.integers(4))
    fx, fy = bool(rng.integers(2)), bool(rng.integers(2))
    return _apply(obs, k, fx, fy), k, fx, fy


def _apply(a: np.ndarray, k: int, fx: bool, fy: bool) -> np.ndarray:
    a = np.rot90(a, k)
    if fx:
        a = a[:, ::-1]
    if fy:
        a = a[::-1, :]
    return np.ascontiguousarray(a)


def _query(rng: np.random.Generator, obs: np.ndarray, start_mask: np.ndarray, goal_mask: np.ndarray,
           goal_tolerance: float, min_geo: float, name: str, tries: int = 50) -> Problem:
    """Pick a goal in ``goal_mask`` and a start in ``start_mask`` at least ``min_geo`` apart (geodesic)."""
    size = obs.shape[0]
    for _ in range(tries):
        goals = np.argwhere(goal_mask & ~obs)
        if len(goals) == 0:
            break
        g = tuple(goals[rng.integers(len(goals))])
        field = distance_field(obs, g)
        ok = start_mask & np.isfinite(field) & (field >= min_geo)
        # the straight-line distance must exceed the goal radius too
        rr, cc = np.nonzero(ok)
        far = np.hypot(rr - g[0], cc - g[1]) > goal_tolerance + 1.0
        cand = np.stack([rr[far], cc[far]], axis=1)
        if len(cand) == 0:
            continue
        s = tuple(cand[rng.integers(len(cand))])
        grid = OccupancyGrid(obs)
        return Problem(grid, grid.cell_center(*s), grid.cell_center(*g), goal_tolerance=goal_tolerance, name=name,
                       reference_length=float(field[s]))
    raise RuntimeError(f"{name}: found no connected start/goal pair at least {min_geo:g} cells apart")


def _corner_mask(size: int, corner: tuple[int, int], extent: float) -> np.ndarray:
    r, c = np.mgrid[0:size, 0:size]
    cr, cc = corner
    return (np.abs(r - cr * (size - 1)) < extent) & (np.abs(c - cc * (size - 1)) < extent)


def forest(rng: np.random.Generator, size: int = 128, goal_tolerance: float = 4.0, name: str = "forest") -> Problem:
    """Random rectangles and discs (15-25% obstacles); start and goal near opposite corners."""
    obs = np.zeros((size, size), dtype=bool)
    target = rng.uniform(0.15, 0.25)
    r, c = np.mgrid[0:size, 0:size]
    lo, hi = max(2, size // 32), max(3, size // 10)
    while obs.mean() < target:
        if rng.random() < 0.5:
            h, w = rng.integers(lo, hi + 1, 2)
            y, x = rng.integers(0, size - 1, 2)
            obs[y:y + h, x:x + w] = True
        else:
            rad = rng.uniform(lo / 2, hi / 2)
            y, x = rng.uniform(0, size, 2)
            obs |= (r + 0.5 - y) ** 2 + (c + 0.5 - x) ** 2 <= rad**2
    corner = (int(rng.integers(2)), int(rng.integers(2)))
    opposite = (1 - corner[0], 1 - corner[1])
    return _query(rng, obs, _corner_mask(size, corner, size / 4), _corner_mask(size, opposite, size / 4),
                  goal_tolerance, 0.5 * size, name)


def narrow_passage(rng: np.random.Generator, size: int = 128, goal_tolerance: float = 4.0,
                   name: str = "narrow_passage") -> Problem:
    """A wall across the map with one narrow gap (2-3 cells at 128); start and goal on either side."""
    obs = np.zeros((size, size), dtype=bool)
    thick = int(rng.integers(_scale(size, 2), _scale(size, 4) + 1))
    gap = int(rng.integers(_scale(size, 2), _scale(size, 3) + 1))
    x0 = int(rng.integers(int(0.4 * size), int(0.6 * size) - thick))
    obs[:, x0:x0 + thick] = True
    y0 = int(rng.integers(size // 8, size - size // 8 - gap))
    obs[y0:y0 + gap, x0:x0 + thick] = False
    # a few small obstacles away from the wall and the gap
    for _ in range(int(rng.integers(3, 8))):
        h, w = rng.integers(_scale(size, 3), _scale(size, 10) + 1, 2)
        y = int(rng.integers(0, size - h))
        x = int(rng.integers(0, size - w))
        if x + w < x0 - 2 or x > x0 + thick + 2:
            obs[y:y + h, x:x + w] = True
    left = np.zeros_like(obs)
    left[:, : max(1, x0 - size // 8)] = True
    right = np.zeros_like(obs)
    right[:, min(size - 1, x0 + thick + size // 8):] = True
    # orient before choosing the query so the masks turn with the map
    obs, k, fx, fy = _orient(obs, rng)
    left, right = _apply(left, k, fx, fy), _apply(right, k, fx, fy)
    return _query(rng, obs, left, right, goal_tolerance, 0.5 * size, name)


def bugtrap(rng: np.random.Generator, size: int = 128, goal_tolerance: float = 4.0, name: str = "bugtrap") -> Problem:
    """Start deep inside a U whose opening faces away from the goal."""
    obs = np.zeros((size, size), dtype=bool)
    t = _scale(size, 2)
    side = int(rng.integers(size // 4, size // 3 + 1))
    depth = int(rng.integers(int(0.8 * side), int(1.2 * side) + 1))
    y0 = int(rng.integers(size // 6, size - size // 6 - side))
    x0 = int(rng.integers(size // 8, size // 3))
    x1 = x0 + depth  # back wall of the U; the opening is on the left (x0)
    obs[y0:y0 + t, x0:x1 + t] = True
    obs[y0 + side - t:y0 + side, x0:x1 + t] = True
    obs[y0:y0 + side, x1:x1 + t] = True
    # a little clutter outside the trap
    for _ in range(int(rng.integers(2, 6))):
        h, w = rng.integers(_scale(size, 3), _scale(size, 8) + 1, 2)
        y = int(rng.integers(0, size - h))
        x = int(rng.integers(0, size - w))
        if x > x1 + t + 3 or y + h < y0 - 3 or y > y0 + side + 3:
            obs[y:y + h, x:x + w] = True
    inside = np.zeros_like(obs)
    margin = max(t + 1, side // 5)
    inside[y0 + margin:y0 + side - margin, x1 - max(2, depth // 3):x1] = True
    goal = np.zeros_like(obs)
    goal[y0 - side // 4:y0 + side + side // 4, min(size - 2, x1 + t + size // 5):] = True
    obs, k, fx, fy = _orient(obs, rng)
    inside, goal = _apply(inside, k, fx, fy), _apply(goal, k, fx, fy)
    return _query(rng, obs, inside, goal, goal_tolerance, 0.5 * size, name)


def maze(rng: np.random.Generator, size: int = 128, goal_tolerance: float = 4.0, name: str = "maze") -> Problem:
    """A perfect maze (randomised depth-first search) of corridors about size/8 wide (7 x 7 cells at 128)."""
    w = max(2, size // 8)
    t = max(1, int(round(size / 128)))
    n = (size - t) // (w + t)
    obs = np.ones((size, size), dtype=bool)
    cell = lambda i, j: (t + i * (w + t), t + j * (w + t))  # noqa: E731  top-left of maze cell (i, j)
    for i in range(n):
        for j in range(n):
            r, c = cell(i, j)
            obs[r:r + w, c:c + w] = False
    seen = np.zeros((n, n), dtype=bool)
    stack = [(int(rng.integers(n)), int(rng.integers(n)))]
    seen[stack[0]] = True
    while stack:
        i, j = stack[-1]
        nbrs = [(i + di, j + dj) for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1))
                if 0 <= i + di < n and 0 <= j + dj < n and not seen[i + di, j + dj]]
        if not nbrs:
            stack.pop()
            continue
        a, b = nbrs[int(rng.integers(len(nbrs)))]
        r, c = cell(min(i, a), min(j, b))
        if a != i:  # knock down the wall between vertically adjacent cells
            obs[r + w:r + w + t, c:c + w] = False
        else:
            obs[r:r + w, c + w:c + w + t] = False
        seen[a, b] = True
        stack.append((a, b))
    free = ~obs
    return _query(rng, obs, free, free, goal_tolerance, max(0.5 * size, 0.0), name)


def rooms(rng: np.random.Generator, size: int = 128, goal_tolerance: float = 4.0, name: str = "rooms") -> Problem:
    """A k x k grid of rooms (k = 3-4 at 128) joined by doors 4-6 cells wide along a spanning tree."""
    k = int(rng.integers(max(2, size // 42), max(2, size // 32) + 1))
    t = max(1, _scale(size, 1.5))
    obs = np.zeros((size, size), dtype=bool)
    edges = np.linspace(0, size, k + 1).round().astype(int)
    for e in edges[1:-1]:
        obs[e - t // 2:e - t // 2 + t, :] = True
        obs[:, e - t // 2:e - t // 2 + t] = True
    # doors along a random spanning tree of the room grid, plus a few extra
    parent = {(i, j): (i, j) for i in range(k) for j in range(k)}

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    walls = [((i, j), (i + 1, j)) for i in range(k - 1) for j in range(k)]
    walls += [((i, j), (i, j + 1)) for i in range(k) for j in range(k - 1)]
    order = rng.permutation(len(walls))
    for idx in order:
        a, b = walls[idx]
        joined = find(a) != find(b)
        if joined:
            parent[find(a)] = find(b)
        if not joined and rng.random() > 0.2:
            continue
        door = int(rng.integers(_scale(size, 4), _scale(size, 6) + 1))
        if a[0] != b[0]:  # wall between room rows a[0] and b[0] at edges[b[0]]
            e = edges[b[0]]
            lo, hi = edges[a[1]] + t + 1, edges[a[1] + 1] - t - door - 1
            x = int(rng.integers(lo, max(lo + 1, hi)))
            obs[e - t // 2:e - t // 2 + t, x:x + door] = False
        else:
            e = edges[b[1]]
            lo, hi = edges[a[0]] + t + 1, edges[a[0] + 1] - t - door - 1
            y = int(rng.integers(lo, max(lo + 1, hi)))
            obs[y:y + door, e - t // 2:e - t // 2 + t] = False
    free = ~obs
    return _query(rng, obs, free, free, goal_tolerance, 0.5 * size, name)


_GENERATORS = {"forest": forest, "narrow_passage": narrow_passage, "bugtrap": bugtrap, "maze": maze, "rooms": rooms}


def generate(family: str, seed: int | np.random.Generator, size: int = 128, *, goal_tolerance: float = 4.0) -> Problem:
    """A seeded problem of the given family; the same seed always gives the same map and query."""
    if family not in _GENERATORS:
        raise ValueError(f"unknown map family {family!r}; choose from {FAMILIES}")
    if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or size < 32:
        raise ValueError(f"size must be an integer >= 32, got {size!r}")
    if isinstance(seed, np.random.Generator):
        rng, name = seed, f"{family}-{size}"
    else:
        rng, name = np.random.default_rng(seed), f"{family}-{size}-{seed}"
    return _GENERATORS[family](rng, int(size), goal_tolerance, name)
