"""scripts/evaluate.py at its edges: checks before work, the lock, one output set, the journal, interrupts, map sets."""

from __future__ import annotations

import csv
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import load_script

from learning import evaluation as E
from learning.evaluation.journal import JOURNAL, Journal, file_digests, task_key, work_folder
from learning.evaluation.mapsets import UnseenQuery, pooled_tuned, unseen_name, unseen_queries
from planners.base.fileio import MANIFEST, InputError, run_lock
from planners.tools.benchmark import Run

ROOT = Path(__file__).resolve().parents[1]
#: The smallest comparison: one forest map per split, one seed, no other map sets or planners.
TINY = ["--families", "forest", "--size", "64", "--maps", "1", "--tuning-maps", "1", "--seeds", "1",
        "--shifted-maps", "0", "--no-unseen", "--movingai-maps", "--other-planners", "none", "--no-expert",
        "--max-iterations", "2000"]


def _ev():
    return load_script("evaluate")


# --- checks before work ----------------------------------------------------------------------------

@pytest.mark.parametrize("argv, needle", [
    (["--step", "0"], "--step"), (["--step", "nan"], "--step"), (["--step", "1e-9"], "--step = 1e-09"),
    (["--tolerance", "-1"], "--tolerance"), (["--tolerance", "inf"], "--tolerance"),
    (["--size", "10"], "--size"), (["--size", "100000"], "--size = 100000"),
    (["--maps", "0"], "--maps"), (["--seeds", "-2"], "--seeds"), (["--processes", "0"], "--processes"),
    (["--unseen-maps", "-1"], "--unseen-maps"), (["--families", "lava"], "lava"),
    (["--sampler", "mine=missing.zip@SamplerGym/RRT-Forest-v2@bogus=1"], "bogus"),
    (["--sampler", "mine=no_such_module:make"], "no_such_module"),
    (["--map-set", "/no/such/maps"], "/no/such/maps"),
    (["--map-set", str(ROOT / "tests/data/ros"), "--step", "1e-6"], "--step = 1e-06 is"),
])
def test_bad_arguments_exit_2_with_one_line_naming_them(argv, needle, capsys, tmp_path):
    with pytest.raises(SystemExit) as exc:
        _ev().main([*argv, "--out", str(tmp_path / "out")])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err and needle in err[-1] and "Traceback" not in "\n".join(err)
    assert not (tmp_path / "out").exists()


def test_output_places_are_checked_before_work(tmp_path, capsys):
    ev = _ev()
    a_file = tmp_path / "file"
    a_file.write_text("x")
    foreign = tmp_path / "mine"
    foreign.mkdir()
    (foreign / "thesis.tex").write_text("keep me")
    for out, needle in ((a_file, "a file is there"), (a_file / "below", "is a file"), (foreign, "thesis.tex")):
        with pytest.raises(SystemExit) as exc:
            ev.main([*TINY, "--out", str(out)])
        assert exc.value.code == 2
        assert needle in capsys.readouterr().err
    assert (foreign / "thesis.tex").read_text() == "keep me"
    if os.geteuid() != 0:  # root writes anywhere
        ro = tmp_path / "ro"
        ro.mkdir(mode=0o500)
        with pytest.raises(SystemExit):
            ev.main([*TINY, "--out", str(ro / "out")])
        assert "not writable" in capsys.readouterr().err


def test_a_second_run_on_a_locked_folder_exits_2_naming_the_holder(tmp_path, capsys):
    out = tmp_path / "out"
    with run_lock(out, "the first run"), pytest.raises(SystemExit) as exc:
        _ev().main([*TINY, "--out", str(out)])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert f"pid {os.getpid()}" in err and "the first run" in err


# --- the journal ----------------------------------------------------------------------------------

def _run(i: int, sampler: str = "uniform") -> Run:
    return Run(map="forest", query=f"q{i}", split="test", planner="RRT", sampler=sampler, seed=0, solved=i % 2 == 0,
               iterations=100 + i, lower_bound=10, candidates=100 + i, collision_checks=200, wall_time=0.01,
               us_per_iteration=5.0, path_cost=float("inf") if i % 2 else 12.5, forward_passes=0, vertices=50)


