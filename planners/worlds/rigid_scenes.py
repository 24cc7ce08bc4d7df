"""Seeded scene families for the 6-DoF box body, and the split of their seeds into train, validation, tuning and test.

Every scene is the seed project's kind: a 10 x 5 x 2.5 box (``box_body``, 16 points) in a
100 x 60 x 40 workspace (``planners/scenes/window.scene``), checked at ``delta`` 0.5, with a goal
distance of 1.0. Each family builds passages the body can only pass after turning, because every
opening is narrower than the body's long side (10) in at least one direction:

Training families (train, validation, tuning and test parts):

- ``slot``: one wall across x, 1.5 to 2.5 thick, with a slot 9.5 to 10.4 by 5.2 to 5.45 (upright
  or lying), anywhere in the wall: the body passes long side first (the slot is narrower than the
  long side plus the check's margin one way and than the middle side the other), turned about its
  long axis to the slot.
- ``windows``: two or three walls across x, 18 to 24 apart, each with a window 10 to 12.5 square
  (about the body's long side: the body passes long side first, or flat across the wider ones),
  the windows at least 15 apart in (y, z) from one wall to the next: the route zigzags between them.
- ``duct``: a wall 5 to 8 thick with a rectangular duct through it (9.5 to 10.4 by 5.2 to 5.45),
  then a wall with a low band: a slit 5.2 to 5.45 high over the whole width, so the body lies flat.
- ``shelves``: a block 6 to 10 deep with three or four compartments 5.2 to 5.45 high and 12 to 20
  wide stacked in z; one is open at the back, the others are dead ends.
- ``clutter``: a window wall (window 8.5 to 11 square) among 100 to 250 small boxes (sides 0.5 to
  2) strewn over the whole workspace.

Test-only families (``TEST_ONLY_FAMILIES``: a test part only, seeds from ``UNSEEN_SEED0``):

- ``hatch``: a floor across z (1.5 to 2.5 thick) with a hatch like the slot; start below,
  goal above. The passage runs along z, so the body must pitch its long side upright, which no
  training family asks for (every training passage runs along x).
- ``elbow``: a slot in a wall across x, then a slot in a wall across y: the route turns a right
  angle between two passages, and the second one runs along y.

Splits are those of the generated 2-D map families (``planners.maps.generators``): training draws
seeds from ``TRAIN_SEEDS``, validation, tuning and test scenes take consecutive seeds from
``VALIDATION_SEED0``, ``TUNING_SEED0`` and ``TEST_SEED0``, the test-only families from
``UNSEEN_SEED0``; a scene is ``(family, seed)`` and nothing else, so no part holds another part's
scenes.

Every scene is solvable: ``rigid_scene`` draws the geometry and the query from
``np.random.default_rng(seed)`` and builds a witness path (``verify_scene``): the body turned to fit
each opening stands before and after it, the legs between those poses, the start and the goal are
straight motions or seeded RRT-Connect runs, and the exact motion check passes the whole path. A
draw without one is replaced by the generator's next draw, at most ``SCENE_TRIES`` times (then
``RuntimeError``). Numpy and the project's own planners only (mesh scenes: the ``mesh`` extra).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from planners.base.fileio import InputError, check_int
from planners.base.problem import Problem
from planners.maps.generators import TEST_SEED0, TRAIN_SEEDS, TUNING_SEED0, VALIDATION_SEED0
from planners.maps.unseen import UNSEEN_SEED0
from planners.worlds.rigid3d import RRT_SETUP, RigidBodyWorld, box_body

#: Families with every part (train, validation, tuning, test).
TRAINING_FAMILIES = ("slot", "windows", "duct", "shelves", "clutter")
#: Families used for nothing but testing.
TEST_ONLY_FAMILIES = ("hatch", "elbow")
FAMILIES = TRAINING_FAMILIES + TEST_ONLY_FAMILIES
#: The parts of a scene set, in order.
PARTS = ("train", "validation", "tuning", "test")

#: The workspace (its low corner is the origin), the body's sides, the check resolution and goal distance.
WORKSPACE = (100.0, 60.0, 40.0)
BODY_SIDES = (10.0, 5.0, 2.5)
DELTA = 0.5
GOAL_DISTANCE = RRT_SETUP["goal_distance"]
#: Least clearance of a drawn start or goal (body points from every box and from the walls).
QUERY_CLEARANCE = 2 * DELTA

#: Most iterations of each seeded RRT-Connect leg of a scene's witness path.
VERIFY_ITERATIONS = 20_000
#: Draws per scene before ``rigid_scene`` gives up.
SCENE_TRIES = 8

_SEED0 = {"validation": VALIDATION_SEED0, "tuning": TUNING_SEED0, "test": TEST_SEED0}


def scene_seeds(family: str, part: str, count: int, first: int = 0) -> list[int]:
    """The seeds of ``count`` scenes of ``family`` in ``part``, from its ``first``-th scene on (0: its first).

    Validation, tuning and test scenes take consecutive seeds from the part's first seed; the
    test-only families take theirs from ``UNSEEN_SEED0``, in the test part only.
    ``train`` draws from ``TRAIN_SEEDS`` instead (``RigidSceneSet.sample``); asking it for a fixed list
    is refused, as is any part but ``test`` of a test-only family.
    """
    _check_family(family)
    check_int(count, "count", low=0)
    check_int(first, "first", low=0)
    if part not in PARTS:
        raise InputError(f"unknown part {part!r}; choose from {', '.join(PARTS)}")
    if family in TEST_ONLY_FAMILIES:
        if part != "test":
            raise InputError(f"scene family {family!r} is test-only: it has no {part!r} part")
        return [UNSEEN_SEED0 + i for i in range(first, first + count)]
    if part == "train":
        raise InputError("the train part draws its seeds from TRAIN_SEEDS (RigidSceneSet.sample), it has no fixed list")
    return [_SEED0[part] + i for i in range(first, first + count)]


def _check_family(family) -> None:
    if not isinstance(family, str) or family not in _BUILDERS:
        raise InputError(f"unknown scene family {family!r}; choose from {', '.join(FAMILIES)}")


# --- geometry ------------------------------------------------------------------------------------


def subtract_box(box: np.ndarray, hole: np.ndarray) -> list[np.ndarray]:
    """The closed box ``box`` less the open box ``hole``, as at most six boxes (rows ``x0 y0 z0 x1 y1 z1``).

    The pieces cover ``box`` outside the hole and meet only on faces. A hole that misses ``box``
    leaves it whole.
    """
    box = np.asarray(box, dtype=np.float64)
    hole = np.asarray(hole, dtype=np.float64)
    lo, hi = box[:3].copy(), box[3:].copy()
    hlo, hhi = np.maximum(lo, hole[:3]), np.minimum(hi, hole[3:])
    if np.any(hlo >= hhi):
        return [box]
    out = []
    for axis in range(3):  # peel the slabs below and above the hole along each axis in turn
        if lo[axis] < hlo[axis]:
            piece_hi = hi.copy()
            piece_hi[axis] = hlo[axis]
            out.append(np.concatenate([lo, piece_hi]))
        if hhi[axis] < hi[axis]:
            piece_lo = lo.copy()
            piece_lo[axis] = hhi[axis]
            out.append(np.concatenate([piece_lo, hi]))
        lo[axis], hi[axis] = hlo[axis], hhi[axis]
    return out


def carve(solid: np.ndarray, holes: list[np.ndarray]) -> list[np.ndarray]:
    """The box ``solid`` with every box of ``holes`` cut out, as a list of boxes."""
    pieces = [np.asarray(solid, dtype=np.float64)]
    for hole in holes:
        pieces = [p for piece in pieces for p in subtract_box(piece, hole)]
    return pieces


def _slab(axis: int, a: float, b: float) -> np.ndarray:
    """The whole workspace between ``a`` and ``b`` along ``axis``."""
    lo, hi = np.zeros(3), np.array(WORKSPACE)
    lo[axis], hi[axis] = a, b
    return np.concatenate([lo, hi])


def _opening(axis: int, a: float, b: float, centre: tuple[float, float], sides: tuple[float, float]) -> np.ndarray:
    """A hole through the slab ``[a, b]`` along ``axis``, centred at ``centre`` on the two other axes."""
    lo, hi = np.zeros(3), np.zeros(3)
    others = [k for k in range(3) if k != axis]
    lo[axis], hi[axis] = a - 1.0, b + 1.0
    for k, c, s in zip(others, centre, sides, strict=True):
        lo[k], hi[k] = c - s / 2, c + s / 2
    return np.concatenate([lo, hi])


def _centre_in(rng: np.random.Generator, axis: int, sides: tuple[float, float], margin: float = 3.0):
    """A random centre for an opening of ``sides`` in a wall across ``axis``, ``margin`` from the workspace edges."""
    others = [k for k in range(3) if k != axis]
    return tuple(float(rng.uniform(margin + s / 2, WORKSPACE[k] - margin - s / 2))
                 for k, s in zip(others, sides, strict=True))


def _slot_sides(rng: np.random.Generator) -> tuple[float, float]:
    """Sides of a slot narrower than the body's long side and its middle side: upright or lying at random."""
    wide, narrow = rng.uniform(9.5, 10.4), rng.uniform(5.2, 5.45)
    return (wide, narrow) if rng.random() < 0.5 else (narrow, wide)


