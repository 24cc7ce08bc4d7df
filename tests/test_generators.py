"""Generated map families: determinism, valid far-apart queries, each family's structure, speed."""

from __future__ import annotations

import time

import numpy as np
import pytest
from scipy import ndimage

from planners import Problem
from planners.maps.generators import FAMILIES, SHIFTED_SIZES, generate
from planners.maps.gridsearch import connected, free_components, shortest_path_length

SIZES_AND_SEEDS = [(32, range(5)), (64, range(10)), (128, range(30)), (256, range(3))]


def scaled(cells: float, size: int, lo: int) -> int:
    """A length of ``cells`` at size 128 scaled to ``size`` (rounded half up), at least ``lo``."""
    return max(lo, int(cells * size / 128 + 0.5))


def room_index(x: int, bands: list[tuple[int, int]]) -> int:
    """Which room, counting along one axis, coordinate ``x`` lies in, given the wall bands."""
    return sum(x >= b0 for b0, _ in bands)


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, length) of each maximal run of True in a 1-D mask."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return [(int(a), int(b - a)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def widest_free_square(free: np.ndarray) -> int:
    """Side of the largest all-free axis-aligned square (binary search over a summed-area table)."""
    sat = np.pad(free.astype(np.int64).cumsum(0).cumsum(1), ((1, 0), (1, 0)))

    def fits(w: int) -> bool:
        sums = sat[w:, w:] - sat[:-w, w:] - sat[w:, :-w] + sat[:-w, :-w]
        return bool((sums == w * w).any())

    lo, hi = 0, min(free.shape)
    while lo < hi:
        mid = (lo + hi + 1) // 2
        lo, hi = (mid, hi) if fits(mid) else (lo, mid - 1)
    return lo


def wall_bands(obs: np.ndarray, axis: int, cover: float) -> list[tuple[int, int]]:
    """Runs of rows (axis=1) or columns (axis=0) whose obstacle fraction exceeds ``cover``."""
    return runs(obs.mean(axis=axis) > cover)


@pytest.mark.parametrize("family", FAMILIES)
def test_same_seed_same_problem_and_seeds_differ(family):
    a, b, c = generate(family, 7), generate(family, 7), generate(family, 8)
    assert np.array_equal(a.world.obstacles, b.world.obstacles)
    assert np.array_equal(a.start, b.start) and np.array_equal(a.goal, b.goal)
    assert a.reference_length == b.reference_length
    assert not np.array_equal(a.world.obstacles, c.world.obstacles)
    assert (a.name, c.name) == (f"{family}-128-7", f"{family}-128-8")
    # a Generator is consumed as given: equal states give equal problems
    d, e = generate(family, np.random.default_rng(7), 64), generate(family, np.random.default_rng(7), 64)
    assert np.array_equal(d.world.obstacles, e.world.obstacles) and np.array_equal(d.start, e.start)
    assert d.name == f"{family}-64"


@pytest.mark.parametrize("family", FAMILIES)
def test_shifted_variant_is_seeded_named_apart_and_differs_from_training(family):
    a, b = generate(family, 7, shifted=True), generate(family, 7, shifted=True)
    assert np.array_equal(a.world.obstacles, b.world.obstacles) and np.array_equal(a.start, b.start)
    assert a.name == f"{family}-shifted-128-7"
    assert not np.array_equal(a.world.obstacles, generate(family, 7).world.obstacles)
    assert generate(family, np.random.default_rng(1), 64, shifted=True).name == f"{family}-shifted-64"


def test_generators_leave_global_random_state_alone():
    state = np.random.get_state()
    for family in FAMILIES:
        generate(family, 0, 64)
        generate(family, 0, 64, shifted=True)
    after = np.random.get_state()
    assert all(np.array_equal(x, y) for x, y in zip(state, after, strict=True))


