"""Seeded map generators for the five map families the learning work uses.

Each family function takes an ``np.random.Generator`` and a map side ``size`` and returns a
``Problem`` on a ``size x size`` ``OccupancyGrid``. Every dimension scales with ``size`` (the
numbers quoted in docstrings are for ``size = 128``), so 64 looks like a coarser 128 and 512 like a
finer one. Start and goal are free cell centres, 4-connected through free cells (what the
continuous collision model allows), at least ``size / 2`` apart along the octile shortest path,
and further apart in a straight line than the goal tolerance; ``reference_length`` is that octile
shortest-path length. All randomness comes from the generator passed in.
"""

from __future__ import annotations

import numbers

import numpy as np

from planners.base.fileio import InputError, check_int, env_limit
from planners.base.problem import Problem
from planners.maps.caves import cave_map
from planners.maps.gridsearch import distance_field, free_components
from planners.maps.strokes import stroke_map
from planners.worlds.grid import OccupancyGrid

FAMILIES = ("forest", "narrow_passage", "bugtrap", "maze", "rooms")

# Seed ranges of the map splits. Training draws seeds from TRAIN_SEEDS; validation, tuning and test
# maps take consecutive seeds from their SEED0, so no split ever holds another split's maps.
TRAIN_SEEDS = (0, 100_000)
VALIDATION_SEED0 = 200_000
TUNING_SEED0 = 300_000
TEST_SEED0 = 1_000_000
#: Seeds of the shifted test maps (``generate(..., shifted=True)``): generators of their own, never used
#: for training, validation or tuning; the range only keeps their names apart from the others.
SHIFTED_SEED0 = 2_000_000
#: Map sides of the shifted test set, one per map in turn (training draws 64 and 128).
SHIFTED_SIZES = (64, 96, 128, 192, 256)

#: Smallest map side ``generate`` accepts: below it the narrowest features would be under 2 cells.
MIN_SIZE = 32
#: Largest generated map side unless raised: a map of side N holds N*N cells, and planning on it (the
#: grid, its distance field and the search's arrays) takes about 35 bytes per cell: 4096 -> about 0.6 GB
#: (docs/limits.md).
DEFAULT_MAX_SIZE = 4096
#: The environment variable that raises (or lowers) ``DEFAULT_MAX_SIZE``.
MAX_SIZE_ENV = "SAMPLERGYM_MAX_MAP_SIDE"


def max_size_limit() -> int:
    """The largest generated map side in force: ``$SAMPLERGYM_MAX_MAP_SIDE`` if set, else ``DEFAULT_MAX_SIZE``."""
    return env_limit(MAX_SIZE_ENV, DEFAULT_MAX_SIZE, low=MIN_SIZE)


def check_size(size, name: str = "size") -> int:
    """``size`` as a map side in [``MIN_SIZE``, the limit in force], or an ``InputError`` naming ``name``."""
    size = check_int(size, name, low=MIN_SIZE)
    limit = max_size_limit()
    if size > limit:
        raise InputError(f"{name} = {size}: generated maps are at most {limit} cells a side (about "
                         f"{35 * size * size / 1e9:.1f} GB to plan on this one); if that is intended, set "
                         f"{MAX_SIZE_ENV}={size}")
    return size

# rejection budget for a query's goal: every family leaves a large pool of valid starts per goal, so
# in practice the first try succeeds; the bound only turns a broken design into a clear error
_QUERY_TRIES = 32
# forest maps, unlike the others, can seal a corner region off entirely: redraw the map then
_MAP_TRIES = 16


def _scaled(size: int, cells: float, lo: int = 1) -> int:
    """``cells`` at size 128, scaled in proportion to ``size`` (rounded half up), at least ``lo``."""
    return max(lo, int(cells * size / 128 + 0.5))


def _between(rng: np.random.Generator, lo: int, hi: int) -> int:
    """A uniform integer in ``[lo, hi]`` (both ends included)."""
    return int(rng.integers(lo, hi + 1))


def _symmetry(rng: np.random.Generator):
    """A uniformly random one of the 8 symmetries of the square, as a function on (H, W) arrays."""
    turns, flip = _between(rng, 0, 3), bool(rng.integers(2))

    def apply(a: np.ndarray) -> np.ndarray:
        a = np.rot90(a, turns)
        return np.ascontiguousarray(a[:, ::-1] if flip else a)

    return apply


