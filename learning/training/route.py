"""Training the route encoder: the grid search's cost-to-go as targets (training only, never at inference).

The targets are made on CPU worker processes (``workers``); each depends only on its map, so the
tensors do not depend on how many workers made them. Where every map's size is known beforehand
(``Problem``s, ``GeneratedProblem``s), the first epoch's batches are drawn first and the targets are
made in the order that epoch uses them, while it trains: the encoder (on ``device``, the CPU by
default, a GPU where one is asked for) waits only for the maps of its next batch.
"""

from __future__ import annotations

import json
import math
import multiprocessing
import os
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from torch import nn

from learning.device import deterministic
from learning.models.field import TRAINING_MAX_BLOCKS
from learning.models.route_net import MAX_BLOCKS_ENV, RouteNet, make_route_net, max_blocks, route_input, symmetry
from learning.models.route_vin import UNREACHED, RouteVIN
from learning.training.vin_losses import vin_loss
from planners.base.fileio import InputError, atomic_path, short_repr
from planners.base.problem import Problem
from planners.maps.generators import generate
from planners.maps.gridsearch import distance_field

#: Most blocks one training batch holds (maps x blocks a map): 32 maps of 256 cells at a block of 4.
#: Batches of larger maps hold fewer maps, down to one; the shipped recipe's batches (32 maps of 64
#: and 128 cells) are below it.
MAX_BATCH_BLOCKS = 32 * 64 * 64
#: How Adam's learning rate moves over a run: "constant", or "cosine" (from ``lr`` down to 0 over the run's steps).
SCHEDULES = ("constant", "cosine")