@pytest.mark.parametrize("shifted", [False, True], ids=["training", "shifted"])
@pytest.mark.parametrize("size, seeds", SIZES_AND_SEEDS)
@pytest.mark.parametrize("family", FAMILIES)
def test_queries_are_free_connected_and_far_apart(family, size, seeds, shifted):
    for seed in seeds:
        p = generate(family, seed, size, shifted=shifted)
        g = p.world
        assert isinstance(p, Problem) and g.shape == (size, size) and g.resolution == 1.0
        s, t = g.cell_of(p.start), g.cell_of(p.goal)
        assert np.array_equal(p.start, g.cell_center(*s)) and np.array_equal(p.goal, g.cell_center(*t))
        assert not g.obstacles[s] and not g.obstacles[t]
        assert connected(g.obstacles, s, t)
        L = shortest_path_length(g, p.start, p.goal)
        assert L >= 0.5 * size, f"{p.name}: start and goal only {L:.1f} apart"
        assert p.reference_length == pytest.approx(L, rel=1e-12)
        assert np.linalg.norm(p.start - p.goal) > p.goal_tolerance == 4.0


@pytest.mark.parametrize("family", FAMILIES)
def test_goal_tolerance_is_used_and_respected(family):
    for seed in range(5):
        p = generate(family, seed, 64, goal_tolerance=20.0)
        assert p.goal_tolerance == 20.0 and np.linalg.norm(p.start - p.goal) > 20.0


@pytest.mark.parametrize("size", [64, 128, 256])
def test_forest_obstacle_fraction(size):
    fractions = [generate("forest", seed, size).world.obstacles.mean() for seed in range(10)]
    # the target is 15-25%; the last shape may overshoot it a little
    assert 0.15 <= min(fractions) and max(fractions) <= 0.27
    assert max(fractions) - min(fractions) > 0.02  # the target itself is random


@pytest.mark.parametrize("size, seeds", [(64, range(10)), (128, range(30)), (256, range(3))])
def test_bugtrap_start_is_inside_the_u_facing_away_from_the_goal(size, seeds):
    for seed in seeds:
        p = generate("bugtrap", seed, size)
        obs = p.world.obstacles
        r, c = p.world.cell_of(p.start)
        # three of the four axis rays from the start hit the trap's walls; the fourth leaves by the opening
        rays = {(-1, 0): obs[:r, c][::-1], (1, 0): obs[r + 1 :, c], (0, -1): obs[r, :c][::-1], (0, 1): obs[r, c + 1 :]}
        hits = {d: np.flatnonzero(ray)[0] if ray.any() else None for d, ray in rays.items()}
        exits = [d for d, h in hits.items() if h is None]
        assert len(exits) == 1, f"{p.name}: {len(exits)} open directions from the start"
        assert all(h < size / 2 for h in hits.values() if h is not None)
        dr, dc = exits[0]
        to_goal = (p.goal - p.start)[::-1]  # (rows, cols)
        assert dr * to_goal[0] + dc * to_goal[1] < 0, f"{p.name}: the opening faces the goal"
        # straight-line greed is blocked, and the way out is much longer than the straight line
        assert not p.world.check_motion(p.start, p.goal)
        assert p.reference_length > 1.5 * np.linalg.norm(p.goal - p.start)


@pytest.mark.parametrize("size, seeds", [(64, range(10)), (128, range(30)), (256, range(3))])
def test_narrow_passage_has_exactly_one_gap(size, seeds):
    for seed in seeds:
        p = generate("narrow_passage", seed, size)
        obs = p.world.obstacles
        vertical, horizontal = wall_bands(obs, 0, 0.8), wall_bands(obs, 1, 0.8)
        assert len(vertical) + len(horizontal) == 1, f"{p.name}: expected one wall"
        # look at the wall as a vertical band of columns [c0, c0 + thick)
        view = obs if vertical else obs.T
        (c0, thick), = vertical or horizontal
        assert scaled(2, size, 2) <= thick <= scaled(4, size, 2)
        band = view[:, c0 : c0 + thick]
        # every row of the band is either fully blocked or fully open: nothing nibbles at the wall
        assert np.array_equal(band.all(axis=1), band.any(axis=1))
        gaps = runs(~band.any(axis=1))
        assert len(gaps) == 1, f"{p.name}: {len(gaps)} gaps"
        y0, width = gaps[0]
        assert scaled(2, size, 2) <= width <= scaled(3, size, 2)
        s, g = p.world.cell_of(p.start), p.world.cell_of(p.goal)
        # closing the gap must cut start from goal
        closed = view.copy()
        closed[y0 : y0 + width, c0 : c0 + thick] = True
        labels = free_components(closed if vertical else closed.T)
        assert labels[s] != labels[g], f"{p.name}: start and goal still connected with the gap closed"


