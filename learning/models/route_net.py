"""The route encoder: a U-Net with axial attention that predicts every cell's cost-to-go, and its safe file I/O.

``RouteNet`` looks at the whole map once per query. It works on blocks of one planner step; its input is
every cell of each block (so a 1-cell gap is not averaged away) and the goal, and there is no search at
inference. ``learning.samplers.route.RouteSampler`` follows its prediction.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import torch
from torch import nn

from learning.models.threads import planning_threads
from planners.base.fileio import InputError, short_repr


GOAL_CHANNELS = 3  # the goal's block, and the offset to it in x and y

#: The largest encoder input, in blocks (cells of the block grid), and the variable that raises it. A pass
#: holds about ``BYTES_PER_BLOCK`` per block per map in flight; at the default, one map of 1024 x 1024
#: cells at 4 cells per block (65,536 blocks).
MAX_BLOCKS_ENV = "SAMPLERGYM_MAX_ROUTE_BLOCKS"
MAX_BLOCKS = 256 * 256
#: Working memory of one pass per block of one map (activations and attention, measured on the shipped
#: encoder), and how much of it ``predict`` lets one batch of symmetries take: larger maps run their
#: symmetries in smaller batches (one at a time at the largest), so memory stays bounded.
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


def route_input(obstacles: np.ndarray, goal_cell: tuple[int, int], block: int) -> np.ndarray:
    """The encoder's input, (block**2 + 3, h, w) float32: each cell of each block, then the goal channels.

    The map is padded with blocked cells to whole blocks.
    """
    H, W = obstacles.shape
    h, w = -(-H // block), -(-W // block)
    pad = np.ones((h * block, w * block), dtype=np.float32)
    pad[:H, :W] = obstacles
    cells = pad.reshape(h, block, w, block).transpose(1, 3, 0, 2).reshape(block * block, h, w)
    gr, gc = goal_cell[0] // block, goal_cell[1] // block
    ys, xs = np.mgrid[0:h, 0:w]
    goal = np.stack([(ys == gr) & (xs == gc), (gc - xs) / w, (gr - ys) / h]).astype(np.float32)
    return np.concatenate([cells, goal])


def symmetry(obstacles: np.ndarray, goal_cell: tuple[int, int], k: int) -> tuple[np.ndarray, tuple[int, int]]:
    """The map and goal cell under the square's symmetry ``k`` (0-7).

    ``k % 4`` quarter turns, then a transpose if ``k >= 4``.
    """
    mark = np.zeros(obstacles.shape, dtype=bool)
    mark[goal_cell] = True
    obs, mark = np.rot90(obstacles, k % 4), np.rot90(mark, k % 4)
    if k >= 4:
        obs, mark = obs.T, mark.T
    r, c = np.argwhere(mark)[0]
    return np.ascontiguousarray(obs), (int(r), int(c))


def unturn(field: np.ndarray, k: int) -> np.ndarray:
    """A field computed on ``symmetry(..., k)``'s map, turned back onto the original map."""
    return np.rot90(field.T if k >= 4 else field, -(k % 4))