def test_the_journal_keeps_runs_across_a_torn_line_and_refuses_other_settings(tmp_path):
    folder = tmp_path / "out.partial"
    j = Journal(folder, {"step": 4.0}, resume=False)
    runs = [_run(i) for i in range(5)]
    for i, r in enumerate(runs):
        j.add(task_key(("task", i)), r)
    j.close()
    with open(folder / JOURNAL, "a") as f:
        f.write('{"key": "torn", "run": {"map": "fo')  # a kill in the middle of a line
    again = Journal(folder, {"step": 4.0}, resume=True)
    assert again.resumed == 5 and [again.done[task_key(("task", i))] for i in range(5)] == runs
    again.add(task_key(("task", 5)), _run(5))  # after the torn line: on a line of its own
    again.close()
    with pytest.raises(ValueError, match="other settings.*step"):
        Journal(folder, {"step": 2.0}, resume=True)
    with pytest.raises(InputError, match="6 finished runs.*--resume.*--fresh"):  # never discarded unasked
        Journal(folder, {"step": 2.0}, resume=False)
    assert Journal(folder, {"step": 4.0}, resume=True).resumed == 6
    fresh = Journal(folder, {"step": 2.0}, resume=False, fresh=True)  # --fresh: start over
    assert fresh.done == {} and fresh.discarded == 6
    fresh.remove()
    assert not folder.exists()
    assert work_folder(tmp_path / "out") == (tmp_path / "out.partial").absolute()


@pytest.mark.parametrize("resume, fresh", [(False, False), (True, False), (False, True)])
def test_the_work_folder_never_loses_a_file_the_journal_did_not_write(tmp_path, resume, fresh):
    folder = tmp_path / "out.partial"
    folder.mkdir()
    (folder / "thesis.tex").write_text("keep me")
    with pytest.raises(InputError, match=r"out\.partial.*thesis\.tex.*move those files"):
        Journal(folder, {}, resume=resume, fresh=fresh)
    assert (folder / "thesis.tex").read_text() == "keep me"
    (folder / "thesis.tex").unlink()
    (folder / JOURNAL).write_text("my own notes\n1\n")  # a journal.jsonl that is not ours
    with pytest.raises(InputError, match="not an evaluation journal"):
        Journal(folder, {}, resume=resume, fresh=fresh)
    assert (folder / JOURNAL).read_text() == "my own notes\n1\n"
    (folder / JOURNAL).unlink()
    j = Journal(folder, {}, resume=resume, fresh=fresh)  # an empty folder: the journal starts there
    (folder / "arrived.txt").write_text("later")
    j.remove()  # the journal goes, what arrived meanwhile stays
    assert sorted(p.name for p in folder.iterdir()) == ["arrived.txt"]


def test_evaluate_refuses_a_work_folder_of_other_files_and_a_journal_without_resume_or_fresh(tmp_path, capsys):
    ev, out = _ev(), tmp_path / "out"
    work = work_folder(out)
    work.mkdir()
    (work / "data.csv").write_text("keep me")
    for extra in ([], ["--resume"], ["--fresh"]):
        with pytest.raises(SystemExit) as exc:
            ev.main([*TINY, "--out", str(out), *extra])
        assert exc.value.code == 2
        err = capsys.readouterr().err
        assert "data.csv" in err and str(work) in err and "Traceback" not in err
    assert (work / "data.csv").read_text() == "keep me"
    (work / "data.csv").unlink()
    j = Journal(work, {"step": 4.0}, resume=False)
    j.add("k", _run(0))
    j.close()
    with pytest.raises(SystemExit) as exc:
        ev.main([*TINY, "--out", str(out)])
    assert exc.value.code == 2
    assert "1 finished runs" in (err := capsys.readouterr().err) and "--resume" in err and "--fresh" in err
    assert len((work / JOURNAL).read_text().splitlines()) == 2
    with pytest.raises(SystemExit) as exc:
        ev.main([*TINY, "--out", str(out), "--resume", "--fresh"])
    assert exc.value.code == 2 and "choose one" in capsys.readouterr().err


