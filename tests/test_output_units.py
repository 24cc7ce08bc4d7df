"""Output sets, run locks, output-place checks and the JSON readers of ``planners.base.fileio``.

The kill tests are real ``SIGKILL``s of a writing process at each rename (and while it writes): after
each, the target folder holds the old complete set or the new complete set, never a mix.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from planners.base.fileio import (
    MANIFEST,
    MAX_JSON_DEPTH,
    InputError,
    LockedError,
    check_output_place,
    loads_json,
    lock_path,
    output_set,
    read_json,
    recover_output_set,
    run_lock,
)

ROOT = Path(__file__).resolve().parents[1]

WRITER = """
import importlib.util, os, signal, sys
from pathlib import Path

# the module alone, without the planners package (stdlib only: a fast start for each of the many kills)
spec = importlib.util.spec_from_file_location("fileio", sys.argv[5])
fileio = importlib.util.module_from_spec(spec)
spec.loader.exec_module(fileio)

target, tag, kill_at, exchange = Path(sys.argv[1]), sys.argv[2], int(sys.argv[3]), sys.argv[4] == "exchange"
real_rename, real_exchange, count = os.rename, fileio._exchange, 0

def tick():
    global count
    count += 1
    if count == kill_at:
        os.kill(os.getpid(), signal.SIGKILL)

def rename(a, b, *args, **kwargs):
    tick()
    return real_rename(a, b, *args, **kwargs)

def exchange_(a, b):
    tick()
    return real_exchange(a, b) if exchange else False

os.rename, fileio._exchange = rename, exchange_
with fileio.output_set(target) as tmp:
    for i in range(3):
        (tmp / f"part{i}.txt").write_text(tag * (i + 1))
        tick()
