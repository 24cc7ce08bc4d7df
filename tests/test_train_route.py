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
from conftest import load_script, npy_map_folder

from learning.device import CPU_ARITHMETIC, pin_cpu_arithmetic, resolve_device
from learning.models.route_net import load_route_net
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


# one kill point in the default run; the other three with `-m slow`
@pytest.mark.parametrize("fraction", [pytest.param(0.25, marks=pytest.mark.slow), 0.5,
                                      pytest.param(0.75, marks=pytest.mark.slow),
                                      pytest.param(1.0, marks=pytest.mark.slow)])
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
    assert script.main([*TINY, "--epochs", "1", "--blocks-per-step", "1", "--out", str(out)]) == 0
    net = load_route_net(out / "route.pt")
    assert (net.block, net.step) == (4, 4)
    assert json.loads((out / "route.json").read_text())["recipe"]["blocks_per_step"] == 1


def test_with_no_flags_it_trains_the_shipped_teachers_recipe():
    from importlib import util

    spec = util.spec_from_file_location("train_route_script", ROOT / "scripts" / "train_route.py")
    script = util.module_from_spec(spec)
    spec.loader.exec_module(script)
    args = script._parser().parse_args([])
    script._check(args)  # what the flags left out come to (the encoder's blocks)
    defaults = vars(args)
    shipped = json.loads((ROOT / "learning" / "data" / "route_teacher.json").read_text())["recipe"]
    for key, value in shipped.items():
        if key == "device":  # the run named the CPU; with no flag, "auto" is the CPU on a machine without a GPU
            assert str(resolve_device(defaults[key])) == "cpu" or value != "cpu", key
        elif key in defaults and key not in ("out", "export", "workers"):  # workers never change the weights
            assert defaults[key] == value, key
    assert not {"thicken", "speckle", "grad_weight"} & defaults.keys()