def _wall(axis: int, a: float, b: float, holes: list[np.ndarray]) -> list[np.ndarray]:
    return carve(_slab(axis, a, b), holes)


#: How far before and after a passage its witness poses stand: half the body's long side and room to spare.
_STANDOFF = 6.5


def _aligned(long_axis: int, wide_axis: int) -> np.ndarray:
    """Quarter-turn angles that put the body's long side along ``long_axis``, its middle side along ``wide_axis``."""
    from planners.worlds.rigid3d import rotation_matrix

    quarter = (-math.pi / 2, 0.0, math.pi / 2, -math.pi)
    for tx in quarter:
        for ty in quarter:
            for tz in quarter:
                R = np.abs(rotation_matrix(tx, ty, tz))
                if R[long_axis, 0] > 0.5 and R[wide_axis, 1] > 0.5:
                    return np.array([tx, ty, tz])
    raise AssertionError("every axis-aligned orientation is a product of quarter turns")


def _through(axis: int, a: float, b: float, centre, sides) -> tuple[np.ndarray, np.ndarray]:
    """The witness poses before and after an opening of ``sides`` at ``centre`` through the slab ``[a, b]``."""
    others = [k for k in range(3) if k != axis]
    angles = _aligned(axis, others[0] if sides[0] >= sides[1] else others[1])
    p = np.zeros(3)
    p[others[0]], p[others[1]] = centre
    front, back = p.copy(), p.copy()
    front[axis], back[axis] = a - _STANDOFF, b + _STANDOFF
    return np.concatenate([front, angles]), np.concatenate([back, angles])


