"""scripts/experiments/distill_route.py: the report's distilled students as they were made, seeded, loadable."""

from __future__ import annotations

import pytest
import torch
from conftest import load_script

from learning.models.route_net import load_route_net
from learning.models.shipped import SHIPPED_ROUTE_TEACHER

pytestmark = pytest.mark.experiments


@pytest.mark.parametrize("hinge", [[], ["--wall-hinge"]])
def test_a_distilled_encoder_is_seeded_loads_and_fits_its_teacher_better_than_at_the_start(tmp_path, capsys, hinge):
    distill = load_script("experiments/distill_route")
    flags = ["--channels", "4", "--maps", "1", "--sizes", "32", "--epochs", "3", "--batch", "4", *hinge]
    assert distill.main([*flags, "--out", str(tmp_path / "a.pt")]) == 0
    losses = [float(line.split("loss ")[1].split()[0]) for line in capsys.readouterr().out.splitlines()
              if line.startswith("epoch")]
    assert len(losses) == 3 and losses[-1] < losses[0]
    assert distill.main([*flags, "--out", str(tmp_path / "b.pt")]) == 0
    a, b = load_route_net(tmp_path / "a.pt"), load_route_net(tmp_path / "b.pt")
    assert a.channels == 4 and (a.block, a.step) == (2, 4)
    assert all(torch.equal(x, y) for x, y in zip(a.state_dict().values(), b.state_dict().values(), strict=True))
    assert load_route_net(SHIPPED_ROUTE_TEACHER).channels == 48  # its default teacher
