"""``scripts/train_route.py``: checks before it works, a lock, outputs as one unit, and resume after a kill.

The kills are real ``SIGKILL``s of the training process, placed just before its n-th rename inside the
output folder (an epoch's checkpoint or the swap of the finished pair), as for ``scripts/train.py``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import torch

from learning.route import load_route_net
from planners.base.fileio import MANIFEST, run_lock

ROOT = Path(__file__).resolve().parents[1]
# tiny: 5 families x 1 map of 32 cells, 3 epochs, a 4-channel encoder; seconds per run
TINY = ["--maps", "1", "--size", "32", "--epochs", "3", "--channels", "4", "--depth", "1", "--attention", "0"]

DRIVER = """
import os, signal, sys
from pathlib import Path
import planners.base.fileio as fileio

out, kill_at = Path(sys.argv[1]).resolve(), int(sys.argv[2])
real_replace, real_rename, real_exchange, count = os.replace, os.rename, fileio._exchange, 0

def tick(dst):
    global count
    if Path(dst).resolve().is_relative_to(out.parent):
        count += 1
        if count == kill_at:
            os.kill(os.getpid(), signal.SIGKILL)

def replace(src, dst, *a, **k):
    tick(dst)
    return real_replace(src, dst, *a, **k)

def rename(src, dst, *a, **k):
    tick(dst)
    return real_rename(src, dst, *a, **k)

def exchange(a, b):
    tick(b)
    return real_exchange(a, b)

os.replace, os.rename, fileio._exchange = replace, rename, exchange
sys.argv = ["train_route.py", *sys.argv[3:]]
import runpy
try:
    runpy.run_path("scripts/train_route.py", run_name="__main__")
except SystemExit as exc:
    print("renames", count)
    raise