class AxialAttention(nn.Module):
    """Attention along each row of a grid, then along each column, each followed by a 1x1 MLP (residual).

    After one of these every pixel has read every pixel of its row and of its column, and after two
    every pixel of the grid, at full resolution: where a long wall is open, or which door of a room
    leads on, is read off across the map instead of surviving a U-Net's coarse middle (which keeps
    24 numbers for a quarter of a map).
    """

    HEADS = 2
    #: Attention weights one inference chunk of sequences holds (floats): 2 MB, so they stay in the cache.
    CHUNK_FLOATS = 1 << 19

    def __init__(self, channels: int) -> None:
        super().__init__()
        self.row, self.col = (nn.MultiheadAttention(channels, self.HEADS, batch_first=True) for _ in range(2))
        self.norms = nn.ModuleList(nn.LayerNorm(channels) for _ in range(4))
        self.mlps = nn.ModuleList(nn.Sequential(nn.Linear(channels, 2 * channels), nn.ReLU(),
                                                nn.Linear(2 * channels, channels)) for _ in range(2))

    def _along(self, x: torch.Tensor, attn: nn.MultiheadAttention, i: int) -> torch.Tensor:
        y = self.norms[2 * i](x)
        x = x + attn(y, y, y, need_weights=False)[0]
        return x + self.mlps[i](self.norms[2 * i + 1](x))

    def _chunked(self, x: torch.Tensor, attn: nn.MultiheadAttention, i: int) -> torch.Tensor:
        """``_along`` without gradients on the CPU, a few sequences at a time (``CHUNK_FLOATS``): each sequence's
        result is the same bit for bit, and the attention weights of a chunk stay in the cache instead of all of
        them going through memory (at 128 x 128 blocks, 8 symmetries: 537 MB at once). A GPU takes the whole
        pass at once: there each chunk would cost kernel launches, not save memory traffic."""
        if torch.is_grad_enabled() or x.device.type != "cpu":
            return self._along(x, attn, i)
        n = max(1, self.CHUNK_FLOATS // (self.HEADS * x.shape[1] * x.shape[1]))
        if n >= len(x):
            return self._along(x, attn, i)
        out = torch.empty_like(x)
        for at in range(0, len(x), n):
            out[at:at + n] = self._along(x[at:at + n], attn, i)
        return out

    def forward(self, h: torch.Tensor) -> torch.Tensor:
        B, C, H, W = h.shape
        x = self._chunked(h.permute(0, 2, 3, 1).reshape(B * H, W, C), self.row, 0)  # each row a sequence
        x = x.reshape(B, H, W, C).transpose(1, 2).reshape(B * W, H, C)
        x = self._chunked(x, self.col, 1)  # each column a sequence
        return x.reshape(B, W, H, C).permute(0, 3, 2, 1)


class UNet(nn.Module):
    """A small U-Net over a grid: halve it ``depth`` times, then come back up with skip connections.

    Every pixel sees the whole of a 32-pixel grid after ``2 * depth + 2`` convolutions, most of them on
    small grids, so a pass costs a few times one full-resolution convolution. ``attention`` axial
    attention layers (``AxialAttention``) are optional; they run on the way up, at the grid halved
    ``attention_level`` times (0: full resolution, before the output). At level 1 they cost about a
    quarter as much, and the full-resolution skip connection still brings back each cell.
    """

    def __init__(self, inputs: int, outputs: int, channels: int = 24, depth: int = 4, attention: int = 0,
                 attention_level: int = 0) -> None:
        super().__init__()
        if not 0 <= attention_level < depth:
            raise ValueError(f"attention_level = {attention_level}, expected 0 to depth - 1 = {depth - 1}")
        self.attention_level = attention_level
        self.inp = nn.Conv2d(inputs, channels, 3, padding=1)
        self.down = nn.ModuleList(nn.Conv2d(channels, channels, 3, stride=2, padding=1) for _ in range(depth))
        self.up = nn.ModuleList(nn.Conv2d(2 * channels, channels, 3, padding=1) for _ in range(depth))
        self.attention = nn.ModuleList(AxialAttention(channels) for _ in range(attention))
        self.out = nn.Conv2d(channels, outputs, 3, padding=1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = torch.relu(self.inp(x))
        skips = []
        for conv in self.down:
            skips.append(h)
            h = torch.relu(conv(h))
        for level, conv, skip in zip(range(len(skips) - 1, -1, -1), self.up, reversed(skips), strict=True):
            h = nn.functional.interpolate(h, size=skip.shape[-2:], mode="nearest")
            h = torch.relu(conv(torch.cat([h, skip], 1)))
            if level == self.attention_level:
                for layer in self.attention:
                    h = layer(h)
        return self.out(h)


class RouteNet(UNet):
    """A ``UNet`` over the block grid that predicts the cost-to-go of every cell, in steps.

    ``trained_side`` is the largest map side (cells) it was trained on, 0 if unknown: ``predict``
    scales its field up on larger maps (see there).
    """

    def __init__(self, block: int = 4, channels: int = 24, depth: int = 4, attention: int = 0,
                 attention_level: int = 0, trained_side: int = 0) -> None:
        if attention and channels % AxialAttention.HEADS:
            raise ValueError(f"channels = {channels} with attention, expected a multiple of {AxialAttention.HEADS}")
        # a cost per cell of the block
        super().__init__(block * block + GOAL_CHANNELS, block * block, channels, depth, attention, attention_level)
        self.block, self.channels, self.depth, self.attention_layers = block, channels, depth, attention
        self.trained_side = trained_side

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return nn.functional.pixel_shuffle(super().forward(x), self.block)[:, 0]

    def check_size(self, shape: tuple[int, int]) -> tuple[int, int]:
        """The block grid of a map of ``shape`` cells, or an ``InputError`` naming the size and the limit."""
        h, w = -(-shape[0] // self.block), -(-shape[1] // self.block)
        limit = max_blocks()
        if h * w > limit:
            raise InputError(f"the route encoder's input for this {shape[0]} x {shape[1]} map is {h} x {w} = "
                             f"{h * w} blocks of {self.block} x {self.block} cells, above the limit of {limit} "
                             f"blocks (a pass over it needs about {BYTES_PER_BLOCK * h * w / 2**30:.1f} GB per "
                             f"symmetry); set {MAX_BLOCKS_ENV} to raise it")
        return h, w

    def predict(self, obstacles: np.ndarray, goal_cell: tuple[int, int], symmetries: int = 1, *,
                threads: int | None = None) -> np.ndarray:
        """Predicted cost-to-go of every cell, in blocks (steps), for one map: (H, W) float64.

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
        totals = [np.zeros(obstacles.shape) for obstacles, _ in queries]
        device = next(self.parameters()).device
        with planning_threads(threads), torch.inference_mode():
            for (h, w), group in by_shape.items():
                blocks = group[0][2].shape[1] * group[0][2].shape[2]
                size = max(1, min(len(group), BATCH_BYTES // (BYTES_PER_BLOCK * blocks)))
                for at in range(0, len(group), size):
                    part = group[at:at + size]
                    x = torch.from_numpy(np.stack([x for _, _, x in part])).to(device)
                    out = self(x)[:, :h, :w].cpu().numpy().astype(np.float64)
                    for (i, k, _), field in zip(part, out, strict=True):
                        totals[i] += unturn(field, k)
        for total in totals:
            total /= symmetries
            side = max(total.shape)
            if self.trained_side and side > self.trained_side:
                total *= side / self.trained_side
        return totals


def save_route_net(net: RouteNet, path: str | os.PathLike) -> None:
    """Write ``net`` to ``path`` as tensors and plain numbers only (``load_route_net`` reads it safely)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    config = {"block": net.block, "channels": net.channels, "depth": net.depth}
    if net.attention_layers:  # files of encoders without attention stay as they were
        config["attention"] = net.attention_layers
    if net.attention_level:
        config["attention_level"] = net.attention_level
    if net.trained_side:
        config["trained_side"] = net.trained_side
    torch.save({"config": config, "state": net.state_dict()}, tmp)
    os.replace(tmp, path)  # whole or not at all


def load_route_net(path: str | os.PathLike) -> RouteNet:
    """Read a ``save_route_net`` file: ``torch.load(weights_only=True)``, so nothing in it can run.

    Every problem with the file is an ``InputError`` naming it.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"route encoder {path} does not exist")
    try:
        blob = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # noqa: BLE001 - whatever torch raises on a bad file, name the file
        raise InputError(f"{path} is not a route encoder file: {type(exc).__name__}: {short_repr(str(exc), 300)}") \
            from None
    if not (isinstance(blob, dict) and isinstance(blob.get("config"), dict) and isinstance(blob.get("state"), dict)):
        raise InputError(f"{path}: expected {{'config': {{...}}, 'state': {{...}}}} as save_route_net writes")
    known = ("block", "channels", "depth", "attention", "attention_level", "trained_side")
    unknown = [k for k in blob["config"] if k not in known]
    if unknown:
        raise InputError(f"{path}: config has unknown keys {short_repr(unknown)}, expected some of {known}")
    config = {"attention": 0, "attention_level": 0, "trained_side": 0, **blob["config"]}
    for key, lo, hi in (("block", 1, 64), ("channels", 1, 64), ("depth", 1, 64), ("attention", 0, 64),
                        ("attention_level", 0, 64), ("trained_side", 0, 1 << 20)):  # a side in cells, 0: unknown
        v = config.get(key)
        if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
            raise InputError(f"{path}: config {key} = {short_repr(v)}, expected an integer in [{lo}, {hi}]")
    try:
        net = RouteNet(*(config[k] for k in ("block", "channels", "depth", "attention", "attention_level",
                                             "trained_side")))
    except ValueError as exc:
        raise InputError(f"{path}: config {exc}") from None
    for name, tensor in blob["state"].items():
        if isinstance(tensor, torch.Tensor) and tensor.is_floating_point() and not torch.isfinite(tensor).all():
            raise InputError(f"{path}: tensor {short_repr(name)} holds NaN or infinite weights")
    try:
        net.load_state_dict(blob["state"])
    except (RuntimeError, TypeError, ValueError) as exc:
        shape = tuple(config[k] for k in ("block", "channels", "depth", "attention", "attention_level"))
        raise InputError(f"{path}: the weights do not fit RouteNet{shape}: {short_repr(str(exc), 300)}") from None
    return net.eval()
