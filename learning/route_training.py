"""Training the route encoder: the grid search's cost-to-go as targets (training only, never at inference)."""

from __future__ import annotations

import json
import os
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import torch
from torch import nn

from learning.route import RouteNet, route_input, symmetry
from planners.base.fileio import InputError, atomic_path, short_repr
from planners.maps.gridsearch import distance_field


def cost_targets(obstacles: np.ndarray, goal_cell: tuple[int, int], block: int) -> np.ndarray:
    """The grid search's cost-to-go of every cell in steps (``block`` cells), padded to whole blocks.

    NaN where a cell is blocked or cut off from the goal. Training only: inference never searches.
    """
    D = distance_field(obstacles, goal_cell)
    H, W = D.shape
    pad = np.full((-(-H // block) * block, -(-W // block) * block), np.nan)
    pad[:H, :W] = np.where(np.isfinite(D), D / block, np.nan)
    return pad


#: What a route training checkpoint holds besides tensors: the recipe it belongs to and how far it got.
CHECKPOINT_VERSION = 1


def _save_checkpoint(path: Path, net: RouteNet, opt: torch.optim.Optimizer, order: torch.Generator, epoch: int,
                     recipe: dict, log_lines: list[str]) -> None:
    """Commit the state after ``epoch`` (atomically: a unique temporary name, renamed into place)."""
    blob = {"version": CHECKPOINT_VERSION, "epoch": epoch, "recipe": json.dumps(recipe, sort_keys=True),
            "log": list(log_lines), "net": net.state_dict(), "optimizer": opt.state_dict(),
            "order": order.get_state(), "torch_rng": torch.get_rng_state()}
    with atomic_path(path) as tmp:
        torch.save(blob, tmp)


def _load_checkpoint(path: Path, recipe: dict) -> dict:
    """A checkpoint of this recipe (``torch.load(weights_only=True)``: nothing in it can run), checked."""
    try:
        blob = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # noqa: BLE001 - whatever torch raises on a bad file, name the file
        raise InputError(f"{path} is not a route training checkpoint: {type(exc).__name__}: "
                         f"{short_repr(str(exc))}") from None
    keys = {"version", "epoch", "recipe", "log", "net", "optimizer", "order", "torch_rng"}
    if not isinstance(blob, dict) or set(blob) != keys or blob["version"] != CHECKPOINT_VERSION:
        raise InputError(f"{path} is not a route training checkpoint of this version; start again without --resume")
    if blob["recipe"] != json.dumps(recipe, sort_keys=True):
        raise InputError(f"{path} belongs to another recipe ({short_repr(blob['recipe'], 200)}); resume with the "
                         "same options, or start again without --resume")
    if not isinstance(blob["epoch"], int) or blob["epoch"] < 0 or not isinstance(blob["log"], list):
        raise InputError(f"{path}: its epoch or log is damaged; start again without --resume")
    return blob


def train_route_net(problems: Sequence, *, block: int = 4, channels: int = 24, depth: int = 4, attention: int = 0,
                    attention_level: int = 0, epochs: int = 40, batch: int = 32, lr: float = 1e-3,
                    augment: bool = False, seed: int = 0, log=print, checkpoint: str | os.PathLike | None = None,
                    resume: bool = False) -> RouteNet:
    """Fit a ``RouteNet`` to the grid search's cost-to-go on ``problems`` (grid problems; one map size per batch).

    The loss is the smooth-L1 error of the predicted cost-to-go, in steps, over the free cells that reach
    the goal. With ``augment`` every map is first turned by one of the square's 8 symmetries, drawn from
    ``seed``: the generators' fixed orientations (start and goal corners, trap openings) stop being
    something to learn. Same seed, same machine: the same weights.

    With ``checkpoint`` (a file path) the weights, the optimiser and the batch order's generator are
    committed there after every epoch; with ``resume`` a run continues from that file to the same
    weights an uninterrupted run reaches (a checkpoint of another recipe is refused; more ``epochs``
    than the interrupted run asked for continue it further).
    """
    torch.manual_seed(seed)
    turns = np.random.default_rng(seed).integers(0, 8, len(problems)) if augment else np.zeros(len(problems), int)
    by_size: dict[tuple[int, int], list] = {}
    for p, k in zip(problems, turns, strict=True):
        goal = p.world.cell_of(p.goal)
        obs, goal = symmetry(p.world.obstacles, goal, int(k))
        by_size.setdefault(obs.shape, []).append((route_input(obs, goal, block), cost_targets(obs, goal, block)))
    data = [(torch.tensor(np.stack([e[0] for e in v])), None,
             torch.tensor(np.stack([e[1] for e in v]), dtype=torch.float32)) for v in by_size.values()]
    net = RouteNet(block, channels, depth, attention, attention_level,
                   trained_side=max(max(p.world.obstacles.shape) for p in problems))
    opt = torch.optim.Adam(net.parameters(), lr)
    order = torch.Generator().manual_seed(seed)
    recipe = {"block": block, "channels": channels, "depth": depth, "attention": attention,
              "attention_level": attention_level, "batch": batch, "lr": lr, "augment": augment, "seed": seed,
              "maps": [p.name for p in problems]}  # not the epochs: each epoch's weights do not depend on them
    lines: list[str] = []
    first = 0
    if resume and checkpoint is not None and Path(checkpoint).is_file():
        state = _load_checkpoint(Path(checkpoint), recipe)
        try:
            net.load_state_dict(state["net"])
            opt.load_state_dict(state["optimizer"])
            order.set_state(state["order"])
            torch.set_rng_state(state["torch_rng"])
        except (RuntimeError, TypeError, ValueError, KeyError) as exc:
            raise InputError(f"{checkpoint}: its state does not fit this recipe: {short_repr(str(exc))}") from None
        first, lines = state["epoch"], [str(s) for s in state["log"]]
        if first > epochs:
            raise InputError(f"{checkpoint} holds {first} epochs, more than the {epochs} asked for")
        for line in lines:
            log(line)
    t0 = time.perf_counter()
    for epoch in range(first, epochs):
        net.train()
        batches = [(i, idx) for i, (X, _, _) in enumerate(data)
                   for idx in torch.randperm(len(X), generator=order).split(batch)]
        total = 0.0
        for j in torch.randperm(len(batches), generator=order).tolist():
            i, idx = batches[j]
            X, _, Yc = data[i]
            out = net(X[idx])
            yc = Yc[idx]
            known = torch.isfinite(yc)
            loss = nn.functional.smooth_l1_loss(out[known], yc[known])
            opt.zero_grad()
            loss.backward()
            opt.step()
            total += loss.item() * len(idx)
        line = f"epoch {epoch}: loss {total / sum(len(d[0]) for d in data):.3f} ({time.perf_counter() - t0:.0f} s)"
        lines.append(line)
        log(line)
        if checkpoint is not None:
            _save_checkpoint(Path(checkpoint), net, opt, order, epoch + 1, recipe, lines)
    return net.eval()
