"""``scripts/experiments/fused_classical.py``: the classical samplers drawn inside the compiled loops plan alike."""

from __future__ import annotations

import pytest
from conftest import load_script

from planners.maps.generators import VALIDATION_SEED0, generate

pytestmark = pytest.mark.experiments


@pytest.mark.parametrize("planner_name", ["RRT", "RRTConnect", "RRTstar"])
def test_the_fused_classical_samplers_make_the_same_runs(planner_name):
    probe = load_script("experiments/fused_classical")
    drawn, fused = {name: (d, f) for name, d, f in probe.SETUPS}[planner_name]
    for family in ("maze", "forest"):
        p = generate(family, VALIDATION_SEED0 + 5, 64, goal_tolerance=4.0)
        for seed in (0, 1, 2):
            assert probe.run(planner_name, p, drawn(), seed)[1] == probe.run(planner_name, p, fused(), seed)[1]


def test_it_refuses_bad_counts():
    probe = load_script("experiments/fused_classical")
    for bad in (["--maps", "0"], ["--seeds", "0"], ["--sets", "nowhere"]):
        with pytest.raises(SystemExit):
            probe.main(bad)
