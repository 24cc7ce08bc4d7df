"""OMPL benchmark logs: read back by a faithful port of OMPL's log reader into SQLite.

``read_benchmark_log`` follows ``readBenchmarkLog`` of OMPL's ``ompl_benchmark_statistics.py``
(ompl/ompl, ``py-bindings/ompl/_benchmark_statistics.py``) line for line: the same token checks,
the same optional lines tried and rewound, the same tables and column naming, so a log it reads is
a log that OMPL's script turns into the database Planner Arena opens.
"""

from __future__ import annotations

import io
import math
import os
import sqlite3
import stat
import sys
from pathlib import Path

import pytest

from planners.base.fileio import InputError
from planners.tools.benchmark_log import PlannerRuns, experiment_name, format_log, write_log

REPO = Path(__file__).resolve().parents[1]


# --- the reader: a port of OMPL's readBenchmarkLog (non-MoveIt format) -------------------------------

def _read_value(f, index, expected):
    start = f.tell()
    tokens = f.readline().split()
    for i, tok in (expected or {}).items():
        if tokens[i] != tok:
            f.seek(start)
            return None
    return tokens[index]


def _required(name, f, index, expected=None):
    v = _read_value(f, index, expected)
    if v is None:
        raise AssertionError(f"unable to read {name}")
    return v


def _multiline(f, required):
    start = f.tell()
    line = f.readline()
    if not line.startswith("<<<|"):
        if required:
            raise AssertionError("expected prefix <<<|")
        f.seek(start)
        return None
    value = ""
    line = f.readline()
    while not line.startswith("|>>>"):
        if not line:
            raise AssertionError("expected token |>>> missing")
        value += line
        line = f.readline()
    return value


def _columns(c, f, table: str, n: int) -> list[str]:
    """The next ``n`` property lines (``name words TYPE``) as ``table``'s columns, added where missing."""
    cols = [col[1] for col in c.execute(f"PRAGMA table_info({table})").fetchall()]
    names = []
    for _ in range(n):
        field = f.readline().split()
        name = "_".join(field[:-1])
        if name not in cols:
            c.execute(f"ALTER TABLE {table} ADD {name} {field[-1]}")
        names.append(name)
    return names


