"""The walk down a cost-to-go field that places the route sampler's target (``planners.guidance.follow.walk_field``)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from conftest import load_script
from hypothesis import given, settings
from hypothesis import strategies as st

from learning.samplers.route import ABLATION_SETTINGS, SHIPPED_SETTINGS, RouteSampler, shipped_ablation
from planners.base.fileio import InputError
from planners.guidance.follow import SCAN_VISITS, last_in_sight, next_cell, path_field, walk_field, walk_path
from planners.kernels.geometry import grid_segment_free
from planners.maps.gridsearch import distance_field, free_components

MOVES = [(dr, dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if dr or dc]


def strict_walk(field, blocked, cell, length):
    """The walk without tolerance, move by move in Python: the lowest strictly lower neighbour, no corner cutting."""
    H, W = field.shape
    acc, v = 0.0, cell
    while acc < length:
        r, c = divmod(v, W)
        best, out = field[r, c], -1
        if not np.isfinite(best):
            break
        for dr, dc in MOVES:
            rr, cc = r + dr, c + dc
            if not (0 <= rr < H and 0 <= cc < W) or blocked[rr, cc]:
                continue
            if dr and dc and (blocked[r + dr, c] or blocked[r, c + dc]):
                continue
            if field[rr, cc] < best:
                best, out = field[rr, cc], rr * W + cc
        if out < 0:
            break
        acc += math.hypot(out // W - r, out % W - c)
        v = out
    return v


def path_of(field, blocked, cell, length, tolerance, growth=0.0):
    """The cells the tolerant walk visits, in order: walks of 1, 2, ... cells of path stop at each in turn.

    Every move covers at least one cell of path, so each move's end is reached by a walk of a whole length.
    """
    cells = [cell]
    for L in range(1, math.ceil(length) + 1):
        v = walk_field(field, blocked, cell, float(L), tolerance, growth)
        if v != cells[-1]:
            cells.append(v)
    return cells


def random_map(seed, side=12, density=0.2):
    rng = np.random.default_rng(seed)
    blocked = rng.random((side, side)) < density
    field = rng.random((side, side)) * 5
    field[blocked] = np.inf
    return field, blocked


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 10_000), st.floats(0.5, 30.0))
def test_without_tolerance_the_walk_goes_strictly_downhill_as_before(seed, length):
    field, blocked = random_map(seed)
    free = np.flatnonzero(~blocked)
    cell = int(free[seed % free.size])
    assert walk_field(field, blocked, cell, length) == strict_walk(field, blocked, cell, length)
    assert walk_field(field, blocked, cell, length, 0.0) == strict_walk(field, blocked, cell, length)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 10_000), st.floats(0.05, 1.0), st.sampled_from([0.0, 0.01, 0.1]))
def test_on_the_grid_searchs_field_the_tolerant_walk_is_the_strict_walk(seed, tolerance, growth):
    """Every reachable cell but the goal has a strictly lower neighbour: no ripple to cross, nothing changes."""
    rng = np.random.default_rng(seed)
    blocked = rng.random((16, 16)) < 0.25
    goal = (int(rng.integers(16)), int(rng.integers(16)))
    blocked[goal] = False
    field = distance_field(blocked, goal)
    reached = np.flatnonzero(np.isfinite(field.ravel()) & ~blocked.ravel())
    for cell in reached[:: max(1, reached.size // 10)]:
        for length in (3.0, 12.0, 40.0):
            assert walk_field(field, blocked, int(cell), length, tolerance, growth) == strict_walk(
                field, blocked, int(cell), length)


def ripple_field(depth):
    """A corridor falling 1 per cell towards column 0, with a pit of ``depth`` at column 6 (cells 5 and 7 higher)."""
    field = np.tile(np.arange(12, dtype=float)[None, :], (3, 1))
    blocked = np.zeros((3, 12), dtype=bool)
    blocked[0, :] = blocked[2, :] = True
    field[blocked] = np.inf
    field[1, 6] = 5.0 - depth  # lower than its left neighbour: a pit of `depth` below column 5
    return field, blocked


@pytest.mark.parametrize("depth, tolerance, crosses", [(0.05, 0.1, True), (0.09, 0.1, True), (0.2, 0.1, False),
                                                       (0.2, 0.25, True), (0.05, 0.0, False)])
def test_the_walk_crosses_pits_shallower_than_its_tolerance_and_stops_in_deeper_ones(depth, tolerance, crosses):
    field, blocked = ripple_field(depth)
    start = 1 * 12 + 11
    end = walk_field(field, blocked, start, 20.0, tolerance)
    assert end == (1 * 12 + 0 if crosses else 1 * 12 + 6)


@pytest.mark.parametrize("depth, growth, crosses", [(0.3, 0.05, True), (0.3, 0.03, False), (0.05, 0.0, True)])
def test_the_tolerance_grows_with_the_cost_to_go(depth, growth, crosses):
    """The pit's bottom lies at a cost of 5 - depth: the walk crosses it where 0.1 + growth * (5 - depth) > depth."""
    field, blocked = ripple_field(depth)
    end = walk_field(field, blocked, 1 * 12 + 11, 20.0, 0.1, growth)
    assert end == (1 * 12 + 0 if crosses else 1 * 12 + 6)
    field += 100.0  # the same pit far from the goal: a tolerance that grows crosses it, a fixed one does not
    assert walk_field(field, blocked, 1 * 12 + 11, 20.0, 0.1, growth) == (1 * 12 + 0 if growth or crosses else 18)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 10_000), st.floats(0.01, 2.0), st.floats(1.0, 25.0), st.sampled_from([0.0, 0.01, 0.1]))
