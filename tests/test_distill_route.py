"""scripts/experiments/distill_route.py: a narrower encoder learned from the shipped one, seeded, loadable."""

from __future__ import annotations

import pytest
import torch
from conftest import load_script

from learning.models.route_net import load_route_net

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


def test_the_wall_hinge_asks_a_wall_to_stay_a_wall_and_an_open_move_its_price():
    distill = load_script("experiments/distill_route")
    wall_log = torch.log(torch.full((8,), 32.0))
    target = torch.tensor([[1.0] * 7 + [7.0]])  # the last move a wall of the teacher's (above log 32)
    fitted = target.clone()
    assert distill.move_cost_loss(fitted, target, wall_log) == 0
    fitted[0, 7] = float(wall_log[7]) + 0.8  # above twice the threshold (log 2 = 0.69): its exact price is free
    assert distill.move_cost_loss(fitted, target, wall_log) == 0
    assert distill.move_cost_loss(fitted, target, None) > 0  # the plain fit asks for the price itself
    leaking = fitted.clone()
    leaking[0, 7] = float(wall_log[7]) - 0.5  # priced below the threshold: value iteration would leak through it
    assert distill.move_cost_loss(leaking, target, wall_log) > 0
    off = fitted.clone()
    off[0, 0] += 0.3  # an open move mispriced pays the squared log difference, over every move
    assert distill.move_cost_loss(off, target, wall_log) == pytest.approx(0.3**2 / 8)
