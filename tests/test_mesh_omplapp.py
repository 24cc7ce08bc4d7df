"""OMPL.app's problem files: the reader on files made here, and, where a copy of OMPL.app is given
(``SAMPLERGYM_OMPLAPP_DIR``), its shipped solutions replayed state by state in our frame."""

from __future__ import annotations

import math

import numpy as np
import pytest

trimesh = pytest.importorskip("trimesh", reason="mesh worlds need the mesh extra (pip install samplergym[mesh])")
pytest.importorskip("fcl", reason="mesh worlds need the mesh extra (pip install samplergym[mesh])")

from planners import RRTConnect  # noqa: E402
from planners.base.fileio import InputError  # noqa: E402
from planners.worlds.omplapp import (  # noqa: E402
    OMPLAPP_ENV,
    axis_angle_matrix,
    load_omplapp,
    load_omplapp_cfg,
    load_omplapp_world,
    omplapp_dir,
    quaternion_matrix,
    read_omplapp_path,
)
from planners.worlds.rigid3d import euler_from_matrix, rotation_matrix  # noqa: E402

PI = math.pi

#: OMPL.app problems whose every shipped solution state is collision-free here (see docs/rigid-body.md
#: for the others).
REPLAYED = ("cubicles", "Twistycool", "Easy", "Apartment", "alpha-1.5", "spirelli")

CFG = """[problem]
name = {name}
robot = robot.obj
world = env.obj
start.x = 2
start.y = 5
start.z = 5
start.theta = {theta}
start.axis.x = 0
start.axis.y = 0
start.axis.z = 1
goal.x = 8
goal.y = 5
goal.z = 5
goal.theta = 0
goal.axis.x = 1
goal.axis.y = 0
goal.axis.z = 0
volume.min.x = 0
volume.min.y = 0
volume.min.z = 0
volume.max.x = 10
volume.max.y = 10
volume.max.z = 10

[benchmark]
time_limit=5.0
mem_limit=1000.0
run_count=7

[planner]
rrtconnect=
prm=
aps=
aps.name=APS1
aps=
aps.name=APS4
"""


def write_problem(folder, theta=0.5, name="hole"):
    box = lambda e, c: trimesh.creation.box(extents=e, transform=trimesh.transformations.translation_matrix(c))  # noqa: E731
    env = trimesh.util.concatenate([box((0.2, 10, 3.5), (5, 5, 1.75)), box((0.2, 10, 3.5), (5, 5, 8.25)),
                                    box((0.2, 3.5, 3), (5, 1.75, 5)), box((0.2, 3.5, 3), (5, 8.25, 5))])
    env.export(folder / "env.obj")
    # the robot off its origin: OMPL.app moves the mean of its vertices there
    box((1.0, 0.6, 0.4), (30, -20, 10)).export(folder / "robot.obj")
    path = folder / f"{name}.cfg"
    path.write_text(CFG.format(name=name, theta=theta))
    return path


def write_offset_problem(folder, name="offset"):
    """``write_problem`` with its start off the hole's line: a tree's first connect does not solve it at once."""
    path = write_problem(folder, name=name)
    path.write_text(path.read_text().replace("start.y = 5\n", "start.y = 1.5\n").replace("start.z = 5\n",
                                                                                          "start.z = 1.5\n"))
    return path


def run_rigid_benchmark(tmp_path, *flags):
    """``benchmark_planners.py --rigid`` with RRT-Connect and ``flags`` on ``write_offset_problem``'s file, 2 runs:
    the script, its arguments, its runs (rows of ``rigid_runs.csv``) and the problem."""
    import csv

    from conftest import load_script

    folder = tmp_path / "problems"
    folder.mkdir()
    path = write_offset_problem(folder)
    bp = load_script("benchmark_planners")
    out = tmp_path / "out"
    argv = ["--rigid", str(folder), "--rigid-runs", "2", "--rigid-time-limit", "10", "--out", str(out),
            "--rigid-planners", "RRTConnect", *flags]
    assert bp.main(argv) == 0
    return bp, argv, list(csv.DictReader((out / "rigid_runs.csv").open())), load_omplapp_cfg(path)