def test_resume_refuses_a_journal_whose_files_changed_naming_the_file(tmp_path):
    folder = tmp_path / "w"
    model = tmp_path / "policy.zip"
    model.write_bytes(b"the first model")
    settings = {"step": 4.0, "inputs": file_digests({f"--policy {model}": model})}
    j = Journal(folder, settings, resume=False)
    j.add("k", _run(0))
    j.close()
    assert Journal(folder, settings, resume=True).resumed == 1
    model.write_bytes(b"the second model")  # replaced between the kill and the resume
    with pytest.raises(InputError, match=rf"--policy {re.escape(str(model))}: its content changed"):
        Journal(folder, {"step": 4.0, "inputs": file_digests({f"--policy {model}": model})}, resume=True)


def test_evaluate_records_the_hashes_of_the_files_it_runs(tmp_path):
    args = _ev().parse_args([*TINY, "--out", str(tmp_path / "out"), "--map-set", str(ROOT / "tests/data/ros")])
    labels = set(args.inputs)
    assert any(k.startswith("--policy ") for k in labels) and any(k.startswith("--route ") for k in labels)
    assert any(k.endswith("turtlebot3_world/map.pgm") for k in labels)
    assert _ev()._settings(args)["inputs"] == args.inputs


@pytest.mark.parametrize("line, needle", [
    ('{"key": "k", "run": RUN_iterations_"12"}', "'iterations' is '12', expected an integer"),
    ('{"key": "k", "run": RUN_solved_1}', "'solved' is 1, expected true or false"),
    ('{"key": 5, "run": {}}', "a \"key\" string"),
    ('[' * 200_000 + ']' * 200_000, "nested too deep"),
])
def test_a_journal_line_of_the_wrong_types_is_refused_on_load_naming_it(tmp_path, line, needle):
    folder = tmp_path / "w"
    j = Journal(folder, {}, resume=False)
    j.add("a", _run(0))
    j.close()
    if line.startswith('{"key": "k"'):
        field, value = line.split("RUN_")[1].rstrip("}").split("_", 1)
        line = json.dumps({"key": "k", "run": {**_run(1).__dict__, field: json.loads(value)}})
    with open(folder / JOURNAL, "a") as f:
        f.write(line + "\n" + json.dumps({"key": "b", "run": _run(2).__dict__}) + "\n")
    with pytest.raises(InputError, match="line 3") as exc:
        Journal(folder, {}, resume=True)
    assert needle in str(exc.value)


def test_a_journal_header_nested_deep_is_refused_not_a_traceback(tmp_path):
    folder = tmp_path / "w"
    folder.mkdir()
    (folder / JOURNAL).write_text("[" * 200_000 + "]" * 200_000 + "\n")
    for resume in (True, False):
        with pytest.raises(InputError, match="not an evaluation journal"):
            Journal(folder, {}, resume=resume)


# --- tables and figures -----------------------------------------------------------------------------

def _rows(medians: dict[str, float], fam: str = "maze (shifted)") -> list[dict]:
    runs = []
    for s, m in medians.items():
        runs += [dataclass_run(fam, s, m + d) for d in (-1, 0, 1)]
    return E.summarize(runs, {(fam, "RRT"): 0.05})


def dataclass_run(fam: str, sampler: str, its: float) -> Run:
    r = _run(0, sampler)
    return Run(**{**r.__dict__, "map": fam, "iterations": int(its), "solved": True, "query": f"{its}"})


