"""Sweeps on Ray Tune (issue 17.4): trials scored on validation maps, logged to TensorBoard, resumable."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from conftest import load_script  # noqa: E402

from learning.training.policy import TrainConfig  # noqa: E402
from learning.training.sweep import BASELINE_GRID, baseline_score  # noqa: E402
from planners import RRT, GoalBiasedSampler  # noqa: E402
from planners.maps.generators import VALIDATION_SEED0, generate  # noqa: E402


@pytest.mark.slow  # two training trials on Ray Tune
def test_a_recipe_sweep_picks_on_validation_logs_every_trial_and_resumes(tmp_path, ray_backend):
    sweep = load_script("sweep")
    args = ["recipe", "--quick", "--samples", "2", "--out", str(tmp_path)]
    assert sweep.main(args) == 0
    chosen = json.loads((tmp_path / "recipe-sweep.chosen.json").read_text())
    assert chosen["trials"] == 2 and chosen["score"] == min(chosen["scores"])
    assert chosen["picked_on"].startswith("validation maps")
    assert set(chosen["config"]) == set(sweep.QUICK_SPACE)
    trials = sorted(p for p in (tmp_path / "recipe-sweep").iterdir() if p.is_dir() and p.name.startswith("_recipe"))
    assert len(trials) == 2
    for t in trials:  # TensorBoard events and the trial's own training run
        assert list(t.glob("events.out.tfevents.*")), t
        assert (t / "trial" / "final.zip").is_file()
    # resuming a finished sweep reruns nothing (each trial still reported once) and chooses the same
    assert sweep.main([*args, "--resume"]) == 0
    assert json.loads((tmp_path / "recipe-sweep.chosen.json").read_text())["config"] == chosen["config"]
    assert [len((t / "result.json").read_text().splitlines()) for t in trials] == [1, 1]


def test_resume_with_nothing_to_resume_says_so(tmp_path, capsys, ray_backend):
    assert load_script("sweep").main(["baselines", "--quick", "--out", str(tmp_path), "--resume"]) == 2
    assert "nothing to resume in" in capsys.readouterr().err


def test_baseline_score_is_the_validation_metric():
    cfg = TrainConfig(families=("forest", "maze"), sizes=(64,), validation_maps=3)
    score, per_family = baseline_score("goal_bias", 0.1, cfg)
    for f in cfg.families:
        ratios = []
        for i in range(3):
            p = generate(f, VALIDATION_SEED0 + i, 64)
            r = RRT(p, step_size=4.0, sampler=GoalBiasedSampler(0.1), seed=i).solve(max_iterations=20000)
            ratios.append(r.iterations / p.iteration_lower_bound(4.0) if r.solved else 20000.0)
        assert per_family[f] == pytest.approx(np.median(ratios))
    assert score == pytest.approx(np.sqrt(per_family["forest"] * per_family["maze"]))
    assert ("goal_bias", 0.0) in BASELINE_GRID and any(k == "constant" for k, _ in BASELINE_GRID)


@pytest.mark.slow  # three training trials, one killed
def test_an_interrupted_sweep_resumes_and_keeps_its_finished_trials(tmp_path):
    """Ctrl-C in the middle of a sweep, then --resume: every trial ends finished, none run twice."""
    pytest.importorskip("ray", reason="Ray is not installed: pip install -e '.[test-ray]' runs these tests")
    import signal
    import subprocess
    import time

    script = Path(__file__).resolve().parents[1] / "scripts" / "sweep.py"
    # three trials: Tune may let the trial running at Ctrl-C finish, so the third is the one that waits
    args = [sys.executable, str(script), "recipe", "--quick", "--samples", "3", "--processes", "1",
            "--out", str(tmp_path)]
    sweep_dir = tmp_path / "recipe-sweep"

    def finished() -> list[Path]:
        return [p for p in sweep_dir.glob("_recipe*/result.json") if p.stat().st_size > 0] if sweep_dir.is_dir() \
            else []

    proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 240
    while not finished() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.2)
    first = finished()
    assert first, "no trial finished before the deadline"
    proc.send_signal(signal.SIGINT)
    proc.wait(timeout=120)
    assert len(finished()) < 3, "the sweep ended before it could be interrupted"
    first_result = first[0].read_text()
    done = subprocess.run([*args, "--resume"], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    results = finished()
    assert len(results) == 3 and all(len(p.read_text().splitlines()) == 1 for p in results)
    assert first[0].read_text() == first_result  # the trial finished before the interruption was kept
    assert json.loads((tmp_path / "recipe-sweep.chosen.json").read_text())["trials"] == 3