print("count", count)
"""


def _write(tmp_path: Path, target: Path, tag: str, kill_at: int, exchange: bool) -> subprocess.CompletedProcess:
    driver = tmp_path / "writer.py"
    driver.write_text(WRITER)
    return subprocess.run([sys.executable, str(driver), str(target), tag, str(kill_at),
                           "exchange" if exchange else "renames",
                           str(ROOT / "planners" / "base" / "fileio.py")], cwd=ROOT, capture_output=True, text=True,
                          timeout=60, env={**os.environ, "PYTHONPATH": str(ROOT)})


def _set_of(target: Path) -> str | None:
    """The tag of the complete set in ``target`` (asserting it is one set, whole), None if it is missing."""
    if not target.exists():
        return None
    files = sorted(p.name for p in target.iterdir())
    assert files == [MANIFEST, "part0.txt", "part1.txt", "part2.txt"], files
    tag = (target / "part0.txt").read_text()
    assert [(target / f"part{i}.txt").read_text() for i in range(3)] == [tag * (i + 1) for i in range(3)], "a mix"
    return tag


@pytest.mark.parametrize("exchange", [True, False], ids=["exchange", "two-renames"])
def test_a_kill_anywhere_leaves_the_old_or_the_new_set(tmp_path, exchange):
    target = tmp_path / "out"
    done = _write(tmp_path, target, "a", 0, exchange)
    assert done.returncode == 0, done.stderr
    assert _set_of(target) == "a"
    points = int(done.stdout.split()[-1]) + 2  # the writes, the swap's renames, one past the end
    seen = set()
    for kill_at in range(1, points + 1):
        got = _write(tmp_path, target, "b", kill_at, exchange)
        recover_output_set(target)
        now = _set_of(target)
        assert now in ("a", "b"), (kill_at, now)
        seen.add(now)
        if now == "b":  # start the next kill from the old set again
            assert _write(tmp_path, target, "a", 0, exchange).returncode == 0
        assert got.returncode in (0, -9)
        assert not list(tmp_path.glob(".out.*")) or got.returncode == -9
    assert seen == {"a", "b"}, "the kills covered both sides of the swap"
    recover_output_set(target)
    assert not list(tmp_path.glob(".out.*")), "leftovers of dead writers are removed"


def test_a_failed_write_leaves_the_old_set_and_no_temporary_folder(tmp_path):
    target = tmp_path / "out"
    with output_set(target) as tmp:
        (tmp / "a.txt").write_text("old")
    with pytest.raises(RuntimeError), output_set(target) as tmp:
        (tmp / "a.txt").write_text("new")
        raise RuntimeError("disk full")
    assert (target / "a.txt").read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    assert json.loads((target / MANIFEST).read_text())["files"] == {"a.txt": 3}


def test_the_lock_names_its_holder_and_stale_locks_are_taken_over(tmp_path):
    folder = tmp_path / "run"
    lines = []
    with run_lock(folder, "first command"):
        with pytest.raises(LockedError, match=rf"in use by pid {os.getpid()} .*first command"), \
                run_lock(folder, "second command"):
            pass
        assert json.loads(lock_path(folder).read_text())["command"] == "first command"
    assert not lock_path(folder).exists()
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    holder = json.loads(json.dumps({"pid": int(dead.stdout), "host": os.uname().nodename, "command": "old run"}))
    import socket

    holder["host"] = socket.gethostname()
    lock_path(folder).write_text(json.dumps(holder))
    with run_lock(folder, "new", log=lines.append):
        assert json.loads(lock_path(folder).read_text())["command"] == "new"
    assert lines and "took over the lock" in lines[0] and "old run" in lines[0]
    lock_path(folder).write_text(json.dumps({**holder, "host": "elsewhere"}))  # another host: never taken over
    with pytest.raises(LockedError, match="elsewhere"), run_lock(folder):
        pass


def test_a_second_process_is_refused_while_the_first_holds_the_lock(tmp_path):
    folder = tmp_path / "run"
    code = ("import sys, time; from planners.base.fileio import run_lock\n"
            "with run_lock(sys.argv[1], 'holder'):\n    print('held', flush=True); time.sleep(30)\n")
    holder = subprocess.Popen([sys.executable, "-c", code, str(folder)], cwd=ROOT, stdout=subprocess.PIPE, text=True,
                              env={**os.environ, "PYTHONPATH": str(ROOT)})
    try:
        assert holder.stdout.readline().strip() == "held"
        with pytest.raises(LockedError, match=f"pid {holder.pid}"), run_lock(folder):
            pass
    finally:
        holder.kill()
        holder.wait()
    with run_lock(folder, log=lambda line: None):  # its pid is gone: taken over
        pass


def test_output_places_are_checked_by_name(tmp_path):
    (tmp_path / "file").write_text("x")
    with pytest.raises(InputError, match="--out .*file: a file is there"):
        check_output_place(tmp_path / "file", "--out")
    with pytest.raises(InputError, match="--out .*is a file, so nothing can be created below it"):
        check_output_place(tmp_path / "file" / "sub", "--out")
    with pytest.raises(InputError, match="--export .*a folder is there"):
        check_output_place(tmp_path, "--export", folder=False)
    with pytest.raises(InputError, match="MiB free on its disk"):
        check_output_place(tmp_path / "new", "--out", need_bytes=1 << 62)
    assert check_output_place(tmp_path / "new" / "deeper", "--out") == tmp_path / "new" / "deeper"
    # a folder still to be made under a figure's name is refused; one already there, or a file's place, is not
    with pytest.raises(InputError, match="--out .*plan.PNG: .*ends in .PNG like a file's; give a folder"):
        check_output_place(tmp_path / "plan.PNG", "--out")
    (tmp_path / "old.png").mkdir()
    assert check_output_place(tmp_path / "old.png", "--out") == tmp_path / "old.png"
    assert check_output_place(tmp_path / "fig.png", "--figure", folder=False) == tmp_path / "fig.png"
    if os.geteuid() != 0:
        ro = tmp_path / "ro"
        ro.mkdir()
        ro.chmod(0o500)
        try:
            with pytest.raises(InputError, match="not writable"):
                check_output_place(ro / "run", "--out")
        finally:
            ro.chmod(0o700)


def test_json_readers_refuse_deep_nesting_by_name(tmp_path):
    for text in ("[" * 100_000 + "]" * 100_000, '{"a":' * 5000 + "1" + "}" * 5000):
        with pytest.raises(InputError, match="nested .* levels deep"):
            loads_json(text, "cfg.json")
    assert loads_json('["[[[[", {"a": "]]]"}]', "x") == ["[[[[", {"a": "]]]"}]
    assert loads_json("[" * MAX_JSON_DEPTH + "]" * MAX_JSON_DEPTH, "x") is not None
    path = tmp_path / "c.json"
    path.write_bytes(b"\xff\xfe")
    with pytest.raises(InputError, match="c.json"):
        read_json(path)
    with pytest.raises(InputError, match="cannot read"):
        read_json(tmp_path / "missing.json")