@pytest.mark.parametrize("size, width", [(64, 8), (128, 16), (256, 32)])
def test_maze_is_perfect_with_corridors_of_the_stated_width(size, width):
    for seed in range(5):
        p = generate("maze", seed, size)
        free = ~p.world.obstacles
        assert free_components(p.world.obstacles).max() == 0  # every corridor is reachable
        # no loops: every wall is 8-connected to the outer boundary (so the free space has no holes)
        walls = np.pad(p.world.obstacles, 1, constant_values=True)
        _, n_walls = ndimage.label(walls, structure=np.ones((3, 3)))
        assert n_walls == 1, f"{p.name}: {n_walls - 1} free-standing walls, so the maze has loops"
        # the widest free square is exactly the corridor width
        assert ndimage.binary_erosion(free, np.ones((width, width)), border_value=0).any()
        assert not ndimage.binary_erosion(free, np.ones((width + 1, width + 1)), border_value=0).any()


@pytest.mark.parametrize("size, seeds", [(64, range(10)), (128, range(30)), (256, range(3))])
def test_rooms_have_doors_and_far_apart_start_and_goal(size, seeds):
    loops = 0
    for seed in seeds:
        p = generate("rooms", seed, size)
        obs = p.world.obstacles
        rows, cols = wall_bands(obs, 1, 0.5), wall_bands(obs, 0, 0.5)
        k = len(rows) + 1
        assert len(cols) + 1 == k and k in (3, 4), f"{p.name}: {len(rows) + 1}x{len(cols) + 1} rooms"
        assert free_components(obs).max() == 0  # every room is reachable
        doors = 0
        for bands, view, crossing in ((rows, obs, cols), (cols, obs.T, rows)):
            for r0, t in bands:
                assert scaled(1, size, 1) <= t <= scaled(2, size, 1)
                band = view[r0 : r0 + t]
                assert np.array_equal(band.all(axis=0), band.any(axis=0))  # doors go through the whole wall
                for x0, width in runs(~band.any(axis=0)):
                    assert scaled(4, size, 2) <= width <= scaled(6, size, 2), f"{p.name}: door {width}"
                    assert not any(c0 <= x0 + width and x0 <= c0 + ct for c0, ct in crossing)  # not at a corner
                    doors += 1
        assert k * k - 1 <= doors <= 2 * k * (k - 1)  # a spanning tree at least
        loops += doors > k * k - 1
        # with every wall band closed the rooms fall apart; start and goal are in rooms far apart
        closed = obs.copy()
        for r0, t in rows:
            closed[r0 : r0 + t] = True
        for c0, t in cols:
            closed[:, c0 : c0 + t] = True
        labels = free_components(closed)
        assert labels.max() + 1 == k * k
        (sr, sc), (gr, gc) = p.world.cell_of(p.start), p.world.cell_of(p.goal)
        hops = abs(room_index(sr, rows) - room_index(gr, rows)) + abs(room_index(sc, cols) - room_index(gc, cols))
        assert hops >= k - 1, f"{p.name}: start and goal rooms only {hops} apart"
    assert loops > 0, "no map has a door beyond the spanning tree"


# The shifted variants: each differs from its training family in the way its docstring says.


def test_shifted_forest_is_denser_than_training():
    fractions = [generate("forest", seed, size, shifted=True).world.obstacles.mean()
                 for size in SHIFTED_SIZES for seed in range(4)]
    assert 0.25 <= min(fractions) and max(fractions) <= 0.40
    assert np.mean(fractions) > 0.27  # training draws 15-25%


@pytest.mark.parametrize("size", SHIFTED_SIZES)
def test_shifted_narrow_passage_has_thick_walls_each_with_one_gap(size):
    counts = set()
    for seed in range(12):
        p = generate("narrow_passage", seed, size, shifted=True)
        obs = p.world.obstacles
        vertical, horizontal = wall_bands(obs, 0, 0.8), wall_bands(obs, 1, 0.8)
        assert not (vertical and horizontal), f"{p.name}: walls in both directions"
        bands, view = (vertical, obs) if vertical else (horizontal, obs.T)
        counts.add(len(bands))
        closed = view.copy()
        for c0, thick in bands:
            assert scaled(6, size, 3) <= thick <= scaled(12, size, 3), f"{p.name}: wall {thick} thick"
            band = view[:, c0 : c0 + thick]
            gaps = runs(~band.any(axis=1))
            assert len(gaps) == 1 and scaled(2, size, 2) <= gaps[0][1] <= scaled(4, size, 2), f"{p.name}: {gaps}"
            closed[:, c0 : c0 + thick] = True
        s, g = p.world.cell_of(p.start), p.world.cell_of(p.goal)
        labels = free_components(closed if vertical else closed.T)
        assert labels[s] != labels[g], f"{p.name}: start and goal connected with every wall closed"
    assert counts == {1, 2}