def test_room_and_share_closed_and_targets_in_words():
    rows = _rows({"route ablation": 400, "route encoder": 250, "exact_route": 100, "policy": 390,
                  "constant (tuned)": 400, "uniform": 900, "goal_bias=0.05": 800})
    room = E.room_table(rows)
    assert room[0]["route encoder: room"] == "75%" and room[0]["route encoder: share closed"] == "0.50"
    assert room[0]["policy: share closed"] == "0.03"
    words = " ".join(E.carry_targets(rows, []))
    assert "holds on 1 of 1" in words and "issue" not in words.lower()
    # where the exact reference is within 20% of the ablation, the target cannot be reached
    rows = _rows({"route ablation": 100, "route encoder": 90, "exact_route": 90})
    words = " ".join(E.carry_targets(rows, []))
    assert "cannot be reached" in words and "10%" in words
    assert E.room_table(_rows({"route ablation": 100, "route encoder": 90})) == []  # no exact reference: no table
    # a set where the learned sampler is more than 5% worse names the exact reference's own ratio beside it
    words = " ".join(E.carry_targets(_rows({"route ablation": 100, "route encoder": 130, "exact_route": 120}), []))
    assert "maze (shifted) 1.30 (exact 1.20)" in words
    words = " ".join(E.carry_targets(_rows({"route ablation": 100, "route encoder": 130}), []))
    assert "maze (shifted) 1.30 (learned" in words
    # success below the ablation's by one run of 150 shows, with the exact reference's own success beside it
    runs = [dataclass_run("maze (shifted)", s, 50) for s in ("route ablation", "route encoder", "exact_route")
            for _ in range(150)]
    failed = {("route encoder", 0), ("exact_route", 0), ("exact_route", 1), ("exact_route", 2)}
    runs = [Run(**{**r.__dict__, "solved": False, "iterations": 20000}) if (r.sampler, i % 150) in failed else r
            for i, r in enumerate(runs)]
    words = " ".join(E.carry_targets(E.summarize(runs, {("maze (shifted)", "RRT"): 0.05}), []))
    assert "maze (shifted) 0.993 against 1.000 (exact 0.980)" in words
    # the exact reference's own failures of those two targets are named, whether or not the learned sampler fails
    assert f"{E.EXACT_FAILS} maze (shifted) 0.980 against 1.000." in words
    words = " ".join(E.carry_targets(_rows({"route ablation": 100, "route encoder": 100, "exact_route": 120}), []))
    assert f"worse than the ablation: holds on every set. {E.EXACT_FAILS} maze (shifted) 1.20." in words
    rows = _rows({"route ablation": 100, "route encoder": 130, "exact_route": 90})
    assert E.EXACT_FAILS not in " ".join(E.carry_targets(rows, []))


def test_a_failure_carries_its_interval_over_the_queries_and_the_target_stays_on_the_measured_value():
    fam = "maze (shifted)"
    runs = [Run(**{**_run(0, s).__dict__, "map": fam, "query": f"q{q}", "seed": seed, "solved": True,
                   "iterations": round((100 + 37 * q + seed) * f)})
            for q in range(10) for seed in range(3)
            for s, f in (("route ablation", 1.0), ("route encoder", 1.2), ("exact_route", 0.9))]
    lo, hi = E.query_bootstrap(runs, fam, "route encoder", "route ablation", E.median_ratio)
    assert 1.19 <= lo <= hi <= 1.21  # 1.2 on every query, whichever queries are drawn
    assert (lo, hi) == E.query_bootstrap(runs, fam, "route encoder", "route ablation", E.median_ratio)  # seeded
    lo, hi = E.query_bootstrap(runs, fam, "route encoder", "route ablation", E.success_difference)
    assert lo == hi == 0.0
    assert all(np.isnan(E.query_bootstrap(runs, fam, "route encoder", "nobody", E.median_ratio)))
    rows = E.summarize(runs, {(fam, "RRT"): 0.05})
    words = " ".join(E.carry_targets(rows, [], runs=runs))
    assert re.search(r"fails on maze \(shifted\) 1\.20 \[1\.(19|20) to 1\.(20|21)\] \(exact 0\.90\)", words)
    assert "its 95% interval over the set's queries in brackets" in words
    plain = " ".join(E.carry_targets(rows, []))  # without the runs: the measured values only
    assert "interval" not in plain and "[" not in plain
    # the interval never turns a failure into a pass: a noisy set just over the margin still fails
    noisy = [Run(**{**r.__dict__, "iterations": r.iterations * (3 if r.query == "q0" and r.sampler == "route encoder"
                                                                 else 1)}) for r in runs]
    assert "5% worse than the ablation: fails" in " ".join(E.carry_targets(E.summarize(noisy, {}), [], runs=noisy))


def test_the_glance_table_has_a_few_columns_and_dashes_for_missing_samplers():
    rows = _rows({"uniform": 900, "goal_bias=0.05": 800, "policy": 300, "route encoder": 200})
    table = E.glance_table(rows, {("maze (shifted)", "RRT"): 0.05})
    assert list(table[0]) == ["map set", "tuned bias", "uniform", "best goal bias", "policy", "route encoder"]
    assert table[0]["best goal bias"] == "800 (100%)"


