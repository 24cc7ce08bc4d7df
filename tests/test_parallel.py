"""Execution backends (issue 17): the same results in this process, on a local pool and on Ray, and a
killed Ray worker costs only its in-flight tasks."""

from __future__ import annotations

import dataclasses
import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import asdict
from pathlib import Path

import pytest
from pool_tasks import dies_at_three

from learning import evaluation as E
from learning.models.shipped import SHIPPED_POLICY, SHIPPED_ROUTE
from planners import movingai_dir
from planners.tools.parallel import BACKENDS, LocalBackend, WorkerDied, default_chunksize, make_backend

ROOT = Path(__file__).resolve().parents[1]
CHECKPOINT = str(SHIPPED_POLICY)
ROUTE = str(SHIPPED_ROUTE)


def _tasks(max_iterations: int = 3000, movingai: bool = True) -> tuple[list[E.Task], E.Protocol]:
    mdir = movingai_dir(None, required=False) if movingai else None
    protocol = E.Protocol(max_iterations=max_iterations, movingai_dir="" if mdir is None else str(mdir))
    qs = E.generated_queries(["forest", "maze"], 64, 2, 0) + E.shifted_queries(["bugtrap"], 1)
    if mdir is not None:
        qs += E.movingai_queries(str(mdir), ["arena"], 1, 0, 4.0)
    samplers = (E.SamplerSpec.of("uniform"), E.bias_spec(0.1), E.policy_spec(CHECKPOINT, None),
                E.constant_spec(0.7, protocol, 8), E.SamplerSpec.of("route", path=ROUTE, step_size=4.0))
    return [E.Task(q, "RRT", s, seed) for q in qs for s in samplers for seed in range(2)], protocol


def _runs(runs) -> list[dict]:
    """Everything a run records but its timing."""
    out = []
    for r in runs:
        d = asdict(r)
        d.pop("wall_time"), d.pop("us_per_iteration"), d.pop("compile_time")
        out.append(d)
    return out


def _serial_and(backend) -> tuple[list[dict], list[dict]]:
    tasks, protocol = _tasks()
    tasks = tasks[::3]  # every sampler, query and seed still appears; a third of the runs
    serial = _runs(E.run_all(tasks, protocol, 1, progress=False))
    assert [r["query"] for r in serial] == [protocol.problem(t.query).name for t in tasks]
    assert [E.SamplerSpec.from_json(r["sampler_spec"]) for r in serial] == [t.sampler for t in tasks]
    return serial, _runs(E.run_all(tasks, protocol, backend, progress=False))


def test_a_worker_that_dies_stops_the_local_pool_with_a_clear_error():
    t0 = time.monotonic()
    with pytest.raises(WorkerDied, match="fewer processes"):
        LocalBackend(2).map(dies_at_three, list(range(8)), context=0, chunksize=1)
    assert time.monotonic() - t0 < 60


def test_a_script_without_a_main_guard_gets_an_error_not_a_hang(tmp_path):
    script = tmp_path / "unguarded.py"
    script.write_text("from operator import add\nfrom planners.tools.parallel import LocalBackend\n"
                      "print(LocalBackend(2).map(add, [1, 2, 3], context=0))\n")
    proc = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300,
                          cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert proc.returncode != 0 and "if __name__ == '__main__':" in proc.stderr


def test_the_local_pool_gives_the_serial_runs_in_task_order():
    serial, pool = _serial_and(make_backend("local", processes=2, worker_init=E.worker_init))
    assert pool == serial


@pytest.mark.slow  # Ray's workers start, import torch and load every kernel (1.5 to 3 min on 2 busy cores);
# test_the_context_travels_loaded_so_workers_need_no_files compares Ray's runs with the serial ones in every tier
def test_ray_gives_the_serial_runs_in_task_order(ray_backend):
    serial, on_ray = _serial_and(ray_backend)
    assert on_ray == serial


def test_the_context_travels_loaded_so_workers_need_no_files(ray_backend, tmp_path):
    # checkpoint paths that do not exist where the runs execute: the policy and encoder come from the context
    tasks, protocol = _tasks(movingai=False)
    tasks = [t for t in tasks if t.seed == 0][:10]
    context = E.shared_context(tasks, protocol)
    # (path, batch, step): the checkpoint's own batch and step here
    assert set(context.models.policies) == {(CHECKPOINT, None, None)}
    assert set(context.models.routes) == {ROUTE}
    elsewhere = {"policy": str(tmp_path / "elsewhere.zip"), "route": str(tmp_path / "elsewhere.pt")}
    relocate = {"policy": E.policy_spec(elsewhere["policy"], None),
                "route": E.SamplerSpec.of("route", path=elsewhere["route"], step_size=4.0)}
    moved = [dataclasses.replace(t, sampler=relocate.get(t.sampler.name, t.sampler)) for t in tasks]
    models = E.ModelCache()
    models.policies[elsewhere["policy"], None, None] = context.models.policies[CHECKPOINT, None, None]
    models.routes[elsewhere["route"]] = context.models.routes[ROUTE]
    got = ray_backend.map(E.run_one, moved, context=E.RunContext(protocol, models), chunksize=3)
    expected = _runs(E.run_all(tasks, protocol, 1, progress=False))
    for r in expected:
        r.pop("sampler_spec")
    assert [{k: v for k, v in r.items() if k != "sampler_spec"} for r in _runs(got)] == expected


def _ray_chunk_pids() -> list[int]:
    """This test's Ray workers executing a chunk now (Ray names a busy worker's process after its task).

    Only descendants of this process (the Ray instance ``ray_backend`` started here): another run's Ray workers on
    the same machine are never touched.
    """
    parents, busy = {}, []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text()
                parents[int(d.name)] = int(stat[stat.rindex(")") + 2:].split()[1])  # the field after the state
                if (d / "cmdline").read_bytes().startswith(b"ray::_ray_chunk"):
                    busy.append(int(d.name))
            except (OSError, ValueError):
                continue

    def ours(pid: int) -> bool:
        seen = set()
        while pid > 1 and pid not in seen:
            if pid == os.getpid():
                return True
            seen.add(pid)
            pid = parents.get(pid, 0)
        return False

    return [pid for pid in busy if ours(pid)]


def test_a_killed_ray_worker_loses_only_its_in_flight_tasks(ray_backend):
    tasks, protocol = _tasks(max_iterations=20000, movingai=False)
    tasks *= 2
    undisturbed = _runs(E.run_all(tasks, protocol, 1, progress=False))
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
    got = ray_backend.map(E.run_one, tasks, context=E.shared_context(tasks, protocol), chunksize=4)
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
