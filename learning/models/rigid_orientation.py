"""The 6-DoF orientation model: which axis-aligned orientation the box body takes at a point of its route.

``OrientationNet`` reads the observation of ``planners.guidance.rigid_orientation.route_observation``
(a patch of voxel occupancy about a route point and the route's direction there) and gives logits over
the six orientation classes (``ORIENTATION_CLASSES``: which world axes the body's long and middle
sides lie along). Three 3-D convolutions (8, 16 and 32 channels, the second of stride 2) over the
13^3 patch, then a hidden layer of 64 with the direction, then the six logits.

Files hold tensors and plain numbers only (``torch.save`` of ``{"config", "state"}``) and are read
with ``torch.load(weights_only=True)``: loading runs no code.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import torch
from torch import nn

from learning.models.checkpoint import load_finite_state, read_config_state
from learning.models.threads import planning_threads
from planners.base.fileio import InputError, short_repr
from planners.guidance.rigid_orientation import N_CLASSES, PATCH_HALF

#: The patch half-sides a model may have (``OrientationNet.half``), inclusive: what a file and a recipe may give.
HALF_RANGE = (2, 32)


class OrientationNet(nn.Module):
    """Logits over the six orientation classes from ``(patch, direction)`` (the module doc).

    Args:
        half: Half the patch side, in voxels (the patch is ``2 half + 1`` voxels a side).
        channels: Channels of the first convolution (the next two take twice and four times as many).
        hidden: Width of the hidden layer.
    """

    def __init__(self, half: int = PATCH_HALF, channels: int = 8, hidden: int = 64) -> None:
        super().__init__()
        self.half, self.channels, self.hidden = int(half), int(channels), int(hidden)
        c = self.channels
        self.conv = nn.Sequential(nn.Conv3d(1, c, 3), nn.ReLU(), nn.Conv3d(c, 2 * c, 3, stride=2), nn.ReLU(),
                                  nn.Conv3d(2 * c, 4 * c, 3), nn.ReLU(), nn.Flatten())
        with torch.no_grad():
            side = 2 * self.half + 1
            flat = self.conv(torch.zeros(1, 1, side, side, side)).shape[1]
        self.head = nn.Sequential(nn.Linear(flat + 3, self.hidden), nn.ReLU(), nn.Linear(self.hidden, N_CLASSES))

    def forward(self, patch: torch.Tensor, direction: torch.Tensor) -> torch.Tensor:
        """``(n, 6)`` logits from ``(n, side, side, side)`` patches and ``(n, 3)`` directions."""
        return self.head(torch.cat([self.conv(patch.unsqueeze(1)), direction], dim=1))

    def config(self) -> dict:
        """The constructor's arguments (what a file stores beside the weights)."""
        return {"half": self.half, "channels": self.channels, "hidden": self.hidden}


def class_probabilities(net: OrientationNet, patches: np.ndarray, directions: np.ndarray,
                        temperature: float = 1.0, chunk: int = 512) -> np.ndarray:
    """``(n, 6)`` float64: the softmax of the net's logits over ``temperature``, in chunks, without gradients."""
    out = []
    with torch.no_grad():
        for i in range(0, len(patches), chunk):
            logits = net(torch.as_tensor(patches[i:i + chunk], dtype=torch.float32),
                         torch.as_tensor(directions[i:i + chunk], dtype=torch.float32))
            out.append(torch.softmax(logits / temperature, dim=1).double().numpy())
    return np.concatenate(out) if out else np.zeros((0, N_CLASSES))


def save_orientation_net(net: OrientationNet, path: str | os.PathLike) -> None:
    """Write ``net`` to ``path`` as tensors and plain numbers only (``load_orientation_net`` reads it safely)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    torch.save({"config": {"kind": "rigid_orientation", **net.config()}, "state": net.state_dict()}, tmp)
    os.replace(tmp, path)  # whole or not at all


def load_orientation_net(path: str | os.PathLike) -> OrientationNet:
    """Read a ``save_orientation_net`` file with ``torch.load(weights_only=True)``; problems are ``InputError``."""
    path, config, state = read_config_state(path, "orientation model", "save_orientation_net")
    if config.pop("kind", None) != "rigid_orientation":
        raise InputError(f"{path}: config kind is not 'rigid_orientation'")
    for key, lo, hi in (("half", *HALF_RANGE), ("channels", 1, 64), ("hidden", 1, 1024)):
        v = config.get(key)
        if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
            raise InputError(f"{path}: config {key} = {short_repr(v)}, expected an integer in [{lo}, {hi}]")
    unknown = sorted(set(config) - {"half", "channels", "hidden"})
    if unknown:
        raise InputError(f"{path}: config has unknown keys {short_repr(unknown)}")
    with planning_threads():  # a sampler loads it per query set: as it plans (two processes side by side)
        return load_finite_state(OrientationNet(**config), state, path, "the config")