@pytest.mark.parametrize("flags, named", [
    (["--epochs", "0"], "--epochs"), (["--size", "64", "8"], "--size"), (["--size", "100000"], "--size = 100000"),
    (["--attention", "1", "--channels", "5"], "--attention"), (["--attention", "1", "--attention-level", "4"],
                                                                "--attention-level"),
    (["--seed", "-1"], "--seed"), (["--maps", "10000000"], "--maps"), (["--resume"], "--resume"),
    (["--size", "2048"], "--size 2048: map 'generated 2048 x 2048' is 2048 x 2048 cells: 1024 x 1024 = 1048576 "
                         "blocks of 2 cells, more than the 262144"),
    (["--blocks-per-step", "3"], "--blocks-per-step 3: a step of 4 cells does not divide into 3 whole blocks"),
    (["--blocks-per-step", "2", "--kind", "unet"], "--blocks-per-step: step = 4, block = 2: the U-Net's blocks"),
    (["--blocks-per-step", "0"], "--blocks-per-step"), (["--grad-clip", "0"], "--grad-clip 0"),
    (["--grad-clip", "inf"], "--grad-clip inf"),
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


def _ctrl_c_in_the_second_epoch(train):
    """``train`` (``train_route_net``) interrupted as its second epoch ends, before that epoch's checkpoint."""

    def interrupted(problems, **kwargs):
        log = kwargs["log"]

        def stop(line):
            log(line)
            if line.startswith("epoch 1"):
                raise KeyboardInterrupt

        return train(problems, **{**kwargs, "log": stop})

    return interrupted


@pytest.mark.slow  # a training run of its own (15-25 s on 2 cores)
def test_ctrl_c_says_what_was_kept_and_exits_130(tmp_path, capsys, monkeypatch):
    from importlib import util

    spec = util.spec_from_file_location("train_route_script", ROOT / "scripts" / "train_route.py")
    script = util.module_from_spec(spec)
    spec.loader.exec_module(script)

    monkeypatch.setattr(script, "train_route_net", _ctrl_c_in_the_second_epoch(script.train_route_net))
    out = tmp_path / "o"
    flags = [*TINY, "--out", str(out)]
    assert script.main(flags) == 130
    err = capsys.readouterr().err.strip()
    assert err == f"interrupted: {out / 'checkpoint.pt'} holds the last finished epoch; continue with --resume"
    assert not (tmp_path / ".o.lock").exists(), "the lock is released"
    monkeypatch.undo()
    assert script.main([*flags, "--resume"]) == 0
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST, "route.json", "route.pt"]


# --- map sets, workers and devices ------------------------------------------------------------------

def _script():
    return load_script("train_route")


_npy_maps = npy_map_folder


SMALL = ["--maps", "6", "--epochs", "2", "--channels", "4", "--depth", "1", "--attention", "0", "--workers", "1",
         "--mix-generated", "no"]  # your sets alone (a small set mixes the generated families in by default)


def test_a_small_map_set_mixes_the_generated_families_in_by_default_and_a_large_one_does_not(tmp_path, capsys):
    script = _script()
    ros = str(ROOT / "tests" / "data" / "ros")
    args = script._parser().parse_args(["--map-set", ros, "--out", str(tmp_path / "o")])
    script._check(args)
    assert args.mixed_generated and [ms.name for ms in args.sets.sets] == ["ros", "generated"]
    assert args.sets.record()["weights"] == [0.25, 0.75]  # --mix-weight 3 against 1
    assert "fewer than 20" in capsys.readouterr().out
    for flags, mixed in ((["--mix-generated", "no"], False), (["--map-set", "generated"], False),
                         (["--mix-generated", "yes", "--mix-weight", "1"], True)):
        args = script._parser().parse_args(["--map-set", ros, *flags, "--out", str(tmp_path / "o")])
        script._check(args)
        assert args.mixed_generated == mixed and sum(ms.name == "generated" for ms in args.sets.sets) == (
            1 if mixed or "generated" in flags else 0)
    big = _npy_maps(tmp_path / "big", 40)  # 40 maps: a training part of 20 or more
    args = script._parser().parse_args(["--map-set", str(big), "--out", str(tmp_path / "o")])
    script._check(args)
    assert not args.mixed_generated and len(args.sets.sets) == 1


def test_map_set_training_writes_a_loadable_encoder_whose_json_records_the_sets(tmp_path, capsys):
    from planners.maps.mapset import MapSet

    a, b = _npy_maps(tmp_path / "a", 6), _npy_maps(tmp_path / "b", 5, side=48, family="maze")
    out = tmp_path / "run"
    assert _script().main([*SMALL, "--map-set", str(a), "--map-set", str(b), "--map-set-weight", "3",
                           "--map-set-weight", "1", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "split sha256-rank" in printed and "validation" in printed
    net = load_route_net(out / "route.pt")
    assert net.channels == 4 and net.trained_side == 0  # the value-iteration encoder keeps its scale on any map
    meta = json.loads((out / "route.json").read_text())
    sets = meta["map_sets"]
    assert sets["kind"] == "mixed" and sets["weights"] == [0.75, 0.25]
    for rec, folder in zip(sets["sets"], (a, b), strict=True):
        ms = MapSet.open(folder)
        assert rec["split"]["rule"] == "sha256-rank" and rec["split"]["parts"]["train"] == list(ms.maps("train"))
    assert meta["step"]["cells"] == 4 and meta["step"]["world_units"]["m0"] == 4.0
    assert meta["chosen_epoch"] in (0, 1) and meta["chosen"].startswith("chose epoch")
    assert "validation" in meta["last_epoch"] and meta["recipe"]["size"] is None


def test_map_set_training_resumes_to_the_weights_of_an_uninterrupted_run(tmp_path, monkeypatch):
    folder = _npy_maps(tmp_path / "maps", 6)
    script = _script()
    flags = [*SMALL, "--map-set", str(folder)]
    assert script.main([*flags, "--out", str(tmp_path / "whole")]) == 0
    monkeypatch.setattr(script, "train_route_net", _ctrl_c_in_the_second_epoch(script.train_route_net))
    assert script.main([*flags, "--out", str(tmp_path / "cut")]) == 130
    monkeypatch.undo()
    assert script.main([*flags, "--out", str(tmp_path / "cut"), "--resume"]) == 0
    whole, cut = _weights(tmp_path / "whole"), _weights(tmp_path / "cut")
    assert all(torch.equal(whole[k], cut[k]) for k in whole)
    meta = [json.loads((tmp_path / d / "route.json").read_text()) for d in ("whole", "cut")]
    assert meta[0]["chosen"] == meta[1]["chosen"] and meta[0]["map_sets"] == meta[1]["map_sets"]


def _manifest_all_test(tmp_path: Path) -> Path:
    folder = _npy_maps(tmp_path / "m", 2)
    manifest = tmp_path / "all_test.json"
    manifest.write_text(json.dumps({"maps": [{"path": str(p), "part": "test"} for p in sorted(folder.glob("*.npy"))]}))
    return manifest


@pytest.mark.parametrize("case, named", [
    ("unreadable", "broken.png"),
    ("empty_train", "'train' part is empty"),
    ("weights", "--map-set-weight: 1 weights"),
    ("weight_alone", "--map-set-weight 2: it applies to --map-set"),
    ("negative_weight", "--map-set-weight -1"),
    ("too_large", "SAMPLERGYM_MAX_ROUTE_BLOCKS"),
    ("step_size", "--step-size 0.3"),
    ("cuda", "--device cuda"),
    ("device", "--device 'gpu'"),
    ("workers", "--workers"),
])
def test_bad_map_set_inputs_exit_2_before_any_work_naming_the_value(tmp_path, capsys, monkeypatch, case, named):
    folder = _npy_maps(tmp_path / "maps", 6)
    flags = ["--map-set", str(folder)]
    if case == "unreadable":
        (folder / "broken.png").write_bytes(b"not a png")
    elif case == "empty_train":
        flags = ["--map-set", str(_manifest_all_test(tmp_path))]
    elif case == "weights":
        flags += ["--map-set", str(folder), "--map-set-weight", "1"]
    elif case == "weight_alone":
        flags = ["--map-set-weight", "2"]
    elif case == "negative_weight":
        flags += ["--map-set-weight", "-1"]
    elif case == "too_large":
        monkeypatch.setenv("SAMPLERGYM_MAX_ROUTE_BLOCKS", "4")  # 32 x 32 cells at a block of 4 are 64 blocks
    elif case == "step_size":
        flags += ["--step-size", "0.3"]  # 0.3 cells of a map of resolution 1
    elif case == "cuda":
        if torch.cuda.is_available():
            pytest.skip("this machine has a GPU")
        flags += ["--device", "cuda"]
    elif case == "device":
        flags += ["--device", "gpu"]
    elif case == "workers":
        flags += ["--workers", "0"]
    script = _script()
    monkeypatch.setattr(script, "train_route_net", lambda *a, **k: pytest.fail("training started"))
    assert script.main([*SMALL, "--out", str(tmp_path / "o"), *flags]) == 2
    err = capsys.readouterr().err
    assert named in err and err.count("\n") == 1, err
    assert not (tmp_path / "o").exists()


def test_a_step_size_must_come_to_one_block_on_every_map(tmp_path, capsys):
    import numpy as np

    folder = _npy_maps(tmp_path / "maps", 6)
    manifest = tmp_path / "mixed.json"
    maps = [{"path": str(p), "resolution": 0.5 if i % 2 else 0.25} for i, p in enumerate(sorted(folder.glob("*.npy")))]
    manifest.write_text(json.dumps({"maps": maps, "fractions": {"train": 0.5, "validation": 0.5}}))
    script = _script()
    assert script.main([*SMALL, "--map-set", str(manifest), "--step-size", "1", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "different cell counts" in err and "m0: 4" in err and "m1: 2" in err
    even = tmp_path / "even.json"
    even.write_text(json.dumps({"maps": [{"path": str(p), "resolution": 0.5} for p in sorted(folder.glob("*.npy"))]}))
    args = script._parser().parse_args([*SMALL, "--map-set", str(even), "--step-size", "1", "--out", str(tmp_path)])
    script._check(args)
    assert args.step == 2 and np.isclose(args.step * 0.5, 1.0)


@pytest.mark.slow  # a training run of its own (15-25 s on 2 cores)
def test_one_and_two_workers_make_the_same_tensors(tmp_path):
    import functools

    import numpy as np

    from learning.training.route import make_examples, train_route_net
    from planners.maps.generators import generate
    from planners.maps.mapset import MapSet

    ms = MapSet.open(_npy_maps(tmp_path / "maps", 6))
    rng = np.random.default_rng(3)
    problems = [functools.partial(generate, f, 7, 32) for f in ("forest", "maze", "rooms")]
    problems += [ms.sample("train", rng) for _ in range(5)]
    turns = np.random.default_rng(0).integers(0, 8, len(problems))
    one, two = make_examples(problems, turns, 4, workers=1), make_examples(problems, turns, 4, workers=2)
    assert [e[0] for e in one] == [e[0] for e in two]
    for a, b in zip(one, two, strict=True):
        assert a[1] == b[1] and np.array_equal(a[2], b[2]) and np.array_equal(a[3], b[3], equal_nan=True)
    kwargs = dict(channels=4, depth=1, epochs=1, augment=True, seed=2, log=lambda _: None,
                  validation=[ms.problem(q) for q in ms.queries("validation")])
    w1 = train_route_net(problems, workers=1, **kwargs).state_dict()
    w2 = train_route_net(problems, workers=2, **kwargs).state_dict()
    assert all(torch.equal(w1[k], w2[k]) for k in w1)


def test_the_cosine_schedule_decays_the_rate_repeatably_and_a_bad_schedule_is_refused():
    import functools

    from learning.training.route import train_route_net
    from planners.base.fileio import InputError
    from planners.maps.generators import generate

    problems = [functools.partial(generate, f, 7, 32) for f in ("forest", "maze", "strokes")]
    kwargs = dict(channels=4, depth=1, epochs=2, batch=1, lr=1e-2, kind="vin", log=lambda _: None)
    cos = [train_route_net(problems, schedule="cosine", **kwargs).state_dict() for _ in range(2)]
    flat = train_route_net(problems, schedule="constant", **kwargs).state_dict()
    assert all(torch.equal(cos[0][k], cos[1][k]) for k in flat)  # same seed, same weights
    assert not all(torch.equal(cos[0][k], flat[k]) for k in flat)  # the rate falls: the steps differ
    with pytest.raises(InputError, match="schedule 'linear'"):
        train_route_net(problems, schedule="linear", **kwargs)


def test_device_auto_is_the_cpu_without_a_gpu_and_cuda_is_refused_by_name():
    from learning.device import resolve_device
    from planners.base.fileio import InputError

    assert resolve_device("cpu").type == "cpu"
    assert resolve_device("auto").type == ("cuda" if torch.cuda.is_available() else "cpu")
    if not torch.cuda.is_available():
        with pytest.raises(InputError, match="--device cuda: torch sees no CUDA GPU"):
            resolve_device("cuda")
    with pytest.raises(InputError, match="--device 'tpu'"):
        resolve_device("tpu")


def test_targets_made_while_the_first_epoch_trains_give_the_same_weights(tmp_path, monkeypatch):
    import numpy as np

    from learning.training import route
    from planners.base.problem import Problem
    from planners.maps.mapset import MapSet
    from planners.worlds.grid import OccupancyGrid

    ms = MapSet.open(_npy_maps(tmp_path / "maps", 6))
    rng = np.random.default_rng(5)
    wide = np.zeros((24, 40), dtype=bool)  # not square: its turns change the group it falls in
    wide[5:20, 18] = True
    odd = [Problem(OccupancyGrid(wide), (2.5, 2.5), (37.5, 20.5), name=f"wide{i}") for i in range(3)]
    problems = [route.GeneratedProblem(f, 7, side) for side in (32, 36) for f in ("forest", "maze", "rooms")]
    problems += [ms.sample("train", rng) for _ in range(4)] + odd
    kwargs = dict(channels=4, depth=1, epochs=2, batch=3, augment=True, seed=4, log=lambda _: None,
                  validation=[ms.problem(q) for q in ms.queries("validation")])
    w1 = route.train_route_net(problems, workers=1, **kwargs).state_dict()

    started_with = []
    real_wait = route._Stream.wait

    def wait(self, j):
        real_wait(self, j)
        if j == 0:
            started_with.append(self.made)

    monkeypatch.setattr(route._Stream, "wait", wait)
    monkeypatch.setattr(route, "make_examples", lambda *a, **k: pytest.fail("targets made before training"))
    w2 = route.train_route_net(problems, workers=2, **kwargs).state_dict()
    assert started_with and started_with[0] < len(problems)  # the first batch trained before the last target came
    assert all(torch.equal(w1[k], w2[k]) for k in w1)


def test_training_holds_the_cpu_arithmetic_to_avx2_keeps_a_users_choice_and_records_it(tmp_path, monkeypatch):
    for name in CPU_ARITHMETIC:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("MKL_CBWR", "COMPATIBLE")  # the user's choice stays
    held = pin_cpu_arithmetic()
    assert held["ATEN_CPU_CAPABILITY"] == "avx2" and held["ONEDNN_MAX_CPU_ISA"] == "AVX2"
    assert held["MKL_CBWR"] == "COMPATIBLE" and held["torch_cpu_capability"] == torch.backends.cpu.get_cpu_capability()
    script = load_script("train_route")
    assert script.main([*TINY, "--epochs", "1", "--out", str(tmp_path / "run")]) == 0
    record = json.loads((tmp_path / "run" / "route.json").read_text())["cpu_arithmetic"]
    assert record == {**held, "torch_cpu_capability": record["torch_cpu_capability"]}


@pytest.mark.slow  # a training run of its own (15-25 s on 2 cores)
def test_a_gradient_cut_is_part_of_the_recipe_and_changes_the_weights_only_when_it_cuts(tmp_path):
    script = load_script("train_route")
    runs = {}
    for name, flags in (("plain", []), ("loose", ["--grad-clip", "1e9"]), ("tight", ["--grad-clip", "1e-3"])):
        assert script.main([*TINY, "--epochs", "1", "--out", str(tmp_path / name), *flags]) == 0
        runs[name] = (torch.load(tmp_path / name / "route.pt", weights_only=True),
                      json.loads((tmp_path / name / "route.json").read_text())["recipe"])
    assert runs["plain"][1]["grad_clip"] is None and runs["tight"][1]["grad_clip"] == 1e-3
    flat = {name: torch.cat([v.flatten() for v in state["state"].values() if torch.is_tensor(v)])
            for name, (state, _) in runs.items()}
    assert torch.equal(flat["plain"], flat["loose"]) and not torch.equal(flat["plain"], flat["tight"])


@pytest.mark.slow  # a training run of its own (15-25 s on 2 cores)
def test_a_run_whose_loss_rose_at_the_end_is_flagged_and_recorded(tmp_path, capsys, monkeypatch):
    from learning.training.route import RISE, loss_rise

    falling = [f"epoch {k}: loss {v:.3f} ({k} s)" for k, v in enumerate([6.3, 3.4, 1.1, 0.8])]
    rising = [f"epoch {k}: loss {v:.3f}, validation 1.0 ({k} s)" for k, v in enumerate([6.3, 3.8, 5.2, 7.0])]
    assert loss_rise(falling) is None and loss_rise(rising) == (1, 3.8, 7.0) and loss_rise([]) is None
    assert loss_rise(["epoch 0: loss 1.000 (1 s)", f"epoch 1: loss {RISE:.3f} (2 s)"]) is None
    script = load_script("train_route")
    assert script.main([*TINY, "--epochs", "1", "--out", str(tmp_path / "ok")]) == 0
    assert "diverged" not in capsys.readouterr().err
    assert json.loads((tmp_path / "ok" / "route.json").read_text())["loss_rose"] is None
    monkeypatch.setattr(script, "loss_rise", lambda lines: (0, 1.0, 2.0))
    assert script.main([*TINY, "--epochs", "1", "--out", str(tmp_path / "bad")]) == 0
    assert "rose from 1.000 at epoch 0 to 2.000: this run diverged" in capsys.readouterr().err
    assert json.loads((tmp_path / "bad" / "route.json").read_text())["loss_rose"] == {"lowest_epoch": 0, "lowest": 1.0,
                                                                                      "last": 2.0}