def read_benchmark_log(text: str, conn: sqlite3.Connection) -> int:
    """Parse one log into ``conn`` (OMPL's schema); returns the experiment id."""
    c = conn.cursor()
    c.executescript("""CREATE TABLE IF NOT EXISTS experiments
        (id INTEGER PRIMARY KEY AUTOINCREMENT, name VARCHAR(512), totaltime REAL, timelimit REAL,
        memorylimit REAL, runcount INTEGER, version VARCHAR(128), hostname VARCHAR(1024), cpuinfo TEXT,
        date DATETIME, seed VARCHAR(24), setup TEXT);
        CREATE TABLE IF NOT EXISTS plannerConfigs
        (id INTEGER PRIMARY KEY AUTOINCREMENT, name VARCHAR(512) NOT NULL, settings TEXT);
        CREATE TABLE IF NOT EXISTS enums (name VARCHAR(512), value INTEGER, description TEXT,
        PRIMARY KEY (name, value));
        CREATE TABLE IF NOT EXISTS runs (id INTEGER PRIMARY KEY AUTOINCREMENT, experimentid INTEGER,
        plannerid INTEGER);
        CREATE TABLE IF NOT EXISTS progress (runid INTEGER, time REAL, PRIMARY KEY (runid, time))""")
    f = io.StringIO(text)
    start = f.tell()
    lib = _read_value(f, 0, {1: "version"}) or "OMPL"
    f.seek(start)
    version = " ".join([lib, _read_value(f, -1, {1: "version"}) or "0.0.0"])
    expname = _required("experiment name", f, -1, {0: "Experiment"})
    nprops = int(_read_value(f, 0, {-2: "experiment", -1: "properties"}) or 0)
    expprops = {}
    for _ in range(nprops):
        entry = f.readline().strip().split(" = ")
        name_type = entry[0].split(" ")
        expprops["".join(name_type[:-1]).replace("-", "_")] = (entry[1], name_type[-1])
    c.execute("PRAGMA table_info(experiments)")
    cols = [col[1] for col in c.fetchall()]
    for name in sorted(expprops):
        if name not in cols:
            c.execute(f"ALTER TABLE experiments ADD {name} {expprops[name][1]}")
    hostname = _required("hostname", f, -1, {0: "Running"})
    line = f.readline()
    assert line.startswith("Starting"), line
    date = " ".join(line.split()[2:])
    setup = _multiline(f, True)
    cpuinfo = _multiline(f, False)
    seed = _required("random seed", f, 0, {-2: "random", -1: "seed"})
    timelimit = float(_required("time limit", f, 0, {-3: "seconds", -2: "per", -1: "run"}))
    memorylimit = float(_required("memory limit", f, 0, {-3: "MB", -2: "per", -1: "run"}))
    nruns = _read_value(f, 0, {-3: "runs", -2: "per", -1: "planner"})
    nruns = -1 if nruns is None else int(nruns)
    totaltime = float(_required("total time", f, 0, {-3: "collect", -2: "the", -1: "data"}))
    nenums = int(_read_value(f, 0, {-2: "enum"}) or 0)
    for _ in range(nenums):
        enum = f.readline()[:-1].split("|")
        for j in range(len(enum) - 1):
            c.execute("INSERT OR IGNORE INTO enums VALUES (?,?,?)", (enum[0], j, enum[j + 1]))
    names = ["name", "totaltime", "timelimit", "memorylimit", "runcount", "version", "hostname", "cpuinfo",
             "date", "seed", "setup", *expprops]
    values = [expname, totaltime, timelimit, memorylimit, nruns, version, hostname, cpuinfo, date, seed, setup,
              *(v[0] for v in expprops.values())]
    c.execute(f"INSERT INTO experiments ({','.join(names)}) VALUES ({','.join('?' * len(values))})", values)
    exp_id = c.lastrowid
    nplanners = int(_required("planner count", f, 0, {-1: "planners"}))
    for _ in range(nplanners):
        planner = f.readline()[:-1]
        ncommon = int(f.readline().split()[0])
        settings = "".join(f.readline() + ";" for _ in range(ncommon))
        c.execute("SELECT id FROM plannerConfigs WHERE (name=? AND settings=?)", (planner, settings))
        row = c.fetchone()
        if row is None:
            c.execute("INSERT INTO plannerConfigs VALUES (?,?,?)", (None, planner, settings))
            planner_id = c.lastrowid
        else:
            planner_id = row[0]
        prop_names = ["experimentid", "plannerid", *_columns(c, f, "runs", int(f.readline().split()[0]))]
        insert = f"INSERT INTO runs ({','.join(prop_names)}) VALUES ({','.join('?' * len(prop_names))})"
        run_ids = []
        for _ in range(int(f.readline().split()[0])):
            vals = [None if not x or x in ("nan", "inf") else x for x in f.readline().split("; ")[:-1]]
            c.execute(insert, tuple([exp_id, planner_id, *vals]))
            run_ids.append(c.lastrowid)
        next_line = f.readline().strip()
        if next_line != ".":  # the planner's progress data
            names = ["runid", *_columns(c, f, "progress", int(next_line.split()[0]))]
            insert = f"INSERT INTO progress ({','.join(names)}) VALUES ({','.join('?' * len(names))})"
            for j in range(int(f.readline().split()[0])):
                for sample in f.readline().split(";")[:-1]:
                    vals = [None if not x or x in ("nan", "inf") else x for x in sample.split(",")[:-1]]
                    c.execute(insert, tuple([run_ids[j], *vals]))  # a repeated time is an IntegrityError
            f.readline()
    assert f.read() == "", "text after the last planner"
    conn.commit()
    return exp_id


def runs_table(conn: sqlite3.Connection, experiment_id: int) -> list[dict]:
    """The runs of one experiment as dicts, with the planner's name under ``planner``."""
    conn.row_factory = sqlite3.Row
    rows = conn.execute("SELECT runs.*, plannerConfigs.name AS planner, plannerConfigs.settings AS settings "
                        "FROM runs JOIN plannerConfigs ON runs.plannerid = plannerConfigs.id "
                        "WHERE experimentid = ? ORDER BY runs.id", (experiment_id,)).fetchall()
    return [dict(r) for r in rows]


# --- the writer ------------------------------------------------------------------------------------

PROPS = [("time", "REAL"), ("solved", "BOOLEAN"), ("iterations", "INTEGER"), ("graph states", "INTEGER"),
         ("solution length", "REAL")]


