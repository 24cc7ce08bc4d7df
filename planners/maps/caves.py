"""Caves: a training-only map family of irregular walls at every angle (cellular-automaton caves).

The five generated families (``planners.maps.generators``) build every wall from axis-aligned boxes, so
an encoder trained on them alone has never seen a slanted or curved wall. Caves fill that gap for
training: random noise smoothed by the cellular-automaton rule (a cell becomes a wall when at least 5 of
the 9 cells around it, itself included, are walls), at a scale drawn per map (the noise drawn on a grid
1, 2 or 3 times coarser and scaled up), so walls run at every angle and are 1 to about 10 cells thick.
The family is registered with ``generate`` for training (``TRAINING_FAMILIES``) and is in no test set.
"""

from __future__ import annotations

import numpy as np


def cave_map(rng: np.random.Generator, size: int) -> np.ndarray:
    """A ``size x size`` cave: True = wall; the map's edge is a wall."""
    k = int(rng.integers(1, 4))  # coarseness of the noise
    n = -(-size // k)
    fill = float(rng.uniform(0.40, 0.48))
    walls = rng.random((n, n)) < fill
    for _ in range(int(rng.integers(3, 6))):
        p = np.pad(walls, 1, constant_values=True).astype(np.int8)
        count = sum(p[1 + dr:1 + dr + n, 1 + dc:1 + dc + n] for dr in (-1, 0, 1) for dc in (-1, 0, 1))
        walls = count >= 5
    walls = np.repeat(np.repeat(walls, k, 0), k, 1)[:size, :size]
    walls[0, :] = walls[-1, :] = walls[:, 0] = walls[:, -1] = True
    return np.ascontiguousarray(walls)

