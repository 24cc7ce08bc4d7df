"""``scripts/experiments/clock_by_set.py``: a sampler's time over a planner's best classical option, set by set."""

from __future__ import annotations

import csv

import pytest
from conftest import load_script

FIELDS = ["map", "query", "split", "planner", "sampler", "seed", "solved", "iterations", "wall_time"]


def _write(path, rows):
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, FIELDS)
        w.writeheader()
        w.writerows({"query": "q", "split": "test", "planner": "RRTstar", "seed": 0, "iterations": 1, **r}
                    for r in rows)
    return path


def _runs(m, sampler, times, solved=True):
    return [{"map": m, "sampler": sampler, "wall_time": t, "solved": str(solved)} for t in times]


@pytest.mark.experiments
def test_each_set_against_its_faster_classical_option_and_movingai_pooled(tmp_path, capsys):
    script = load_script("experiments/clock_by_set")
    path = _write(tmp_path / "runs.csv", [
        *_runs("maze (shifted)", "uniform", [4, 4, 4]), *_runs("maze (shifted)", "goal_bias=0.1", [2, 2, 2]),
        *_runs("maze (shifted)", "lazy route", [1, 1, 1]),
        *_runs("spiral (unseen)", "uniform", [1, 1, 1]), *_runs("spiral (unseen)", "lazy route", [3, 3, 3]),
        *_runs("den312d", "uniform", [2, 2]), *_runs("den312d", "lazy route", [1, 1]),
        *_runs("room-32-32-4", "uniform", [9, 9], solved=False), *_runs("room-32-32-4", "obstacle-based", [4, 4]),
        *_runs("room-32-32-4", "lazy route", [1, 5]),
        *_runs("forest", "uniform", [1]), *_runs("forest", "lazy route", [50]),  # a generated set: not held apart
        *_runs("maze (shifted) (RRT* cost)", "lazy route", [99]),  # the convergence part's: left out
    ])
    runs = script.read_runs(path, "RRTstar")
    rows = dict(script.ratios(runs, ["lazy route"]))
    assert rows["maze (shifted)"]["lazy route"] == 0.5  # against the tuned goal bias, the faster there
    assert rows["spiral (unseen)"]["lazy route"] == 3.0
    # MovingAI pooled: den312d's uniform and room-32-32-4's obstacle-based sampling (its uniform never solves): 3
    assert rows["MovingAI pooled"]["lazy route"] == pytest.approx(1.0 / 3.0)
    assert "forest" not in rows and len(rows) == 3
    assert script.main([str(path), "--samplers", "lazy route"]) == 0
    assert "lazy route on 2 of 3" in capsys.readouterr().out
    swept = _write(tmp_path / "swept.csv", [*_runs("maze (shifted)", "goal_bias=0.1", [2]),
                                            *_runs("maze (shifted)", "goal_bias=0.2", [3]),
                                            *_runs("maze (shifted)", "lazy route", [1])])
    with pytest.raises(SystemExit, match="2 goal biases"):
        script.ratios(script.read_runs(swept, "RRTstar"), ["lazy route"])
    with pytest.raises(SystemExit):
        script.main([str(path), "--planner", "RRT"])


@pytest.mark.experiments
def test_a_file_that_is_not_a_comparisons_runs_is_refused(tmp_path, capsys):
    script = load_script("experiments/clock_by_set")
    with pytest.raises(SystemExit) as exc:
        script.main([str(tmp_path / "none.csv")])
    assert exc.value.code == 2 and "none.csv" in capsys.readouterr().err
    bad = tmp_path / "bad.csv"
    bad.write_text("a,b\n1,2\n")
    with pytest.raises(SystemExit, match="not a runs.csv"):
        script.main([str(bad)])
