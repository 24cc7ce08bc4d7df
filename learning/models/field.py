"""What every route encoder shares: its input, the square's symmetries, the size limit, and ``predict``.

A route encoder (``learning.models.route_net.RouteNet``, ``learning.models.route_vin.RouteVIN``) reads a map in
blocks (of one planner step, or a whole fraction of one) and gives the cost-to-go of every cell, in steps;
``FieldEncoder`` turns a map and a goal into that field, averaged over the square's symmetries, within a memory
bound.
"""

from __future__ import annotations

import contextlib
import os

import numba as nb
import numpy as np
import torch

from learning.device import full_float32
from learning.models.threads import planning_threads
from planners.base.fileio import InputError, short_repr

GOAL_CHANNELS = 3  # the goal's block, and the offset to it in x and y

#: The largest encoder input, in blocks (cells of the block grid), and the variable that raises it: one map of
#: 4096 x 4096 cells at the shipped encoder's 2 cells per block (4,194,304 blocks). The value-iteration encoder
#: runs its passes over maps above ``RouteVIN.strip_blocks`` in strips of rows, so its memory grows with the
#: map's blocks at a few hundred bytes each (``RouteVIN.pass_bytes``; its pass over 4096 x 4096 cells stays
#: within 1.5 GB); the U-Net encoder holds the whole map's activations, ``BYTES_PER_BLOCK`` per block.
MAX_BLOCKS_ENV = "SAMPLERGYM_MAX_ROUTE_BLOCKS"
MAX_BLOCKS = 2048 * 2048
#: The largest training map, in blocks: a training pass holds the whole map's activations and their gradients
#: (one 1024 x 1024 map at 2 cells per block). ``SAMPLERGYM_MAX_ROUTE_BLOCKS`` can only lower it.
TRAINING_MAX_BLOCKS = 512 * 512
#: Working memory of one pass per block of one map (activations and attention, measured on the U-Net
#: encoder, which needs the most), and how much of it ``predict`` lets one batch of symmetries take: larger
#: maps run their symmetries in smaller batches (one at a time at the largest), so memory stays bounded.
BYTES_PER_BLOCK = 5_000
BATCH_BYTES = 1 << 30


def max_blocks() -> int:
    """``SAMPLERGYM_MAX_ROUTE_BLOCKS`` if set (a positive integer), else ``MAX_BLOCKS``."""
    value = os.environ.get(MAX_BLOCKS_ENV)
    if value is None or value == "":
        return MAX_BLOCKS
    try:
        n = int(value)
    except ValueError:
        n = 0
    if n < 1:
        raise InputError(f"{MAX_BLOCKS_ENV} = {short_repr(value)}: expected a positive whole number of blocks")
    return n


