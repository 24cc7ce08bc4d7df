"""A narrower route encoder distilled from a trained one: its walls, its move prices and its cell head.

The route encoder's pass is almost all its local network's convolutions, whose cost grows with the square of their
width. A student of the same design (``RouteVIN``) with fewer channels learns, on the training families (training
seeds only), the teacher's answers on each map:

- the log price of every move out of every block with a free cell; where the teacher makes a move a wall at
  inference (priced above ``wall_cost`` blocks per block of length), only that it is a wall, by a margin of twice
  the threshold (``move_cost_loss``): a wall's exact price changes no route, and fitting it took the capacity that
  the moves a route takes need;
- its cell head's output given the teacher's block values (inference's values: the wall rules applied), on every
  free cell the goal reaches.

Each map is turned by one of the square's 8 symmetries. Adam, its rate falling to 0 along a cosine; one torch
thread; seeded. ``scripts/distill_route.py`` is the command line; the shipped encoder is made by it (see
``learning/data/README.md``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass

import numpy as np
import torch
from torch import nn

from learning.models.field import route_input, symmetry
from learning.models.route_vin import UNREACHED, RouteVIN
from planners.maps.generators import TRAIN_SEEDS, TRAINING_FAMILIES, generate


@dataclass(frozen=True)
class DistillConfig:
    """A distillation's recipe (the shipped student's by default)."""

    #: The student's local network width (the teacher's depth, blocks and step).
    channels: int = 16
    #: Training maps per family and side.
    maps: int = 150
    sizes: tuple[int, ...] = (32, 64, 128, 256)
    epochs: int = 24
    batch: int = 16
    lr: float = 2e-3
    seed: int = 0
    #: Learn the teacher's walls as walls (``move_cost_loss``); False: every move's price.
    walls: bool = True

    def record(self) -> dict:
        return {**asdict(self), "sizes": list(self.sizes)}


def teacher_targets(teacher: RouteVIN, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """(log move costs (B, 8, h, w), inference block values (B, h, w), cell field (B, H, W)) of the teacher."""
    with torch.no_grad():
        goal, walls = teacher.goal_and_walls(x)
        f, costs = teacher.move_costs(x)
        v = teacher.inference_values(x, costs, goal, walls)
        return torch.log(costs), v, teacher.cell_field(f, v)


def move_cost_loss(pred: torch.Tensor, target: torch.Tensor, wall_log: torch.Tensor | None) -> torch.Tensor:
    """The student's loss on its log move costs ``pred`` against the teacher's ``target`` (N, 8), in ``MOVES`` order.

    With ``wall_log`` (8,), the log price above which inference makes each move a wall: where the teacher's move is
    a wall, only a squared hinge below twice that price (a wall by a margin; its exact price is free), elsewhere the
    squared log difference. Without it, the squared log difference everywhere.
    """
    if wall_log is None:
        return nn.functional.mse_loss(pred, target)
    walled = target > wall_log
    return torch.where(walled, nn.functional.relu(wall_log + math.log(2.0) - pred), pred - target).square().mean()


def distill_route_net(teacher: RouteVIN, config: DistillConfig = DistillConfig(),
                      log: Callable[[str], None] = print, student: RouteVIN | None = None) -> RouteVIN:
    """A ``RouteVIN`` of ``config.channels`` learned from ``teacher`` (see the module docstring), in evaluation mode.

    One torch thread for the run (the caller's setting is restored); ``log`` gets one line when the maps and
    targets are made and one per epoch. The same config and teacher on the same arithmetic give the same weights.
    ``student``: start from these weights instead of ``config.seed``'s initial ones (trained in place).
    """
    if not isinstance(teacher, RouteVIN):
        raise TypeError(f"the teacher is a {type(teacher).__name__}; distillation learns a RouteVIN's move costs")
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        return _distill(teacher.eval(), config, log, student)
    finally:
        torch.set_num_threads(threads)


def _distill(teacher: RouteVIN, config: DistillConfig, log: Callable[[str], None],
             student: RouteVIN | None) -> RouteVIN:
    torch.manual_seed(config.seed)
    rng = np.random.default_rng(config.seed)
    if student is None:
        student = RouteVIN(teacher.block, config.channels, teacher.depth, teacher.step)
    elif (student.block, student.depth, student.step) != (teacher.block, teacher.depth, teacher.step):
        raise ValueError(f"a student of blocks {student.block}, depth {student.depth}, step {student.step} cannot "
                         f"learn a teacher of {teacher.block}, {teacher.depth}, {teacher.step}")
    cells = teacher.block * teacher.block
    t0 = time.perf_counter()
    data: dict[int, list] = {}  # by side: (input, log costs, values, cell field, moves to learn, cells to learn)
    for size in config.sizes:
        for family in TRAINING_FAMILIES:
            for _ in range(config.maps):
                p = generate(family, TRAIN_SEEDS[0] + rng.integers(TRAIN_SEEDS[1] - TRAIN_SEEDS[0]), size)
                obs, goal = symmetry(np.asarray(p.world.obstacles), p.world.cell_of(p.goal), int(rng.integers(8)))
                x = torch.from_numpy(route_input(obs, goal, teacher.block)[None, :cells + 1])
                log_c, v, field = teacher_targets(teacher, x)
                _, walls = teacher.goal_and_walls(x)
                free = torch.from_numpy(~obs)[None] & (field < UNREACHED / 2)
                data.setdefault(size, []).append((x, log_c, v, field, ~walls, free))
    log(f"{sum(map(len, data.values()))} maps and the teacher's targets in {time.perf_counter() - t0:.0f} s")
    wall_log = torch.log(teacher.wall_cost * teacher.lengths.view(-1)) if config.walls else None
    opt = torch.optim.Adam(student.parameters(), lr=config.lr)
    steps = config.epochs * sum(math.ceil(len(v) / config.batch) for v in data.values())
    sched = torch.optim.lr_scheduler.LambdaLR(opt, lambda k: 0.5 * (1 + math.cos(math.pi * min(k, steps) / steps)))
    for epoch in range(config.epochs):
        total, n = 0.0, 0
        batches = [(size, idx[k:k + config.batch]) for size, rows in data.items()
                   for idx in [rng.permutation(len(rows))] for k in range(0, len(rows), config.batch)]
        for b in rng.permutation(len(batches)):
            size, idx = batches[b]
            x, log_c, v, field, moving, free = (torch.cat(t) for t in zip(*(data[size][i] for i in idx), strict=True))
            f, costs = student.move_costs(x)
            cost_loss = move_cost_loss(torch.log(costs).permute(0, 2, 3, 1)[moving],
                                       log_c.permute(0, 2, 3, 1)[moving], wall_log)
            cell_loss = nn.functional.smooth_l1_loss(student.cell_field(f, v)[free], field[free])
            loss = cost_loss + cell_loss
            opt.zero_grad()
            loss.backward()
            opt.step()
            sched.step()
            total, n = total + loss.item(), n + 1
        log(f"epoch {epoch}: loss {total / n:.4f} ({time.perf_counter() - t0:.0f} s)")
    return student.eval()
