"""Problem validation and MovingAI scenarios."""

from __future__ import annotations

import numpy as np
import pytest

from planners import OccupancyGrid, Problem, load_movingai_scenarios
from planners.base.fileio import InputError


@pytest.fixture
def grid():
    a = np.zeros((10, 10), bool)
    a[5, 5] = True
    return OccupancyGrid(a)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(start=(5.5, 5.5)), r"start \(5.5, 5.5\).*blocked cell \(row 5, col 5\)"),
        (dict(goal=(12.0, 1.0)), r"goal \(12.0, 1.0\).*outside the map"),
        (dict(goal=(-0.5, 1.0)), "goal.*outside"),
        (dict(start=(np.nan, 1.0)), "start.*NaN"),
        (dict(start=(1.0, 2.0, 3.0)), r"start must have shape \(2,\)"),
        (dict(start="ab"), "start"),
        (dict(goal_tolerance=0.0), "goal_tolerance.*positive"),
        (dict(goal_tolerance=-1), "goal_tolerance"),
        (dict(goal_tolerance=np.nan), "goal_tolerance"),
        (dict(metric="cosine"), "metric 'cosine'.*euclidean"),
    ],
)
def test_bad_problems_name_the_value(grid, kwargs, match):
    args = dict(start=(1.5, 1.5), goal=(8.5, 8.5), goal_tolerance=1.0) | kwargs
    with pytest.raises(ValueError, match=match):
        Problem(grid, **args)


def test_problem_is_frozen_and_normalised(grid):
    p = Problem(grid, start=[1.5, 1.5], goal=(8, 8), goal_tolerance=2)
    assert p.goal_tolerance == 2.0 and p.metric == "euclidean"
    with pytest.raises(ValueError):
        p.start[0] = 3.0
    assert p.distance(p.start, p.goal) == pytest.approx(np.hypot(6.5, 6.5))
    assert Problem(grid, (1.5, 1.5), (8, 8), metric="manhattan").distance((0, 0), (1, 2)) == 3.0
    assert Problem(grid, (1.5, 1.5), (8, 8), metric="chebyshev").distance((0, 0), (1, 2)) == 2.0
    with pytest.raises(TypeError, match="World"):
        Problem(np.zeros((3, 3)), (1, 1), (2, 2))


def test_scenarios_load_with_reference_lengths(movingai):
    probs = list(load_movingai_scenarios(movingai / "arena.map.scen"))
    assert len(probs) == 160  # README: 160 problems
    p = probs[-1]
    assert p.reference_length == pytest.approx(62.1543)
    assert p.name.startswith("arena#")
    # start/goal are cell centres of the scenario's (x, y) = (column, row)
    line = (movingai / "arena.map.scen").read_text().splitlines()[-1].split("\t")
    assert p.start.tolist() == [int(line[4]) + 0.5, int(line[5]) + 0.5]
    assert len(list(load_movingai_scenarios(movingai / "maze-32-32-2-random-1.scen", limit=5))) == 5


def test_every_scenario_file_loads(movingai):
    for scen in sorted(movingai.glob("*.scen")):
        first = next(load_movingai_scenarios(scen))
        assert first.reference_length > 0


def test_malformed_scenarios(tmp_path):
    a = np.zeros((4, 4), bool)
    a[0, 0] = True
    (tmp_path / "m.map").write_text("type octile\nheight 4\nwidth 4\nmap\n@...\n....\n....\n....\n")
    (tmp_path / "a.scen").write_text("version 1\n0\tm.map\t4\t4\t1\t1\t3\t3\t2.8\n0\tm.map\t4\t4\t1\t1\n")
    with pytest.raises(ValueError, match="a.scen, line 3: expected 9"):
        list(load_movingai_scenarios(tmp_path / "a.scen"))
    (tmp_path / "b.scen").write_text("version 1\n0\tmaps/x/m.map\t4\t4\t0\t0\t3\t3\t4.2\n")
    with pytest.raises(ValueError, match=r"b.scen, line 2: start cell \(x=0, y=0\)"):
        list(load_movingai_scenarios(tmp_path / "b.scen"))
    (tmp_path / "c.scen").write_text("version 1\n0\tm.map\t5\t4\t1\t1\t3\t3\t2.8\n")
    with pytest.raises(ValueError, match="5x4 does not match"):
        list(load_movingai_scenarios(tmp_path / "c.scen"))
    with pytest.raises(FileNotFoundError):
        list(load_movingai_scenarios(tmp_path / "none.scen"))


