"""The route encoder: a U-Net with axial attention that predicts every cell's cost-to-go, and its safe file I/O.

``RouteNet`` looks at the whole map once per query. It works on blocks of one planner step; its input is
every cell of each block (so a 1-cell gap is not averaged away) and the goal, and there is no search at
inference. ``learning.samplers.route.RouteSampler`` follows its prediction.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import torch
from torch import nn

from learning.models.checkpoint import load_finite_state, read_config_state
from learning.models.field import (  # re-exported (``__all__``): where users of the route encoder find them
    BATCH_BYTES,
    BYTES_PER_BLOCK,
    GOAL_CHANNELS,
    MAX_BLOCKS,
    MAX_BLOCKS_ENV,
    FieldEncoder,
    max_blocks,
    route_input,
    symmetry,
    unturn,
)
from learning.models.route_vin import RouteVIN
from learning.models.threads import planning_threads
from planners.base.fileio import InputError, atomic_write_bytes, atomic_write_text, output_set, short_repr

__all__ = ["BATCH_BYTES", "BYTES_PER_BLOCK", "GOAL_CHANNELS", "KINDS", "MAX_BLOCKS", "MAX_BLOCKS_ENV",
           "AxialAttention", "FieldEncoder", "RouteNet", "RouteVIN", "UNet", "load_route_net", "make_route_net",
           "max_blocks", "route_input", "save_route_net", "save_route_set", "symmetry", "unturn"]


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
        pass at once: there each chunk would cost kernel launches, not save memory traffic.
        """
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


class RouteNet(UNet, FieldEncoder):
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
        self.step = block  # its blocks are one planner step
        self.trained_side = trained_side

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return nn.functional.pixel_shuffle(super().forward(x), self.block)[:, 0]

def save_route_net(net: RouteNet | RouteVIN, path: str | os.PathLike) -> None:
    """Write ``net`` to ``path`` as tensors and plain numbers only (``load_route_net`` reads it safely)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    if isinstance(net, RouteVIN):
        config = {"kind": "vin", "block": net.block, "channels": net.channels, "depth": net.depth}
        if net.step != net.block:  # files of one-step blocks stay as they were
            config["step"] = net.step
    else:
        config = {"block": net.block, "channels": net.channels, "depth": net.depth}
        if net.attention_layers:  # files of encoders without attention stay as they were
            config["attention"] = net.attention_layers
        if net.attention_level:
            config["attention_level"] = net.attention_level
        if net.trained_side:
            config["trained_side"] = net.trained_side
    torch.save({"config": config, "state": net.state_dict()}, tmp)
    os.replace(tmp, path)  # whole or not at all


def save_route_set(net: RouteNet | RouteVIN, info: dict, out: str | os.PathLike,
                   export: str | os.PathLike | None = None) -> None:
    """Write ``out/route.pt`` and ``out/route.json`` (``info`` as JSON) as one set, and copy both to ``export``.

    The folder is built beside ``out`` and swapped into place whole (``output_set``), so a kill leaves the old pair
    or the new one; ``export`` (a file; its ``.json`` beside it) is written description first, each file whole.
    """
    out = Path(out)
    meta = json.dumps(info, indent=1) + "\n"
    with output_set(out) as folder:
        save_route_net(net, folder / "route.pt")
        (folder / "route.json").write_text(meta, encoding="utf-8")
    if export is not None:
        export = Path(export)
        atomic_write_text(export.with_suffix(".json"), meta)
        atomic_write_bytes(export, (out / "route.pt").read_bytes())


#: The encoder kinds a file may hold (its config's "kind"; a file without one holds a ``RouteNet``).
KINDS = ("unet", "vin")


def make_route_net(kind: str = "unet", block: int = 4, channels: int = 24, depth: int = 4, attention: int = 0,
                   attention_level: int = 0, trained_side: int = 0, step: int | None = None) -> RouteNet | RouteVIN:
    """A new encoder of ``kind``: "unet" (``RouteNet``) or "vin" (``RouteVIN``, whose ``depth`` is its local layers,
    which takes no attention, and whose ``step`` in cells may be several blocks); a ``ValueError`` naming what
    does not fit.
    """
    if kind == "vin":
        if attention or attention_level:
            raise ValueError(f"attention = {attention}, attention_level = {attention_level}: the value-iteration "
                             f"encoder has no attention layers (expected 0)")
        return RouteVIN(block, channels, depth, step)
    if kind != "unet":
        raise ValueError(f"kind = {kind!r}, expected one of {KINDS}")
    if step is not None and step != block:
        raise ValueError(f"step = {step}, block = {block}: the U-Net's blocks are one step (expected step = block)")
    return RouteNet(block, channels, depth, attention, attention_level, trained_side)


def load_route_net(path: str | os.PathLike) -> RouteNet | RouteVIN:
    """Read a ``save_route_net`` file: ``torch.load(weights_only=True)``, so nothing in it can run.

    Every problem with the file is an ``InputError`` naming it.
    """
    path, stored, state = read_config_state(path, "route encoder", "save_route_net")
    known = ("kind", "block", "channels", "depth", "attention", "attention_level", "trained_side", "step")
    unknown = [k for k in stored if k not in known]
    if unknown:
        raise InputError(f"{path}: config has unknown keys {short_repr(unknown)}, expected some of {known}")
    config = {"kind": "unet", "attention": 0, "attention_level": 0, "trained_side": 0, **stored}
    config.setdefault("step", config.get("block"))
    if config["kind"] not in KINDS:
        raise InputError(f"{path}: config kind = {short_repr(config['kind'])}, expected one of {KINDS}")
    for key, lo, hi in (("block", 1, 64), ("channels", 1, 64), ("depth", 1, 64), ("attention", 0, 64),
                        ("attention_level", 0, 64), ("trained_side", 0, 1 << 20),  # a side in cells, 0: unknown
                        ("step", 1, 64)):
        v = config.get(key)
        if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
            raise InputError(f"{path}: config {key} = {short_repr(v)}, expected an integer in [{lo}, {hi}]")
    shape = tuple(config[k] for k in ("kind", "block", "channels", "depth", "attention", "attention_level",
                                      "trained_side", "step"))
    with planning_threads():  # built at the planning thread count, as it plans (two processes side by side)
        try:
            net = make_route_net(*shape)
        except ValueError as exc:
            raise InputError(f"{path}: config {exc}") from None
        return load_finite_state(net, state, path, f"{type(net).__name__}{shape[1:6]}")