def test_a_problem_file_reads_into_a_mesh_problem(tmp_path):
    task = load_omplapp(write_problem(tmp_path))
    p = task.problem
    assert p.name == "hole" and task.time_limit == 5.0 and task.mem_limit == 1000.0 and task.run_count == 7
    assert task.planners == ("rrtconnect", "prm", "aps")
    w = p.world
    assert np.allclose(w.bounds[0][:3], 0) and np.allclose(w.bounds[1][:3], 10)
    assert np.allclose(w.body_vertices.mean(axis=0), 0)  # the robot's origin is its vertex mean
    assert np.allclose(p.start[:3], [2, 5, 5]) and np.allclose(rotation_matrix(*p.start[3:]),
                                                                axis_angle_matrix([0, 0, 1], 0.5))
    assert np.allclose(p.goal, [8, 5, 5, 0, 0, 0])
    r = RRTConnect(p, step_size=1.0, seed=0).solve(max_iterations=3000)
    assert r.solved and w.path_valid(r.path)
    assert np.array_equal(load_omplapp_cfg(write_problem(tmp_path)).start, p.start)


@pytest.mark.parametrize("edit, message", [
    (lambda t: t.replace("start.x = 2\n", ""), r"start\.x is missing"),
    (lambda t: t.replace("goal.y = 5", "goal.y = five"), r"goal\.y = 'five' is not a number"),
    (lambda t: t.replace("robot = robot.obj", "robot = nothing.obj"), "nothing.obj not found"),
    (lambda t: t.replace("goal.x = 8\ngoal.y = 5", "goal.x = 5\ngoal.y = 2"), "goal .* is not a valid state"),
    (lambda t: t.replace("start.axis.z = 1", "start.axis.z = 0"), "non-zero axis"),
    (lambda t: t.replace("run_count=7", "run_count=7.5"), "run_count = '7.5' is not an integer"),
    (lambda t: t.replace("[problem]", "[nothing]"), r"no \[problem\] section"),
])
def test_a_bad_problem_file_names_the_file_and_the_key(tmp_path, edit, message):
    path = write_problem(tmp_path)
    path.write_text(edit(path.read_text()))
    with pytest.raises(InputError, match=message) as e:
        load_omplapp(path)
    assert str(path) in str(e.value)


def test_the_world_alone_reads_where_the_query_does_not(tmp_path):
    path = write_problem(tmp_path)
    p = load_omplapp(path).problem
    w = load_omplapp_world(path)
    assert np.array_equal(w.env_vertices, p.world.env_vertices)
    assert np.array_equal(w.body_vertices, p.world.body_vertices)
    assert np.array_equal(w.grid, p.world.grid) and w.delta == p.world.delta and w.name == "hole"
    assert np.array_equal(w.bounds[0], p.world.bounds[0]) and np.array_equal(w.bounds[1], p.world.bounds[1])
    assert w.is_valid(p.goal) and w is not p.world
    # a goal inside the wall: the problem is refused, its world still reads
    path.write_text(path.read_text().replace("goal.x = 8\ngoal.y = 5", "goal.x = 5\ngoal.y = 2"))
    with pytest.raises(InputError, match="goal .* is not a valid state"):
        load_omplapp(path)
    assert not load_omplapp_world(path).is_valid(np.array([5.0, 2, 5, 0, 0, 0]))
    path.write_text(path.read_text().replace("robot = robot.obj", "robot = nothing.obj"))
    with pytest.raises(InputError, match="nothing.obj not found") as e:
        load_omplapp_world(path)
    assert str(path) in str(e.value)


def test_quaternions_and_axis_angles_agree():
    rng = np.random.default_rng(0)
    for _ in range(50):
        axis, theta = rng.normal(size=3), rng.uniform(-PI, PI)
        x, y, z = axis / np.linalg.norm(axis) * math.sin(theta / 2)
        assert np.allclose(quaternion_matrix(x, y, z, math.cos(theta / 2)), axis_angle_matrix(axis, theta))
        R = trimesh.transformations.rotation_matrix(theta, axis)[:3, :3]
        assert np.allclose(axis_angle_matrix(axis, theta), R)