def _slotted_wall(rng: np.random.Generator, axis: int, a: float, b: float, sides, centre=None):
    """A wall across ``axis`` over ``[a, b]`` with an opening of ``sides``; its boxes and its witness poses."""
    centre = _centre_in(rng, axis, sides) if centre is None else centre
    return _wall(axis, a, b, [_opening(axis, a, b, centre, sides)]), _through(axis, a, b, centre, sides)


def _slot(rng: np.random.Generator):
    c, t = rng.uniform(40.0, 60.0), rng.uniform(1.5, 2.5)
    boxes, poses = _slotted_wall(rng, 0, c - t / 2, c + t / 2, _slot_sides(rng))
    return boxes, _before(0, c - t / 2), _after(0, c + t / 2), [poses]


def _windows(rng: np.random.Generator):
    k = int(rng.integers(2, 4))
    gaps = rng.uniform(18.0, 24.0, k - 1)
    first = rng.uniform(20.0, 80.0 - gaps.sum())
    xs = np.concatenate([[first], first + np.cumsum(gaps)])
    boxes, passages, last = [], [], None
    for x in xs:
        t, s = rng.uniform(1.5, 3.0), rng.uniform(10.0, 12.5)
        for _ in range(100):  # windows at least 15 apart from one wall to the next
            c = _centre_in(rng, 0, (s, s))
            if last is None or math.dist(c, last) >= 15.0:
                break
        last = c
        wall, poses = _slotted_wall(rng, 0, x - t / 2, x + t / 2, (s, s), c)
        boxes += wall
        passages.append(poses)
    return boxes, _before(0, xs[0] - 1.5), _after(0, xs[-1] + 1.5), passages


def _duct(rng: np.random.Generator):
    t = rng.uniform(5.0, 8.0)
    a = rng.uniform(25.0, 45.0)
    w, h = rng.uniform(9.5, 10.4), rng.uniform(5.2, 5.45)
    boxes, duct = _slotted_wall(rng, 0, a, a + t, (w, h) if rng.random() < 0.5 else (h, w))
    b = a + t + rng.uniform(14.0, 20.0)  # the low band: a slit over the whole width
    tb, hb = rng.uniform(2.0, 4.0), rng.uniform(5.2, 5.45)
    zb = rng.uniform(3.0 + hb / 2, WORKSPACE[2] - 3.0 - hb / 2)
    band, poses = _slotted_wall(rng, 0, b, b + tb, (WORKSPACE[1] + 2.0, hb), (float(duct[1][1]), zb))
    return boxes + band, _before(0, a), _after(0, b + tb), [duct, poses]


