"""``scripts/experiments/compare_runs.py``: two runs.csv files compared row for row."""

from __future__ import annotations

import csv

import pytest
from conftest import load_script

FIELDS = ["map", "query", "split", "planner", "sampler", "seed", "solved", "iterations", "wall_time"]


def _write(path, rows):
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, FIELDS)
        w.writeheader()
        w.writerows(rows)
    return path


def _row(seed=0, iterations=10, solved="True", wall=0.1):
    return {"map": "forest", "query": "q0", "split": "test", "planner": "RRT", "sampler": "uniform",
            "seed": seed, "solved": solved, "iterations": iterations, "wall_time": wall}


@pytest.mark.experiments
def test_equal_runs_pass_whatever_their_timing_and_order(tmp_path, capsys):
    script = load_script("experiments/compare_runs")
    a = _write(tmp_path / "a.csv", [_row(0), _row(1, 20)])
    b = _write(tmp_path / "b.csv", [_row(1, 20, wall=9.0), _row(0, wall=3.0)])
    assert script.main([str(a), str(b)]) == 0
    assert "0 differences" in capsys.readouterr().out


@pytest.mark.experiments
@pytest.mark.parametrize("change", [{"iterations": 11}, {"solved": "False"}, {"seed": 5}])
def test_a_changed_or_missing_run_fails(tmp_path, change, capsys):
    script = load_script("experiments/compare_runs")
    a = _write(tmp_path / "a.csv", [_row(0), _row(1)])
    b = _write(tmp_path / "b.csv", [_row(0), {**_row(1), **change}])
    assert script.main([str(a), str(b)]) == 1
    out = capsys.readouterr().out
    assert ("-> " in out) if "seed" not in change else ("only in the first" in out and "only in the second" in out)


@pytest.mark.experiments
def test_bad_files_are_refused_by_name(tmp_path, capsys):
    script = load_script("experiments/compare_runs")
    a = _write(tmp_path / "a.csv", [_row(0), _row(0)])
    with pytest.raises(SystemExit) as exc:
        script.main([str(a), str(tmp_path / "none.csv")])
    assert exc.value.code == 2 and "none.csv" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        script.main([str(a), str(a)])
    assert exc.value.code == 2 and "appears twice" in capsys.readouterr().err
