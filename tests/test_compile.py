"""The kernel cache (its folder keyed by the sources, the read-only fallback), the first-call notice,
``python -m planners.compile``, and the typed world/space dispatch agreeing with the run-time one."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planners import OccupancyGrid, RigidBodyWorld
from planners.kernels import cache, geometry
from planners.kernels.space import (
    METRIC_COSSIN,
    METRIC_L1,
    METRIC_L2,
    METRIC_SE3,
    SPACE_RIGID,
    SPACE_RN,
    Space,
    SpaceRigidCossin,
    SpaceRnL2,
    make_space,
)
from planners.kernels.state import WorldKernel

ROOT = Path(__file__).resolve().parent.parent


def test_the_cache_key_changes_with_any_source_file(tmp_path):
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "a.py").write_text("x = 1\n")
    (pkg / "sub" / "helper.py").write_text("def f():\n    return 1\n")
    before = cache.source_hash(pkg)
    assert cache.source_hash(pkg) == before
    (pkg / "sub" / "helper.py").write_text("def f():\n    return 2\n")  # a helper another file imports
    edited = cache.source_hash(pkg)
    assert edited != before
    (pkg / "sub" / "new.py").write_text("")
    assert cache.source_hash(pkg) not in (before, edited)


def test_a_read_only_install_falls_back_to_the_user_cache_and_says_where(tmp_path, monkeypatch, capsys):
    blocker = tmp_path / "site-packages"
    blocker.write_text("")  # a file where the folder would go: nothing can be created under it
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    d = cache.choose_dir("abc123", package=blocker / "planners")
    assert d == tmp_path / "xdg" / "samplergym" / "numba" / "abc123" and d.is_dir()
    err = capsys.readouterr().err
    assert "not writable" in err and str(d) in err


def test_no_writable_cache_anywhere_compiles_into_a_temporary_folder_and_says_so(tmp_path, monkeypatch, capsys):
    import tempfile

    blocker = tmp_path / "site-packages"
    blocker.write_text("")  # neither the install nor the user cache can be written
    monkeypatch.setenv("XDG_CACHE_HOME", str(blocker / "xdg"))
    d = cache.choose_dir("abc123", package=blocker / "planners")
    assert d.is_dir() and d.name.startswith("samplergym-numba-")
    err = capsys.readouterr().err
    assert "compiled again in every process" in err and "NUMBA_CACHE_DIR" in err and str(d) in err
    monkeypatch.setattr(tempfile, "tempdir", str(blocker / "tmp"))  # nor a temporary folder: one clear line
    with pytest.raises(OSError, match="no writable folder for compiled kernels.*set NUMBA_CACHE_DIR"):
        cache.choose_dir("abc123", package=blocker / "planners")


def test_a_writable_install_caches_next_to_its_sources(tmp_path, capsys):
    d = cache.choose_dir("abc123", package=tmp_path / "planners")
    assert d == tmp_path / "planners" / "__pycache__" / "numba" / "abc123" and d.is_dir()
    assert capsys.readouterr().err == ""


def test_numba_caches_in_the_keyed_folder_unless_the_user_chose_one():
    code = "import numba, planners; from planners.kernels import cache; print(numba.config.CACHE_DIR)"
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["PYTHONPATH"] = str(ROOT)
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.strip().endswith(os.path.join("numba", cache.source_hash()))
    env["NUMBA_CACHE_DIR"] = "/tmp/somewhere-else"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "/tmp/somewhere-else"


@pytest.fixture
def fresh_notice(tmp_path, monkeypatch):
    monkeypatch.setitem(cache._state, "dir", tmp_path)
    monkeypatch.setitem(cache._state, "notice", None)
    monkeypatch.setattr(cache, "_seen", set())
    monkeypatch.delenv(cache.NOTICE_ENV, raising=False)
    return tmp_path


def test_the_notice_shows_once_per_install(fresh_notice, monkeypatch, capsys):
    world, space = OccupancyGrid(np.zeros((4, 4), dtype=bool)).kernel, make_space(SPACE_RN, METRIC_L2, 1.0)
    assert not cache.is_compiled("RRT", world, space)
    cache.announce("RRT", world, space)
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "compiling the RRT kernels for occupancy grids once for this install, about" in err
    assert "other planners, worlds and samplers compile at their own first use" in err
    assert "docs/compiling.md says where the time goes" in err  # why a first call can take this long
    assert cache.is_compiled("RRT", world, space)
    cache.announce("RRT", world, space)
    monkeypatch.setattr(cache, "_seen", set())  # a new process: the stamp is on disk
    cache.announce("RRT", world, space)
    assert capsys.readouterr().err == ""
    cache.announce("PRM", world, space)  # another planner has its own kernels
    assert "compiling the PRM kernels" in capsys.readouterr().err


def test_the_notice_quotes_the_measured_figure_or_a_range(tmp_path):
    rn, rigid = make_space(SPACE_RN, METRIC_L2, 1.0), make_space(SPACE_RIGID, METRIC_COSSIN, 1.0)
    grid = OccupancyGrid(np.zeros((4, 4), dtype=bool)).kernel
    boxes = RigidBodyWorld().kernel
    mesh = type("MeshKernel", (), {})()  # the kind is read off the kernel's type name
    figures = tmp_path / "compile_seconds.json"
    assert cache.expected_seconds("RRT", grid, rn, figures) == cache.UNMEASURED  # no file
    figures.write_text(json.dumps({"seconds": {"RRT/2d": 4.26, "PRM/6dof": 0.2}, "cpus": 2}))
    assert cache.expected_seconds("RRT", grid, rn, figures) == "about 4 s of CPU time (measured on a 2-CPU machine)"
    assert cache.expected_seconds("PRM", boxes, rigid, figures).startswith("about 1 s ")
    # no figure for that row: the range its kind's rows span, else every row's
    assert cache.expected_seconds("RRT", boxes, rigid, figures) == "about 1 s of CPU time (measured on a 2-CPU machine)"
    assert cache.expected_seconds("RRT", mesh, rigid, figures).startswith("about 1-5 s of CPU time ")
    figures.write_text(json.dumps({"seconds": {"RRT/2d": 4.26, "PRM/6dof": 0.2, "RRTConnect/mesh": 17.4,
                                               "PRM/mesh": 24.6}, "cpus": 2}))
    # a mesh world is quoted its own figures, not the box world's
    assert cache.expected_seconds("RRTConnect", mesh, rigid, figures).startswith("about 17 s ")
    assert cache.expected_seconds("PRM", mesh, rigid, figures).startswith("about 25 s ")
    assert cache.expected_seconds("RRT", mesh, rigid, figures).startswith("about 17-25 s ")
    assert cache.expected_seconds("PRM", boxes, rigid, figures).startswith("about 1 s ")
    figures.write_text("{not json")
    assert cache.expected_seconds("RRT", grid, rn, figures) == cache.UNMEASURED


@pytest.mark.parametrize("how", ["env", "function"])
def test_the_notice_can_be_silenced(fresh_notice, monkeypatch, capsys, how):
    if how == "env":
        monkeypatch.setenv(cache.NOTICE_ENV, "0")
    else:
        cache.set_compile_notice(False)
    cache.announce("RRT", OccupancyGrid(np.zeros((4, 4), dtype=bool)).kernel, make_space(SPACE_RN, METRIC_L2, 1.0))
    assert capsys.readouterr().err == ""


def test_spaces_and_worlds_carry_their_kind_in_their_class():
    assert type(make_space(SPACE_RN, METRIC_L2, 1.0)) is SpaceRnL2
    assert type(make_space(SPACE_RIGID, METRIC_COSSIN, 1.0)) is SpaceRigidCossin
    assert type(make_space(SPACE_RN, METRIC_SE3, 1.0)) is Space  # no such space: dispatched at run time
    assert make_space(SPACE_RN, METRIC_L1, 2.0) == (SPACE_RN, METRIC_L1, 2.0)
    k = OccupancyGrid(np.zeros((4, 4), dtype=bool)).kernel
    assert type(k) is geometry.GridKernel and isinstance(k, WorldKernel)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(0.0, 16.0), min_size=4, max_size=4))
def test_the_typed_grid_check_agrees_with_the_run_time_dispatch(xy):
    obs = np.zeros((16, 16), dtype=bool)
    obs[4:12, 7:9] = True
    typed = OccupancyGrid(obs).kernel
    plain = WorldKernel(*typed)
    a, b = np.array(xy[:2]), np.array(xy[2:])
    out = np.zeros((2, 1), dtype=np.bool_)
    geometry.motions_free(typed, a[None], b[None], out[0])
    geometry.motions_free(plain, a[None], b[None], out[1])
    assert out[0, 0] == out[1, 0]


@pytest.mark.parametrize("command, args, what", [
    ("planners.compile", ["--worlds", "cube"], "--worlds: unknown value 'cube'"),
    ("planners.compile", ["--planners", "RRR"], "--planners: unknown value 'RRR'"),
    ("planners.compile", ["--worlds", "grid", "--metrics", "se3"], "--metrics: 'se3' does not fit the grid world"),
    ("planners.compile", ["--jobs", "0"], "--jobs: must be at least 1, got 0"),
    ("learning.compile", ["--samplers", "uniform"], "--samplers: unknown value 'uniform'"),
    ("learning.compile", ["--planners", "RRR"], "--planners: unknown value 'RRR'"),
    ("learning.compile", ["--jobs", "0"], "--jobs: must be at least 1, got 0"),
])
def test_the_compile_commands_check_their_arguments_first(command, args, what):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = subprocess.run([sys.executable, "-m", command, *args], env=env, capture_output=True, text=True)
    assert out.returncode == 2 and what in out.stderr, out.stderr


def test_the_compile_command_lists_its_jobs_and_the_folder():
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = subprocess.run([sys.executable, "-m", "planners.compile", "--list", "--planners", "RRT", "PRM",
                          "--worlds", "grid", "rigid"], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split("\n")[:-1] == ["RRT grid euclidean", "PRM grid euclidean", "RRT rigid cossin",
                                           "PRM rigid cossin", "RRT rigid se3", "PRM rigid se3"]
    assert "compiled kernels are cached in" in out.stderr


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(["RRT", "PRM", "RRTConnect"]),
                          st.sampled_from(["grid", "shapes", "rigid", "mesh"]),
                          st.sampled_from(["euclidean", "cossin", "se3"])), min_size=1, max_size=14, unique=True),
       st.integers(1, 5), st.randoms(use_true_random=False))
def test_the_job_queue_hands_out_every_job_once_and_keeps_a_worker_on_its_group(todo, workers, order):
    from planners.compile import JobQueue, job_groups

    groups = job_groups(todo)
    assert sorted(j for g in groups for j in g) == sorted(todo)
    key = {j: i for i, g in enumerate(groups) for j in g}
    queue = JobQueue(groups)
    handed, places = [], {}
    for lane in range(workers):  # every worker starts on a group of its own while there are any
        nxt = queue.next(None)
        if nxt is not None:
            places[lane] = nxt[0]
            handed.append(nxt[1])
    assert len({p[0] for p in places.values()}) == min(workers, len(groups), len(places))
    while places:  # workers finish in a random order
        lane = order.choice(sorted(places))
        place = places.pop(lane)
        left_in_own = len([j for j in todo if key[j] == place[0] and j not in handed])
        nxt = queue.next(place)
        if nxt is None:
            continue
        if left_in_own:
            assert nxt[0] == place and key[nxt[1]] == place[0]
        places[lane] = nxt[0]
        handed.append(nxt[1])
    assert sorted(handed) == sorted(todo)


def test_the_compile_command_in_two_processes_fills_the_cache_a_later_process_loads(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT), NUMBA_CACHE_DIR=str(tmp_path), SAMPLERGYM_COMPILE_NOTICE="0")
    out = subprocess.run([sys.executable, "-m", "planners.compile", "--worlds", "grid", "shapes", "--planners", "RRT",
                          "--jobs", "2", "--no-progress"], env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "[2/2]" in out.stderr and "(2 processes)" in out.stderr
    stamps = {p.name for p in (tmp_path / "compiled").iterdir()}
    assert {"RRT-GridKernel-SpaceRnL2", "RRT-ShapesKernel-SpaceRnL2"} <= stamps
    later = ("from planners.compile import compile_one; from planners.base.planner import compile_seconds; "
             "compile_one('RRT', 'shapes', 'euclidean'); print(compile_seconds())")
    out = subprocess.run([sys.executable, "-c", later], env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]
    assert float(out.stdout) < 0.5  # loaded from the cache, not compiled again


def test_mesh_worlds_compile_where_their_extra_is_installed_and_are_refused_by_name_where_not(monkeypatch, capsys):
    from planners import compile as pc

    monkeypatch.setattr(pc.cache, "set_compile_notice", lambda on: None)
    assert pc.main(["--list", "--planners", "RRTConnect"]) == 0
    jobs = capsys.readouterr().out.split("\n")[:-1]
    assert ("RRTConnect mesh se3" in jobs) == pc.mesh_installed()  # the test extra brings it: listed
    problem = pc._mesh("se3")  # a small mesh problem the project makes itself: start and goal free
    assert problem.world.is_valid(problem.start) and problem.world.is_valid(problem.goal)
    monkeypatch.setitem(pc.NEEDS, "mesh", (lambda: False, "mesh"))
    assert pc.main(["--list", "--planners", "RRT"]) == 0
    out, err = capsys.readouterr()
    assert "mesh" not in out and "mesh worlds: not compiled, the mesh extra is not installed" in err
    assert pc.main(["--list", "--worlds", "mesh"]) == 2
    assert "--worlds mesh: needs the mesh extra" in capsys.readouterr().err


_RRTSTAR_AFTER = """
import sys
import numpy as np
from planners import OccupancyGrid, Problem, make_planner
obs = np.zeros((64, 96), dtype=bool)
obs[12:52, 30:34] = True
problem = Problem(OccupancyGrid(obs), (5.5, 5.5), (90.5, 58.5), goal_tolerance=2.0)
for name in sys.argv[1:]:
    r = make_planner(name, problem, seed=1).solve(max_iterations=1500)