def _shelves(rng: np.random.Generator):
    d = rng.uniform(6.0, 10.0)
    a = rng.uniform(30.0, 70.0 - d)
    n = int(rng.integers(3, 5))
    open_one = int(rng.integers(n))
    heights = rng.uniform(5.2, 5.45, n)
    boards = rng.uniform(1.5, 3.0, n + 1)
    room = WORKSPACE[2] - boards.sum() - heights.sum()
    z = boards[0] + rng.uniform(0.0, max(room, 0.0))  # the stack sits at a random height
    holes, poses = [], None
    for i in range(n):
        w = rng.uniform(12.0, 20.0)
        y = rng.uniform(3.0 + w / 2, WORKSPACE[1] - 3.0 - w / 2)
        back = a + d + 1.0 if i == open_one else a + d - 2.0  # dead ends keep a back board 2 thick
        holes.append(np.array([a - 1.0, y - w / 2, z, back, y + w / 2, z + heights[i]]))
        if i == open_one:
            poses = _through(0, a, a + d, (y, z + heights[i] / 2), (w, heights[i]))
        z += heights[i] + boards[i + 1]
    return carve(_slab(0, a, a + d), holes), _before(0, a), _after(0, a + d), [poses]


def _clutter(rng: np.random.Generator):
    c, t, s = rng.uniform(40.0, 60.0), rng.uniform(1.5, 3.0), rng.uniform(8.5, 11.0)
    boxes, poses = _slotted_wall(rng, 0, c - t / 2, c + t / 2, (s, s))
    n = int(rng.integers(100, 251))
    sides = rng.uniform(0.5, 2.0, (n, 3))
    centres = rng.uniform(0.0, 1.0, (n, 3)) * np.array(WORKSPACE)
    boxes += list(np.concatenate([centres - sides / 2, centres + sides / 2], axis=1))
    return boxes, _before(0, c - t / 2), _after(0, c + t / 2), [poses]


def _hatch(rng: np.random.Generator):
    c, t = rng.uniform(16.0, 24.0), rng.uniform(1.5, 2.5)
    boxes, poses = _slotted_wall(rng, 2, c - t / 2, c + t / 2, _slot_sides(rng))
    return boxes, _before(2, c - t / 2), _after(2, c + t / 2), [poses]


def _elbow(rng: np.random.Generator):
    cx, tx = rng.uniform(30.0, 50.0), rng.uniform(1.5, 2.5)
    cy, ty = rng.uniform(28.0, 34.0), rng.uniform(1.5, 2.5)
    # the first wall across x, its slot in the lower half in y (the room it opens onto)
    sides = _slot_sides(rng)
    y = rng.uniform(3.0 + sides[0] / 2, cy - ty / 2 - 3.0 - sides[0] / 2)
    z = rng.uniform(3.0 + sides[1] / 2, WORKSPACE[2] - 3.0 - sides[1] / 2)
    boxes, first = _slotted_wall(rng, 0, cx - tx / 2, cx + tx / 2, sides, (y, z))
    # the second wall across y, beyond the first, its slot far along x
    sides = _slot_sides(rng)
    x = rng.uniform(cx + tx / 2 + 15.0, WORKSPACE[0] - 3.0 - sides[0] / 2)
    z = rng.uniform(3.0 + sides[1] / 2, WORKSPACE[2] - 3.0 - sides[1] / 2)
    wall = np.array([cx + tx / 2, cy - ty / 2, 0.0, WORKSPACE[0], cy + ty / 2, WORKSPACE[2]])
    boxes += carve(wall, [_opening(1, cy - ty / 2, cy + ty / 2, (x, z), sides)])
    second = _through(1, cy - ty / 2, cy + ty / 2, (x, z), sides)
    goal = np.array([cx + tx / 2, cy + ty / 2, 0.0, WORKSPACE[0], WORKSPACE[1], WORKSPACE[2]])
    return boxes, _before(0, cx - tx / 2), goal, [first, second]


def _before(axis: int, end: float) -> np.ndarray:
    """The region of the workspace below ``end`` along ``axis`` (where a start is drawn)."""
    return _slab(axis, 0.0, end)


def _after(axis: int, begin: float) -> np.ndarray:
    """The region of the workspace above ``begin`` along ``axis`` (where a goal is drawn)."""
    return _slab(axis, begin, WORKSPACE[axis])


_BUILDERS = {"slot": _slot, "windows": _windows, "duct": _duct, "shelves": _shelves, "clutter": _clutter,
             "hatch": _hatch, "elbow": _elbow}