@pytest.mark.parametrize("size", SHIFTED_SIZES)
def test_shifted_bugtrap_encloses_the_start_but_for_a_small_opening(size):
    k = scaled(6, size, 2) + 1  # a square one cell wider than the widest opening cannot leave the trap
    for seed in range(12):
        p = generate("bugtrap", seed, size, shifted=True)
        s, g = p.world.cell_of(p.start), p.world.cell_of(p.goal)
        assert not p.world.check_motion(p.start, p.goal)
        # the union of every free k x k square: the trap's inside is cut off from everything else
        roomy = ndimage.binary_opening(~p.world.obstacles, np.ones((k, k)))
        labels, _ = ndimage.label(roomy)
        assert roomy[s], f"{p.name}: the start is not inside a box of side >= {k}"
        assert (labels == labels[s]).sum() < (0.45 * size) ** 2, f"{p.name}: the trap is open"
        if roomy[g]:
            assert labels[s] != labels[g], f"{p.name}: a wide way out of the trap"


@pytest.mark.parametrize("size", [64, 128, 256])
def test_shifted_maze_has_other_corridor_widths_and_loops(size):
    widths, loops = set(), 0
    for seed in range(12):
        p = generate("maze", seed, size, shifted=True)
        free = ~p.world.obstacles
        assert free_components(p.world.obstacles).max() == 0
        w = widest_free_square(free)
        assert w in {scaled(x, size, 2) for x in (8, 10, 12, 20)} and w != scaled(16, size, 2), f"{p.name}: {w}"
        widths.add(w)
        walls = np.pad(p.world.obstacles, 1, constant_values=True)
        loops += ndimage.label(walls, structure=np.ones((3, 3)))[1] > 1
    assert len(widths) >= 3 and loops >= 6


@pytest.mark.parametrize("size", [64, 128, 256])
def test_shifted_rooms_have_other_room_counts(size):
    ks = set()
    for seed in range(20):
        p = generate("rooms", seed, size, shifted=True)
        obs = p.world.obstacles
        rows, cols = wall_bands(obs, 1, 0.5), wall_bands(obs, 0, 0.5)
        assert len(rows) == len(cols), p.name
        ks.add(len(rows) + 1)
        assert free_components(obs).max() == 0
    assert ks == {2, 5, 6}


@pytest.mark.parametrize(
    "args, error, match",
    [
        (dict(family="lava"), ValueError, "unknown map family 'lava'; choose from forest, narrow_passage, bugtrap"),
        (dict(family=None), ValueError, "unknown map family None"),
        (dict(size=16), ValueError, "size must be an integer >= 32, got 16"),
        (dict(size=64.0), ValueError, "size must be an integer >= 32, got 64.0"),
        (dict(size=True), ValueError, "got True"),
        (dict(seed=-3), ValueError, "seed must be a non-negative integer .* got -3"),
        (dict(seed=1.5), TypeError, "seed must be an int or a np.random.Generator, got float 1.5"),
        (dict(goal_tolerance=0.0), ValueError, "goal_tolerance must be a positive finite number, got 0.0"),
        (dict(goal_tolerance=float("nan")), ValueError, "got nan"),
    ],
)
def test_bad_arguments(args, error, match):
    with pytest.raises(error, match=match):
        generate(**(dict(family="forest", seed=0, size=64) | args))


def test_generation_is_fast():
    for family in FAMILIES:
        generate(family, 0, 64)  # compile, or load the cache
    for size, budget, seeds in ((128, 0.05, range(5)), (512, 0.5, range(1))):
        for family in FAMILIES:
            t = time.perf_counter()
            for seed in seeds:
                generate(family, seed, size)
            mean = (time.perf_counter() - t) / len(seeds)
            assert mean < budget, f"{family} at {size}: {mean * 1e3:.0f} ms per problem"