def _example() -> dict:
    return {
        "RRT uniform": PlannerRuns({"step_size": 4.0, "sampler": "uniform"}, [
            {"time": 0.25, "solved": True, "iterations": 120, "graph states": 80, "solution length": 51.5},
            {"time": 1.5, "solved": False, "iterations": 20000, "graph states": 9000, "solution length": math.inf},
        ]),
        "RRT goal bias 0.05": PlannerRuns({"step_size": 4.0, "sampler": "goal_bias=0.05"}, [
            {"time": 0.125, "solved": True, "iterations": 60, "graph states": 41, "solution length": 49.0},
            {"time": 0.5, "solved": True, "iterations": 200, "graph states": None, "solution length": 50.25},
        ]),
    }


def test_log_reads_back_through_ompls_reader():
    text = format_log("forest", _example(), PROPS, setup="two planners\non forest maps", total_time=2.375, seed=7,
                      experiment_properties={"step_size": ("REAL", 4.0), "max_iterations": ("INTEGER", 20000)},
                      version="1.2", hostname="host name")
    conn = sqlite3.connect(":memory:")
    exp = read_benchmark_log(text, conn)
    e = dict(zip([d[0] for d in conn.execute("SELECT * FROM experiments").description],
                 conn.execute("SELECT * FROM experiments").fetchone(), strict=True))
    assert (e["name"], e["runcount"], e["version"], e["seed"]) == ("forest", 2, "SamplerGym 1.2", "7")
    assert e["totaltime"] == 2.375 and e["setup"] == "two planners\non forest maps\n" and e["hostname"] == "host_name"
    assert (float(e["step_size"]), int(e["max_iterations"])) == (4.0, 20000)
    rows = runs_table(conn, exp)
    assert [r["planner"] for r in rows] == ["RRT uniform"] * 2 + ["RRT goal bias 0.05"] * 2
    assert [r["iterations"] for r in rows] == [120, 20000, 60, 200]
    assert [r["solved"] for r in rows] == [1, 0, 1, 1]
    assert [r["graph_states"] for r in rows] == [80, 9000, 41, None]
    assert [r["solution_length"] for r in rows] == [51.5, None, 49.0, 50.25]  # unsolved: no length
    assert [r["time"] for r in rows] == [0.25, 1.5, 0.125, 0.5]
    assert "sampler = goal_bias=0.05" in rows[2]["settings"]


PROGRESS = [("time", "REAL"), ("iterations", "INTEGER"), ("best cost", "REAL")]


def test_progress_data_reads_back_into_the_progress_table():
    example = _example()
    example["RRT uniform"] = PlannerRuns(example["RRT uniform"].settings, example["RRT uniform"].runs, progress=[
        [{"time": 0.01, "iterations": 25, "best cost": 60.5}, {"time": 0.02, "iterations": 50, "best cost": 51.5}],
        []])  # the second run never found a path: no points
    text = format_log("forest", example, PROPS, setup="s", total_time=1.0, progress_properties=PROGRESS)
    conn = sqlite3.connect(":memory:")
    exp = read_benchmark_log(text, conn)
    ids = [r["id"] for r in runs_table(conn, exp)]
    rows = conn.execute("SELECT runid, time, iterations, best_cost FROM progress ORDER BY runid, time").fetchall()
    assert [tuple(r) for r in rows] == [(ids[0], 0.01, 25, 60.5), (ids[0], 0.02, 50, 51.5)]


@pytest.mark.parametrize(("progress", "props", "match"), [
    ([[{"time": 0.02, "iterations": 1, "best cost": 2.0}, {"time": 0.02, "iterations": 2, "best cost": 1.0}], []],
     PROGRESS, "above the point before"),
    ([[{"time": 0.01, "iterations": 1, "cost": 2.0}], []], PROGRESS, "not declared"),
    ([[]], PROGRESS, "one per run"),
    ([[], []], (), "no progress properties"),
    ([[], []], [("iterations", "INTEGER"), ("time", "REAL")], "first"),
])
def test_bad_progress_data_is_refused(progress, props, match):
    example = _example()
    example["RRT uniform"] = PlannerRuns({}, example["RRT uniform"].runs, progress=progress)
    with pytest.raises(InputError, match=match):
        format_log("forest", example, PROPS, setup="s", total_time=1.0, progress_properties=props)