def _draw_state(rng: np.random.Generator, world: RigidBodyWorld, region: np.ndarray, tries: int = 4000) -> np.ndarray:
    """A state whose centre lies in ``region``, with uniform angles and a clearance over ``QUERY_CLEARANCE``."""
    for _ in range(tries):
        q = np.concatenate([rng.uniform(region[:3], region[3:]), rng.uniform(-math.pi, math.pi, 3)])
        if world.clearance(q) > QUERY_CLEARANCE:
            return q
    raise RuntimeError(f"no state with clearance {QUERY_CLEARANCE:g} in the region {region.tolist()} "
                       f"in {tries} tries")


def draw_scene(family: str, rng: np.random.Generator, name: str = "") -> tuple[Problem, list]:
    """One unverified draw of ``family`` from ``rng``: the scene and its passages' witness poses.

    The boxes come first, then a start and a goal on either side of the passages. The passages are
    ``(before, after)`` pairs of poses, in the order a route meets them: the body turned to fit the
    opening, ``_STANDOFF`` before and after it.
    """
    _check_family(family)
    boxes, start_region, goal_region, passages = _BUILDERS[family](rng)
    boxes = np.array(boxes, dtype=np.float64).reshape(-1, 6)
    boxes[:, :3] = np.maximum(boxes[:, :3], 0.0)  # pieces of holes cut past the workspace stay inside it
    boxes[:, 3:] = np.minimum(boxes[:, 3:], WORKSPACE)
    boxes = boxes[np.all(boxes[:, 3:] > boxes[:, :3], axis=1)]
    world = RigidBodyWorld(boxes, box_body(*BODY_SIDES, points=16), low=(0, 0, 0), high=WORKSPACE, delta=DELTA)
    start = _draw_state(rng, world, start_region)
    goal = _draw_state(rng, world, goal_region)
    return Problem(world, start, goal, goal_tolerance=GOAL_DISTANCE, metric="cossin", name=name), passages


@dataclass(frozen=True)
class Verification:
    """The witness that a scene is solvable: a path every motion of which the exact check passed.

    ``iterations``: RRT-Connect's iterations over all legs; ``path``: ``(k, 6)`` states from the start
    to the goal.
    """

    seed: int
    iterations: int
    path: np.ndarray


def verify_scene(problem: Problem, passages, seed: int, max_iterations: int = VERIFY_ITERATIONS) -> Verification | None:
    """A witness path through ``passages`` (``draw_scene``'s), or None when a leg is not found.

    The legs run start -> first passage's ``before`` pose -> its ``after`` pose -> the next one's
    ``before`` pose ... -> goal. A leg whose straight motion the exact check passes is taken as it is;
    any other leg is planned by RRT-Connect (step 0.01 of the workspace's longest side, seeded, at
    most ``max_iterations``). The whole path is checked again motion by motion at the end.
    """
    from planners.algorithms.rrt import RRTConnect

    world = problem.world
    step = RRT_SETUP["step_fraction"] * max(WORKSPACE)
    stops = [problem.start] + [pose for pair in passages for pose in pair] + [problem.goal]
    if not all(world.is_valid(q) for q in stops):
        return None
    path, iterations = [np.asarray(problem.start)], 0
    for i, (a, b) in enumerate(zip(stops[:-1], stops[1:], strict=True)):
        if world.check_motion(a, b):
            path.append(np.asarray(b))
            continue
        leg = RRTConnect(problem.with_query(a, b), step_size=step, seed=seed + i).solve(max_iterations=max_iterations)
        iterations += int(leg.iterations)
        if not leg.solved:
            return None
        path.extend(leg.path[1:])
    path = np.array(path)
    if not (np.allclose(path[-1], problem.goal) and world.path_valid(path)):
        return None
    return Verification(seed, iterations, path)


def scene_with_witness(family: str, seed: int, *, max_iterations: int = VERIFY_ITERATIONS) -> tuple[Problem,
                                                                                                   Verification]:
    """``rigid_scene(family, seed)`` and the witness path that proved it solvable."""
    _check_family(family)
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise InputError(f"seed must be a non-negative integer, got {seed!r}")
    check_int(max_iterations, "max_iterations", low=1)
    rng = np.random.default_rng(int(seed))
    name = f"{family}-{seed}"
    for attempt in range(SCENE_TRIES):
        problem, passages = draw_scene(family, rng, name)
        witness = verify_scene(problem, passages, int(seed) + 1000 * attempt, max_iterations)
        if witness is not None:
            return problem, witness
    raise RuntimeError(f"{name}: no draw of {SCENE_TRIES} had a witness path (RRT-Connect legs of at most "
                       f"{max_iterations:,} iterations)")


