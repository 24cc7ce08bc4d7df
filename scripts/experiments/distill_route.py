"""A narrower route encoder distilled from the shipped one: its move costs and cell head, learned from the teacher.

    python scripts/experiments/distill_route.py --out runs/d16/route.pt                # 16 channels
    python scripts/experiments/distill_route.py --maps 150 --sizes 32 64 128 256 --epochs 24 --wall-hinge \
        --out runs/d16h/route.pt                                                        # the report's second student
    python scripts/experiments/vin_validation.py --route runs/d16/route.pt             # then judge it

The shipped encoder's time per query is its four 48-channel convolutions. A student of the same design with
fewer channels (``--channels``) learns, on the recipe's training families (training seeds only), the teacher's
log move costs of every move out of every block with a free cell, and its cell head's output given the
teacher's block values (inference's values: the wall rules applied) on every free cell. Each map is turned by one
of the square's 8 symmetries. Adam, its rate falling to 0 along a cosine; one torch thread; seeded (the machine's
own instruction set: the report's students were trained on an AVX-512 CPU). ``--wall-hinge`` learns the teacher's
wall decisions rather than their prices (``move_cost_loss``).
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np
import torch
from torch import nn

from learning.models.field import route_input, symmetry
from learning.models.route_net import load_route_net, save_route_net
from learning.models.route_vin import UNREACHED, RouteVIN
from learning.models.shipped import SHIPPED_ROUTE
from planners.base.fileio import check_int_flags, check_output_place
from planners.maps.generators import TRAIN_SEEDS, TRAINING_FAMILIES, generate


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


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--teacher", type=Path, default=SHIPPED_ROUTE)
    ap.add_argument("--channels", type=int, default=16)
    ap.add_argument("--maps", type=int, default=60, help="training maps per family and side")
    ap.add_argument("--sizes", type=int, nargs="+", default=[64, 128])
    ap.add_argument("--epochs", type=int, default=10)
    ap.add_argument("--batch", type=int, default=16)
    ap.add_argument("--lr", type=float, default=2e-3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--wall-hinge", action="store_true",
                    help="a move the teacher walls at inference (priced above wall_cost x its length) costs the student "
                         "only a squared hinge below twice that price in log terms: the wall decision, not the price")
    ap.add_argument("--out", type=Path, default=Path("runs/distilled/route.pt"))
    args = ap.parse_args(argv)
    check_int_flags(args, ("channels", "maps", "epochs", "batch"))
    check_output_place(args.out, "--out", folder=False)
    torch.set_num_threads(1)
    torch.manual_seed(args.seed)
    rng = np.random.default_rng(args.seed)
    teacher = load_route_net(args.teacher)
    student = RouteVIN(teacher.block, args.channels, teacher.depth, teacher.step)
    cells = teacher.block * teacher.block
    t0 = time.perf_counter()
    data: dict[int, list] = {}  # by side: (input, log costs, values, cell field, moves to learn, cells to learn)
    for size in args.sizes:
        for family in TRAINING_FAMILIES:
            for _ in range(args.maps):
                p = generate(family, TRAIN_SEEDS[0] + rng.integers(TRAIN_SEEDS[1] - TRAIN_SEEDS[0]), size)
                obs, goal = symmetry(np.asarray(p.world.obstacles), p.world.cell_of(p.goal), int(rng.integers(8)))
                x = torch.from_numpy(route_input(obs, goal, teacher.block)[None, :cells + 1])
                log_c, v, field = teacher_targets(teacher, x)
                _, walls = teacher.goal_and_walls(x)
                free = torch.from_numpy(~obs)[None] & (field < UNREACHED / 2)
                data.setdefault(size, []).append((x, log_c, v, field, ~walls, free))
    print(f"{sum(map(len, data.values()))} maps and the teacher's targets in {time.perf_counter() - t0:.0f} s",
          flush=True)
    wall_log = torch.log(teacher.wall_cost * teacher.lengths.view(-1))  # the inference wall threshold, per move
    opt = torch.optim.Adam(student.parameters(), lr=args.lr)
    steps = args.epochs * sum(math.ceil(len(v) / args.batch) for v in data.values())
    sched = torch.optim.lr_scheduler.LambdaLR(opt, lambda k: 0.5 * (1 + math.cos(math.pi * min(k, steps) / steps)))
    for epoch in range(args.epochs):
        total, n = 0.0, 0
        batches = [(size, idx[k:k + args.batch]) for size, rows in data.items()
                   for idx in [rng.permutation(len(rows))] for k in range(0, len(rows), args.batch)]
        for b in rng.permutation(len(batches)):
            size, idx = batches[b]
            x, log_c, v, field, moving, free = (torch.cat(t) for t in zip(*(data[size][i] for i in idx), strict=True))
            f, costs = student.move_costs(x)
            cost_loss = move_cost_loss(torch.log(costs).permute(0, 2, 3, 1)[moving],
                                       log_c.permute(0, 2, 3, 1)[moving], wall_log if args.wall_hinge else None)
            cell_loss = nn.functional.smooth_l1_loss(student.cell_field(f, v)[free], field[free])
            loss = cost_loss + cell_loss
            opt.zero_grad()
            loss.backward()
            opt.step()
            sched.step()
            total, n = total + float(loss), n + 1
        print(f"epoch {epoch}: loss {total / n:.4f} ({time.perf_counter() - t0:.0f} s)", flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    save_route_net(student.eval(), args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