"""


def _run(tmp: Path, out: Path, kill_at: int, *flags: str) -> subprocess.CompletedProcess:
    driver = tmp / "driver.py"
    driver.write_text(DRIVER)
    return subprocess.run([sys.executable, str(driver), str(out), str(kill_at), *TINY, "--out", str(out), *flags],
                          cwd=ROOT, capture_output=True, text=True, timeout=300,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})


def _weights(out: Path) -> dict:
    return load_route_net(out / "route.pt").state_dict()


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("route_reference")
    done = _run(tmp, tmp / "route", 0)
    assert done.returncode == 0, done.stderr[-2000:]
    return int(done.stdout.split()[-1]), _weights(tmp / "route")


@pytest.mark.parametrize("fraction", [0.25, 0.5, 0.75, 1.0])
def test_a_kill_then_resume_equals_an_uninterrupted_run(tmp_path, reference, fraction):
    renames, weights = reference
    kill_at = max(1, round(fraction * renames))
    out = tmp_path / "route"
    killed = _run(tmp_path, out, kill_at)
    assert killed.returncode == -9, (kill_at, killed.stderr[-2000:])
    assert not (out / "route.pt").exists() or (out / MANIFEST).is_file(), "a pair only with its manifest"
    if not (out / "route.pt").exists():  # killed before the swap: resume from the last epoch
        resumed = _run(tmp_path, out, 0, *(["--resume"] if (out / "checkpoint.pt").is_file() else []))
        assert resumed.returncode == 0, (kill_at, resumed.stderr[-2000:])
        assert "took over the lock" in resumed.stderr
    got = _weights(out)
    assert all(torch.equal(got[k], weights[k]) for k in weights), kill_at
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST, "route.json", "route.pt"]
    assert not list(tmp_path.glob(".route.*.set")) or killed.returncode == -9


def test_the_script_writes_a_pair_exports_it_and_the_pair_replaces_the_old_one(tmp_path):
    from importlib import util

    spec = util.spec_from_file_location("train_route_script", ROOT / "scripts" / "train_route.py")
    script = util.module_from_spec(spec)
    spec.loader.exec_module(script)
    out = tmp_path / "run"
    assert script.main([*TINY, "--out", str(out), "--export", str(tmp_path / "r.pt")]) == 0
    assert load_route_net(out / "route.pt").channels == 4 and load_route_net(tmp_path / "r.pt").depth == 1
    meta = json.loads((tmp_path / "r.json").read_text())
    assert meta["recipe"]["size"] == [32] and meta["recipe"]["augment"] is True
    assert script.main([*TINY, "--epochs", "1", "--no-augment", "--out", str(out)]) == 0
    assert json.loads((out / "route.json").read_text())["recipe"]["augment"] is False
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST, "route.json", "route.pt"]


def test_with_no_flags_it_trains_the_shipped_recipe():
    from importlib import util

    spec = util.spec_from_file_location("train_route_script", ROOT / "scripts" / "train_route.py")
    script = util.module_from_spec(spec)
    spec.loader.exec_module(script)
    defaults = vars(script._parser().parse_args([]))
    shipped = json.loads((ROOT / "learning" / "data" / "route.json").read_text())["recipe"]
    for key, value in shipped.items():
        if key in defaults and key not in ("out", "export"):
            assert defaults[key] == value, key
    assert not {"thicken", "speckle", "grad_weight"} & defaults.keys()


@pytest.mark.parametrize("flags, named", [
    (["--epochs", "0"], "--epochs"), (["--size", "64", "8"], "--size"), (["--size", "100000"], "--size = 100000"),
    (["--attention", "1", "--channels", "5"], "--attention"), (["--attention", "1", "--attention-level", "4"],
                                                                "--attention-level"),
    (["--seed", "-1"], "--seed"), (["--maps", "10000000"], "--maps"), (["--resume"], "--resume"),
])
def test_bad_flags_exit_2_with_one_line_naming_them(tmp_path, capsys, flags, named):
    from importlib import util

    spec = util.spec_from_file_location("train_route_script", ROOT / "scripts" / "train_route.py")
    script = util.module_from_spec(spec)
    spec.loader.exec_module(script)
    assert script.main([*TINY, "--out", str(tmp_path / "o"), *flags]) == 2
    err = capsys.readouterr().err
    assert named in err and err.count("\n") == 1, err


def test_output_places_and_the_lock_are_checked_before_the_work(tmp_path, capsys):
    from importlib import util

    spec = util.spec_from_file_location("train_route_script", ROOT / "scripts" / "train_route.py")
    script = util.module_from_spec(spec)
    spec.loader.exec_module(script)
    (tmp_path / "file").write_text("x")
    assert script.main([*TINY, "--out", str(tmp_path / "file")]) == 2
    assert "--out" in capsys.readouterr().err
    assert script.main([*TINY, "--out", str(tmp_path / "o"), "--export", str(tmp_path)]) == 2
    assert "--export" in capsys.readouterr().err
    with run_lock(tmp_path / "o", "the other training"):
        assert script.main([*TINY, "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "in use by pid" in err and "the other training" in err and err.count("\n") == 1
    assert not (tmp_path / "o").exists()


def test_ctrl_c_says_what_was_kept_and_exits_130(tmp_path, capsys, monkeypatch):
    from importlib import util

    spec = util.spec_from_file_location("train_route_script", ROOT / "scripts" / "train_route.py")
    script = util.module_from_spec(spec)
    spec.loader.exec_module(script)
    real = script.train_route_net

    def interrupted_after_one_epoch(problems, **kwargs):
        real(problems, **{**kwargs, "epochs": 1})
        raise KeyboardInterrupt

    monkeypatch.setattr(script, "train_route_net", interrupted_after_one_epoch)
    out = tmp_path / "o"
    assert script.main([*TINY, "--out", str(out)]) == 130
    err = capsys.readouterr().err.strip()
    assert err == f"interrupted: {out / 'checkpoint.pt'} holds the last finished epoch; continue with --resume"
    assert not (tmp_path / ".o.lock").exists(), "the lock is released"
    monkeypatch.undo()
    assert script.main([*TINY, "--out", str(out), "--resume"]) == 0
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST, "route.json", "route.pt"]