def rigid_scene(family: str, seed: int, *, verify: bool = True, max_iterations: int = VERIFY_ITERATIONS) -> Problem:
    """The scene of ``family`` drawn from ``np.random.default_rng(seed)``, named ``f"{family}-{seed}"``.

    With ``verify`` (the default), a draw without a witness path (``verify_scene``) is replaced by the
    generator's next draw, at most ``SCENE_TRIES`` draws in all; the same family and seed always give
    the same scene. Without it the first draw is returned as it is (solvable or not: for quick looks).

    Raises:
        InputError: An unknown family or a seed that is not a non-negative integer.
        RuntimeError: No draw had a witness.
    """
    if verify:
        return scene_with_witness(family, seed, max_iterations=max_iterations)[0]
    _check_family(family)
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise InputError(f"seed must be a non-negative integer, got {seed!r}")
    return draw_scene(family, np.random.default_rng(int(seed)), f"{family}-{seed}")[0]


# --- the set --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SceneQuery:
    """One scene of a set: its family, seed and part (the problem is ``rigid_scene(family, seed)``).

    A mesh scene has ``mesh`` set: the box scene written as meshes (``mesh_scene``), or with ``path``
    an OMPL.app problem file (family ``"omplapp"``).
    """

    family: str
    seed: int
    part: str
    mesh: bool = False
    path: str = ""

    @property
    def name(self) -> str:
        if self.path:
            return Path(self.path).stem
        return f"{self.family}-{self.seed}" + ("-mesh" if self.mesh else "")


#: Scenes per family in each fixed part unless told otherwise.
DEFAULT_COUNTS = {"validation": 4, "tuning": 4, "test": 8}


class RigidSceneSet:
    """The generated rigid-body scenes as a set split into parts, as ``planners.maps.mapset.GeneratedMapSet`` is.

    Args:
        families: Training families in the set (default all of ``TRAINING_FAMILIES``); their
            validation, tuning and test scenes are consecutive seeds from each part's first seed.
        test_only: Test-only families (default all of ``TEST_ONLY_FAMILIES``), in the test part only.
        counts: Scenes per family in ``validation``, ``tuning`` and ``test`` (``DEFAULT_COUNTS``).
        first: Per part, the index of its first scene in the set (default 0): a part's scenes from there on, so
            that a rule can be judged on scenes nobody has looked at beside the ones that were.
        verify: Prove every scene solvable (``rigid_scene``); off only for quick looks.
    """

    def __init__(self, families=TRAINING_FAMILIES, test_only=TEST_ONLY_FAMILIES, counts: dict | None = None,
                 *, first: dict | None = None, verify: bool = True) -> None:
        for f in families:
            if f not in TRAINING_FAMILIES:
                raise InputError(f"{f!r} is not a training scene family; choose from {', '.join(TRAINING_FAMILIES)}")
        for f in test_only:
            if f not in TEST_ONLY_FAMILIES:
                raise InputError(f"{f!r} is not a test-only scene family; choose from {', '.join(TEST_ONLY_FAMILIES)}")
        self.families = tuple(families)
        self.test_only = tuple(test_only)
        self.counts = dict(DEFAULT_COUNTS)
        for part, n in (counts or {}).items():
            if part not in DEFAULT_COUNTS:
                raise InputError(f"counts: unknown part {part!r}; give counts for {', '.join(DEFAULT_COUNTS)}")
            self.counts[part] = check_int(n, f"counts[{part!r}]", low=0)
        self.first = dict.fromkeys(DEFAULT_COUNTS, 0)
        for part, n in (first or {}).items():
            if part not in DEFAULT_COUNTS:
                raise InputError(f"first: unknown part {part!r}; give first scenes for {', '.join(DEFAULT_COUNTS)}")
            self.first[part] = check_int(n, f"first[{part!r}]", low=0)
        self.verify = bool(verify)
        self._cache: dict[tuple[str, int], Problem] = {}

    def queries(self, part: str) -> list[SceneQuery]:
        """The scenes of a fixed part (``validation``, ``tuning``, ``test``), family by family."""
        if part not in DEFAULT_COUNTS:
            raise InputError(f"part must be one of {', '.join(DEFAULT_COUNTS)} (train is drawn: sample), got {part!r}")
        fams = self.families + (self.test_only if part == "test" else ())
        return [SceneQuery(f, s, part) for f in fams
                for s in scene_seeds(f, part, self.counts[part], self.first[part])]

    def problem(self, query: SceneQuery) -> Problem:
        """The scene of ``query`` (generated and verified once, then kept)."""
        key = (query.family, query.seed)
        if key not in self._cache:
            self._cache[key] = rigid_scene(query.family, query.seed, verify=self.verify)
        return self._cache[key]

    def sample(self, part: str, rng: np.random.Generator) -> Problem:
        """A scene of ``part`` drawn with ``rng``: a family at random, then a seed (train: from ``TRAIN_SEEDS``)."""
        if part == "train":
            family = self.families[int(rng.integers(len(self.families)))]
            return rigid_scene(family, int(rng.integers(*TRAIN_SEEDS)), verify=self.verify)
        qs = self.queries(part)
        if not qs:
            raise InputError(f"the {part!r} part of the scene set holds no scene")
        return self.problem(qs[int(rng.integers(len(qs)))])

    def describe(self) -> str:
        """The families, the parts' seeds and their counts, in words."""
        lines = [f"rigid-body scene set: training families {', '.join(self.families) or 'none'}; "
                 f"test-only families {', '.join(self.test_only) or 'none'}",
                 f"  train: seeds drawn from [{TRAIN_SEEDS[0]}, {TRAIN_SEEDS[1]})"]
        for part in DEFAULT_COUNTS:
            seed0 = _SEED0[part] + self.first[part]
            lines.append(f"  {part}: {self.counts[part]} scenes per family, seeds from {seed0}")
        if self.test_only:
            lines.append(f"  test-only families: {self.counts['test']} test scenes each, seeds from "
                         f"{UNSEEN_SEED0 + self.first['test']}")
        return "\n".join(lines)

    def record(self) -> dict:
        """The set as JSON-able data (what a run's outputs keep)."""
        return {"kind": "rigid scenes", "families": list(self.families), "test_only": list(self.test_only),
                "verified": self.verify,
                "parts": {part: [q.name for q in self.queries(part)] for part in DEFAULT_COUNTS},
                "train_seeds": list(TRAIN_SEEDS)}


