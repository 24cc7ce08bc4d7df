"""``scripts/experiments/encoder_rule.py``: a candidate encoder's held-apart rule, with what its bound can tell."""

from __future__ import annotations

import csv

import pytest
from conftest import load_script

pytestmark = pytest.mark.experiments
FIELDS = ["map", "query", "split", "planner", "sampler", "seed", "solved", "iterations"]


def _write(path, sets):
    """``sets``: {name: [(shipped iterations, candidate iterations, candidate solved), ...]} (one run a query)."""
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, FIELDS)
        w.writeheader()
        for name, runs in sets.items():
            for q, (a, b, solved) in enumerate(runs):
                for sampler, it, ok in (("route encoder", a, True), ("mine", b, solved)):
                    w.writerow({"map": name, "query": f"q{q}", "split": "test", "planner": "RRT", "sampler": sampler,
                                "seed": 0, "solved": str(ok), "iterations": it})
                w.writerow({"map": name, "query": f"q{q}", "split": "tuning", "planner": "RRT",
                            "sampler": "mine", "seed": 0, "solved": "True", "iterations": 10**6})  # not a test run
    return path


def test_an_even_candidate_holds_and_a_worse_one_fails_naming_the_set(tmp_path, capsys):
    script = load_script("experiments/encoder_rule")
    even = {"a": [(10 + i, 10 + i, True) for i in range(20)], "b": [(50, 50, True)] * 20}
    assert script.main([str(_write(tmp_path / "even.csv", even)), "--candidate", "mine", "--resamples", "50"]) == 0
    out = capsys.readouterr().out
    assert "geometric mean 1.000: the rule holds" in out and "| a | 20 | 19.5 | 19.5 | 1.00 |" in out
    worse = {**even, "b": [(50, 70, True)] * 20}
    script.main([str(_write(tmp_path / "worse.csv", worse)), "--candidate", "mine", "--resamples", "50"])
    assert "the rule fails (geometric mean 1.183 > 1.05; b: 1.40 > 1.25)" in capsys.readouterr().out
    fewer = {**even, "b": [(50, 50, i >= 2) for i in range(20)]}
    script.main([str(_write(tmp_path / "fewer.csv", fewer)), "--candidate", "mine", "--resamples", "50"])
    assert "b: solved 18 against 20" in capsys.readouterr().out


def test_the_shipped_encoder_against_itself_shows_where_the_bound_cannot_tell(tmp_path):
    script = load_script("experiments/encoder_rule")
    steady = [(100, 100, True)] * 30  # every run the same: a resample never moves the median
    spread = [(10 * (1 + i % 7) ** 2, 100, True) for i in range(30)]  # a wide spread of iterations
    pairs = script.paired_runs(_write(tmp_path / "r.csv", {"steady": steady, "spread": spread}), "mine")
    rows = {r["set"]: r for r in script.set_rows(pairs, 1.25, 400, seed=0)}
    assert rows["steady"]["self_above"] == 0 and rows["steady"]["interval"] == (1.0, 1.0)
    assert rows["spread"]["self_above"] > 0.1
    again = {r["set"]: r for r in script.set_rows(pairs, 1.25, 400, seed=0)}
    assert again == rows  # seeded


def test_bad_input_is_refused_by_name(tmp_path, capsys):
    script = load_script("experiments/encoder_rule")
    with pytest.raises(SystemExit) as exc:
        script.main([str(tmp_path / "missing.csv"), "--candidate", "mine"])
    assert exc.value.code == 2 and "missing.csv: not a file" in capsys.readouterr().err
    path = _write(tmp_path / "r.csv", {"a": [(10, 10, True)]})
    with pytest.raises(SystemExit):
        script.main([str(path), "--candidate", "other"])
    assert "no test runs of RRT with both 'route encoder' and 'other'" in capsys.readouterr().err


def test_with_unclear_a_set_above_the_bound_passes_only_where_its_interval_holds_one(tmp_path, capsys):
    script = load_script("experiments/encoder_rule")
    noisy = [(10 * (1 + i % 7) ** 2, 13 * (1 + (i + 3) % 7) ** 2, True) for i in range(30)]  # wide, overlapping
    clear = [(50, 70, True)] * 30  # every run 1.4 times the shipped one's
    for name, runs, holds in (("noisy", noisy, True), ("clear", clear, False)):
        path = _write(tmp_path / f"{name}.csv", {"a": [(40, 40, True)] * 30, name: runs})
        rows = script.set_rows(script.paired_runs(path, "mine"), 1.25, 400, seed=0)
        row = next(r for r in rows if r["set"] == name)
        assert row["ratio"] > 1.25
        assert script.verdict(rows, 1.5, 1.25, unclear=True)[0] is holds
        assert script.verdict(rows, 1.5, 1.25)[0] is False