def test_the_tolerant_walk_never_revisits_a_cell_nor_rises_more_than_its_tolerance(seed, tolerance, length, growth):
    field, blocked = random_map(seed, side=10, density=0.15)
    free = np.flatnonzero(~blocked)
    cell = int(free[seed % free.size])
    cells = path_of(field, blocked, cell, length, tolerance, growth)
    assert len(cells) == len(set(cells))
    W = field.shape[1]
    values = [field[v // W, v % W] for v in cells]
    low = np.minimum.accumulate(values)
    assert all(values[k + 1] < low[k] + tolerance + growth * max(low[k], 0) for k in range(len(values) - 1))
    for a, b in itertools.pairwise(cells):  # octile moves between free cells
        assert max(abs(a // W - b // W), abs(a % W - b % W)) == 1 and not blocked[b // W, b % W]


def test_an_infinite_start_or_a_cell_without_a_free_neighbour_stays_put():
    field = np.full((3, 3), np.inf)
    blocked = np.ones((3, 3), dtype=bool)
    blocked[1, 1] = False
    field[1, 1] = 1.0
    assert walk_field(field, blocked, 4, 10.0, 0.5) == 4
    field[1, 1] = np.inf
    assert walk_field(field, blocked, 4, 10.0, 0.5) == 4
    assert next_cell(field, blocked, 1, 1) == -1


def test_the_shipped_sampler_crosses_ripples_and_its_ablation_walks_strictly_downhill():
    """Each at the setting chosen for it on the validation maps; both cut the walk at the sight line."""
    assert SHIPPED_SETTINGS["ripple"] > 0 and SHIPPED_SETTINGS["ripple_growth"] > 0
    ablation = shipped_ablation()
    assert ABLATION_SETTINGS["ripple"] == ABLATION_SETTINGS["ripple_growth"] == 0.0
    assert ablation.ripple == ablation.ripple_growth == 0.0
    assert SHIPPED_SETTINGS["sight"] and ablation.sight and RouteSampler(None).sight


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 10_000), st.floats(0.0, 1.0), st.floats(1.0, 25.0), st.sampled_from([0.0, 0.01]))
def test_walk_path_keeps_the_walks_cells_in_order(seed, tolerance, length, growth):
    """Its last cell is ``walk_field``'s end; its cells are the walk's, one octile move apart (strict walk too)."""
    field, blocked = random_map(seed, side=10, density=0.15)
    free = np.flatnonzero(~blocked)
    cell = int(free[seed % free.size])
    path = np.empty(int(length) + 2, np.int64)
    moves = walk_path(field, blocked, cell, length, tolerance, growth, path)
    cells = list(path[:moves])
    assert cells[0] == cell and cells[-1] == walk_field(field, blocked, cell, length, tolerance, growth)
    if tolerance > 0 or growth > 0:
        assert cells == path_of(field, blocked, cell, length, tolerance, growth)
    W = field.shape[1]
    for a, b in itertools.pairwise(cells):
        assert max(abs(a // W - b // W), abs(a % W - b % W)) == 1 and not blocked[b // W, b % W]


def python_walk(field, blocked, cell, tolerance, growth):
    """The tolerant walk over the whole map in plain Python, its visits in a set: what ``walk_path`` must return."""
    H, W = field.shape
    cells, seen = [cell], {cell}
    v, low = cell, field[cell // W, cell % W]
    while True:
        r, c = divmod(v, W)
        best, out = math.inf, -1
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                rr, cc = r + dr, c + dc
                if (dr, dc) == (0, 0) or not (0 <= rr < H and 0 <= cc < W) or blocked[rr, cc]:
                    continue
                if dr and dc and (blocked[r + dr, c] or blocked[r, c + dc]):
                    continue
                if rr * W + cc not in seen and field[rr, cc] < best:
                    best, out = field[rr, cc], rr * W + cc
        if out < 0 or best >= low + tolerance + growth * max(low, 0.0):
            return cells
        v, low = out, min(low, best)
        cells.append(v)
        seen.add(v)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 10_000), st.floats(0.5, 5.0), st.sampled_from([0.0, 0.01]))
def test_a_walk_over_the_whole_map_looks_its_visits_up_in_a_set_and_walks_the_same(seed, tolerance, growth):
    """Buffers longer than ``SCAN_VISITS`` keep the visits in a hash set (grown as the walk goes): the same cells."""
    field, blocked = random_map(seed, side=30, density=0.1)
    free = np.flatnonzero(~blocked)
    cell = int(free[seed % free.size])
    path = np.empty(blocked.size + 2, np.int64)
    assert path.size > SCAN_VISITS
    moves = walk_path(field, blocked, cell, float(blocked.size), tolerance, growth, path)
    assert list(path[:moves]) == python_walk(field, blocked, cell, tolerance, growth)


def test_a_long_walk_grows_its_set_past_its_first_size():
    """Along a serpentine corridor of 860 cells (rows joined at alternate ends) whose every third cell is a ripple
    higher than the cell behind: only the visits keep the walk going on; the set is grown three times."""
    blocked = np.ones((41, 40), dtype=bool)
    blocked[0::2] = False
    order = []
    for r in range(0, 41, 2):
        order += [r * 40 + c for c in (range(40) if r % 4 == 0 else range(39, -1, -1))]
        if r < 40:
            c = 39 if r % 4 == 0 else 0
            blocked[r + 1, c] = False
            order.append((r + 1) * 40 + c)
    field = np.full(blocked.shape, np.inf)
    along = np.arange(len(order))
    field.ravel()[order] = len(order) - along + 2.5 * (along % 3 == 2)  # the far end lowest, ripples of 2.5
    path = np.empty(blocked.size + 2, np.int64)
    moves = walk_path(field, blocked, order[0], float(blocked.size), 3.0, 0.0, path)
    assert list(path[:moves]) == order == python_walk(field, blocked, order[0], 3.0, 0.0)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 10_000))
def test_the_path_field_falls_along_the_path_to_its_first_cell_and_towards_the_path_elsewhere(seed):
    """The path: a strict walk down the grid search's field. Along it, its length so far; from any cell of its
    component a strict walk down the path field ends at the path's first cell; elsewhere infinite."""
    rng = np.random.default_rng(seed)
    blocked = rng.random((16, 16)) < 0.25
    free = np.flatnonzero(~blocked)
    a, b = (int(v) for v in rng.choice(free, 2, replace=False))
    W = blocked.shape[1]
    exact = distance_field(blocked, (a // W, a % W))  # the walk down it from b ends at a, where a is reachable
    path = np.empty(blocked.size + 2, np.int64)
    moves = walk_path(exact, blocked, b, float(blocked.size), 0.0, 0.0, path)
    field = path_field(blocked, path, moves)
    steps = [math.dist(divmod(int(u), W), divmod(int(v), W)) for u, v in itertools.pairwise(path[:moves])]
    assert np.allclose(field.ravel()[path[:moves]], np.concatenate([[0.0], np.cumsum(steps)]))
    labels = free_components(blocked).ravel()
    mine = labels == labels[b]
    assert np.isfinite(field.ravel()[mine]).all() and np.isinf(field.ravel()[~mine]).all()
    for cell in np.flatnonzero(mine):
        assert walk_field(field, blocked, int(cell), float(blocked.size)) == b


def in_sight(blocked, a, b):
    """Whether the centres of flat cells ``a`` and ``b`` see each other (the grid check's own source, in Python)."""
    W = blocked.shape[1]
    return bool(grid_segment_free.py_func(blocked, 1.0, a % W + 0.5, a // W + 0.5, b % W + 0.5, b // W + 0.5))


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 10_000), st.floats(2.0, 25.0))
def test_the_cut_is_the_end_in_sight_or_the_cell_before_the_first_out_of_it(seed, length):
    field, blocked = random_map(seed, side=14, density=0.2)
    free = np.flatnonzero(~blocked)
    cell = int(free[seed % free.size])
    path = np.empty(int(length) + 2, np.int64)
    moves = walk_path(field, blocked, cell, length, 0.5, 0.0, path)
    cut = last_in_sight(blocked, path, moves)
    cells = list(path[:moves])
    seen = [in_sight(blocked, cell, u) for u in cells]
    assert seen[0]  # a free cell's centre sees itself
    expected = cells[-1] if seen[-1] else cells[seen.index(False) - 1]
    assert cut == expected and in_sight(blocked, cell, cut)


def test_round_a_corner_the_cut_stops_where_the_wall_begins_to_hide_the_walk():
    """An L-shaped corridor: along row 1 to the right, then down column 8; the wall at (2..6, 1..7) hides the leg."""
    blocked = np.ones((9, 10), dtype=bool)
    blocked[1, 1:9] = False  # the corridor's first leg, row 1
    blocked[1:8, 8] = False  # its second leg, column 8
    field = np.full(blocked.shape, np.inf)
    for c in range(1, 9):
        field[1, c] = 7 + (8 - c)
    for r in range(1, 8):
        field[r, 8] = 7 - (r - 1)
    W = blocked.shape[1]
    path = np.empty(40, np.int64)
    moves = walk_path(field, blocked, 1 * W + 1, 30.0, 0.0, 0.0, path)
    assert path[moves - 1] == 7 * W + 8  # the walk turns the corner to the corridor's end
    assert last_in_sight(blocked, path, moves) == 1 * W + 8  # the corner: all of row 1 is in sight, no more
    open_map = np.zeros_like(blocked)
    assert last_in_sight(open_map, path, moves) == 7 * W + 8  # nothing hides the end: it is the target


@pytest.mark.parametrize("kwargs", [{"ripple": -0.1}, {"ripple": float("nan")}, {"ripple_growth": -0.01}])
def test_a_negative_ripple_is_refused_by_name(kwargs):
    with pytest.raises(InputError, match="ripple = .*ripple_growth = "):
        RouteSampler(None, **kwargs)


@pytest.mark.parametrize("sight", ["yes", 1, None])
def test_a_sight_that_is_not_a_bool_is_refused_by_name(sight):
    with pytest.raises(InputError, match="sight = .*True or False"):
        RouteSampler(None, sight=sight)


@pytest.mark.experiments
def test_the_validation_script_runs_each_column_at_the_walk_it_is_given(capsys, monkeypatch):
    script = load_script("experiments/vin_validation")
    made = []
    real = script.RouteSampler.__init__

    def record(self, *args, **kwargs):
        real(self, *args, **kwargs)
        made.append((type(self).__name__, self.net is None, self.ripple, self.ripple_growth, self.sight))

    monkeypatch.setattr(script.RouteSampler, "__init__", record)
    assert script.main(["--maps", "1", "--sides", "64", "--seeds", "1", "--families", "bugtrap",
                        "--walk", "0.25", "0.02", "--ablation-walk", "0.1", "0", "--ablation-sight", "off"]) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| bugtrap | 64 |")]
    assert len(rows) == 1 and len(rows[0].strip("|").split("|")) == 8  # 4 samplers, share, unsolved
    assert set(made) == {("RouteSampler", True, 0.1, 0.0, False), ("RouteSampler", False, 0.25, 0.02, True),
                         ("GeodesicRouteSampler", True, 0.25, 0.02, True)}
    with pytest.raises(SystemExit) as stop:
        script.main(["--walk", "-0.1", "0"])
    assert stop.value.code == 2 and "--walk" in capsys.readouterr().err
    for bad in (["--wall-cost", "0"], ["--wall-cost", "lots"]):
        with pytest.raises(SystemExit) as stop:
            script.main(bad)
        assert stop.value.code == 2 and "--wall-cost" in capsys.readouterr().err


@pytest.mark.experiments
@pytest.mark.parametrize("argv, seeds", [([], {0, 1}), (["--first-seed", "3"], {3, 4}),
                                         (["--first-seed", "2", "--seeds", "1"], {2})])
def test_the_validation_script_plans_with_the_seeds_it_is_given(argv, seeds, monkeypatch, capsys):
    script = load_script("experiments/vin_validation")
    used = set()
    real = script.make_planner

    def record(*args, seed, **kwargs):
        used.add(seed)
        return real(*args, seed=seed, **kwargs)

    monkeypatch.setattr(script, "make_planner", record)
    assert script.main(["--maps", "1", "--sides", "64", "--families", "bugtrap", *argv]) == 0
    assert used == seeds
    for bad in (["--first-seed", "-1"], ["--seeds", "0"], ["--maps", "0"]):
        with pytest.raises(SystemExit) as stop:
            script.main(bad)
        assert stop.value.code == 2 and "--first-seed" in capsys.readouterr().err


@pytest.mark.experiments
def test_the_walk_cost_script_times_each_walk_and_refuses_no_walks(capsys):
    script = load_script("experiments/walk_cost")
    assert script.main(["--walks", "50"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split(" (")[0] for line in lines] == [w for w in ("strictly downhill", "tolerance 0.1 step", "shipped")
                                                      for _ in range(2)]
    assert [line.split("), ")[1].split(":")[0] for line in lines] == ["uncut", "cut at the sight line"] * 3
    assert all(line.endswith("ns per walk") for line in lines)
    with pytest.raises(SystemExit) as stop:
        script.main(["--walks", "0"])
    assert stop.value.code == 2
    assert script.main(["--whole", "--walks", "20", "--side", "64"]) == 0
    line = capsys.readouterr().out.strip()
    assert line.startswith("whole route, shipped") and "moves per walk" in line and line.endswith("ns per move")
    with pytest.raises(SystemExit) as stop:
        script.main(["--whole", "--side", "8"])
    assert stop.value.code == 2


@pytest.mark.experiments
def test_the_route_table_shows_any_sampler_of_a_run_and_refuses_one_it_lacks(tmp_path, capsys):
    script = load_script("experiments/route_table")
    runs = tmp_path / "runs.csv"
    lines = ["map,split,planner,sampler,iterations,solved"]
    for sampler, its in (("route ablation", 100), ("exact_route", 20), ("route encoder", 40), ("strict walk", 60)):
        lines += [f"bugtrap,test,RRT,{sampler},{its + d},True" for d in (-1, 0, 1)]
    runs.write_text("\n".join(lines) + "\n")
    assert script.main([f"shipped={runs}", f"strict={runs}@strict walk"]) == 0
    row = next(line for line in capsys.readouterr().out.splitlines() if line.startswith("| bugtrap |"))
    assert row == "| bugtrap | 20 | 100 (1.00) | 40, 0.75, 1.00 | 60, 0.50, 1.00 |"
    assert script.main([f"{runs}", f"x={runs}@nope"]) == 2
    assert "no test runs of the sampler 'nope'" in capsys.readouterr().err
    assert script.main([f"x={tmp_path / 'missing.csv'}"]) == 2
    assert "'x') is not a file" in capsys.readouterr().err
    assert script.main(["--help"]) == 0 and "side by side" in capsys.readouterr().out