# --- mesh scenes ------------------------------------------------------------------------------------


def box_mesh(box) -> tuple[np.ndarray, np.ndarray]:
    """The closed box ``(x0, y0, z0, x1, y1, z1)`` as a triangle mesh: 8 vertices, 12 outward triangles."""
    b = np.asarray(box, dtype=np.float64)
    v = np.array([[(b[0], b[3])[i], (b[1], b[4])[j], (b[2], b[5])[k]] for i in (0, 1) for j in (0, 1) for k in (0, 1)])
    # vertex index = 4 i + 2 j + k; two triangles per face, wound so their normals point out
    f = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5],   # x = x0, x = x1
                  [0, 4, 5], [0, 5, 1], [2, 3, 7], [2, 7, 6],   # y = y0, y = y1
                  [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])  # z = z0, z = z1
    return v, f


def as_mesh_scene(problem: Problem, delta: float | None = None, band: float | None = None) -> Problem:
    """A box scene written as a mesh world (``planners.worlds.mesh.MeshWorld``, the ``mesh`` extra).

    The environment is every box as a closed mesh, the robot the body's box (its points' bounding box)
    as one; the bounds, start, goal, tolerance and metric are the box scene's, and so is ``delta``
    unless one is given (``MeshWorld``'s ``delta``; ``band``, ``MeshWorld``'s, default ``delta / 8``).
    Checks are then exact on the body's whole surface, not on its points.
    """
    return _mesh_problem(problem, _mesh_world(problem, delta, band))


def _mesh_world(problem: Problem, delta: float | None, band: float | None):
    """``as_mesh_scene``'s world: every box of ``problem``'s world as a closed mesh, the body's box as the robot."""
    from planners.worlds.mesh import MeshWorld

    world = problem.world
    meshes = [box_mesh(b) for b in world.boxes]
    verts = np.concatenate([v for v, _ in meshes]) if meshes else np.zeros((0, 3))
    faces = np.concatenate([f + 8 * i for i, (_, f) in enumerate(meshes)]) if meshes else np.zeros((0, 3), int)
    body = np.concatenate([world.body.min(axis=0), world.body.max(axis=0)])
    return MeshWorld((verts, faces), box_mesh(body), low=world.low3, high=world.high3,
                     delta=world.delta if delta is None else delta, band=band, name=f"{problem.name}-mesh")


def _mesh_problem(problem: Problem, mesh_world) -> Problem:
    """``problem`` on ``mesh_world``: the same start, goal, tolerance and metric."""
    return Problem(mesh_world, problem.start, problem.goal, goal_tolerance=problem.goal_tolerance,
                   metric=problem.metric, name=f"{problem.name}-mesh")