def check_route_map(name: str, shape: tuple[int, int], block: int) -> None:
    """Refuse a training map of more blocks of ``block`` cells than a training pass takes.

    At most ``TRAINING_MAX_BLOCKS`` (a training pass holds the whole map's activations and gradients) and at
    most the planning limit (``learning.models.field.max_blocks``), so an encoder is never trained on maps it
    would refuse to plan on.
    """
    rows, cols = -(-shape[0] // block), -(-shape[1] // block)
    limit = min(max_blocks(), TRAINING_MAX_BLOCKS)
    if rows * cols > limit:
        why = (f"the route encoder takes ({MAX_BLOCKS_ENV})" if limit < TRAINING_MAX_BLOCKS else
               "a training pass takes (it holds the whole map's activations and gradients)")
        raise InputError(f"map {name!r} is {shape[0]} x {shape[1]} cells: {rows} x {cols} = {rows * cols} blocks of "
                         f"{block} cells, more than the {limit} {why}; take a larger step or downsample the map"
                         + (", or raise the limit" if limit < TRAINING_MAX_BLOCKS else ""))


def default_workers() -> int:
    """``min(cores this process may use, 8)``: the default number of target-making processes."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cores = os.cpu_count() or 1
    return max(1, min(cores, 8))


def cost_targets(obstacles: np.ndarray, goal_cell: tuple[int, int], block: int) -> np.ndarray:
    """The grid search's cost-to-go of every cell in steps (``block`` cells), padded to whole blocks.

    NaN where a cell is blocked or cut off from the goal. Training only: inference never searches.
    """
    D = distance_field(obstacles, goal_cell)
    H, W = D.shape
    pad = np.full((-(-H // block) * block, -(-W // block) * block), np.nan)
    pad[:H, :W] = np.where(np.isfinite(D), D / block, np.nan)
    return pad


def _example(task: tuple) -> tuple[str, int, np.ndarray, np.ndarray]:
    """One training example: (problem name, larger map side, encoder input, float32 targets).

    ``task`` is ``(problem, turn, block)``; the problem may be a zero-argument callable that makes
    it (a generated map is then made in the worker, not sent to it).
    """
    problem, k, block = task
    if not isinstance(problem, Problem):
        problem = problem()
    goal = problem.world.cell_of(problem.goal)
    obs, goal = symmetry(problem.world.obstacles, goal, int(k))
    check_route_map(problem.name, obs.shape, block)
    return (problem.name, max(obs.shape), route_input(obs, goal, block),
            cost_targets(obs, goal, block).astype(np.float32))


@dataclass(frozen=True)
class GeneratedProblem:
    """``generate(family, seed, size)`` made where it is called (on a worker), with its size known beforehand."""

    family: str
    seed: int
    size: int

    @property
    def shape(self) -> tuple[int, int]:
        """The map's shape in cells."""
        return (self.size, self.size)

    def __call__(self) -> Problem:
        return generate(self.family, self.seed, self.size)


def _turned_shape(problem: Problem | Callable[[], Problem], k: int) -> tuple[int, int] | None:
    """The map's shape under symmetry ``k`` without making it: a ``Problem``'s, or a callable's ``shape``; else None."""
    shape = problem.world.obstacles.shape if isinstance(problem, Problem) else getattr(problem, "shape", None)
    if shape is None:
        return None
    rows, cols = (int(v) for v in shape)
    return (cols, rows) if (k % 4 % 2 == 1) != (k >= 4) else (rows, cols)


def _pool(workers: int, tasks: int):
    """A pool of ``min(workers, tasks)`` processes forked from a fresh single-threaded server ("forkserver";
    "spawn" where there is none): forking this process itself could copy a lock held by one of its threads
    (torch's, Ray's) and hang, and a child must not inherit a CUDA context.
    """
    methods = multiprocessing.get_all_start_methods()
    ctx = multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")
    return ctx.Pool(min(workers, tasks))


def _chunk(tasks: int, workers: int, most: int = 64) -> int:
    return max(1, min(most, tasks // (4 * workers)))


def make_examples(problems: Sequence[Problem | Callable[[], Problem]], turns: Sequence[int], block: int,
                  workers: int = 1) -> list[tuple[str, int, np.ndarray, np.ndarray]]:
    """``_example`` of every problem under its turn, in the problems' order, on ``workers`` processes.

    Each example depends only on its problem, turn and block, and they come back in order, so the
    result is the same for any number of workers. With more than one, a pool makes them (``_pool``).
    """
    tasks = [(p, int(k), block) for p, k in zip(problems, turns, strict=True)]
    if workers <= 1 or len(tasks) < 2:
        return [_example(t) for t in tasks]
    with _pool(workers, len(tasks)) as pool:
        return list(pool.imap(_example, tasks, chunksize=_chunk(len(tasks), workers)))


def _tensors(examples) -> list[tuple[torch.Tensor, None, torch.Tensor]]:
    """Examples grouped by shape, in order of first appearance: (inputs, None, targets) per shape."""
    by_size: dict[tuple[int, ...], list] = {}
    for _, _, x, y in examples:
        by_size.setdefault(y.shape, []).append((x, y))
    return [(torch.tensor(np.stack([e[0] for e in v])), None,
             torch.tensor(np.stack([e[1] for e in v]), dtype=torch.float32)) for v in by_size.values()]


def _on_device(data: list, device: torch.device) -> list:
    """The example tensors moved to a GPU once, where they take less than half its free memory; else as they are.

    Batches are then cut on the GPU; otherwise each batch is copied there when it is used.
    """
    if device.type != "cuda":
        return data
    need = sum(X.nbytes + Y.nbytes for X, _, Y in data)
    free, _ = torch.cuda.mem_get_info(device)
    if need >= free / 2:
        return data
    return [(X.to(device), None, Y.to(device)) for X, _, Y in data]


def _group_batch(X: torch.Tensor, batch: int) -> int:
    """Maps per batch for a group of maps of one shape: ``batch``, fewer where the maps are large."""
    return max(1, min(batch, MAX_BATCH_BLOCKS // (X.shape[-1] * X.shape[-2])))


def _epoch_batches(data: list, batch: int, order: torch.Generator) -> list[tuple[int, torch.Tensor]]:
    """One epoch's batches in training order, drawn from ``order``: (group, indices into the group) each.

    Only the groups' sizes and shapes are read, so the batches can be drawn before the examples are made.
    """
    batches = [(i, idx) for i, (X, _, _) in enumerate(data)
               for idx in torch.randperm(len(X), generator=order).split(_group_batch(X, batch))]
    return [batches[j] for j in torch.randperm(len(batches), generator=order).tolist()]


class _Stream:
    """The training examples made on a pool while the first epoch trains, in the order it uses them.

    ``data`` holds the groups' tensors (as ``_tensors`` would make them from all the examples), filled
    as the examples come; ``wait(i, idx)`` returns when those of a batch are in. The validation
    examples are made after them on the same pool (``validation()``).
    """

    def __init__(self, tasks: list[tuple], shapes: list[tuple[int, int]], block: int, batch: int,
                 order: torch.Generator, workers: int, validation: list[tuple]) -> None:
        padded = [(-(-r // block) * block, -(-c // block) * block) for r, c in shapes]
        members: dict[tuple[int, int], list[int]] = {}
        for n, shape in enumerate(padded):  # groups in order of first appearance, as _tensors makes them
            members.setdefault(shape, []).append(n)
        self.members = list(members.values())
        self.data = [(torch.empty((len(m), block * block + 3, r // block, c // block), dtype=torch.float32), None,
                      torch.empty((len(m), r, c), dtype=torch.float32)) for (r, c), m in members.items()]
        self.batches = _epoch_batches(self.data, batch, order)
        self.names: list[str | None] = [None] * len(tasks)
        self.sides = [max(shape) for shape in shapes]
        self.planned = padded
        # each example's (group, row) in the order the epoch's batches use them
        self.slots = [(i, int(r)) for i, idx in self.batches for r in idx]
        self.ends = np.cumsum([len(idx) for _, idx in self.batches]).tolist()
        self.made = 0
        self.pool = _pool(workers, len(tasks))
        self.results: Iterator = self.pool.imap(_example, [tasks[self.members[i][r]] for i, r in self.slots],
                                                chunksize=_chunk(len(tasks), workers, 8))
        self.held_out = self.pool.map_async(_example, validation, chunksize=_chunk(len(validation), workers)) \
            if validation else None

    def wait(self, j: int) -> None:
        """Return once the examples of the epoch's ``j``-th batch are in ``data``."""
        while self.made < self.ends[j]:
            i, r = self.slots[self.made]
            n = self.members[i][r]
            name, _, x, y = next(self.results)
            if y.shape != self.planned[n]:
                raise RuntimeError(f"training map {name!r} came out {y.shape} (padded), not the {self.planned[n]} "
                                   "its shape promised")
            X, _, Y = self.data[i]
            X[r] = torch.from_numpy(x)
            Y[r] = torch.from_numpy(y)
            self.names[n] = name
            self.made += 1

    def validation(self) -> list | None:
        """The validation examples' tensors (``_tensors``), once made."""
        return _tensors(self.held_out.get()) if self.held_out is not None else None

    def close(self) -> None:
        """End the pool (once every example is in, or when training stops early)."""
        if self.pool is not None:
            self.pool.terminate()
            self.pool.join()
            self.pool = None


#: What a route training checkpoint holds besides tensors: the recipe it belongs to and how far it got.
CHECKPOINT_VERSION = 1
_CHECKPOINT_KEYS = {"version", "epoch", "recipe", "log", "net", "optimizer", "order", "torch_rng"}


def _save_checkpoint(path: Path, net: RouteNet, opt: torch.optim.Optimizer, order: torch.Generator, epoch: int,
                     recipe: dict, log_lines: list[str], best: dict | None = None) -> None:
    """Commit the state after ``epoch`` (atomically: a unique temporary name, renamed into place).

    ``best`` (runs with validation maps): the epoch, validation loss and weights of the best epoch so far.
    """
    blob = {"version": CHECKPOINT_VERSION, "epoch": epoch, "recipe": json.dumps(recipe, sort_keys=True),
            "log": list(log_lines), "net": net.state_dict(), "optimizer": opt.state_dict(),
            "order": order.get_state(), "torch_rng": torch.get_rng_state()}
    if best is not None:
        blob["best"] = best
    with atomic_path(path) as tmp:
        torch.save(blob, tmp)


def _load_checkpoint(path: Path, recipe: dict) -> dict:
    """A checkpoint of this recipe (``torch.load(weights_only=True)``: nothing in it can run), checked."""
    try:
        blob = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # noqa: BLE001 - whatever torch raises on a bad file, name the file
        raise InputError(f"{path} is not a route training checkpoint: {type(exc).__name__}: "
                         f"{short_repr(str(exc))}") from None
    if not isinstance(blob, dict) or set(blob) - {"best"} != _CHECKPOINT_KEYS or blob["version"] != CHECKPOINT_VERSION:
        raise InputError(f"{path} is not a route training checkpoint of this version; start again without --resume")
    if blob["recipe"] != json.dumps(recipe, sort_keys=True):
        raise InputError(f"{path} belongs to another recipe ({short_repr(blob['recipe'], 200)}); resume with the "
                         "same options, or start again without --resume")
    if not isinstance(blob["epoch"], int) or blob["epoch"] < 0 or not isinstance(blob["log"], list):
        raise InputError(f"{path}: its epoch or log is damaged; start again without --resume")
    best = blob.get("best")
    if best is not None and not (isinstance(best, dict) and isinstance(best.get("epoch"), int)
                                 and isinstance(best.get("loss"), float) and isinstance(best.get("net"), dict)):
        raise InputError(f"{path}: its best epoch is damaged; start again without --resume")
    return blob


def _loss(net: RouteNet | RouteVIN, x: torch.Tensor, cells: torch.Tensor) -> torch.Tensor:
    """The training loss of one batch: a ``RouteNet``'s smooth-L1 error of every reached cell's cost-to-go,
    a ``RouteVIN``'s ``vin_loss``.
    """
    if isinstance(net, RouteVIN):
        return vin_loss(net, x, cells)
    out = net(x)
    known = torch.isfinite(cells)
    return nn.functional.smooth_l1_loss(out[known], cells[known])


@torch.no_grad()
def _validation_loss(net: RouteNet | RouteVIN, data, batch: int, device: torch.device) -> float:
    """Mean smooth-L1 error per map on the validation examples (as the training loss, no turns)."""
    net.eval()
    total, count = 0.0, 0
    for X, _, Yc in data:
        step = _group_batch(X, batch)
        for i in range(0, len(X), step):
            out = net(X[i:i + step].to(device))
            yc = Yc[i:i + step].to(device)
            known = torch.isfinite(yc) & (out < UNREACHED / 2)
            total += nn.functional.smooth_l1_loss(out[known], yc[known]).item() * len(out)
            count += len(out)
    return total / count


#: A run whose last epoch's loss is above this multiple of its lowest epoch's has diverged (``loss_rise``). Of five
#: seeds of the shipped recipe, the two whose loss rose from the sixth epoch ended 1.64 and 1.85 times their lowest
#: and came out 1.14 and 1.42 times the shipped encoder's pooled validation median; the other three fell to the end.
RISE = 1.2


def loss_rise(lines: Sequence[str]) -> tuple[int, float, float] | None:
    """Where a run diverged: (epoch, loss) of its lowest training loss and its last epoch's loss, or None.

    ``lines`` are the run's ``epoch K: loss X`` log lines; a run diverged where its last loss is above ``RISE``
    times its lowest.
    """
    losses = [float(line.split("loss ")[1].split(",")[0].split()[0]) for line in lines
              if line.startswith("epoch ") and "loss " in line]
    if not losses:
        return None
    low = min(range(len(losses)), key=losses.__getitem__)
    return (low, losses[low], losses[-1]) if losses[-1] > RISE * losses[low] else None


def train_route_net(problems: Sequence[Problem | Callable[[], Problem]], *, block: int = 4, channels: int = 24,
                    depth: int = 4, attention: int = 0, attention_level: int = 0, epochs: int = 40, batch: int = 32,
                    lr: float = 1e-3, augment: bool = False, seed: int = 0, log=print,
                    checkpoint: str | os.PathLike | None = None, resume: bool = False,
                    validation: Sequence[Problem] | None = None, recipe_extra: dict | None = None,
                    workers: int = 1, device: str | torch.device = "cpu", kind: str = "unet",
                    schedule: str = "constant", step: int | None = None,
                    grad_clip: float | None = None) -> RouteNet | RouteVIN:
    """Fit a route encoder to the grid search's cost-to-go on ``problems`` (grid problems; one map size per batch).

    ``block``: cells per block side; ``step``: the planner's step in cells, a whole number of blocks (default
    one block; only the value-iteration encoder takes more). The targets are in blocks.
    ``kind``: "unet" (``RouteNet``), whose loss is the smooth-L1 error of the predicted cost-to-go, in steps,
    over the free cells that reach the goal; or "vin" (``RouteVIN``, ``depth`` local layers, no attention),
    whose loss is ``learning.training.vin_losses.vin_loss``. With ``augment`` every map is first turned by one
    of the square's 8 symmetries, drawn from
    ``seed``: the generators' fixed orientations (start and goal corners, trap openings) stop being
    something to learn. Same seed, same machine, same device: the same weights, whatever ``workers``.

    A problem may be given as a zero-argument callable that makes it (on a worker). Batches hold
    ``batch`` maps of one padded shape, fewer where the maps are large (``MAX_BATCH_BLOCKS``); a map
    larger than ``max_blocks()`` blocks a side is refused before training.

    With ``validation`` problems the loss on them (unturned) is measured after every epoch, logged,
    and the weights of the epoch with the lowest validation loss are returned (``net.chosen_epoch``).
    Without, the last epoch's. ``recipe_extra`` joins the recipe a checkpoint must match (what the
    problems were drawn from). ``schedule``: Adam's learning rate stays ``lr`` ("constant") or falls from
    ``lr`` to 0 along half a cosine over the run's steps ("cosine"; then ``epochs`` is part of the recipe, as
    every step's rate depends on it). ``grad_clip``: the gradients' total norm is cut to this before each step
    (``torch.nn.utils.clip_grad_norm_``; None: never, as the shipped recipe). ``device``: where the encoder
    trains; the targets are made on ``workers`` CPU processes (``make_examples``). With more than one worker,
    and the size of every map known beforehand (``Problem``s, or callables with a ``shape`` such as
    ``GeneratedProblem``), they are made while the first epoch trains, in the order its batches (drawn first)
    use them; the validation targets follow on the same processes. Else all are made before it.

    With ``checkpoint`` (a file path) the weights, the optimiser and the batch order's generator are
    committed there after every epoch; with ``resume`` a run continues from that file to the same
    weights an uninterrupted run reaches (a checkpoint of another recipe is refused; more ``epochs``
    than the interrupted run asked for continue it further).
    """
    if schedule not in SCHEDULES:
        raise InputError(f"schedule {short_repr(schedule)}: expected one of {', '.join(SCHEDULES)}")
    if grad_clip is not None and (isinstance(grad_clip, bool) or not isinstance(grad_clip, int | float)
                                  or not 0 < grad_clip < math.inf):
        raise InputError(f"grad_clip {short_repr(grad_clip)}: expected a positive finite norm, or None")
    try:  # the encoder's shape is refused now, before any map is made
        make_route_net(kind, block, channels, depth, attention, attention_level, 0, step)
    except ValueError as exc:
        raise InputError(str(exc)) from None
    device = torch.device(device)
    torch.manual_seed(seed)
    turns = np.random.default_rng(seed).integers(0, 8, len(problems)) if augment else np.zeros(len(problems), int)
    tasks = [(p, int(k), block) for p, k in zip(problems, turns, strict=True)]
    held_tasks = [(p, 0, block) for p in validation or ()]
    shapes = [_turned_shape(p, k) for p, k, _ in tasks]
    order = torch.Generator().manual_seed(seed)
    resuming = resume and checkpoint is not None and Path(checkpoint).is_file()
    stream = None
    if workers > 1 and len(tasks) > 1 and not resuming and None not in shapes:
        for (p, _, _), shape in zip(tasks, shapes, strict=True):  # what _example checks, before any work
            check_route_map(getattr(p, "name", str(p)), shape, block)
        # the first epoch's batches are drawn now (from ``order``, as the loop below would): the targets are
        # made in the order it uses them while it trains
        stream = _Stream(tasks, shapes, block, batch, order, workers, held_tasks)
        data, held_out, names, trained_side = stream.data, None, None, max(max(shape) for shape in shapes)
    else:
        examples = make_examples(problems, turns, block, workers)
        names = [e[0] for e in examples]
        trained_side = max(e[1] for e in examples)
        data = _tensors(examples)
        del examples
        held_out = _tensors(make_examples(validation, [0] * len(validation), block, workers)) if validation else None
    try:
        return _train(data, held_out, stream, names, trained_side, order, device, kind=kind,
                      block=block, channels=channels, depth=depth, attention=attention,
                      attention_level=attention_level, epochs=epochs, batch=batch, lr=lr, augment=augment, seed=seed,
                      log=log, checkpoint=checkpoint, resuming=resuming, validation=validation,
                      recipe_extra=recipe_extra, schedule=schedule, step=step, grad_clip=grad_clip)
    finally:
        if stream is not None:
            stream.close()


def _train(data: list, held_out: list | None, stream: _Stream | None, names: list[str] | None, trained_side: int,
           order: torch.Generator, device: torch.device, *, kind: str, block: int, channels: int, depth: int,
           attention: int, attention_level: int, epochs: int, batch: int, lr: float, augment: bool, seed: int, log,
           checkpoint, resuming: bool, validation, recipe_extra: dict | None, schedule: str,
           step: int | None, grad_clip: float | None) -> RouteNet | RouteVIN:
    """``train_route_net``'s epochs, on the examples made (``data``) or being made (``stream``)."""
    deterministic(device)
    if stream is None:
        data = _on_device(data, device)
        held_out = _on_device(held_out, device) if held_out is not None else None
    net = make_route_net(kind, block, channels, depth, attention, attention_level, trained_side, step).to(device)
    opt = torch.optim.Adam(net.parameters(), lr)

    def recipe_of(maps: list[str]) -> dict:
        recipe = {"block": block, "channels": channels, "depth": depth, "attention": attention,
                  "attention_level": attention_level, "batch": batch, "lr": lr, "augment": augment, "seed": seed,
                  "maps": maps}  # not the epochs: each epoch's weights do not depend on them
        if kind != "unet":  # recipes of the U-Net stay as they were
            recipe["kind"] = kind
        if step is not None and step != block:  # as do those of one-step blocks
            recipe["step"] = step
        if schedule != "constant":  # as are those at a constant rate
            recipe["schedule"], recipe["epochs"] = schedule, epochs
        if grad_clip is not None:  # and those without a cut
            recipe["grad_clip"] = grad_clip
        if validation:
            recipe["validation"] = [p.name for p in validation]
        if recipe_extra:
            recipe.update(recipe_extra)
        return recipe

    recipe = recipe_of(names) if names is not None else None
    lines: list[str] = []
    best: dict | None = None
    first = 0
    if resuming:
        state = _load_checkpoint(Path(checkpoint), recipe)
        try:
            net.load_state_dict(state["net"])
            opt.load_state_dict(state["optimizer"])
            order.set_state(state["order"])
            torch.set_rng_state(state["torch_rng"])
        except (RuntimeError, TypeError, ValueError, KeyError) as exc:
            raise InputError(f"{checkpoint}: its state does not fit this recipe: {short_repr(str(exc))}") from None
        first, lines, best = state["epoch"], [str(s) for s in state["log"]], state.get("best")
        if first > epochs:
            raise InputError(f"{checkpoint} holds {first} epochs, more than the {epochs} asked for")
        for line in lines:
            log(line)
    t0 = time.perf_counter()
    for epoch in range(first, epochs):
        net.train()
        streaming = stream is not None and epoch == 0
        batches = stream.batches if streaming else _epoch_batches(data, batch, order)
        total = 0.0
        for j, (i, idx) in enumerate(batches):
            if streaming:
                stream.wait(j)
            X, _, Yc = data[i]
            loss = _loss(net, X[idx].to(device), Yc[idx].to(device))
            opt.zero_grad()
            loss.backward()
            if schedule == "cosine":  # every epoch has as many batches: the step's place in the run is known
                done = (epoch * len(batches) + j) / (epochs * len(batches))
                for group in opt.param_groups:
                    group["lr"] = lr * 0.5 * (1 + math.cos(math.pi * done))
            if grad_clip is not None:
                torch.nn.utils.clip_grad_norm_(net.parameters(), grad_clip)
            opt.step()
            total += loss.item() * len(idx)
        if streaming:  # every example is in now: the tensors as _tensors would have made them
            recipe = recipe_of(stream.names)
            held_out = _on_device(stream.validation(), device) if validation else None
            data = _on_device(data, device)
            stream.close()
        line = f"epoch {epoch}: loss {total / sum(len(d[0]) for d in data):.3f}"
        if held_out is not None:
            score = _validation_loss(net, held_out, batch, device)
            line += f", validation {score:.3f}"
            if best is None or score < best["loss"]:
                best = {"epoch": epoch, "loss": score,
                        "net": {k: v.detach().cpu().clone() for k, v in net.state_dict().items()}}
        line += f" ({time.perf_counter() - t0:.0f} s)"
        lines.append(line)
        log(line)
        if checkpoint is not None:
            _save_checkpoint(Path(checkpoint), net, opt, order, epoch + 1, recipe, lines, best)
    net = net.cpu()
    net.chosen_epoch = epochs - 1
    if best is not None:
        net.load_state_dict(best["net"])
        net.chosen_epoch = best["epoch"]
        log(f"chose epoch {best['epoch']}: validation loss {best['loss']:.3f}")
    return net.eval()
