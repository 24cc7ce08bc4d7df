"""Strokes: a training-only map family of thin walls at every angle, straight, bent and curved, with gaps.

Every wall of the five generated families (``planners.maps.generators``) is an axis-aligned box, and
the caves (``planners.maps.caves``) are thick and blobby, so an encoder trained on them has rarely seen a
wall thinner than a planner step running at a slant, where it splits the blocks the encoder reads. Strokes
fill that gap for training: pen strokes 1 to 3 cells thick (at side 128), each a bent line of 2 to 5
straight pieces or an arc of a circle, some pieces broken by a gap, among a few solid rotated boxes.
Nothing is lined up or nested: there are no concentric walls and no parallel walls in series, and the map's
edge is free. The family is registered with ``generate`` for training (``TRAINING_FAMILIES``) and is in no
test set.
"""

from __future__ import annotations

import math

import numpy as np

# a stroke's cells are those whose centre lies within (thickness / 2 + _PAD) of the pen's line: a diagonal
# wall one cell thick then joins its cells along their sides, so no straight motion slips between two corners
_PAD = 0.25


def _scaled(size: int, cells: float, lo: float = 1.0) -> float:
    """``cells`` at side 128 scaled to ``size``, at least ``lo``."""
    return max(lo, cells * size / 128)


def _segment(walls: np.ndarray, a: np.ndarray, b: np.ndarray, radius: float) -> None:
    """Marks every cell whose centre is within ``radius`` of the segment from ``a`` to ``b`` ((row, col) points)."""
    size = walls.shape[0]
    lo = np.maximum(np.floor(np.minimum(a, b) - radius).astype(int), 0)
    hi = np.minimum(np.ceil(np.maximum(a, b) + radius).astype(int) + 1, size)
    if (hi <= lo).any():
        return
    r, c = np.ogrid[lo[0]:hi[0], lo[1]:hi[1]]
    py, px = r + 0.5 - a[0], c + 0.5 - a[1]
    d = b - a
    t = np.clip((py * d[0] + px * d[1]) / max(float(d @ d), 1e-12), 0.0, 1.0)  # a point's segment: t = 0
    walls[lo[0]:hi[0], lo[1]:hi[1]] |= (py - t * d[0]) ** 2 + (px - t * d[1]) ** 2 <= radius * radius


def _pen_path(rng: np.random.Generator, size: int) -> list[np.ndarray]:
    """The points of one stroke: a bent line of 2-5 straight pieces, or an arc drawn as short chords."""
    p = rng.uniform(0, size, 2)
    heading = rng.uniform(0, 2 * math.pi)
    points = [p]
    if rng.random() < 0.5:
        for _ in range(int(rng.integers(2, 6))):
            length = rng.uniform(_scaled(size, 8, 4), _scaled(size, 48, 8))
            p = p + length * np.array([math.sin(heading), math.cos(heading)])
            points.append(p)
            heading += rng.uniform(-1.75, 1.75)  # up to 100 degrees either way
    else:
        radius = rng.uniform(_scaled(size, 10, 5), _scaled(size, 60, 10))
        sweep = rng.uniform(math.pi / 3, 5 * math.pi / 3) * (1 if rng.random() < 0.5 else -1)
        pieces = max(4, int(abs(sweep) * radius / 3))  # chords about 3 cells long
        centre = p - radius * np.array([math.sin(heading), math.cos(heading)])
        for k in range(1, pieces + 1):
            angle = heading + sweep * k / pieces
            points.append(centre + radius * np.array([math.sin(angle), math.cos(angle)]))
    return points


def _box(rng: np.random.Generator, walls: np.ndarray) -> None:
    """A solid box 3-14 cells across (at side 128), turned by any angle."""
    size = walls.shape[0]
    h, w = (rng.uniform(_scaled(size, 3, 2), _scaled(size, 14, 3)) for _ in range(2))
    cy, cx = rng.uniform(0, size, 2)
    angle = rng.uniform(0, math.pi)
    reach = int(math.ceil(math.hypot(h, w) / 2)) + 1
    r0, c0 = max(int(cy) - reach, 0), max(int(cx) - reach, 0)
    r, c = np.ogrid[r0:min(int(cy) + reach + 1, size), c0:min(int(cx) + reach + 1, size)]
    dy, dx = r + 0.5 - cy, c + 0.5 - cx
    u = dy * math.cos(angle) + dx * math.sin(angle)
    v = -dy * math.sin(angle) + dx * math.cos(angle)
    walls[r0:r0 + u.shape[0], c0:c0 + v.shape[1]] |= (np.abs(u) <= h / 2) & (np.abs(v) <= w / 2)


def stroke_map(rng: np.random.Generator, size: int) -> np.ndarray:
    """A ``size x size`` map of strokes and a few boxes: True = wall; 8-25% of the cells are walls."""
    walls = np.zeros((size, size), dtype=bool)
    target = rng.uniform(0.08, 0.25) * size * size
    gap_lo, gap_hi = _scaled(size, 4, 3), _scaled(size, 10, 4)
    while walls.sum() < target:
        if rng.random() < 0.2:
            _box(rng, walls)
            continue
        radius = float(rng.integers(1, int(round(_scaled(size, 3))) + 1)) / 2 + _PAD
        points = _pen_path(rng, size)
        for a, b in zip(points[:-1], points[1:], strict=True):
            length = float(np.hypot(*(b - a)))
            if length > 4 * gap_hi and rng.random() < 0.3:
                # a gap in this piece: draw the piece in two parts around it
                gap = rng.uniform(gap_lo, gap_hi) + 2 * radius
                at = rng.uniform(gap_hi, length - gap - gap_hi) / length
                _segment(walls, a, a + at * (b - a), radius)
                _segment(walls, a + (at + gap / length) * (b - a), b, radius)
            else:
                _segment(walls, a, b, radius)
    return walls