def test_omplapp_dir_takes_the_root_or_the_folder(tmp_path, monkeypatch):
    monkeypatch.delenv(OMPLAPP_ENV, raising=False)
    assert omplapp_dir() is None
    folder = tmp_path / "resources" / "3D"
    folder.mkdir(parents=True)
    write_problem(folder)
    assert omplapp_dir(tmp_path) == folder and omplapp_dir(folder) == folder
    monkeypatch.setenv(OMPLAPP_ENV, str(tmp_path))
    assert omplapp_dir() == folder
    with pytest.raises(InputError, match="--omplapp"):
        omplapp_dir(tmp_path / "elsewhere")


# --- OMPL.app's own files ----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def omplapp():
    try:
        d = omplapp_dir()
    except InputError as e:
        pytest.skip(str(e))
    if d is None:
        pytest.skip(f"OMPL.app's problems not found: set {OMPLAPP_ENV} to a copy of OMPL.app (its root or "
                    f"resources/3D); its licence does not let us ship them")
    return d


@pytest.mark.parametrize("name", REPLAYED)
def test_every_state_of_omplapps_solution_is_free_and_a_nudged_one_is_not(omplapp, name):
    cfg, solution = omplapp / f"{name}.cfg", omplapp / f"{name}.path"
    if not (cfg.is_file() and solution.is_file()):
        pytest.skip(f"{cfg.name} or {solution.name} is not in {omplapp}")
    task = load_omplapp(cfg)
    w = task.problem.world
    Q = read_omplapp_path(solution)
    assert np.allclose(Q[0, :3], task.problem.start[:3])
    assert all(w.is_valid(q) for q in Q)
    # nudged: each state moved towards the environment's nearest point until it touches, which the
    # check must see; the frame is then right to within the nudge
    fcl = pytest.importorskip("fcl")
    hits = 0
    for q in Q[:: max(1, len(Q) // 8)]:
        w._check.body.setTransform(fcl.Transform(np.asarray(rotation_matrix(*q[3:])), q[:3].copy()))
        result = fcl.DistanceResult()
        d = fcl.distance(w._check.body, w._check.env, fcl.DistanceRequest(enable_nearest_points=True), result)
        direction = result.nearest_points[1] - result.nearest_points[0]
        nudged = q.copy()
        nudged[:3] += direction * (1 + 1e-3) + direction / max(np.linalg.norm(direction), 1e-12) * 1e-3 * w.radius
        assert d > 0 and not w.is_valid(nudged), (name, q)
        hits += 1
    assert hits >= 2


def test_escapes_goal_meets_the_environment_and_its_solution_replays_in_the_world(omplapp):
    cfg, solution = omplapp / "escape.cfg", omplapp / "escape.path"
    if not (cfg.is_file() and solution.is_file()):
        pytest.skip(f"{cfg.name} or {solution.name} is not in {omplapp}")
    with pytest.raises(InputError, match="goal .* is not a valid state"):
        load_omplapp(cfg)
    w = load_omplapp_world(cfg)
    Q = read_omplapp_path(solution)
    assert len(Q) == 326 and all(w.is_valid(q) for q in Q)
    goal = np.array([-53.04, 18.23, 0.83, *euler_from_matrix(axis_angle_matrix([1, 0, 0], 3.14159265359))])
    assert not w.is_valid(goal) and np.linalg.norm(Q[-1, :3] - goal[:3]) < 0.02


def test_without_assimps_up_axis_turn_the_start_collides(omplapp, monkeypatch):
    if not (omplapp / "cubicles.cfg").is_file():
        pytest.skip(f"cubicles.cfg is not in {omplapp}")
    import planners.worlds.mesh as mesh

    load_omplapp(omplapp / "cubicles.cfg")  # in OMPL.app's frame it loads
    monkeypatch.setitem(mesh._UP_TO_Y, "Z_UP", np.eye(3))  # the files are Z_UP: read them untouched
    with pytest.raises(InputError, match="start .* is not a valid state"):
        load_omplapp(omplapp / "cubicles.cfg")


def test_plan3d_plans_and_draws_a_problem_file(tmp_path):
    import os
    import subprocess
    import sys
    from pathlib import Path

    repo = Path(__file__).resolve().parents[1]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(repo), os.environ.get("PYTHONPATH")]))}

    def plan3d(*args):
        return subprocess.run([sys.executable, str(repo / "scripts" / "plan3d.py"), *map(str, args)],
                              capture_output=True, text=True, env=env, timeout=600)

    out = tmp_path / "out"
    done = plan3d(write_problem(tmp_path), "--time-limit", 20, "--frames", 3, "--out", out)
    assert done.returncode == 0, done.stderr
    assert "solved:           True" in done.stdout
    assert (out / "plan3d.png").stat().st_size > 0 and (out / "plan3d.gif").stat().st_size > 0
    bad = plan3d(tmp_path / "nothing.cfg", "--out", out)
    assert bad.returncode == 2 and "does not exist" in bad.stderr
    again = plan3d(write_problem(tmp_path), "--restarts", 3, "--sampler", "rigid_route_ablation", "--frames", 3,
                   "--out", tmp_path / "again")
    assert again.returncode == 0, again.stderr
    assert "restarts by Luby's sequence x 3" in again.stdout and " attempts" in again.stdout
    scene = plan3d(Path(repo / "planners" / "scenes" / "window.scene"), "--setup", "rrt", "--restarts", 5,
                   "--out", out)
    assert scene.returncode == 2 and "--restarts is for OMPL.app .cfg problems" in scene.stderr
    # a .cfg problem with the seed project's PRM set-up: its samples, within the problem's time limit too
    roadmap = plan3d(write_problem(tmp_path), "--setup", "prm", "--time-limit", 20, "--frames", 3,
                     "--out", tmp_path / "prm")
    assert roadmap.returncode == 0, roadmap.stderr
    assert "set-up:           prm: PRM, seed 0, budget 5000 iterations, 20 s" in roadmap.stdout
    assert (tmp_path / "prm" / "plan3d.gif").stat().st_size > 0
    both = plan3d(write_problem(tmp_path), "--setup", "prm", "--restarts", 5, "--out", out)
    assert both.returncode == 2 and "a set-up (--setup) plans without restarts" in both.stderr