def _scenario_dir(tmp_path):
    (tmp_path / "m.map").write_text("type octile\nheight 4\nwidth 4\nmap\n@...\n....\n....\n....\n")
    return tmp_path


@pytest.mark.parametrize("optimal", ["nan", "NaN", "inf", "-1"])
def test_scenario_with_a_non_finite_or_negative_optimum_is_refused(tmp_path, optimal):
    d = _scenario_dir(tmp_path)
    (d / "n.scen").write_text(f"version 1\n0\tm.map\t4\t4\t1\t1\t3\t3\t{optimal}\n")
    with pytest.raises(InputError, match=f"n.scen, line 2: optimal length.*'{optimal}'"):
        list(load_movingai_scenarios(d / "n.scen"))


@pytest.mark.parametrize("data", ["version 1\n0\tmé.map\t4\t4\t1\t1\t3\t3\t2.8\n".encode(), b"version 1\n\xff\xfe\n"])
def test_non_ascii_scenario_names_the_file(tmp_path, data):
    d = _scenario_dir(tmp_path)
    (d / "u.scen").write_bytes(data)
    with pytest.raises(InputError, match="u.scen.*not an ASCII"):
        list(load_movingai_scenarios(d / "u.scen"))


def test_scenario_whose_map_is_missing_names_the_line(tmp_path):
    (tmp_path / "x.scen").write_text("version 1\n0\tmaps/absent.map\t4\t4\t1\t1\t3\t3\t2.8\n")
    with pytest.raises(InputError, match=r"x.scen, line 2: its map 'maps/absent.map'.*map_path="):
        list(load_movingai_scenarios(tmp_path / "x.scen"))


def test_problem_in_a_world_frame():
    a = np.zeros((10, 10), bool)
    a[5, 5] = True
    g = OccupancyGrid(a, 0.1, origin=(-0.5, 2.0), y_up=True)
    p = Problem(g, start=(-0.45, 2.05), goal=(0.45, 2.95), goal_tolerance=0.05)
    assert p.start.tolist() == [-0.45, 2.05]
    # y_up: array row 5 is drawn as row 4 of the map image (row 0 at the top), the row messages name
    with pytest.raises(InputError, match=r"start \(0.05, 2.55\).*blocked cell \(row 4, col 5 of the map image"):
        Problem(g, start=(0.05, 2.55), goal=(0.45, 2.95))
    with pytest.raises(InputError, match=r"goal \(0.55, 1.0\).*outside the map interior \(-0.5, 0.5\) x \(2, 3\)"):
        Problem(g, start=(-0.45, 2.05), goal=(0.55, 1.0))


def test_a_scenario_read_with_another_map_than_it_names_is_refused(tmp_path):
    d = _scenario_dir(tmp_path)
    (d / "s.scen").write_text("version 1\n0\tmaps/m.map\t4\t4\t1\t1\t3\t3\t2.8\n0\tother.map\t4\t4\t1\t1\t3\t3\t2.8\n")
    with pytest.raises(InputError, match=r"s.scen, line 3: its map column names 'other.map', but the file is read "
                                         r"with the map .*m.map"):
        list(load_movingai_scenarios(d / "s.scen", map_path=d / "m.map"))
    assert len(list(load_movingai_scenarios(d / "s.scen", map_path=d / "m.map", limit=1))) == 1
