"""Execution backends (issue 17): the same results in this process, on a local pool and on Ray, and a
killed Ray worker costs only its in-flight tasks."""

from __future__ import annotations

import os
import signal
import threading
import time
from dataclasses import asdict
from pathlib import Path

import pytest

from learning import evaluation as E
from learning.models.shipped import SHIPPED_POLICY, SHIPPED_ROUTE
from planners import movingai_dir
from planners.tools.parallel import BACKENDS, LocalBackend, default_chunksize, make_backend

CHECKPOINT = str(SHIPPED_POLICY)
ROUTE = str(SHIPPED_ROUTE)


def _tasks(max_iterations: int = 3000, movingai: bool = True) -> list[tuple]:
    mdir = movingai_dir(None, required=False) if movingai else None
    qs = E.generated_queries(["forest", "maze"], 64, 3, 0) + E.shifted_queries(["bugtrap"], 2)
    if mdir is not None:
        qs += E.movingai_queries(str(mdir), ["arena"], 2, 0, 4.0)
    cfg = {"movingai_dir": "" if mdir is None else str(mdir), "tolerance": 4.0, "policy": CHECKPOINT, "route": ROUTE,
           "step": 4.0, "max_iterations": max_iterations, "user_samplers": {}}
    samplers = ("uniform", "goal_bias=0.1", "policy", "constant=0.7", E.ROUTE)
    return [(q, "RRT", s, seed, cfg) for q in qs for s in samplers for seed in range(2)]


def _runs(runs) -> list[dict]:
    """Everything a run records but its timing."""
    out = []
    for r in runs:
        d = asdict(r)
        d.pop("wall_time"), d.pop("us_per_iteration")
        out.append(d)
    return out


def test_every_backend_gives_the_same_runs_in_task_order(ray_backend):
    tasks = _tasks()
    serial = _runs(E.run_all(tasks, 1, progress=False))
    pool = _runs(E.run_all(tasks, make_backend("local", processes=2, worker_init=E.worker_init), progress=False))
    on_ray = _runs(E.run_all(tasks, ray_backend, progress=False))
    assert serial == pool == on_ray
    assert [r["query"] for r in serial] == [t[0].problem(t[4]["movingai_dir"], 4.0).name for t in tasks]


def test_the_context_travels_loaded_so_workers_need_no_files(ray_backend, tmp_path):
    # checkpoint paths that do not exist where the runs execute: the policy and encoder come from the context
    tasks = _tasks(movingai=False)[:10]
    context = E.shared_context(tasks)
    assert set(context["policies"]) == {(CHECKPOINT, None)}  # (path, batch): the checkpoint's own batch here
    assert set(context["routes"]) == {ROUTE}
    elsewhere = {"policy": str(tmp_path / "elsewhere.zip"), "route": str(tmp_path / "elsewhere.pt")}
    moved = [(q, p, s, seed, {**cfg, **elsewhere}) for q, p, s, seed, cfg in tasks]
    context = {"policies": {(elsewhere["policy"], None): context["policies"][CHECKPOINT, None]},
               "routes": {elsewhere["route"]: context["routes"][ROUTE]}, "scenarios": {}}
    got = ray_backend.map(E.run_one, moved, context=context, chunksize=3)
    assert _runs(got) == _runs(E.run_all(tasks, 1, progress=False))


def _ray_chunk_pids() -> list[int]:
    """Ray workers executing a chunk now (Ray names a busy worker's process after its task)."""
    pids = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                if (d / "cmdline").read_bytes().startswith(b"ray::_ray_chunk"):
                    pids.append(int(d.name))
            except OSError:
                continue
    return pids


def test_a_killed_ray_worker_loses_only_its_in_flight_tasks(ray_backend):
    tasks = _tasks(max_iterations=20000, movingai=False) * 2
    undisturbed = _runs(E.run_all(tasks, 1, progress=False))
    killed = []

    def kill_one_busy_worker():
        deadline = time.monotonic() + 60
        while not killed and time.monotonic() < deadline:
            pids = _ray_chunk_pids()
            if pids:
                os.kill(pids[0], signal.SIGKILL)
                killed.append(pids[0])
            time.sleep(0.01)

    killer = threading.Thread(target=kill_one_busy_worker)
    killer.start()
    got = ray_backend.map(E.run_one, tasks, context=E.shared_context(tasks), chunksize=4)
    killer.join()
    assert killed, "no busy Ray worker was seen to kill"
    assert _runs(got) == undisturbed


def test_chunks_keep_scheduling_small_and_load_balanced():
    assert default_chunksize(16_800, 2) == 525  # 32 chunks for 2 workers
    assert default_chunksize(10, 2) == 1
    assert default_chunksize(0, 4) == 1


def test_bad_backend_arguments_are_refused():
    with pytest.raises(ValueError, match="unknown backend 'spark'; choose from local, ray"):
        make_backend("spark")
    with pytest.raises(ValueError, match="--address is for the ray backend"):
        make_backend("local", address="auto")
    assert BACKENDS == ("local", "ray")
    assert isinstance(make_backend("local", processes=1), LocalBackend)


def test_evaluate_script_takes_backend_flags(capsys):
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from conftest import load_script

    ev = load_script("evaluate")
    with pytest.raises(SystemExit):
        ev.parse_args(["--address", "auto"])
    assert "--address needs --backend ray" in capsys.readouterr().err
    assert ev.parse_args(["--backend", "ray", "--address", "auto"]).backend == "ray"


def test_without_ray_the_error_names_the_extra(monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "ray", None)  # what a core install sees
    with pytest.raises(ImportError, match=r'pip install -c constraints.txt -e "\.\[distributed\]"'):
        make_backend("ray")