def test_ompl_runs_its_planners_on_a_problem_file(tmp_path):
    from planners.tools import ompl_bridge

    if not ompl_bridge.available():
        pytest.skip("OMPL's Python bindings are not installed (the bench extra)")
    from planners.tools.ompl_bridge import _axis_angle
    from planners.worlds.omplapp import axis_angle_matrix

    rng = np.random.default_rng(1)
    for R in [trimesh.transformations.random_rotation_matrix(rng.random(3))[:3, :3] for _ in range(50)] + \
            [axis_angle_matrix([1, 0, 0], PI), axis_angle_matrix([1, -1, 0.5], PI), np.eye(3)]:
        *axis, theta = _axis_angle(R)
        assert np.allclose(axis_angle_matrix(axis, theta), R, atol=1e-6)
    problem = load_omplapp_cfg(write_problem(tmp_path))
    for planner in ompl_bridge.OMPL_RIGID_PLANNERS:
        run, again = (ompl_bridge.ompl_rigid(problem, planner, seed=0, time_limit=20.0) for _ in range(2))
        assert run.solved and run.path.shape[1] == 6 and np.allclose(run.path[0], problem.start), planner
        assert np.allclose(run.path[-1], problem.goal) and 0 < run.iterations == again.iterations, planner
    with pytest.raises(ValueError, match="planner must be one of"):
        ompl_bridge.ompl_rigid(problem, "PRM")


def test_the_rigid_benchmark_writes_its_table_runs_and_planner_arena_logs(tmp_path):
    """``benchmark_planners.py --rigid`` on a folder of problem files: every set-up's runs, in the table, the CSV
    and one OMPL benchmark log per problem that OMPL's reader accepts."""
    import csv
    import sqlite3

    from conftest import load_script
    from test_benchmark_log import read_benchmark_log, runs_table

    from planners.tools import ompl_bridge

    folder = tmp_path / "problems"
    folder.mkdir()
    write_problem(folder)
    bp = load_script("benchmark_planners")
    out = tmp_path / "out"
    use_ompl = ompl_bridge.available()
    argv = ["--rigid", str(folder), "--rigid-runs", "2", "--rigid-time-limit", "10", "--out", str(out)]
    route = ["--rigid-samplers", "rigid_route_ablation"]  # a registry sampler in place of each set-up's own
    assert bp.main(argv + route + (["--rigid-ompl"] if use_ompl else [])) == 0
    rows = list(csv.DictReader((out / "rigid_runs.csv").open()))
    labels = (list(bp.RIGID_SETUPS) + [f"OMPL {k}" for k in bp.RIGID_SETUPS if use_ompl]
              + [f"{p} with rigid_route_ablation" for p in bp.RIGID_SETUPS.values()])
    assert {r["sampler"] for r in rows if "with" in r["planner"]} == {"RigidRouteSampler"}
    assert sorted({r["planner"] for r in rows}) == sorted(labels) and len(rows) == 2 * len(labels)
    assert all(r["solved"] == "True" and int(r["iterations"]) > 0 for r in rows)
    table = (out / "rigid.md").read_text()
    assert all(f"| hole | {label} | 2 | 5 | 100% |" in table for label in labels)  # the .cfg's 5 s limit
    conn = sqlite3.connect(":memory:")
    runs = runs_table(conn, read_benchmark_log((out / "ompl" / "hole.log").read_text(), conn))
    assert [r["planner"] for r in runs] == [r["planner"] for r in rows]
    assert [r["iterations"] for r in runs] == [int(r["iterations"]) for r in rows]
    assert bp.main(argv + ["--rigid-problems", "nothing"]) == 2  # refused before any run, naming what is there
    with pytest.raises(SystemExit) as refused:  # the argument checks, before anything runs
        bp.main(argv + ["--rigid-samplers", "nothing"])
    assert refused.value.code == 2