def _box(size: int, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
    """Mask of rows ``[r0, r1)`` and columns ``[c0, c1)``, clipped to the map."""
    m = np.zeros((size, size), dtype=bool)
    m[max(r0, 0) : max(r1, 0), max(c0, 0) : max(c1, 0)] = True
    return m


def _query(
    rng: np.random.Generator,
    obs: np.ndarray,
    goal_mask: np.ndarray,
    start_mask: np.ndarray,
    *,
    goal_tolerance: float,
    name: str,
) -> Problem | None:
    """A problem with its goal drawn from ``goal_mask`` and its start from ``start_mask``, or None.

    Both are drawn from the free cells of the largest 4-connected free component. Rejection: draw a
    goal, keep the starts at least ``size / 2`` away along the octile shortest path and more than
    ``goal_tolerance`` away in a straight line, and draw one of them; redraw the goal if none is left.
    """
    size = obs.shape[0]
    min_geodesic = 0.5 * size
    # only the largest free component: a goal in a sealed pocket would waste a try
    labels = free_components(obs)
    main = labels == np.argmax(np.bincount(labels[labels >= 0]))
    goals = np.argwhere(goal_mask & main)
    rows, cols = np.nonzero(start_mask & main)
    if len(goals) and len(rows):
        for _ in range(_QUERY_TRIES):
            g = goals[rng.integers(len(goals))]
            field = distance_field(obs, (int(g[0]), int(g[1])))
            geo = field[rows, cols]
            far = (geo >= min_geodesic) & (np.hypot(rows - g[0], cols - g[1]) > goal_tolerance)
            ok = np.flatnonzero(far)
            if len(ok):
                i = ok[rng.integers(len(ok))]
                grid = OccupancyGrid(obs)
                return Problem(
                    grid,
                    start=grid.cell_center(rows[i], cols[i]),
                    goal=grid.cell_center(g[0], g[1]),
                    goal_tolerance=goal_tolerance,
                    name=name,
                    reference_length=float(geo[i]) * grid.resolution,
                )
    return None


def _found(problem: Problem | None, name: str, goal_tolerance: float) -> Problem:
    """``problem``, or a RuntimeError if the rejection sampling found none."""
    if problem is None:
        raise RuntimeError(
            f"{name}: no connected start/goal pair at least half the map side apart along the shortest path "
            f"and more than goal_tolerance={goal_tolerance:g} apart in a straight line"
        )
    return problem


def _across(rng: np.random.Generator, obs: np.ndarray, side_a: np.ndarray, side_b: np.ndarray, *,
            goal_tolerance: float, name: str) -> Problem | None:
    """A query from one side to the other (which is the goal's, at random), under a random symmetry."""
    sides = [side_a, side_b]
    if rng.integers(2):
        sides.reverse()
    turn = _symmetry(rng)
    return _query(rng, turn(obs), turn(sides[0]), turn(sides[1]), goal_tolerance=goal_tolerance, name=name)


def _clutter(rng: np.random.Generator, obs: np.ndarray, count: int, lo: int, hi: int, keep_clear: np.ndarray) -> None:
    """Adds up to ``count`` random rectangles with sides in ``[lo, hi]`` that avoid ``keep_clear``."""
    size = obs.shape[0]
    for _ in range(count):
        h, w = _between(rng, lo, hi), _between(rng, lo, hi)
        r, c = _between(rng, 0, size - h), _between(rng, 0, size - w)
        if not keep_clear[r : r + h, c : c + w].any():
            obs[r : r + h, c : c + w] = True


def _forest_map(rng: np.random.Generator, size: int) -> np.ndarray:
    obs = np.zeros((size, size), dtype=bool)
    target = rng.uniform(0.15, 0.25) * size * size
    lo, hi = _scaled(size, 3, 2), _scaled(size, 12, 3)
    covered = 0
    while covered < target:
        if rng.random() < 0.5:
            h, w = _between(rng, lo, hi), _between(rng, lo, hi)
            # top-left corners may hang off the map so the edges get partial shapes too
            r, c = _between(rng, 1 - h, size - 1), _between(rng, 1 - w, size - 1)
            r0, c0 = max(r, 0), max(c, 0)
            shape = np.ones((r + h - r0, c + w - c0), dtype=bool)
        else:
            rad = rng.uniform(lo / 2, hi / 2)
            y, x = rng.uniform(0, size, 2)
            r0, c0 = max(int(y - rad), 0), max(int(x - rad), 0)
            rr, cc = np.ogrid[r0 : min(int(y + rad) + 1, size), c0 : min(int(x + rad) + 1, size)]
            shape = (rr + 0.5 - y) ** 2 + (cc + 0.5 - x) ** 2 <= rad * rad
        patch = obs[r0 : r0 + shape.shape[0], c0 : c0 + shape.shape[1]]
        shape = shape[: patch.shape[0], : patch.shape[1]]
        covered += int((shape & ~patch).sum())
        patch |= shape
    return obs


def forest(
    rng: np.random.Generator, size: int = 128, *, goal_tolerance: float = 4.0, name: str | None = None
) -> Problem:
    """Random rectangles and discs, 3-12 cells across, covering 15-25% of the map.

    Start and goal lie in opposite corner squares of side ``size / 4``. Shapes can seal a corner off
    (rarely, mostly on small maps); then the whole map is redrawn.
    """
    name = name or f"forest-{size}"
    q = size // 4
    problem = None
    for _ in range(_MAP_TRIES):
        obs = _forest_map(rng, size)
        corners = [_box(size, 0, q, 0, q), _box(size, size - q, size, size - q, size)]
        if rng.integers(2):  # the other diagonal
            corners = [np.ascontiguousarray(m[:, ::-1]) for m in corners]
        if rng.integers(2):
            corners.reverse()
        problem = _query(rng, obs, corners[0], corners[1], goal_tolerance=goal_tolerance, name=name)
        if problem is not None:
            break
    return _found(problem, name, goal_tolerance)


def narrow_passage(
    rng: np.random.Generator, size: int = 128, *, goal_tolerance: float = 4.0, name: str | None = None
) -> Problem:
    """A wall 2-4 cells thick across the whole map with one gap 2-3 cells wide, and a few small blocks.

    The wall runs vertically or horizontally within the middle fifth of the map; the gap lies
    anywhere but the outer eighths of the wall; start and goal are on opposite sides, each at least
    ``size / 8`` from the wall.
    """
    obs = np.zeros((size, size), dtype=bool)
    thick = _between(rng, _scaled(size, 2, 2), _scaled(size, 4, 2))
    gap = _between(rng, _scaled(size, 2, 2), _scaled(size, 3, 2))
    # drawn as a vertical wall at columns [x0, x1); the random symmetry below turns it
    x0 = _between(rng, int(0.4 * size), int(0.6 * size) - thick)
    x1 = x0 + thick
    obs[:, x0:x1] = True
    y0 = _between(rng, size // 8, size - size // 8 - gap)
    obs[y0 : y0 + gap, x0:x1] = False
    # blocks stay clear of the wall, so the gap is never narrowed or sealed off
    clear = _scaled(size, 3, 2)
    near_wall = _box(size, 0, size, x0 - clear, x1 + clear)
    _clutter(rng, obs, _between(rng, 3, 8), _scaled(size, 3), _scaled(size, 10), near_wall)
    name = name or f"narrow_passage-{size}"
    problem = _across(rng, obs, _box(size, 0, size, 0, x0 - size // 8), _box(size, 0, size, x1 + size // 8, size),
                      goal_tolerance=goal_tolerance, name=name)
    return _found(problem, name, goal_tolerance)


def bugtrap(
    rng: np.random.Generator, size: int = 128, *, goal_tolerance: float = 4.0, name: str | None = None
) -> Problem:
    """A U-shaped trap with walls 2 cells thick and an inside 32-42 cells wide and deep.

    The start lies in the third of the inside next to the back wall, the goal beyond the back wall
    (at least ``size / 8`` past it, within the rows the trap spans), and the opening faces away from
    the goal, so the straight segment from start to goal always crosses the back wall. A few small
    blocks lie well clear of the trap.
    """
    obs = np.zeros((size, size), dtype=bool)
    t = _scaled(size, 2)
    inner = _between(rng, size // 4, size // 3)  # between the two arms
    depth = _between(rng, size // 4, size // 3)  # from the opening to the back wall
    outer = inner + 2 * t
    # drawn opening west, back wall east at columns [xb, xb + t), goal further east; turned below
    x0 = _between(rng, size // 8, size // 4)
    xb = x0 + depth
    y0 = _between(rng, size // 8, size - size // 8 - outer)
    obs[y0 : y0 + t, x0 : xb + t] = True
    obs[y0 + outer - t : y0 + outer, x0 : xb + t] = True
    obs[y0 : y0 + outer, xb : xb + t] = True
    # the margin keeps every way out of the trap and around it free of clutter
    clear = _scaled(size, 6, 3)
    around = _box(size, y0 - clear, y0 + outer + clear, 0, xb + t + clear)
    _clutter(rng, obs, _between(rng, 2, 6), _scaled(size, 3), _scaled(size, 8), around)
    side = max(1, inner // 8)
    inside = _box(size, y0 + t + side, y0 + outer - t - side, xb - max(1, depth // 3), xb)
    beyond = _box(size, y0, y0 + outer, xb + t + size // 8, size)
    turn = _symmetry(rng)
    name = name or f"bugtrap-{size}"
    problem = _query(rng, turn(obs), turn(beyond), turn(inside), goal_tolerance=goal_tolerance, name=name)
    return _found(problem, name, goal_tolerance)


def maze(
    rng: np.random.Generator, size: int = 128, *, goal_tolerance: float = 4.0, name: str | None = None
) -> Problem:
    """A perfect maze (randomised depth-first search) with corridors 16 cells wide and walls 1-2 thick.

    Corridors are size/8 wide (7 x 7 maze cells at 128): hard for RRT with step 4, but not so narrow
    that most runs hit the 20,000-iteration cap, which would hide the differences between samplers.

    Start and goal are at the centres of two maze cells (lattice squares of the corridor width).
    """
    w = _scaled(size, 16, 2)
    t = _between(rng, _scaled(size, 1), _scaled(size, 2))
    return _maze(rng, size, w, t, 0.0, goal_tolerance=goal_tolerance, name=name or f"maze-{size}")


def long_maze(seed: int | np.random.Generator, size: int, *, goal_tolerance: float = 4.0) -> Problem:
    """The training maze's corridors (16 cells wide, walls 1-2 thick) on a map of any side: long winding routes.

    ``generate("maze", seed, size)`` scales its corridors with the side, so its routes have the same number of
    turns at every size; here the corridors keep their width and a larger map holds more of them (31 x 31 maze
    cells at 512), so the route is longer the larger the map: what a model's reach has to span. Validation
    only (``scripts/experiments/long_mazes.py``); no training or test set uses it. Names read
    ``long-maze-{size}-{seed}``.
    """
    size = check_size(size)
    tol = _check_tolerance(goal_tolerance)
    rng, name = seeded_map(seed, "long-maze", size)
    t = _between(rng, 1, 2)
    return _maze(rng, size, 16, t, 0.0, goal_tolerance=tol, name=name)


def diagonal_maze(seed: int | np.random.Generator, size: int, *, goal_tolerance: float = 4.0) -> Problem:
    """``long_maze``'s corridors turned by 45 degrees: walls one or two cells thick become staircases at a slant.

    The maze is built on a side of ``size * sqrt(2)`` and each cell of the ``size`` x ``size`` map takes the
    state of the maze cell its centre turns onto (outside it: blocked). Start and goal anywhere in the largest
    free region (a maze without a far enough pair is redrawn). Validation only (``long_mazes.py --diagonal``);
    no training or test set uses it. Names read ``diagonal-maze-{size}-{seed}``.
    """
    size = check_size(size)
    tol = _check_tolerance(goal_tolerance)
    rng, name = seeded_map(seed, "diagonal-maze", size)
    side = int(np.ceil(size * np.sqrt(2.0))) + 2

    def draw(r: np.random.Generator, n: int) -> np.ndarray:
        t = _between(r, 1, 2)
        src = _maze(r, side, 16, t, 0.0, goal_tolerance=tol, name=name).world.obstacles
        y, x = np.mgrid[0:n, 0:n] + 0.5 - n / 2
        row = np.floor((y + x) / np.sqrt(2.0) + side / 2).astype(int)
        col = np.floor((x - y) / np.sqrt(2.0) + side / 2).astype(int)
        inside = (row >= 0) & (row < side) & (col >= 0) & (col < side)
        obs = np.ones((n, n), dtype=bool)
        obs[inside] = src[row[inside], col[inside]]
        return obs

    return _anywhere(rng, draw, size, tol, name)


def _check_tolerance(goal_tolerance) -> float:
    """``goal_tolerance`` as a positive finite float, or a ``ValueError`` naming it."""
    try:
        tol = float(goal_tolerance)
    except (TypeError, ValueError):
        tol = float("nan")
    if not (np.isfinite(tol) and tol > 0):
        raise ValueError(f"goal_tolerance must be a positive finite number, got {goal_tolerance!r}")
    return tol


def _maze(rng: np.random.Generator, size: int, w: int, t: int, braid: float, *, goal_tolerance: float,
          name: str) -> Problem:
    """A maze of corridors ``w`` wide and walls ``t`` thick, carved by randomised depth-first search.

    With ``braid > 0`` each wall the search left standing is then removed with that probability (loops).
    Start and goal are at the centres of two maze cells.
    """
    n = (size - t) // (w + t)  # maze cells per side
    margin = (size - t - n * (w + t)) // 2  # the leftover band is solid wall
    obs = np.ones((size, size), dtype=bool)

    def corner(i: int, j: int) -> tuple[int, int]:
        return margin + t + i * (w + t), margin + t + j * (w + t)

    def open_wall(i: int, j: int, a: int, b: int) -> None:
        r, c = corner(min(i, a), min(j, b))
        if a != i:  # the wall below the upper of two vertically adjacent cells
            obs[r + w : r + w + t, c : c + w] = False
        else:
            obs[r : r + w, c + w : c + w + t] = False

    for i in range(n):
        for j in range(n):
            r, c = corner(i, j)
            obs[r : r + w, c : c + w] = False
    seen = np.zeros((n, n), dtype=bool)
    opened = set()
    stack = [(_between(rng, 0, n - 1), _between(rng, 0, n - 1))]
    seen[stack[0]] = True
    while stack:
        i, j = stack[-1]
        nbrs = [(i + di, j + dj) for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1))
                if 0 <= i + di < n and 0 <= j + dj < n and not seen[i + di, j + dj]]
        if not nbrs:
            stack.pop()
            continue
        a, b = nbrs[int(rng.integers(len(nbrs)))]
        open_wall(i, j, a, b)
        opened.add((min(i, a), min(j, b), a != i))
        seen[a, b] = True
        stack.append((a, b))
    if braid > 0:
        for i in range(n):
            for j in range(n):
                for a, b in ((i + 1, j), (i, j + 1)):
                    if a < n and b < n and (i, j, a != i) not in opened and rng.random() < braid:
                        open_wall(i, j, a, b)
    centres = np.zeros((size, size), dtype=bool)
    first = margin + t + w // 2
    centres[first : first + n * (w + t) : w + t, first : first + n * (w + t) : w + t] = True
    problem = _query(rng, obs, centres, centres, goal_tolerance=goal_tolerance, name=name)
    return _found(problem, name, goal_tolerance)


def rooms(
    rng: np.random.Generator, size: int = 128, *, goal_tolerance: float = 4.0, name: str | None = None
) -> Problem:
    """A 3x3 or 4x4 grid of rooms (walls 1-2 thick, jittered) joined by doors 4-6 cells wide.

    Doors follow a random spanning tree of the room grid, so every room is reachable, and each
    remaining wall gets a door with probability 1/4, adding loops. Start and goal lie in rooms at
    least ``k - 1`` steps apart in the room grid (``k`` rooms per side), away from the walls.
    """
    k = _between(rng, 3, 4)
    t = _between(rng, _scaled(size, 1), _scaled(size, 2))
    return _room_grid(rng, size, k, t, (_scaled(size, 4, 2), _scaled(size, 6, 2)), 0.25,
                      goal_tolerance=goal_tolerance, name=name or f"rooms-{size}")


def _room_grid(rng: np.random.Generator, size: int, k: int, t: int, doors: tuple[int, int], loops: float, *,
               goal_tolerance: float, name: str) -> Problem:
    """``k x k`` rooms behind jittered walls ``t`` thick, doors ``doors[0]``-``doors[1]`` cells wide.

    Doors follow a random spanning tree of the room grid, so every room is reachable, and each remaining
    wall gets a door with probability ``loops``. A door is never wider than its room side less 2 cells.
    Start and goal lie in rooms at least ``k - 1`` steps apart, away from the walls.
    """
    span = size / k
    jitter = int(span / 8)
    walls = [int(round(i * span)) + _between(rng, -jitter, jitter) for i in range(1, k)]
    obs = np.zeros((size, size), dtype=bool)
    for e in walls:
        obs[e : e + t, :] = True
        obs[:, e : e + t] = True
    # free extent [lo[i], hi[i]) of room i along either axis
    lo = [0] + [e + t for e in walls]
    hi = walls + [size]
    parent = list(range(k * k))

    def root(a: int) -> int:
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    # (room row, room col) pairs sharing a wall: below and to the right
    pairs = [((i, j), (i + 1, j)) for i in range(k - 1) for j in range(k)]
    pairs += [((i, j), (i, j + 1)) for i in range(k) for j in range(k - 1)]
    for idx in rng.permutation(len(pairs)):
        (i, j), (a, b) = pairs[idx]
        ra, rb = root(i * k + j), root(a * k + b)
        if ra != rb:
            parent[ra] = rb
        elif rng.random() >= loops:
            continue
        # in the wall between the two rooms, within their shared side, a cell clear of the crossing walls
        side = j if a != i else i
        door = _between(rng, doors[0], max(doors[0], min(doors[1], hi[side] - lo[side] - 2)))
        x = _between(rng, lo[side] + 1, hi[side] - 1 - door)
        if a != i:
            obs[walls[i] : walls[i] + t, x : x + door] = False
        else:
            obs[x : x + door, walls[j] : walls[j] + t] = False
    gap = _scaled(size, 2)

    def interior(i: int, j: int) -> np.ndarray:
        return _box(size, lo[i] + gap, hi[i] - gap, lo[j] + gap, hi[j] - gap)

    gi, gj = _between(rng, 0, k - 1), _between(rng, 0, k - 1)
    far = np.zeros((size, size), dtype=bool)
    for i in range(k):
        for j in range(k):
            if abs(i - gi) + abs(j - gj) >= k - 1:
                far |= interior(i, j)
    problem = _query(rng, obs, interior(gi, gj), far, goal_tolerance=goal_tolerance, name=name)
    return _found(problem, name, goal_tolerance)


# Shifted variants: the same five kinds of problem, drawn differently from the training generators
# above, so a sampler tuned or trained on those is tested on layouts it never saw. Each docstring says
# what differs from its training family.


def forest_shifted(
    rng: np.random.Generator, size: int = 128, *, goal_tolerance: float = 4.0, name: str | None = None
) -> Problem:
    """Forest, shifted: denser, with thin bars among the blocks, start and goal at opposite edges.

    Cover 25-35% (training 15-25%); thin bars 1-3 cells thick and 8-40 long beside blocks 2-16 across
    (training: blocks and discs 3-12 across). Start and goal lie in opposite edge bands of width
    ``size / 8`` (training: opposite corners).
    """
    name = name or f"forest-shifted-{size}"
    band = size // 8
    problem = None
    for _ in range(_MAP_TRIES):
        obs = np.zeros((size, size), dtype=bool)
        target = rng.uniform(0.25, 0.35) * size * size
        covered = 0
        while covered < target:
            if rng.random() < 0.5:
                thin = _between(rng, _scaled(size, 1), _scaled(size, 3))
                long = _between(rng, _scaled(size, 8, 2), _scaled(size, 40, 3))
                h, w = (thin, long) if rng.integers(2) else (long, thin)
            else:
                lo, hi = _scaled(size, 2), _scaled(size, 16, 2)
                h, w = _between(rng, lo, hi), _between(rng, lo, hi)
            r, c = _between(rng, 1 - h, size - 1), _between(rng, 1 - w, size - 1)
            patch = obs[max(r, 0) : r + h, max(c, 0) : c + w]
            covered += int((~patch).sum())
            patch[...] = True
        problem = _across(rng, obs, _box(size, 0, size, 0, band), _box(size, 0, size, size - band, size),
                          goal_tolerance=goal_tolerance, name=name)
        if problem is not None:
            break
    return _found(problem, name, goal_tolerance)


def narrow_passage_shifted(
    rng: np.random.Generator, size: int = 128, *, goal_tolerance: float = 4.0, name: str | None = None
) -> Problem:
    """Narrow passage, shifted: one or two thick walls, each gap a short corridor, more clutter.

    Walls 6-12 cells thick (training: one wall, 2-4); each gap 2-4 cells wide (training 2-3) anywhere
    along its wall (training: not in the outer eighths); 6-14 blocks of clutter (training 3-8). Start
    and goal lie beyond the outermost walls, at least ``size / 16`` from them.
    """
    obs = np.zeros((size, size), dtype=bool)
    n_walls = _between(rng, 1, 2)
    spans = [(0.3, 0.7)] if n_walls == 1 else [(0.2, 0.4), (0.6, 0.8)]
    walls = []
    for lo, hi in spans:  # drawn as vertical walls at columns [x0, x1); turned below
        thick = _between(rng, _scaled(size, 6, 3), _scaled(size, 12, 3))
        x0 = _between(rng, int(lo * size), int(hi * size) - thick)
        gap = _between(rng, _scaled(size, 2, 2), _scaled(size, 4, 2))
        y0 = _between(rng, 0, size - gap)
        obs[:, x0 : x0 + thick] = True
        obs[y0 : y0 + gap, x0 : x0 + thick] = False
        walls.append((x0, x0 + thick))
    clear = _scaled(size, 3, 2)
    near_walls = np.zeros((size, size), dtype=bool)
    for x0, x1 in walls:
        near_walls |= _box(size, 0, size, x0 - clear, x1 + clear)
    _clutter(rng, obs, _between(rng, 6, 14), _scaled(size, 2), _scaled(size, 12), near_walls)
    margin = size // 16
    name = name or f"narrow_passage-shifted-{size}"
    problem = _across(rng, obs, _box(size, 0, size, 0, walls[0][0] - margin),
                      _box(size, 0, size, walls[-1][1] + margin, size), goal_tolerance=goal_tolerance, name=name)
    return _found(problem, name, goal_tolerance)


def bugtrap_shifted(
    rng: np.random.Generator, size: int = 128, *, goal_tolerance: float = 4.0, name: str | None = None
) -> Problem:
    """Bugtrap, shifted: a box closed on all sides but for one small opening.

    The opening is 3-6 cells wide, in one of the three walls that do not face the goal (training: a U
    open over its whole width, facing away from the goal); walls 2-4 thick (training 2), inside
    ``size / 6`` to ``size / 2.5`` wide and deep (training ``size / 4`` to ``size / 3``).

    The start lies anywhere inside, clear of the walls; the goal beyond the back wall, as in training,
    so the straight segment from start to goal crosses it. The box is redrawn in the rare case that no
    start is half the map side from the goal along the shortest path.
    """
    name = name or f"bugtrap-shifted-{size}"
    problem = None
    for _ in range(_MAP_TRIES):
        obs = np.zeros((size, size), dtype=bool)
        t = _between(rng, _scaled(size, 2), _scaled(size, 4))
        inner = _between(rng, size // 6, int(size / 2.5))
        depth = _between(rng, size // 6, int(size / 2.5))
        outer = inner + 2 * t
        # drawn with the back wall east at columns [xb, xb + t) and the goal further east; turned below
        x0 = _between(rng, size // 16, size - size // 4 - depth - 2 * t)
        xb = x0 + t + depth
        y0 = _between(rng, size // 16, size - size // 16 - outer)
        obs[y0 : y0 + outer, x0 : xb + t] = True
        obs[y0 + t : y0 + outer - t, x0 + t : xb] = False
        width = _between(rng, _scaled(size, 3, 2), _scaled(size, 6, 2))
        wall = _between(rng, 0, 2)  # north, south or west; never the back wall
        if wall < 2:
            a = _between(rng, x0 + t + 1, xb - 1 - width)
            r = y0 if wall == 0 else y0 + outer - t
            obs[r : r + t, a : a + width] = False
        else:
            a = _between(rng, y0 + t + 1, y0 + outer - t - 1 - width)
            obs[a : a + width, x0 : x0 + t] = False
        clear = _scaled(size, 6, 3)
        around = _box(size, y0 - clear, y0 + outer + clear, x0 - clear, xb + t + clear)
        _clutter(rng, obs, _between(rng, 2, 6), _scaled(size, 3), _scaled(size, 8), around)
        side = max(1, inner // 8)
        inside = _box(size, y0 + t + side, y0 + outer - t - side, x0 + t + side, xb - side)
        beyond = _box(size, y0, y0 + outer, xb + t + size // 8, size)
        turn = _symmetry(rng)
        problem = _query(rng, turn(obs), turn(beyond), turn(inside), goal_tolerance=goal_tolerance, name=name)
        if problem is not None:
            break
    return _found(problem, name, goal_tolerance)


def maze_shifted(
    rng: np.random.Generator, size: int = 128, *, goal_tolerance: float = 4.0, name: str | None = None
) -> Problem:
    """Maze, shifted: braided (with loops), other corridor widths, thicker walls.

    Corridors 8, 10, 12 or 20 cells wide (training 16), walls 2-4 thick (training 1-2), and each wall
    left standing by the depth-first search removed with probability 0.1 (training: a perfect maze).
    """
    w = _scaled(size, float(rng.choice([8, 10, 12, 20])), 2)
    t = _between(rng, _scaled(size, 2), _scaled(size, 4))
    return _maze(rng, size, w, t, 0.1, goal_tolerance=goal_tolerance, name=name or f"maze-shifted-{size}")


def rooms_shifted(
    rng: np.random.Generator, size: int = 128, *, goal_tolerance: float = 4.0, name: str | None = None
) -> Problem:
    """Rooms, shifted: other room counts and door widths, more doors.

    A 2x2, 5x5 or 6x6 grid of rooms (training 3x3 or 4x4), walls 1-3 thick (training 1-2), doors 3-8
    cells wide (training 4-6), and each wall beyond the spanning tree given a door with probability 1/2
    (training 1/4), so there are more doors and more loops. Start and goal lie in rooms at least ``k - 1``
    steps apart in the room grid, as in training.
    """
    k = int(rng.choice([2, 5, 6]))
    t = _between(rng, _scaled(size, 1), _scaled(size, 3))
    return _room_grid(rng, size, k, t, (_scaled(size, 3, 2), _scaled(size, 8, 2)), 0.5,
                      goal_tolerance=goal_tolerance, name=name or f"rooms-shifted-{size}")


def _anywhere(rng: np.random.Generator, draw, size: int, goal_tolerance: float, name: str) -> Problem:
    """A map from ``draw(rng, size)`` with start and goal anywhere in its largest free region; redrawn if none fits."""
    problem = None
    for _ in range(_MAP_TRIES):
        everywhere = np.ones((size, size), dtype=bool)
        problem = _query(rng, draw(rng, size), everywhere, everywhere, goal_tolerance=goal_tolerance, name=name)
        if problem is not None:
            break
    return _found(problem, name, goal_tolerance)


def caves(
    rng: np.random.Generator, size: int = 128, *, goal_tolerance: float = 4.0, name: str = "caves"
) -> Problem:
    """Irregular cave walls at every angle (``planners.maps.caves``): a training-only family, in no test set.

    Start and goal anywhere in the largest free region; a map without a far enough pair is redrawn.
    """
    return _anywhere(rng, cave_map, size, goal_tolerance, name)


def strokes(
    rng: np.random.Generator, size: int = 128, *, goal_tolerance: float = 4.0, name: str = "strokes"
) -> Problem:
    """Thin walls at every angle, straight, bent and curved (``planners.maps.strokes``): training only, in no test set.

    Start and goal anywhere in the largest free region; a map without a far enough pair is redrawn.
    """
    return _anywhere(rng, stroke_map, size, goal_tolerance, name)


_GENERATORS = {"forest": forest, "narrow_passage": narrow_passage, "bugtrap": bugtrap, "maze": maze, "rooms": rooms,
               "caves": caves, "strokes": strokes}
#: The families the route encoder trains on: the five test families' training generators, and caves and strokes,
#: which no test set holds (their walls run at every angle; every other training wall is axis-aligned).
TRAINING_FAMILIES = (*FAMILIES, "caves", "strokes")
_SHIFTED = {"forest": forest_shifted, "narrow_passage": narrow_passage_shifted, "bugtrap": bugtrap_shifted,
            "maze": maze_shifted, "rooms": rooms_shifted}


def seeded_map(seed: int | np.random.Generator, label: str, size: int) -> tuple[np.random.Generator, str]:
    """The generator and the map name of a seed: ``label-size-seed`` for an int seed, ``label-size`` for a Generator.

    Raises:
        ValueError: If an int seed is negative.
        TypeError: If the seed is neither an int nor a ``np.random.Generator``.
    """
    if isinstance(seed, np.random.Generator):
        return seed, f"{label}-{size}"
    if isinstance(seed, numbers.Integral) and not isinstance(seed, bool):
        if seed < 0:
            raise ValueError(f"seed must be a non-negative integer or a np.random.Generator, got {seed!r}")
        return np.random.default_rng(int(seed)), f"{label}-{size}-{seed}"
    raise TypeError(f"seed must be an int or a np.random.Generator, got {type(seed).__name__} {seed!r}")


def generate(
    family: str, seed: int | np.random.Generator, size: int = 128, *, goal_tolerance: float = 4.0, shifted: bool = False
) -> Problem:
    """A seeded problem of one family; the same family, seed, size and variant always give the same problem.

    Args:
        family: One of ``FAMILIES``.
        seed: A non-negative int (named in the problem, ``f"{family}-{size}-{seed}"``) or a
            ``np.random.Generator`` to draw from (the name is then ``f"{family}-{size}"``).
        size: Map side in cells, an integer >= ``MIN_SIZE``.
        goal_tolerance: Goal radius (cells), a positive number.
        shifted: Draw the family's shifted variant (other wall thicknesses, trap shapes, gap widths,
            door counts, densities; see ``forest_shifted`` and its siblings), which training, validation
            and tuning never use; names then read ``f"{family}-shifted-{size}-{seed}"``.

    Raises:
        ValueError: For an unknown family, a size below ``MIN_SIZE`` or above ``max_size_limit()``, a
            negative seed or a non-positive goal tolerance.
    """
    if not isinstance(family, str) or family not in _GENERATORS:
        raise ValueError(f"unknown map family {family!r}; choose from {', '.join(TRAINING_FAMILIES)}")
    if shifted and family not in _SHIFTED:
        raise ValueError(f"map family {family!r} has no shifted variant; those of {', '.join(FAMILIES)} have")
    check_size(size)
    tol = _check_tolerance(goal_tolerance)
    size = int(size)
    rng, name = seeded_map(seed, f"{family}-shifted" if shifted else family, size)
    return (_SHIFTED if shifted else _GENERATORS)[family](rng, size, goal_tolerance=tol, name=name)