print(r.iterations, r.num_vertices, repr(r.cost), r.path.tobytes().hex())
"""


@pytest.mark.slow
def test_rrtstar_reusing_what_rrt_compiled_gives_the_same_results(tmp_path):
    # RRT compiles the helpers it shares with RRT* (nearest query, insertion, collision check) first; RRT*
    # reusing them, in the same process or from the cache, must give what it gives alone.
    def run(cache, *names):
        env = dict(os.environ, PYTHONPATH=str(ROOT), NUMBA_CACHE_DIR=str(cache), SAMPLERGYM_COMPILE_NOTICE="0")
        out = subprocess.run([sys.executable, "-c", _RRTSTAR_AFTER, *names], env=env, capture_output=True, text=True)
        assert out.returncode == 0, out.stderr[-2000:]
        return out.stdout

    alone = run(tmp_path / "alone", "RRTstar")
    assert run(tmp_path / "shared", "RRT", "RRTstar") == alone
    assert run(tmp_path / "shared", "RRTstar") == alone


def test_the_learned_samplers_compile_command_lists_each_sampler_on_its_worlds():
    from planners.compile import mesh_installed

    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = subprocess.run([sys.executable, "-m", "learning.compile", "--list", "--samplers", "route", "rigid_route",
                          "--planners", "RRT"], env=env, capture_output=True, text=True, check=True)
    meshes = ["RRT mesh cossin rigid_route", "RRT mesh se3 rigid_route"] if mesh_installed() else []
    assert out.stdout.split("\n")[:-1] == ["RRT grid euclidean route", "RRT rigid cossin rigid_route",
                                           "RRT rigid se3 rigid_route", *meshes]
    assert "compiled kernels are cached in" in out.stderr


def test_a_learned_sampler_compiled_ahead_loads_from_the_cache_in_a_later_process():
    from learning.compile import compile_sampler

    assert compile_sampler("RRT", "rigid", "cossin", "route") is None  # a 2-D sampler refuses the rigid body: skipped
    assert compile_sampler("RRT", "grid", "euclidean", "follower") > 0
    env = dict(os.environ, PYTHONPATH=str(ROOT), SAMPLERGYM_COMPILE_NOTICE="0")
    later = ("from learning.compile import compile_sampler; from planners.base.planner import compile_seconds; "
             "compile_sampler('RRT', 'grid', 'euclidean', 'follower'); print(compile_seconds())")
    out = subprocess.run([sys.executable, "-c", later], env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]
    assert float(out.stdout) < 0.5  # loaded from the cache, not compiled again
