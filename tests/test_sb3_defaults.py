"""``learning.sb3_defaults``: the comparison behind docs/first-steps.md's table, on a tiny budget."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from learning.sb3_defaults import BATCH_GRID, BIAS_GRID, choose_batch, compare, family_id
from planners.base.fileio import InputError


def test_family_ids():
    assert family_id("forest") == "SamplerGym/RRT-Forest-v2"
    assert family_id("narrow_passage") == "SamplerGym/RRT-NarrowPassage-v2"
    with pytest.raises(InputError, match="lake"):
        family_id("lake")


@settings(max_examples=50, deadline=None)
@given(st.lists(st.lists(st.floats(1, 2000), min_size=len(BATCH_GRID), max_size=len(BATCH_GRID)),
                min_size=1, max_size=4))
def test_the_chosen_batch_stays_within_a_tenth_of_deciding_every_sample(medians):
    per_model = [{b: (m, 1.0) for b, m in zip(BATCH_GRID, model, strict=True)} for model in medians]
    chosen = choose_batch(per_model)
    pooled = {b: sum(m[b][0] for m in per_model) / len(per_model) for b in BATCH_GRID}
    assert pooled[chosen] <= 1.1 * pooled[1]
    assert all(pooled[b] > 1.1 * pooled[1] for b in BATCH_GRID if b > chosen)


def test_compare_tunes_goal_bias_and_adds_the_untrained_ablation():
    rows = compare("forest", [], n_test=1, n_tune=1, seeds=1)
    assert [r["sampler"].split()[0] for r in rows] == ["goal", "PPO"]
    assert float(rows[0]["sampler"].split()[2]) in BIAS_GRID
    assert rows[1]["wins"] in ("0/1", "1/1") and 0 <= rows[1]["success"] <= 1
