"""Map sets: seeded splits by map, drawn and file queries, the checks before any work, and one code path
with the generated families and MovingAI (the same problems as the evaluation's own query lists)."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from planners.base.fileio import InputError
from planners.maps.gridsearch import free_components
from planners.maps.mapset import (
    PARTS,
    FileMapSet,
    GeneratedMapSet,
    MapSet,
    MixedMapSet,
    MovingAIMapSet,
    ShiftedMapSet,
    draw_query,
    split_by_hash,
)
from planners.worlds.grid import OccupancyGrid

REPO = Path(__file__).resolve().parents[1]
ROS = REPO / "tests" / "data" / "ros"

names = st.lists(st.text("abcdefgh/_-0123456789", min_size=1, max_size=8), min_size=1, max_size=30, unique=True)
fractions = st.dictionaries(st.sampled_from(PARTS), st.floats(0.0, 1.0), min_size=1).filter(
    lambda d: sum(d.values()) > 0)


@given(names, st.integers(0, 2**31), fractions, st.randoms(use_true_random=False))
def test_split_is_disjoint_covering_and_seeded(maps, seed, fr, shuffler):
    split = split_by_hash(maps, seed, fr)
    parts = [set(split.parts[p]) for p in PARTS]
    assert sum(len(p) for p in parts) == len(maps)
    assert set().union(*parts) == set(maps)
    shuffled = list(maps)
    shuffler.shuffle(shuffled)
    assert split_by_hash(shuffled, seed, fr).parts == split.parts  # order of the names does not matter
    wanted = [p for p in PARTS if fr.get(p, 0) > 0]
    if len(maps) >= len(wanted):
        assert all(split.parts[p] for p in wanted)
    assert all(not split.parts[p] for p in PARTS if fr.get(p, 0) == 0)
    json.dumps(split.record())


def test_split_depends_on_the_seed():
    maps = [f"m{i}" for i in range(40)]
    assert split_by_hash(maps, 0).parts != split_by_hash(maps, 1).parts
    assert split_by_hash(maps, 3).parts == split_by_hash(maps, 3).parts


@pytest.mark.parametrize("bad", [{"training": 1.0}, {"test": -1.0}, {"test": 0.0}, {"test": float("nan")}])
def test_split_refuses_bad_fractions(bad):
    with pytest.raises(InputError, match="fractions"):
        split_by_hash(["a", "b"], 0, bad)


def test_ros_folder_is_a_map_set():
    ms = MapSet.open(ROS)
    assert ms.maps() == ("forest", "maze", "rooms", "turtlebot3_world")
    assert all(len(ms.maps(p)) == 1 for p in PARTS)
    assert ms.maps_by_name["maze"].grid.resolution == 0.1
    assert tuple(ms.maps_by_name["rooms"].grid.origin) == (-1.0, -2.0)
    rec = json.loads(json.dumps(ms.record()))
    assert rec["split"]["seed"] == 0 and sorted(sum(rec["split"]["parts"].values(), [])) == list(ms.maps())
    assert "sha256" in ms.describe()
    for part in PARTS:
        qs = ms.queries(part)
        assert len(qs) == 10 and {q.part for q in qs} == {part}
        for q in qs[:3]:
            p = ms.problem(q)
            assert p.world.resolution == ms.maps_by_name[q.map].grid.resolution


def _npy_maps(folder: Path, count: int, side: int = 24) -> None:
    rng = np.random.default_rng(0)
    folder.mkdir(parents=True, exist_ok=True)
    for i in range(count):
        obs = rng.random((side, side)) < 0.15
        obs[side // 2, 2:-2] = True
        np.save(folder / f"m{i}.npy", obs)


def test_drawn_queries_depend_on_seed_and_map_only(tmp_path):
    _npy_maps(tmp_path / "maps", 8)
    a = FileMapSet(tmp_path / "maps", seed=5, split_seed=1)
    b = FileMapSet(tmp_path / "maps", seed=5, split_seed=2)
    c = FileMapSet(tmp_path / "maps", seed=6, split_seed=1)
    qa = {(q.map, q.key): (q.start, q.goal) for p in PARTS for q in a.queries(p)}
    qb = {(q.map, q.key): (q.start, q.goal) for p in PARTS for q in b.queries(p)}
    qc = {(q.map, q.key): (q.start, q.goal) for p in PARTS for q in c.queries(p)}
    assert qa == qb and qa != qc
    assert a.split.parts != b.split.parts


@given(st.integers(0, 2**32), st.floats(0.0, 14.0), st.floats(0.5, 2.0))
def test_drawn_queries_are_free_connected_and_apart(seed, distance, resolution):
    rng = np.random.default_rng(seed)
    obs = np.random.default_rng(7).random((20, 20)) < 0.3
    grid = OccupancyGrid(obs, resolution, origin=(1.5, -3.0))
    labels = free_components(obs)
    start, goal = draw_query(grid, labels, rng, distance * resolution)
    assert grid.is_valid(np.array(start)) and grid.is_valid(np.array(goal))
    assert labels[grid.cell_of(start)] == labels[grid.cell_of(goal)] >= 0
    assert np.hypot(start[0] - goal[0], start[1] - goal[1]) >= distance * resolution - 1e-9


def test_drawn_query_refuses_an_impossible_distance():
    grid = OccupancyGrid(np.zeros((5, 5), bool))
    with pytest.raises(InputError, match="min_distance"):
        draw_query(grid, free_components(grid.obstacles), np.random.default_rng(0), 100.0)


def test_robot_radius_inflates_before_drawing(tmp_path):
    _npy_maps(tmp_path, 4)
    plain = FileMapSet(tmp_path, fractions={"test": 1})
    fat = FileMapSet(tmp_path, fractions={"test": 1}, robot_radius=0.4, min_distance=3.0)
    g0, g1 = plain.maps_by_name["m0"].grid, fat.maps_by_name["m0"].grid
    assert g1.obstacles.sum() > g0.obstacles.sum()
    for q in fat.queries("test"):
        grid = fat.maps_by_name[q.map].grid
        assert grid.is_valid(np.array(q.start)) and grid.is_valid(np.array(q.goal))


def _queries_folder(tmp_path: Path, rows: list[str]) -> Path:
    folder = tmp_path / "maps"
    folder.mkdir()
    obs = np.zeros((10, 10), bool)
    obs[:, 5] = True  # two halves: x < 5 and x > 6
    for name in ("left", "right"):
        np.save(folder / f"{name}.npy", obs)
    (folder / "queries.csv").write_text("# my queries\nmap,start_x,start_y,goal_x,goal_y\n" + "\n".join(rows) + "\n")
    return folder


def test_queries_file_gives_the_queries(tmp_path):
    folder = _queries_folder(tmp_path, ["left,1.5,1.5,3.5,8.5", "right,7.5,1.5,8.5,8.5", "right,6.5,2,9.5,9"])
    ms = FileMapSet(folder, fractions={"tuning": 1, "test": 1})
    qs = ms.queries("tuning") + ms.queries("test")
    assert sorted((q.map, q.start, q.goal) for q in qs) == [
        ("left", (1.5, 1.5), (3.5, 8.5)), ("right", (6.5, 2.0), (9.5, 9.0)), ("right", (7.5, 1.5), (8.5, 8.5))]
    assert {q.origin for q in qs} == {f"{folder / 'queries.csv'}, line {n}" for n in (3, 4, 5)}
    p = ms.problem(qs[0])
    assert tuple(p.start) == qs[0].start and p.goal_tolerance == 4.0


@pytest.mark.parametrize("row, message", [
    ("left,5.5,1.5,3.5,8.5", r"line 4: start \(5.5, 1.5\) on map 'left' lies in blocked cell"),
    ("left,1.5,1.5,3.5,12", r"line 4: goal \(3.5, 12\) on map 'left' lies outside the map"),
    ("left,1.5,1.5,8.5,8.5", r"line 4: .*two free regions"),
    ("attic,1.5,1.5,3.5,8.5", r"line 4: map 'attic' is not in map set"),
    ("left,1.5,one,3.5,8.5", r"line 4: start_y must be a finite number, got 'one'"),
    ("left,1.5,1.5,3.5", r"line 4: expected 5 values"),
])
def test_queries_file_errors_name_file_line_and_value(tmp_path, row, message):
    folder = _queries_folder(tmp_path, ["right,7.5,1.5,8.5,8.5", row])
    with pytest.raises(InputError, match=message) as info:
        FileMapSet(folder, fractions={"test": 1})
    assert "queries.csv" in str(info.value)


def test_manifest_queries_file_and_parts_without_queries(tmp_path):
    folder = _queries_folder(tmp_path, ["left,1.5,1.5,3.5,8.5"])
    manifest = {"maps": [{"path": "left.npy", "part": "train"}, {"path": "right.npy", "part": "test"}],
                "queries": "queries.csv"}
    (folder / "set.json").write_text(json.dumps(manifest))
    with pytest.raises(InputError, match=r"'test' part is empty: its maps \['right'\] have no queries"):
        MapSet.open(folder / "set.json")
    manifest["maps"].pop()
    (folder / "set.json").write_text(json.dumps(manifest))
    ms = MapSet.open(folder / "set.json")  # read relative to the manifest, whatever the working directory
    assert [q.map for q in ms.queries("train")] == ["left"] and ms.sample("train", np.random.default_rng(0))


def test_queries_file_needs_its_header(tmp_path):
    folder = _queries_folder(tmp_path, [])
    (folder / "queries.csv").write_text("map,x0,y0,x1,y1\n")
    with pytest.raises(InputError, match="line 1: expected the header map,start_x"):
        FileMapSet(folder, fractions={"test": 1})


def test_query_inside_an_inflated_obstacle_is_refused(tmp_path):
    folder = _queries_folder(tmp_path, ["left,4.5,1.5,1.5,8.5"])
    assert FileMapSet(folder, fractions={"test": 1}).queries("test")
    with pytest.raises(InputError, match="line 3: start .* (blocked|robot radius)"):
        FileMapSet(folder, fractions={"test": 1}, robot_radius=0.6)


def test_unreadable_map_is_refused_by_name(tmp_path):
    _npy_maps(tmp_path, 4)
    (tmp_path / "broken.png").write_bytes(b"not a png")
    with pytest.raises(InputError, match="broken.png"):
        FileMapSet(tmp_path)


def test_unknown_file_in_the_folder_is_refused(tmp_path):
    _npy_maps(tmp_path, 4)
    (tmp_path / "notes.docx").write_bytes(b"x")
    with pytest.raises(InputError, match=r"notes.docx is not a map file"):
        FileMapSet(tmp_path)


def test_empty_part_is_refused(tmp_path):
    _npy_maps(tmp_path, 3)
    with pytest.raises(InputError, match="part is empty"):
        FileMapSet(tmp_path)  # 3 maps cannot fill 4 parts
    ms = FileMapSet(tmp_path, fractions={"train": 2, "test": 1})
    assert len(ms.maps("train")) == 2 and len(ms.maps("test")) == 1
    with pytest.raises(InputError, match="'tuning' part is empty"):
        ms.validate(["tuning"])


def test_manifest(tmp_path):
    _npy_maps(tmp_path / "maps", 2)
    shutil.copytree(ROS / "maze", tmp_path / "ros_maze")
    manifest = {"maps": [{"path": "maps/m0.npy", "name": "a", "resolution": 0.5, "origin": [2, 3], "part": "train"},
                         {"path": "maps/m1.npy", "part": "test"},
                         {"path": "ros_maze/map.yaml", "part": "test"}],
                "per_map": 3, "goal_tolerance": 1.0}
    (tmp_path / "set.json").write_text(json.dumps(manifest))
    ms = MapSet.open(tmp_path / "set.json")
    assert ms.name == "set" and ms.split.parts["train"] == ("a",) and ms.split.parts["test"] == ("maps/m1", "ros_maze")
    a = ms.maps_by_name["a"].grid
    assert a.resolution == 0.5 and tuple(a.origin) == (2.0, 3.0)
    assert ms.maps_by_name["ros_maze"].grid.resolution == 0.1
    assert len(ms.queries("test")) == 6 and ms.problem(ms.queries("train")[0]).goal_tolerance == 1.0
    assert ms.split.record()["rule"] == "manifest"


@pytest.mark.parametrize("manifest, message", [
    ('{"maps": [{"path": "ros_maze/map.yaml", "resolution": 0.2}]}', "sets its own resolution"),
    ('{"maps": [], "colour": 1}', r"unknown keys \['colour'\]"),
    ('{"maps": [{"path": "nowhere.png"}]}', r"maps\[0\].*nowhere.png"),
    ('{"maps": [{"path": "ros_maze/map.yaml", "part": "exam"}]}', "part 'exam'"),
    ('{"maps": [\n  {"path": }]}', "line 2: not valid JSON"),
])
def test_manifest_errors(tmp_path, manifest, message):
    shutil.copytree(ROS / "maze", tmp_path / "ros_maze")
    (tmp_path / "set.json").write_text(manifest)
    with pytest.raises(InputError, match=message):
        MapSet.open(tmp_path / "set.json")


def test_open_refuses_what_is_not_a_map_set(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        MapSet.open(tmp_path / "missing")
    with pytest.raises(InputError, match="unknown map families"):
        MapSet.open("generated:forests")
    # one map file is not a set: the message says how it is read instead
    with pytest.raises(InputError, match="is one map file, read by itself"):
        MapSet.open(str(ROS / "maze" / "map.yaml"))


def test_mixed_map_set_draws_by_weight(tmp_path):
    _npy_maps(tmp_path / "a", 4)
    _npy_maps(tmp_path / "b", 4, side=16)
    a, b = FileMapSet(tmp_path / "a", name="a"), FileMapSet(tmp_path / "b", name="b")
    mix = MixedMapSet([a, b], [3, 1])
    draws = [mix.sample("train", np.random.default_rng(i)).world.width for i in range(200)]
    again = [mix.sample("train", np.random.default_rng(i)).world.width for i in range(200)]
    assert draws == again
    assert 0.6 < draws.count(24) / len(draws) < 0.9  # weight 3 of 4
    json.dumps(mix.record())
    with pytest.raises(InputError, match="weight"):
        MixedMapSet([a, b], [1, 0])
    with pytest.raises(InputError, match="2 map sets but 1 weights"):
        MixedMapSet([a, b], [1])


# --- one code path: the generated families, their shifted variants and MovingAI ---------------------

def _same(p, q):
    assert p.name == q.name
    assert np.array_equal(p.world.obstacles, q.world.obstacles)
    assert np.array_equal(p.start, q.start) and np.array_equal(p.goal, q.goal)
    assert p.goal_tolerance == q.goal_tolerance and p.reference_length == q.reference_length


def test_generated_map_sets_reproduce_the_evaluation_queries():
    from learning import evaluation as E
    from planners.maps.generators import FAMILIES

    old = E.generated_queries(FAMILIES, 64, 2, 1)
    ms = GeneratedMapSet(FAMILIES, 64, n_test=2, n_tune=1)
    new = ms.queries("test") + ms.queries("tuning")
    assert [(q.family, q.key, q.split) for q in old] == [(q.group, q.key, q.part) for q in new]
    for q_old, q_new in zip(old, new, strict=True):
        _same(q_old.problem(None, 4.0), ms.problem(q_new))
    old = E.shifted_queries(FAMILIES, 2)
    sh = ShiftedMapSet(FAMILIES, 2)
    assert [q.map_set for q in old] == [q.group for q in sh.queries("test")]
    for q_old, q_new in zip(old, sh.queries("test"), strict=True):
        _same(q_old.problem(None, 4.0), sh.problem(q_new))


def test_movingai_map_set_reproduces_the_evaluation_queries(movingai):
    from learning import evaluation as E

    maps = ["arena", "random-32-32-10"]
    old = E.movingai_queries(str(movingai), maps, 3, 2, 4.0)
    ms = MovingAIMapSet(movingai, maps, n_test=3, n_tune=2)
    new = ms.queries("test") + ms.queries("tuning")
    key = sorted((q.family, q.key, q.split) for q in old)
    assert key == sorted((q.group, q.key, q.part) for q in new)
    by_key = {(q.group, q.key, q.part): q for q in new}
    for q in old:
        _same(q.problem(str(movingai), 4.0), ms.problem(by_key[(q.family, q.key, q.split)]))


def test_scenario_queries_in_a_folder(tmp_path, movingai):
    for f in ("random-32-32-10.map", "random-32-32-10-random-1.scen"):
        shutil.copy(movingai / f, tmp_path / f)
    ms = FileMapSet(tmp_path, fractions={"test": 1}, resolution=2.0, origin=(10, 0))
    qs = ms.queries("test")
    assert ms.query_rule == "scen" and len(qs) > 10
    assert qs[0].origin.endswith("random-32-32-10-random-1.scen, line 2")
    p = ms.problem(qs[0])
    assert p.world.resolution == 2.0 and p.start[0] > 10 and (p.start[0] - 10) % 2 == 1.0


# --- the environment ---------------------------------------------------------------------------

def test_planning_env_draws_from_a_map_set_part():
    import gymnasium as gym

    import envs

    gym.register_envs(envs)
    env = gym.make("SamplerGym/Planning-v1", map_set=str(ROS), split="test", max_iterations=20)
    test_map = MapSet.open(ROS).maps("test")[0]
    seen = []
    for seed in (0, 1, 2):
        env.reset(seed=seed)
        seen.append(env.unwrapped.problem)
    assert {str(Path(p.world.source).parent.name) for p in seen} == {test_map}
    env.reset(seed=1)
    assert np.array_equal(env.unwrapped.problem.start, seen[1].start)
    with pytest.raises(InputError, match="split must be one of"):
        gym.make("SamplerGym/Planning-v1", map_set=str(ROS), split="exam")
    with pytest.raises(InputError, match="not both"):
        gym.make("SamplerGym/Planning-v1", map_set=str(ROS), map=np.zeros((8, 8), bool))


def test_example_maps_are_what_the_script_writes(tmp_path):
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_ros_maps", REPO / "examples" / "make_ros_maps.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    mod.main(["--out", str(tmp_path)])
    for folder in ("forest", "maze", "rooms"):
        for f in ("map.pgm", "map.yaml"):
            assert (tmp_path / folder / f).read_bytes() == (ROS / folder / f).read_bytes(), f"{folder}/{f}"


def test_a_manifest_may_lower_the_cell_limit_but_never_raise_it(tmp_path, monkeypatch):
    shutil.copytree(ROS / "maze", tmp_path / "ros_maze")  # 96 x 96 = 9,216 cells
    monkeypatch.setenv("SAMPLERGYM_MAX_PIXELS", "100")
    manifest = {"maps": [{"path": "ros_maze/map.yaml", "part": "test"}], "max_pixels": 10**12}
    (tmp_path / "set.json").write_text(json.dumps(manifest))
    with pytest.raises(InputError, match=r"set.json: max_pixels = 1,000,000,000,000 is above the limit in force "
                                         r"\(100\); a manifest may only lower it.*SAMPLERGYM_MAX_PIXELS"):
        MapSet.open(tmp_path / "set.json")
    monkeypatch.delenv("SAMPLERGYM_MAX_PIXELS")
    manifest["max_pixels"] = 1000  # lower than the default: in force
    (tmp_path / "set.json").write_text(json.dumps(manifest))
    with pytest.raises(InputError, match="more than the limit of 1,000"):
        MapSet.open(tmp_path / "set.json")
    assert MapSet.open(tmp_path / "set.json", max_pixels=10_000).maps() == ("ros_maze",)  # code may raise it


def test_drawn_queries_per_map_have_a_limit_refused_before_drawing(tmp_path, monkeypatch):
    import time

    _npy_maps(tmp_path, 4)
    t0 = time.monotonic()
    with pytest.raises(InputError, match=r"per_map = 1,000,000 drawn queries per map, more than the limit of 1,000.*"
                                         r"SAMPLERGYM_MAX_PER_MAP"):
        FileMapSet(tmp_path, per_map=10**6)
    assert time.monotonic() - t0 < 5
    monkeypatch.setenv("SAMPLERGYM_MAX_PER_MAP", "2000")
    assert len(FileMapSet(tmp_path, per_map=1001, fractions={"train": 1}).queries("train")) == 4 * 1001


def _hostile_set(tmp_path: Path, case: str) -> Path:
    """A map set holding one hostile input: a manifest nested deep, a manifest entry '.', a huge queries value."""
    if case == "deep":
        (tmp_path / "deep.json").write_text('{"maps": ' + "[" * 200_000 + "]" * 200_000 + "}")
        return tmp_path / "deep.json"
    if case == "dot":
        _npy_maps(tmp_path, 4)
        (tmp_path / "dot.json").write_text('{"maps": ["."]}')
        return tmp_path / "dot.json"
    folder = _queries_folder(tmp_path, ["left," + "1" * (130 * 1024) + ",1.5,3.5,8.5"])
    return folder


HOSTILE = [("deep", r"deep.json: JSON nested \d+ levels deep"),
           ("dot", r"dot.json: maps\[0\]: path '.' is a folder, expected a map file"),
           ("field", r"queries.csv, line 3: a value longer than the 128 KiB a field may hold")]


@pytest.mark.parametrize("case, message", HOSTILE)
def test_hostile_map_sets_are_refused_by_name(tmp_path, case, message):
    spec = _hostile_set(tmp_path, case)
    with pytest.raises(InputError, match=message):
        MapSet.open(spec)
    import gymnasium as gym

    with pytest.raises(InputError, match=message):
        gym.make("samplergym:SamplerGym/Planning-v1", map_set=str(spec))


@pytest.mark.parametrize("kind", ["folder", "fifo", "dev-zero"])
def test_a_queries_file_that_is_not_a_regular_file_is_refused_not_ignored(tmp_path, kind):
    import os

    _npy_maps(tmp_path, 4)
    q = tmp_path / "queries.csv"
    if kind == "folder":
        q.mkdir()
    elif kind == "fifo":
        os.mkfifo(q)
    else:
        q.symlink_to("/dev/zero")
    want = {"folder": "a folder", "fifo": "a FIFO", "dev-zero": "a device"}[kind]
    with pytest.raises(InputError, match=rf"queries.csv' is {want}; expected a regular file"):
        FileMapSet(tmp_path)
    with pytest.raises(InputError, match=rf"is {want}; expected a regular file"):
        FileMapSet(tmp_path, queries=str(q))


@pytest.mark.parametrize("spec, given", [("generated:forest@-5", "-5"), ("generated:maze@0", "0"),
                                         ("generated:@8", "8")])
def test_a_generated_size_is_refused_at_open_with_the_value_as_given(spec, given):
    with pytest.raises(InputError, match=rf"map set '{re.escape(spec)}': size must be an integer >= 32, got {given}$"):
        MapSet.open(spec)
    with pytest.raises(InputError, match="train_sizes"):
        GeneratedMapSet(("forest",), train_sizes=(64, -1))