def test_the_rigid_benchmark_takes_the_trees_step_as_a_share_of_ompls_range_when_asked(tmp_path):
    from planners import make_planner
    from planners.base.world import DEFAULT_RANGE_FRACTION

    bp, argv, rows, problem = run_rigid_benchmark(tmp_path, "--rigid-step", "1")
    low, high = problem.world.bounds
    step = DEFAULT_RANGE_FRACTION * float(np.linalg.norm(high - low))
    for seed, row in enumerate(rows):  # the run is the planner's at OMPL's range, iteration for iteration
        r = make_planner("RRTConnect", problem, seed=seed, step_size=step).solve(time_limit=10.0)
        assert row["solved"] == "True" and int(row["iterations"]) == r.iterations
    assert "our step 0.2 of the state box's diagonal" in (tmp_path / "out" / "rigid.md").read_text()
    with pytest.raises(SystemExit) as refused:  # refused before any run
        bp.main(argv[:-1] + ["0"])
    assert refused.value.code == 2


def test_the_rigid_benchmark_restarts_our_runs_when_asked(tmp_path):
    from planners import solve_with_restarts

    bp, argv, rows, problem = run_rigid_benchmark(tmp_path, "--rigid-restarts", "2")
    assert [r["planner"] for r in rows] == ["RRTConnect, Luby restarts x 2"] * 2
    restarted = 0
    for seed, row in enumerate(rows):  # the run is solve_with_restarts' own, iteration for iteration
        r = solve_with_restarts("RRTConnect", problem, seed=seed, unit=2, time_limit=10.0)
        assert row["solved"] == "True" and int(row["iterations"]) == r.iterations
        restarted += r.restarts
    assert restarted >= 1  # the runs restarted
    with pytest.raises(SystemExit):
        bp.main(argv[:-1] + ["-1"])


def test_a_problems_files_are_kept_by_content_digest_with_the_mesh_libraries_versions(tmp_path):
    import hashlib

    from planners.worlds.omplapp import mesh_library_versions, problem_digests, problem_files
    from planners.worlds.rigid_scenes import MeshSceneSet

    path = write_problem(tmp_path)
    files = problem_files(path)
    assert files == {"cfg": path, "world": tmp_path / "env.obj", "robot": tmp_path / "robot.obj"}
    digests = problem_digests(path)
    assert digests["world"] == f"env.obj sha256:{hashlib.sha256((tmp_path / 'env.obj').read_bytes()).hexdigest()}"
    record = MeshSceneSet(count=0, omplapp=tmp_path).record()
    assert record["omplapp_files"] == {"hole": digests}
    assert set(record["mesh_libraries"]) == {"trimesh", "pycollada", "python-fcl"}
    assert mesh_library_versions()["trimesh"] == trimesh.__version__
    (tmp_path / "robot.obj").write_bytes(b"# another robot\n")  # another file, another digest
    assert problem_digests(path)["robot"] != digests["robot"]
    (tmp_path / "robot.obj").unlink()
    with pytest.raises(InputError, match=r"robot = robot.obj not found beside it"):
        problem_files(path)
