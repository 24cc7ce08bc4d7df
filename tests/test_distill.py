"""Distilling the route encoder (``learning.training.distill``, ``scripts/distill_route.py``): seeded, whole, refused
by name where the input is wrong; the loss that learns the teacher's walls as walls."""

from __future__ import annotations

import json

import pytest
import torch
from conftest import load_script

from learning.models.route_net import load_route_net, make_route_net, save_route_net
from learning.models.shipped import SHIPPED_ROUTE, SHIPPED_ROUTE_TEACHER
from learning.training.distill import DistillConfig, distill_route_net, move_cost_loss

TINY = ["--channels", "4", "--maps", "1", "--sizes", "32", "--epochs", "2", "--batch", "4"]


def test_the_wall_loss_asks_a_wall_to_stay_a_wall_and_an_open_move_its_price():
    wall_log = torch.log(torch.full((8,), 32.0))
    target = torch.tensor([[1.0] * 7 + [7.0]])  # the last move a wall of the teacher's (above log 32)
    fitted = target.clone()
    assert move_cost_loss(fitted, target, wall_log) == 0
    fitted[0, 7] = float(wall_log[7]) + 0.8  # above twice the threshold (log 2 = 0.69): its exact price is free
    assert move_cost_loss(fitted, target, wall_log) == 0
    assert move_cost_loss(fitted, target, None) > 0  # fitting prices asks for the price itself
    leaking = fitted.clone()
    leaking[0, 7] = float(wall_log[7]) - 0.5  # priced below the threshold: value iteration would leak through it
    assert move_cost_loss(leaking, target, wall_log) > 0
    off = fitted.clone()
    off[0, 0] += 0.3  # an open move mispriced pays the squared log difference, over every move
    assert move_cost_loss(off, target, wall_log) == pytest.approx(0.3**2 / 8)


def test_the_library_gives_the_same_student_for_the_same_recipe_and_restores_threads():
    teacher = load_route_net(SHIPPED_ROUTE_TEACHER)
    config = DistillConfig(channels=4, maps=1, sizes=(32,), epochs=2, batch=4)
    threads = torch.get_num_threads()
    lines: list[str] = []
    a = distill_route_net(teacher, config, lines.append)
    b = distill_route_net(teacher, config, lambda line: None)
    assert torch.get_num_threads() == threads
    assert all(torch.equal(x, y) for x, y in zip(a.state_dict().values(), b.state_dict().values(), strict=True))
    assert (a.channels, a.block, a.depth, a.step) == (4, teacher.block, teacher.depth, teacher.step)
    assert len(lines) == 3 and lines[-1].startswith("epoch 1: loss")
    other = distill_route_net(teacher, DistillConfig(channels=4, maps=1, sizes=(32,), epochs=2, batch=4, seed=1),
                              lambda line: None)
    assert not torch.equal(a.local[0].weight, other.local[0].weight)


def test_the_shipped_encoder_is_its_teachers_student():
    teacher, student = load_route_net(SHIPPED_ROUTE_TEACHER), load_route_net(SHIPPED_ROUTE)
    record = json.loads(SHIPPED_ROUTE.with_suffix(".json").read_text())
    assert (student.block, student.depth, student.step) == (teacher.block, teacher.depth, teacher.step)
    assert student.channels == record["recipe"]["channels"] < teacher.channels
    import hashlib

    assert record["teacher"]["sha256"] == hashlib.sha256(SHIPPED_ROUTE_TEACHER.read_bytes()).hexdigest()
    assert record["cpu_arithmetic"]["ATEN_CPU_CAPABILITY"] == "avx2"
    script = load_script("distill_route")
    defaults = vars(script._parser().parse_args([]))
    for key in ("channels", "maps", "epochs", "batch", "lr", "seed"):
        assert defaults[key] == record["recipe"][key], key
    assert defaults["sizes"] == record["recipe"]["sizes"] and defaults["prices"] is not record["recipe"]["walls"]


def test_the_command_writes_the_pair_whole_and_the_same_twice(tmp_path, capsys):
    script = load_script("distill_route")
    assert script.main([*TINY, "--out", str(tmp_path / "a"), "--export", str(tmp_path / "x" / "mine.pt")]) == 0
    assert script.main([*TINY, "--out", str(tmp_path / "b")]) == 0
    a, b = load_route_net(tmp_path / "a" / "route.pt"), load_route_net(tmp_path / "b" / "route.pt")
    assert all(torch.equal(x, y) for x, y in zip(a.state_dict().values(), b.state_dict().values(), strict=True))
    record = json.loads((tmp_path / "a" / "route.json").read_text())
    assert record["recipe"]["channels"] == 4 and record["teacher"]["file"] == SHIPPED_ROUTE_TEACHER.name
    assert (tmp_path / "x" / "mine.pt").read_bytes() == (tmp_path / "a" / "route.pt").read_bytes()
    assert json.loads((tmp_path / "x" / "mine.json").read_text()) == record
    assert "wrote" in capsys.readouterr().out


@pytest.mark.parametrize("flags, named", [
    (["--sizes", "4"], "--sizes"), (["--epochs", "0"], "--epochs"), (["--lr", "0"], "--lr 0"),
    (["--teacher", "MISSING"], "MISSING"),
])
def test_bad_input_is_refused_by_name_before_any_work(tmp_path, capsys, flags, named):
    script = load_script("distill_route")
    if flags[-1] == "MISSING":
        flags = ["--teacher", str(tmp_path / "none.pt")]
        named = "none.pt"
    assert script.main([*TINY, *flags, "--out", str(tmp_path / "out")]) == 2
    assert named in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_a_unet_teacher_is_refused(tmp_path, capsys):
    unet = tmp_path / "unet.pt"
    save_route_net(make_route_net("unet", block=4, channels=4, depth=1), unet)
    script = load_script("distill_route")
    assert script.main([*TINY, "--teacher", str(unet), "--out", str(tmp_path / "out")]) == 2
    assert "a RouteNet file; distillation learns a value-iteration encoder" in capsys.readouterr().err


def test_an_interrupted_run_writes_nothing(tmp_path, capsys, monkeypatch):
    script = load_script("distill_route")

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(script, "distill_route_net", interrupted)
    assert script.main([*TINY, "--out", str(tmp_path / "out")]) == 130
    assert "nothing was written" in capsys.readouterr().err and not (tmp_path / "out").exists()