@nb.njit(cache=True)
def _route_input(obstacles, gr, gc, block, out):
    H, W = obstacles.shape
    _, h, w = out.shape
    cells = block * block
    one = np.float32(1.0)
    for i in range(block):
        for j in range(block):
            channel = out[i * block + j]
            inside = min(w, -(-(W - j) // block))  # the blocks whose cell (i, j) lies on the map's columns
            for r in range(h):
                line = channel[r]
                row = r * block + i
                if row >= H:
                    line[:] = one
                    continue
                cells_row = obstacles[row]
                for c in range(inside):
                    line[c] = np.float32(cells_row[c * block + j])
                line[inside:] = one
    out[cells] = 0.0
    if 0 <= gr < h and 0 <= gc < w:
        out[cells, gr, gc] = one
    for c in range(w):
        out[cells + 1, :, c] = np.float32((gc - c) / w)  # formed in float64, stored in float32, as ever
    for r in range(h):
        out[cells + 2, r, :] = np.float32((gr - r) / h)
    return out


def route_input(obstacles: np.ndarray, goal_cell: tuple[int, int], block: int) -> np.ndarray:
    """The encoder's input, (block**2 + 3, h, w) float32: each cell of each block, then the goal channels.

    The map is padded with blocked cells to whole blocks. Made in one compiled pass (a query's input was a dozen
    numpy calls).
    """
    obstacles = np.asarray(obstacles)
    if obstacles.dtype != np.bool_:
        obstacles = obstacles.astype(np.float32)  # the values the cell channels store
    H, W = obstacles.shape
    h, w = -(-H // block), -(-W // block)
    out = np.empty((block * block + GOAL_CHANNELS, h, w), dtype=np.float32)
    return _route_input(obstacles, int(goal_cell[0]) // block, int(goal_cell[1]) // block, int(block), out)


def symmetry(obstacles: np.ndarray, goal_cell: tuple[int, int], k: int) -> tuple[np.ndarray, tuple[int, int]]:
    """The map and goal cell under the square's symmetry ``k`` (0-7).

    ``k % 4`` quarter turns, then a transpose if ``k >= 4``.
    """
    if k == 0:  # the map as it is
        return np.ascontiguousarray(obstacles), (int(goal_cell[0]), int(goal_cell[1]))
    mark = np.zeros(obstacles.shape, dtype=bool)
    mark[goal_cell] = True
    obs, mark = np.rot90(obstacles, k % 4), np.rot90(mark, k % 4)
    if k >= 4:
        obs, mark = obs.T, mark.T
    r, c = np.argwhere(mark)[0]
    return np.ascontiguousarray(obs), (int(r), int(c))


def check_start(obstacles: np.ndarray, start_cell) -> tuple[int, int]:
    """``start_cell`` as (row, column) ints, or an ``InputError`` where it is not a cell of the map ``obstacles``."""
    try:
        r, c = (int(v) for v in start_cell)
    except (TypeError, ValueError):
        raise InputError(f"start_cell = {short_repr(start_cell)}: expected a (row, column) cell") from None
    h, w = np.shape(obstacles)[:2]
    if not (0 <= r < h and 0 <= c < w):
        raise InputError(f"start_cell = ({r}, {c}) is outside the {h} x {w} map")
    return r, c


def batch_of(arrays) -> np.ndarray:
    """``np.stack(arrays)``, except that a single array becomes a batch of one as a view, without a copy."""
    return arrays[0][None] if len(arrays) == 1 else np.stack(arrays)


def unturn(field: np.ndarray, k: int) -> np.ndarray:
    """A field computed on ``symmetry(..., k)``'s map, turned back onto the original map."""
    return np.rot90(field.T if k >= 4 else field, -(k % 4))


class FieldEncoder:
    """What a route encoder offers the route sampler: the cost-to-go of every cell of a map, in steps.

    Mixed into ``torch.nn.Module`` encoders (``RouteNet``, ``learning.models.route_vin.RouteVIN``) that have
    ``block`` (cells per block side), ``step`` (the planner's step in cells, a whole number of blocks),
    ``trained_side`` (0 or the largest map side trained on) and a ``forward`` from ``route_input``'s channels
    to every cell's cost-to-go in blocks.
    """

    block: int
    step: int
    trained_side: int
    #: How many of the square's symmetries the route sampler averages this encoder's field over by default.
    symmetries: int = 8
    #: The field's value, in steps, where the encoder sees no route to the goal (None: it always gives one).
    unreached_steps: float | None = None
    #: Passes on a CUDA GPU with cuDNN's convolutions in full float32 (``learning.device.full_float32``), as the CPU
    #: computes them; False leaves torch's TF32 default (``scripts/experiments/gpu_route.py`` compares the two).
    full_float32: bool = True

    def pass_bytes(self, h: int, w: int) -> int:
        """About how many bytes one pass over an ``h`` x ``w`` block grid holds at its peak (one symmetry)."""
        return BYTES_PER_BLOCK * h * w

    def inference_key(self) -> tuple:
        """The settings a pass depends on besides the weights, the device and the query (part of a kept field's key)."""
        return (self.full_float32,)

    def open_walls(self) -> contextlib.AbstractContextManager | None:
        """A context in which passes run without the encoder's learned wall rule; None where it has none.

        The route sampler takes it for a query whose start the encoder sees no route from: there the rule has shut
        a passage the map leaves open (a door priced above the threshold), and the learned move costs without it
        still rank the route through it.
        """
        return None

    def infer(self, x: torch.Tensor) -> torch.Tensor:
        """The pass ``predict`` takes (no gradients): ``forward``, unless the encoder has a cheaper way there.

        ``RouteVIN`` reuses what it computed for a map at its next query on that map. The result may be memory the
        encoder writes again at its next pass (``RouteVIN.keep_buffers``): ``predict`` copies it.
        """
        return self(x)

    def check_size(self, shape: tuple[int, int]) -> tuple[int, int]:
        """The block grid of a map of ``shape`` cells, or an ``InputError`` naming the size and the limit."""
        h, w = -(-shape[0] // self.block), -(-shape[1] // self.block)
        limit = max_blocks()
        if h * w > limit:
            raise InputError(f"the route encoder's input for this {shape[0]} x {shape[1]} map is {h} x {w} = "
                             f"{h * w} blocks of {self.block} x {self.block} cells, above the limit of {limit} "
                             f"blocks (a pass over it needs about {self.pass_bytes(h, w) / 2**30:.1f} GB per "
                             f"symmetry); set {MAX_BLOCKS_ENV} to raise it")
        return h, w

    def predict(self, obstacles: np.ndarray, goal_cell: tuple[int, int], symmetries: int = 1, *,
                threads: int | None = None) -> np.ndarray:
        """Predicted cost-to-go of every cell, in steps (of ``step`` cells), for one map: (H, W) float64.

        With ``symmetries`` > 1 the prediction is the mean over the map turned by the first that many of
        the square's symmetries (``symmetry``), each turned back: at 8 it is exactly equivariant, as the
        true cost-to-go is, at 8 times the cost. Those of one shape run as one batch, in smaller ones
        where a batch would take more than ``BATCH_BYTES``; a map above ``max_blocks()`` is refused
        before any work. Runs on the device the encoder is on (``to``), at ``planning_threads(threads)``.

        On a map whose larger side exceeds ``trained_side`` the field is multiplied by their ratio. The
        goal offsets it reads are fractions of the map, so beyond its training sizes it predicts the
        route's shape at the training scale: on MovingAI's random512-10-0 the start, 126 steps out,
        came out at 35. Only the order of the field steers the sampler's progress and target; its
        scale sets how sharply the frontier prefers its best cells.
        """
        return self.predict_many([(obstacles, goal_cell)], symmetries, threads=threads)[0]

    def predict_many(self, queries: list[tuple[np.ndarray, tuple[int, int]]], symmetries: int = 1, *,
                     threads: int | None = None) -> list[np.ndarray]:
        """``predict`` for many (obstacles, goal cell) queries, the passes of same-shaped inputs batched together.

        On a GPU one batch of many queries costs little more than one query; the results are those of
        ``predict`` one query at a time up to floating-point rounding.
        """
        if isinstance(symmetries, bool) or not isinstance(symmetries, int) or not 1 <= symmetries <= 8:
            raise InputError(f"symmetries must be 1 to 8, got {short_repr(symmetries)}")
        for obstacles, _ in queries:
            self.check_size(obstacles.shape)
        by_shape: dict[tuple[int, int], list[tuple[int, int, np.ndarray]]] = {}
        for i, (obstacles, goal_cell) in enumerate(queries):
            for k in range(symmetries):
                obs, goal = symmetry(obstacles, goal_cell, k)
                by_shape.setdefault(obs.shape, []).append((i, k, route_input(obs, goal, self.block)))
        totals: list[np.ndarray | None] = [None] * len(queries)
        device = next(self.parameters()).device
        precision = full_float32(device) if self.full_float32 else contextlib.nullcontext()
        with planning_threads(threads), torch.inference_mode(), precision:
            for (h, w), group in by_shape.items():
                blocks = group[0][2].shape[1] * group[0][2].shape[2]
                size = max(1, min(len(group), BATCH_BYTES // (BYTES_PER_BLOCK * blocks)))
                for at in range(0, len(group), size):
                    part = group[at:at + size]
                    x = batch_of([x for _, _, x in part])
                    out = self.infer(torch.from_numpy(x).to(device))[:, :h, :w].cpu().numpy()
                    for (i, k, _), field in zip(part, out, strict=True):
                        # float64 sums, in the order the symmetries come (the first one taken as it is)
                        turned = unturn(field, k).astype(np.float64)
                        totals[i] = turned if totals[i] is None else totals[i] + turned
        return [self.in_steps(total, symmetries) for total in totals]

    def in_steps(self, total: np.ndarray, symmetries: int = 1) -> np.ndarray:
        """A pass's field in blocks (float64; over ``symmetries`` turns, their sum) as ``predict`` gives it: the mean,
        in steps, rescaled past ``trained_side``. In place; returns ``total``.
        """
        total *= self.block / (self.step * symmetries)
        side = max(total.shape)
        if self.trained_side and side > self.trained_side:
            total *= side / self.trained_side
        return total

    def shuts(self, field: np.ndarray, start_cell: tuple[int, int]) -> bool:
        """Whether ``predict``'s ``field`` sees no route from ``start_cell`` (at least half ``unreached_steps``)."""
        return self.unreached_steps is not None and bool(field[start_cell] >= 0.5 * self.unreached_steps)

    def predict_reaching(self, obstacles: np.ndarray, goal_cell: tuple[int, int], start_cell: tuple[int, int] | None,
                         symmetries: int = 1, *, threads: int | None = None) -> tuple[np.ndarray, bool]:
        """``predict``'s field, or the field without the encoder's learned wall rule (``open_walls``) where that rule
        shuts every route from ``start_cell`` (``shuts``): (the field, whether it is the one without the rule).

        What the route sampler asks for a query (``start_cell`` None: ``predict``'s field, no start to reach). Here
        two ``predict`` calls where the start is shut; an encoder may compute both in one pass (``RouteVIN`` does: the
        same values).
        """
        if start_cell is not None:
            check_start(obstacles, start_cell)
        field = self.predict(obstacles, goal_cell, symmetries, threads=threads)
        opened = self.open_walls() if start_cell is not None and self.shuts(field, start_cell) else None
        if opened is None:
            return field, False
        with opened:
            return self.predict(obstacles, goal_cell, symmetries, threads=threads), True