def test_two_logs_make_one_database_with_two_experiments():
    conn = sqlite3.connect(":memory:")
    ids = [read_benchmark_log(format_log(experiment_name(n), _example(), PROPS, setup="s", total_time=1.0), conn)
           for n in ("forest", "MovingAI (all)")]
    names = [r[0] for r in conn.execute("SELECT name FROM experiments ORDER BY id")]
    assert names == ["forest", "MovingAI_(all)"]
    assert len(runs_table(conn, ids[1])) == 4
    # same planner name and settings in both experiments: one configuration, as OMPL's reader keeps it
    assert conn.execute("SELECT COUNT(*) FROM plannerConfigs").fetchone()[0] == 2


@pytest.mark.parametrize("kwargs, match", [
    ({"experiment": "two words"}, "whitespace"),
    ({"properties": [("time/iteration", "REAL")]}, "database column"),
    ({"properties": [("time", "FLOAT")]}, "FLOAT"),
    ({"properties": [("time", "REAL"), ("time", "REAL")]}, "distinct"),
    ({"planners": {}}, "at least one planner"),
    ({"planners": {"a\nb": PlannerRuns({}, [])}}, "single line"),
    ({"planners": {"p": PlannerRuns({}, [{"solved": 2}])}}, "boolean"),
    ({"planners": {"p": PlannerRuns({}, [{"iterations": 1.5}])}}, "integer"),
    ({"planners": {"p": PlannerRuns({}, [{"oops": 1}])}}, "not declared"),
    ({"setup": "x\n|>>> y"}, "end its block"),
])
def test_bad_log_content_is_refused(kwargs, match):
    args = {"experiment": "e", "planners": _example(), "properties": PROPS, "setup": "s"}
    args.update(kwargs)
    with pytest.raises(InputError, match=match):
        format_log(args.pop("experiment"), args.pop("planners"), args.pop("properties"), total_time=1.0, **args)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def test_written_log_has_umask_permissions(tmp_path):
    p = write_log(tmp_path / "sub" / "e.log", "e", _example(), PROPS, setup="s", total_time=1.0)
    assert stat.S_IMODE(p.stat().st_mode) == 0o666 & ~_umask()
    assert [q.name for q in p.parent.iterdir()] == ["e.log"]  # no temporary left beside it


def _load_script(name: str):
    import importlib.util

    spec = importlib.util.spec_from_file_location(f"_script_{name}", REPO / "scripts" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


def test_benchmark_planners_writes_a_log_per_map(tmp_path):
    from types import SimpleNamespace

    from planners.maps.generators import generate
    from planners.tools import benchmark

    bp = _load_script("benchmark_planners")
    args = SimpleNamespace(step=4.0, max_iterations=3000)
    problems = [generate("forest", s, 64) for s in range(2)]
    recs = [benchmark.run_one(p, label, step=4.0, seed=i, max_iterations=3000, map_name="forest-64")
            for label in ("RRT", "PRM") for i, p in enumerate(problems)]
    # OMPL's runs report no collision checks (-1 in the CSV): NULL in the database
    recs.append(benchmark.Run(map="forest-64", query=problems[0].name, split="test", planner="OMPL RRT b=0.0",
                              sampler="OMPL", seed=0, solved=True, iterations=10, lower_bound=-1, candidates=10,
                              collision_checks=-1, wall_time=0.01, us_per_iteration=1000.0, path_cost=40.0,
                              forward_passes=0, vertices=11))
    paths = bp.write_ompl_logs(recs, args, tmp_path / "ompl")
    assert [p.name for p in paths] == ["forest-64.log"]
    assert stat.S_IMODE(paths[0].stat().st_mode) == 0o666 & ~_umask()
    conn = sqlite3.connect(":memory:")
    rows = runs_table(conn, read_benchmark_log(paths[0].read_text(), conn))
    assert [r["planner"] for r in rows] == ["RRT", "RRT", "PRM", "PRM", "OMPL RRT b=0.0"]
    assert [r["iterations"] for r in rows] == [r.iterations for r in recs]
    assert [r["graph_states"] for r in rows] == [r.vertices for r in recs]
    assert [r["collision_checks"] for r in rows] == [r.collision_checks for r in recs[:-1]] + [None]
    assert [(r["solved"], r["time"]) for r in rows] == [(int(x.solved), pytest.approx(x.wall_time)) for x in recs]
