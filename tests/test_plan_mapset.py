"""``scripts/plan.py --map-set``: a map set's query planned through its public API; bad choices refused in one line."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from conftest import REPO, load_script

from planners.maps.mapset import MapSet

ROS = REPO / "tests" / "data" / "ros"


@pytest.fixture(scope="module")
def plan():
    return load_script("plan")


@pytest.fixture(scope="module")
def ros():
    return MapSet.open(ROS)


def _listed(stdout: str) -> list[tuple[str, int, str, list[float]]]:
    """(part, number, map, [start x, start y, goal x, goal y]) of each query line of --list-queries."""
    number = r"(-?[0-9.e+-]+)"
    line = re.compile(rf"^(\w+) +(\d+)  (\S+)  \({number}, {number}\) -> \({number}, {number}\), ", re.M)
    return [(m[1], int(m[2]), m[3], [float(v) for v in m.groups()[3:]]) for m in line.finditer(stdout)]


def test_list_queries_numbers_each_part_as_the_map_set_orders_it(plan, ros, capsys):
    assert plan.main(["--map-set", str(ROS), "--list-queries"]) == 0
    rows = _listed(capsys.readouterr().out)
    expected = [(part, k, q.map, [*q.start, *q.goal]) for part in ("train", "validation", "tuning", "test")
                for k, q in enumerate(ros.queries(part))]
    assert [r[:3] for r in rows] == [e[:3] for e in expected] and len(rows) == 40
    for (_, _, _, got), (_, _, _, want) in zip(rows, expected, strict=True):
        np.testing.assert_allclose(got, want, atol=1e-9)
    assert plan.main(["--map-set", str(ROS), "--list-queries", "--split", "tuning"]) == 0
    assert {r[0] for r in _listed(capsys.readouterr().out)} == {"tuning"}


def test_a_query_is_planned_on_its_map_from_its_start_to_its_goal(plan, ros, tmp_path, capsys):
    out = tmp_path / "out"
    q = ros.queries("validation")[4]
    code = plan.main(["--map-set", str(ROS), "--split", "validation", "--query", "4", "--out", str(out),
                      "--headless", "--no-gif", "--planner", "rrt", "--seed", "1", "--max-iterations", "20000"])
    text = capsys.readouterr().out
    assert code == 0, text
    problem = ros.problem(q)
    assert f"map:              {q.map} ({problem.world.width}x{problem.world.height}" in text
    assert f"start ({problem.start[0]:g}, {problem.start[1]:g}) -> goal ({problem.goal[0]:g}, {problem.goal[1]:g})" \
        in text
    assert f"tolerance {problem.goal_tolerance:g}" in text and "validation query 4" in text
    assert sorted(f.name for f in out.iterdir()) == ["plan.png"]


def _manifest_without_tuning(tmp_path) -> str:
    parts = {"forest": "test", "maze": "train", "rooms": "validation", "turtlebot3_world": "train"}
    maps = [{"path": str(ROS / name / "map.yaml"), "name": name, "part": part} for name, part in parts.items()]
    path = tmp_path / "set.json"
    path.write_text(json.dumps({"maps": maps}))
    return str(path)


@pytest.mark.parametrize("args, message", [
    (["--map-set", "{ros}", "--split", "testing"],
     "--split 'testing': expected one of train, validation, tuning, test"),
    (["--map-set", "{ros}", "--query", "10"], "--query 10: the 'test' part of map set ros holds 10 queries"),
    (["--map-set", "{ros}", "--split", "train", "--query", "-1"], "--query -1: expected a query number from 0"),
    (["--map-set", "{manifest}", "--split", "tuning"],
     "--split tuning: the 'tuning' part of map set set holds no query"),
    (["--map-set", "{manifest}", "--split", "tuning", "--list-queries"], "--split tuning: the 'tuning' part"),
    (["--map-set", "{ros}/missing"], "--map-set {ros}/missing:"),
    (["--map-set", "generated", "--split-seed", "1"], "--split-seed: map set 'generated' has its own maps"),
    (["--map-set", "{ros}", "--start", "0", "0", "--goal", "1", "1"], "--start / --goal: a --map-set query brings"),
    (["{ros}/forest/map.yaml", "--map-set", "{ros}"], "not both"),
    (["{ros}/forest/map.yaml", "--split", "test"], "--split test: it applies to --map-set, and none is given"),
    (["{ros}/forest/map.yaml", "--query", "2"], "--query 2: it applies to --map-set"),
    ([], "give a map file, or --map-set"),
])
def test_bad_choices_exit_2_with_one_line_and_write_nothing(plan, tmp_path, capsys, args, message):
    fill = {"ros": str(ROS), "manifest": _manifest_without_tuning(tmp_path)}
    out = tmp_path / "out"
    code = plan.main([a.format(**fill) for a in args] + ["--out", str(out), "--headless"])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert err.startswith("error: ") and "\n" not in err, err
    assert message.format(**fill) in err, err
    assert not out.exists()


@pytest.mark.parametrize("case, message", [
    ("deep", "JSON nested"), ("dot", "path '.' is a folder"), ("field", "a value longer than the 128 KiB")])
def test_a_hostile_map_set_exits_2_not_1(plan, tmp_path, capsys, case, message):
    from test_mapset import _hostile_set

    code = plan.main(["--map-set", str(_hostile_set(tmp_path, case)), "--out", str(tmp_path / "out"), "--headless"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and message in err[0] and "Traceback" not in err[0]