def mesh_scene(family: str, seed: int, delta: float | None = None, band: float | None = None) -> Problem:
    """``rigid_scene(family, seed)`` as a mesh world, refused unless its witness path is free there too.

    ``delta``, ``band``: the mesh world's motion resolution and band (``as_mesh_scene``; default the box
    scene's ``delta`` and ``MeshWorld``'s band).

    Raises:
        RuntimeError: The box scene's witness path meets the mesh environment (the body's surface
            reaches where its points did not), its start or goal included.
    """
    problem, witness = scene_with_witness(family, seed)
    world = _mesh_world(problem, delta, band)  # a bad delta or band is the world's InputError, not a refusal
    ends = [name for name, q in (("start", problem.start), ("goal", problem.goal)) if not world.is_valid(q)]
    if ends:  # checked before the problem, which would refuse them with an InputError
        raise RuntimeError(f"{problem.name}: the witness path of the box scene meets the mesh environment "
                           f"at its ends (its {' and '.join(ends)})")
    if not world.path_valid(witness.path):
        raise RuntimeError(f"{problem.name}: the witness path of the box scene meets the mesh environment")
    return _mesh_problem(problem, world)


class MeshSceneSet:
    """The test-only mesh scenes: the test-only families written as meshes, and OMPL.app's problems.

    Args:
        families: Families whose test scenes (``scene_seeds(family, "test", count)``) are written as
            meshes (``mesh_scene``); default the test-only ones.
        count: Scenes per family.
        omplapp: A folder of OMPL.app problems (``planners.worlds.omplapp.omplapp_dir``: the root or
            its ``resources/3D``), or None for ``$SAMPLERGYM_OMPLAPP_DIR`` or none at all.
        problems: OMPL.app problem names to take (file stems); default every ``.cfg`` in the folder.

    Nothing here is ever trained or tuned on: it has a ``test`` part only.
    """

    def __init__(self, families=TEST_ONLY_FAMILIES, count: int = 2, omplapp=None, problems=None) -> None:
        from planners.worlds.omplapp import omplapp_dir

        for f in families:
            _check_family(f)
        self.families = tuple(families)
        self.count = check_int(count, "count", low=0)
        self.omplapp = omplapp_dir(omplapp)
        cfgs = sorted(self.omplapp.glob("*.cfg")) if self.omplapp is not None else []
        if problems is not None:
            known = {p.stem: p for p in cfgs}
            missing = [p for p in problems if p not in known]
            if missing:
                raise InputError(f"no OMPL.app problem {', '.join(missing)} in {self.omplapp}; there are "
                                 f"{', '.join(known) or 'none'}")
            cfgs = [known[p] for p in problems]
        self.cfgs = cfgs
        self._cache: dict[str, Problem] = {}

    def queries(self, part: str) -> list[SceneQuery]:
        """The test scenes (any other part is refused: the set is test-only)."""
        if part != "test":
            raise InputError(f"the mesh scene set is test-only: it has no {part!r} part")
        qs = [SceneQuery(f, s, "test", mesh=True) for f in self.families for s in scene_seeds(f, "test", self.count)]
        return qs + [SceneQuery("omplapp", i, "test", mesh=True, path=str(p)) for i, p in enumerate(self.cfgs)]

    def problem(self, query: SceneQuery) -> Problem:
        """The mesh scene of ``query`` (built once, then kept)."""
        if query.name not in self._cache:
            if query.path:
                from planners.worlds.omplapp import load_omplapp_cfg

                self._cache[query.name] = load_omplapp_cfg(query.path)
            else:
                self._cache[query.name] = mesh_scene(query.family, query.seed)
        return self._cache[query.name]

    def describe(self) -> str:
        """The set in words."""
        where = f"OMPL.app problems from {self.omplapp}: {', '.join(p.stem for p in self.cfgs)}" if self.cfgs \
            else "no OMPL.app folder given (--omplapp or $SAMPLERGYM_OMPLAPP_DIR)"
        return (f"mesh scene set (test only): {self.count} mesh scenes of each of {', '.join(self.families)}; "
                f"{where}")

    def record(self) -> dict:
        """The set as JSON-able data: with OMPL.app's problems, each one's files by content digest
        (``problem_digests``) and the mesh libraries' versions, so two runs tell whether they read the same problems.
        """
        out = {"kind": "mesh scenes", "families": list(self.families), "count": self.count,
               "omplapp": [p.name for p in self.cfgs], "parts": {"test": [q.name for q in self.queries("test")]}}
        if self.cfgs:
            from planners.worlds.omplapp import mesh_library_versions, problem_digests

            out["omplapp_files"] = {p.stem: problem_digests(p) for p in self.cfgs}
            out["mesh_libraries"] = mesh_library_versions()
        return out