def test_the_time_glance_table_gives_median_ms_and_bolds_the_fastest_sampler_but_not_the_expert():
    rows = _rows({"uniform": 900, "goal_bias=0.05": 800, "route encoder": 200, "expert (reference)": 50})
    ms = {"uniform": 4.0, "goal bias 0.05 (default, best)": 2.5, "route encoder": 12.0, "expert (reference)": 0.5}
    for r in rows:
        r["median_wall_ms"] = ms[r["sampler"]]
    table = E.glance_table(rows, {("maze (shifted)", "RRT"): 0.05}, metric="time")
    assert table[0]["best goal bias"] == "**2.5 ms**" and table[0]["uniform"] == "4 ms"
    assert table[0]["route encoder"] == "12 ms" and table[0]["expert"] == "0.5 ms"  # privileged: never bold
    with pytest.raises(ValueError, match="metric"):
        E.glance_table(rows, {}, metric="seconds")


def test_one_colour_per_sampler_in_both_figures():
    runs = []
    for s, base in (("uniform", 900), ("goal_bias=0.05", 700), ("goal_bias=0.2", 500), ("policy", 300),
                    ("route encoder", 200), ("expert (reference)", 60)):
        runs += [dataclass_run(f, s, base + 13 * i) for f in ("forest", "maze") for i in range(4)]
    biases = {("forest", "RRT"): 0.2, ("maze", "RRT"): 0.05}
    rows = E.summarize(runs, biases)
    ecdf = E.ecdf_figure(runs, biases, extra=["route encoder"])
    med = E.medians_figure(runs, rows, biases, extra=["route encoder"])
    lines = {ln.get_label(): ln.get_color() for ax in ecdf.axes for ln in ax.get_lines()}
    bars = {c.get_label(): c.patches[0].get_facecolor() for c in med.axes[0].containers if hasattr(c, "patches")}
    from matplotlib.colors import to_hex

    for name, label in (("uniform", "uniform"), ("policy", "policy"), ("route encoder", "route encoder"),
                        ("expert (reference)", "expert")):
        assert lines[label] == E.PALETTE[name] and to_hex(bars[label]) == E.PALETTE[name]
    assert len(set(E.PALETTE.values())) == len(E.PALETTE)
    assert not any(ax.get_legend() for ax in ecdf.axes) and ecdf.legends  # one legend, outside the panels


# --- map sets ---------------------------------------------------------------------------------------

def test_unseen_families_take_the_pooled_generated_tuning():
    qs = unseen_queries(64, 2)
    assert {q.map_set for q in qs} == {unseen_name(f) for f in ("spiral", "warehouse", "baffles")}
    assert all(q.split == "test" for q in qs) and qs[0].problem(None, 4.0).name.startswith("spiral-64-")
    runs = [Run(**{**_run(0).__dict__, "map": fam, "split": "tuning", "sampler": E.bias_sampler(b),
                   "sampler_spec": E.bias_spec(b).to_json(), "iterations": its, "solved": True})
            for fam, b, its in (("forest", 0, 100), ("forest", 0.1, 50), ("maze", 0, 300), ("maze", 0.1, 400),
                                ("maze", 0.1, 60), ("maze", 0, 200))]
    tuned = pooled_tuned(runs, ["forest", "maze"], E.best_bias, [unseen_name("spiral")])
    # pooled medians: uniform [100, 300, 200] -> 200, bias 0.1 [50, 400, 60] -> 60
    assert tuned == {(unseen_name("spiral"), "RRT"): 0.1}
    assert isinstance(qs[0], UnseenQuery)


@pytest.mark.slow
def test_a_map_set_is_tuned_on_its_tuning_part_and_tested_on_its_test_part(tmp_path, capsys):
    out = tmp_path / "out"
    rc = _ev().main(["--map-set", str(ROOT / "tests" / "data" / "ros"), "--step", "0.2", "--tolerance", "0.2",
                     "--seeds", "1", "--no-expert", "--processes", "1", "--max-iterations", "2000",
                     "--out", str(out)])
    assert rc == 0
    printed = capsys.readouterr().out
    assert "split sha256-rank" in printed
    record = json.loads((out / "map-sets.json").read_text())
    assert record["map set"]["split"]["parts"]["test"] and record["map sets"] == ["ros"]
    rows = list(csv.DictReader((out / "runs.csv").open()))
    parts = record["map set"]["split"]["parts"]
    for r in rows:
        assert r["query"].split("#")[0] in parts["tuning" if r["split"] == "tuning" else "test"]
    assert "| sampler | ros | time per query | success |" in (out / "summary.md").read_text()  # the short table
    summary = (out / "details.md").read_text()
    assert summary.index("## Results at a glance") < summary.index("## All cells") and "| ros |" in summary
    assert (out / "ompl" / "ros.log").is_file()


