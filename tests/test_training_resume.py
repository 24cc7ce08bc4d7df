"""A killed training run resumes to the weights and logs of one that was never interrupted.

The kills are real ``SIGKILL``s of a training process, placed deterministically: the process kills
itself just before its n-th file replacement inside the run folder, the instant at which a
checkpoint is half written (its temporary file complete, the rename not done). Between two
replacements nothing on disk changes, so these points cover every state a kill can leave.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import pytest
import torch
from conftest import load_script, npy_map_folder

from learning.models.checkpoint import read_sb3_zip
from learning.training.policy import TrainConfig, read_state, train
from planners.base.fileio import InputError

ROOT = Path(__file__).resolve().parents[1]
# two DAgger rounds, the transition, two PPO segments (warm-up, then the actor), the selection
CFG = TrainConfig(name="kill", families=("forest",), sizes=(64,), dagger_rounds=2, maps_per_round=16, bc_epochs=4,
                  ppo_steps=1024, value_warmup=512, ppo_n_steps=256, ppo_batch=128, ppo_epochs=2,
                  validation_maps=1, checkpoint_every=512, max_iterations=1000)

DRIVER = """
import json, os, signal, sys
from pathlib import Path
from learning.training.policy import TrainConfig, train

out, kill_at, resume = Path(sys.argv[1]).resolve(), int(sys.argv[2]), sys.argv[3] == "resume"
real, count = os.replace, 0

def replace(src, dst, *args, **kwargs):
    global count
    if Path(dst).resolve().is_relative_to(out):
        count += 1
        if count == kill_at:
            os.kill(os.getpid(), signal.SIGKILL)
    return real(src, dst, *args, **kwargs)

os.replace = replace
train(TrainConfig.from_json(sys.argv[4]), out, resume=resume, progress=False, log_stdout=False)
print("replacements", count)
"""


def _run(tmp: Path, out: Path, kill_at: int, resume: bool) -> subprocess.CompletedProcess:
    tmp.mkdir(parents=True, exist_ok=True)
    driver, config = tmp / "driver.py", tmp / "config.json"
    driver.write_text(DRIVER)
    config.write_text(json.dumps(dataclasses.asdict(CFG)))
    return subprocess.run([sys.executable, str(driver), str(out), str(kill_at), "resume" if resume else "fresh",
                           str(config)], cwd=ROOT, capture_output=True, text=True, timeout=300)


def _weights(path: Path) -> dict:
    return read_sb3_zip(path)[1]


def _log(path: Path) -> list[dict]:
    """progress.csv without the columns that measure time."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return [{k: v for k, v in r.items() if not k.startswith("time/") and k != "dagger/collect_seconds"} for r in rows]


def _events(folder: Path) -> list[tuple[str, int]]:
    """Every (tag, step) of the run's TensorBoard scalars, over all its events files, sorted."""
    from tensorboard.backend.event_processing.event_file_loader import EventFileLoader

    return sorted((v.tag, e.step) for path in folder.glob("events.out.tfevents.*")
                  for e in EventFileLoader(str(path)).Load() for v in e.summary.value)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("reference")
    done = _run(tmp, tmp / "runs", 0, resume=False)
    assert done.returncode == 0, done.stderr
    replacements = int(done.stdout.split()[-1])
    run = tmp / "runs" / CFG.name
    return replacements, _weights(run / "final.zip"), _log(run / "tb" / "progress.csv"), _events(run / "tb")


def _kill_and_resume(tmp: Path, kill_at: int, reference) -> None:
    _, weights, log, events = reference
    out = tmp / "runs"
    killed = _run(tmp, out, kill_at, resume=False)
    assert killed.returncode == -9, (kill_at, killed.stderr[-2000:])
    run = out / CFG.name
    resumed = _run(tmp, out, 0, resume=(run / "checkpoint.zip").is_file())
    assert resumed.returncode == 0, (kill_at, resumed.stderr[-2000:])
    got = _weights(run / "final.zip")
    assert got.keys() == weights.keys()
    for k in weights:
        assert torch.equal(got[k], weights[k]), (kill_at, k)
    assert _log(run / "tb" / "progress.csv") == log, kill_at
    # TensorBoard shows each step once: what the killed run logged after its checkpoint was dropped
    assert _events(run / "tb") == events, kill_at
    assert not list(run.rglob(".*.tmp*")), "the resumed run removes the temporary files the kill left"


# one kill point in the default run; the other three with `-m slow`
@pytest.mark.parametrize("fraction", [pytest.param(0.25, marks=pytest.mark.slow), 0.5,
                                      pytest.param(0.75, marks=pytest.mark.slow),
                                      pytest.param(1.0, marks=pytest.mark.slow)])
def test_a_kill_then_resume_equals_an_uninterrupted_run(tmp_path, reference, fraction):
    _kill_and_resume(tmp_path, max(1, round(fraction * reference[0])), reference)


@pytest.mark.slow
def test_a_kill_at_every_checkpoint_write_then_resume_equals_an_uninterrupted_run(tmp_path, reference):
    for k in range(1, reference[0] + 1):
        _kill_and_resume(tmp_path / str(k), k, reference)


def test_resume_without_a_checkpoint_says_so(tmp_path):
    with pytest.raises(FileNotFoundError, match="nothing to resume.*without --resume"):
        train(CFG, tmp_path, resume=True, progress=False, log_stdout=False)


