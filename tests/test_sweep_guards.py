"""``scripts/sweep.py`` checks its arguments and folder before starting Ray, never resumes a folder it did not
start, and stops on Ctrl-C or SIGTERM with one line and exit 130 / 143. No Ray needed: the sweep is replaced."""

from __future__ import annotations

import json
import os
import pickle
import signal
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from conftest import load_script  # noqa: E402

import learning.training.sweep  # noqa: E402


class _Bomb:
    def __reduce__(self):
        return (os.system, ("touch PWNED",))


@pytest.mark.parametrize("flags, named", [
    (["--samples", "0"], "--samples"), (["--seed", "-1"], "--seed"), (["--processes", "0"], "--processes"),
    (["--name", "../up"], "--name"), (["--out", "FILE"], "--out"),
])
def test_bad_flags_exit_2_before_ray_starts(tmp_path, capsys, monkeypatch, flags, named):
    (tmp_path / "FILE").write_text("x")
    flags = [str(tmp_path / "FILE") if f == "FILE" else f for f in flags]
    monkeypatch.setattr(learning.training.sweep, "run_sweep", lambda *a, **k: pytest.fail("the sweep started"))
    assert load_script("sweep").main(["recipe", "--quick", "--out", str(tmp_path / "o"), *flags]) == 2
    err = capsys.readouterr().err
    assert named in err and err.count("\n") == 1, err


def test_resume_refuses_a_folder_it_did_not_start_without_unpickling(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    folder = tmp_path / "o" / "recipe-sweep"
    folder.mkdir(parents=True)
    (folder / "tuner.pkl").write_bytes(pickle.dumps(_Bomb()))
    monkeypatch.setattr(learning.training.sweep, "run_sweep", lambda *a, **k: pytest.fail("the sweep started"))
    assert load_script("sweep").main(["recipe", "--out", str(tmp_path / "o"), "--resume"]) == 2
    assert "not started by scripts/sweep.py" in capsys.readouterr().err
    (folder / learning.training.sweep.MANIFEST).write_text(json.dumps({"kind": "baselines"}))
    assert load_script("sweep").main(["recipe", "--out", str(tmp_path / "o"), "--resume"]) == 2
    assert "'baselines' sweep, not a 'recipe' one" in capsys.readouterr().err
    assert not (tmp_path / "PWNED").exists()
    assert "code" in load_script("sweep").__doc__ and "unpickles" in load_script("sweep").__doc__


@pytest.mark.parametrize("how, code", [("interrupt", 130), ("sigterm", 143), ("tune", 130)])
def test_interrupts_print_one_line_and_exit_130_or_143(tmp_path, capsys, monkeypatch, how, code):
    def interrupted(*args, **kwargs):
        if how == "sigterm":
            os.kill(os.getpid(), signal.SIGTERM)
        if how == "tune":
            raise learning.training.sweep.SweepInterrupted(1, 3)
        raise KeyboardInterrupt

    monkeypatch.setattr(learning.training.sweep, "run_sweep", interrupted)
    before = signal.getsignal(signal.SIGTERM)
    assert load_script("sweep").main(["recipe", "--quick", "--out", str(tmp_path)]) == code
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("interrupted:") and "--resume" in err, err
    assert ("1 of 3 trials finished" in err) == (how == "tune")
    assert signal.getsignal(signal.SIGTERM) is before