# --- interrupts, resume and kills, in a subprocess -----------------------------------------------------

SLOW = '''
import time
from planners.base.samplers import SamplerBase


class Slow(SamplerBase):
    """Uniform, a few milliseconds per draw: long enough to interrupt the comparison mid-run."""

    def draw(self, rng, n, view):
        time.sleep(0.004)
        return self._uniform(rng.random((n, self.problem.dim)))


def make():
    return Slow()
'''


def _start(tmp_path: Path, out: Path, *extra: str) -> subprocess.Popen:
    (tmp_path / "slow_sampler.py").write_text(SLOW)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.Popen([sys.executable, str(ROOT / "scripts" / "evaluate.py"), *TINY, "--processes", "2",
                             "--sampler", "slow=slow_sampler:make", "--out", str(out), *extra],
                            cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)


def _children(pid: int) -> list[int]:
    out = []
    for d in Path("/proc").iterdir():
        try:
            if d.name.isdigit() and f"PPid:\t{pid}\n" in (d / "status").read_text():
                out.append(int(d.name))
        except OSError:
            continue
    return out


def _wait_for_runs(out: Path, n: int, proc: subprocess.Popen, limit: float = 240) -> None:
    journal = work_folder(out) / JOURNAL
    t0 = time.monotonic()
    while time.monotonic() - t0 < limit:
        assert proc.poll() is None, proc.communicate()
        if journal.is_file() and len(journal.read_text().splitlines()) > n:
            return
        time.sleep(0.2)
    raise AssertionError("no runs journaled in time")


def _csv_without_times(path: Path) -> list[dict]:
    return [{k: v for k, v in r.items() if k not in ("wall_time", "us_per_iteration", "compile_time")}
            for r in csv.DictReader(path.open())]