def test_interrupts_report_what_was_saved(tmp_path, monkeypatch, capsys):
    import importlib.util

    spec = importlib.util.spec_from_file_location("train_script", ROOT / "scripts" / "train.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)

    def interrupted(cfg, out, **kwargs):
        raise KeyboardInterrupt

    flags = ["--out", str(tmp_path), "--name", "kill", "--dagger-rounds", "1", "--maps-per-round", "4",
             "--families", "forest", "--sizes", "64", "--ppo-steps", "0", "--validation-maps", "1", "--no-progress"]
    monkeypatch.setattr(script, "train", interrupted)
    assert script.main(flags) == 130
    assert "before the first checkpoint: nothing was saved" in capsys.readouterr().err
    assert script.main([*flags, "--resume"]) == 130
    monkeypatch.undo()
    assert script.main([*flags, "--resume"]) == 2
    assert "nothing to resume" in capsys.readouterr().err
    assert script.main(flags) == 0
    monkeypatch.setattr(script, "train", interrupted)
    assert script.main(flags) == 130
    err = capsys.readouterr().err
    assert "kill/checkpoint.zip holds the run up to PPO step 0 of 0; continue with --resume" in err, err
    assert read_state(tmp_path / "kill")["phase"] == "ppo"


@pytest.mark.parametrize("field, value", [
    ("uniform_floor", float("nan")), ("uniform_floor", -1.0), ("uniform_floor", 5.0), ("max_iterations", -5),
    ("gamma", 1.5), ("sizes", (8,)), ("families", ("nope",)), ("name", "../escape"), ("dagger_betas", ()),
])
def test_bad_config_values_are_refused_by_name(tmp_path, field, value):
    cfg = dataclasses.replace(CFG, **{field: value})
    with pytest.raises(InputError, match=field):
        train(cfg, tmp_path, progress=False, log_stdout=False)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(dataclasses.asdict(cfg)))
    with pytest.raises(InputError, match=rf"bad.json.*{field}"):
        TrainConfig.from_json(path)


def test_unreadable_config_files_are_named(tmp_path):
    for name, text in (("junk.json", "{not json"), ("list.json", "[1, 2]"), ("keys.json", '{"colour": 1}')):
        (tmp_path / name).write_text(text)
        with pytest.raises(InputError, match=name):
            TrainConfig.from_json(tmp_path / name)


def test_a_second_run_on_a_locked_folder_exits_2_naming_the_holder(tmp_path, capsys):
    import importlib.util

    from planners.base.fileio import run_lock

    spec = importlib.util.spec_from_file_location("train_script", ROOT / "scripts" / "train.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    flags = ["--out", str(tmp_path), "--name", "kill", "--no-progress"]
    with run_lock(tmp_path / "kill", "the first training run"):
        assert script.main(flags) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "in use by pid" in err and "the first training run" in err, err
    (tmp_path / "file").write_text("x")
    assert script.main(["--out", str(tmp_path / "file"), "--no-progress"]) == 2
    assert "--out" in capsys.readouterr().err


# --- map sets and devices ---------------------------------------------------------------------------

def _train_script():
    return load_script("train")


_npy_maps = npy_map_folder


TINY_SET = ["--dagger-rounds", "1", "--maps-per-round", "4", "--bc-epochs", "1", "--ppo-steps", "64",
            "--ppo-n-steps", "32", "--ppo-batch", "32", "--value-warmup", "0", "--checkpoint-every", "64",
            "--validation-maps", "2", "--max-iterations", "300", "--step-size", "2", "--goal-tolerance", "2",
            "--no-progress", "--device", "auto"]


def test_train_script_trains_on_a_map_set_and_records_it(tmp_path, capsys):
    from planners.maps.mapset import MapSet

    folder = _npy_maps(tmp_path / "maps", 6)
    assert _train_script().main(["--out", str(tmp_path), "--name", "mine", "--map-set", str(folder),
                                 *TINY_SET]) == 0
    run = tmp_path / "mine"
    assert "split sha256-rank" in capsys.readouterr().out
    assert TrainConfig.from_json(run / "config.json").map_set == (str(folder),)
    record = json.loads((run / "map_sets.json").read_text())
    assert record["sets"][0]["split"]["parts"]["validation"] == list(MapSet.open(folder).maps("validation"))
    summary = json.loads((run / "summary.json").read_text())
    assert set(summary["validation_ppo_families"]) == {"maps"}  # the folder set's one group
    assert (run / "final.zip").is_file()


@pytest.mark.parametrize("flags, named", [
    (["--map-set", "MAPS", "--map-set-weight", "1", "--map-set-weight", "2"], "map_set_weight"),
    (["--map-set", "MAPS", "--map-set-weight", "0"], "map_set_weight"),
    (["--map-set", "NOWHERE"], "NOWHERE"),
    (["--map-set", "MAPS", "--step-size", "0.5"], "less than one cell of map 'm0'"),
    (["--device", "cuda"], "--device cuda"),
    (["--device", "gpu"], "--device 'gpu'"),
])
def test_train_script_refuses_bad_map_sets_and_devices_before_any_work(tmp_path, capsys, monkeypatch, flags, named):
    if "cuda" in flags and torch.cuda.is_available():
        pytest.skip("this machine has a GPU")
    folder = _npy_maps(tmp_path / "maps", 6)
    script = _train_script()
    monkeypatch.setattr(script, "train", lambda *a, **k: pytest.fail("training started"))
    flags = [str(folder) if f == "MAPS" else str(tmp_path / f) if f == "NOWHERE" else f for f in flags]
    assert script.main(["--out", str(tmp_path / "o"), "--no-progress", *flags]) == 2
    err = capsys.readouterr().err
    assert named in err and err.count("\n") == 1, err
    assert not (tmp_path / "o").exists()