@pytest.mark.slow
@pytest.mark.parametrize("sig, status", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_an_interrupt_stops_every_worker_keeps_the_journal_and_resume_finishes(tmp_path, sig, status):
    out = tmp_path / "out"
    proc = _start(tmp_path, out)
    _wait_for_runs(out, 2, proc)
    workers = _children(proc.pid)
    t0 = time.monotonic()
    if sig == signal.SIGINT:  # Ctrl-C in a terminal reaches the whole process group, workers included
        os.killpg(proc.pid, sig)
    else:  # kill PID: the main process only
        proc.send_signal(sig)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == status and time.monotonic() - t0 < 10
    lines = [ln for ln in err.splitlines() if ln.strip() and "it/s" not in ln and "s/it" not in ln]
    assert "Traceback" not in err and sum("interrupted:" in ln for ln in lines) == 1, err
    assert "--resume" in err and not out.exists()
    time.sleep(1)
    assert not [w for w in workers if Path(f"/proc/{w}").exists() and "zombie" not in
                (Path(f"/proc/{w}/status").read_text() if Path(f"/proc/{w}").exists() else "zombie").lower()]
    kept = len((work_folder(out) / JOURNAL).read_text().splitlines()) - 1
    assert kept >= 2
    resumed = _start(tmp_path, out, "--resume")
    so, se = resumed.communicate(timeout=600)
    assert resumed.returncode == 0, se
    assert f"resuming: {kept}" in so or "resuming:" in so
    assert not work_folder(out).exists() and (out / MANIFEST).is_file()
    whole = tmp_path / "whole"
    full = _start(tmp_path, whole)
    full.communicate(timeout=600)
    assert full.returncode == 0
    assert _csv_without_times(out / "runs.csv") == _csv_without_times(whole / "runs.csv")


@pytest.mark.slow
def test_a_kill_leaves_the_old_output_set_whole(tmp_path):
    out = tmp_path / "out"
    first = _start(tmp_path, out)
    first.communicate(timeout=600)
    assert first.returncode == 0
    before = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    manifest = json.loads((out / MANIFEST).read_text())
    assert set(manifest["files"]) == {str(p) for p in before if str(p) != MANIFEST}
    second = _start(tmp_path, out)
    _wait_for_runs(out, 2, second)
    second.kill()
    second.communicate()
    after = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert after == before
    # the dead run's lock is taken over, and --resume finishes from its journal
    third = _start(tmp_path, out, "--resume")
    so, se = third.communicate(timeout=600)
    assert third.returncode == 0, se
    assert "took over the lock" in se and "resuming:" in so


def test_progress_names_the_phase_and_the_cost_per_sampler(tmp_path, capsys):
    from learning.evaluation.journal import run_phase
    from planners.tools.parallel import make_backend

    q = E.generated_queries(["forest"], 64, 1, 0)[0]
    context = E.RunContext(E.Protocol(max_iterations=500))
    specs = (E.SamplerSpec.of("uniform"), E.bias_spec(0.05))
    tasks = [E.Task(q, "RRT", s, seed) for s in specs for seed in range(4)]
    j = Journal(tmp_path / "w", {}, resume=False)
    runs = run_phase(tasks, context, make_backend("local", processes=1), j, "a phase")
    err = capsys.readouterr().err
    assert "a phase" in err and "ms/run" in err and "goal bias" in err
    assert [r.sampler for r in runs] == [t.sampler_label for t in tasks] and len(j.done) == 8
    assert [E.spec_of(r) for r in runs] == [t.sampler for t in tasks]
    again = run_phase(tasks, context, make_backend("local", processes=1), j, "again")  # all from the journal
    assert again == runs
    assert np.all([r.iterations > 0 for r in runs])
    # a task's key holds its spec and the protocol: another cap is other runs, not these
    other = E.RunContext(E.Protocol(max_iterations=400))
    assert task_key((tasks[0], context.protocol)) != task_key((tasks[0], other.protocol))
    assert task_key((tasks[0], context.protocol)) == task_key((E.Task(q, "RRT", E.SamplerSpec.of("uniform"), 0),
                                                              E.Protocol(max_iterations=500)))


def test_ompl_log_names_are_bounded_and_one_per_map_set(tmp_path):
    long = "a map set named at length " * 12  # 312 characters
    runs = [Run(**{**_run(0).__dict__, "map": m, "split": "test"}) for m in (long, long + "!", "a b", "a_b")]
    paths = E.write_ompl_logs(runs, {}, tmp_path / "ompl", E.Protocol())
    assert len({p.name for p in paths}) == 4 and all(p.is_file() for p in paths)
    assert max(len(p.name) for p in paths) <= 124 and "a_b.log" in {p.name for p in paths}


def test_an_out_name_too_long_for_its_temporary_names_is_refused_before_work(tmp_path, capsys):
    out = tmp_path / ("o" * 230)  # fits a file system's 255 bytes, but not with the temporary set's name beside it
    with pytest.raises(SystemExit) as exc:
        _ev().main([*TINY, "--out", str(out)])
    assert exc.value.code == 2 and "230 bytes long" in capsys.readouterr().err


def test_resume_without_a_journal_and_fresh_over_one_say_what_they_do(tmp_path, capsys, monkeypatch):
    ev, out = _ev(), tmp_path / "out"
    class NoRuns:  # the checks and the journal, not the runs (learning.evaluation.compare runs the phases)
        def write(self, out, settings):
            pass

        def printed(self, out):
            return ""

    monkeypatch.setattr(E.Comparison, "run", lambda self, *args, **kwargs: NoRuns())
    assert ev.main([*TINY, "--processes", "1", "--out", str(out), "--resume"]) == 0
    assert "--resume: no finished runs in" in capsys.readouterr().out
    j = Journal(work_folder(out), {"step": 4.0}, resume=False)
    j.add("k", _run(0))
    j.close()
    assert ev.main([*TINY, "--processes", "1", "--out", str(out), "--fresh"]) == 0
    assert "--fresh: discarded the 1 finished runs" in capsys.readouterr().out
    assert not work_folder(out).exists()
