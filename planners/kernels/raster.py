"""Compiled line rasterisation for figures and animations of huge trees (millions of pixels per second)."""

from __future__ import annotations

import math

import numba as nb


@nb.njit(cache=True, no_cfunc_wrapper=True)
def draw_segments(img, seg, cols):
    """Draw 1-pixel lines ``seg[i] = (x0, y0, x1, y1)`` (pixel coordinates) in colour ``cols[i]`` into ``img``.

    ``img`` is (H, W, C) uint8 with C >= 3; channels past ``cols.shape[1]`` are set to 255 where a
    line is drawn (opaque in an RGBA layer). Pixels outside the image are skipped.
    """
    H = img.shape[0]
    W = img.shape[1]
    C = img.shape[2]
    nc = cols.shape[1]
    for i in range(seg.shape[0]):
        x0 = seg[i, 0]
        y0 = seg[i, 1]
        dx = seg[i, 2] - x0
        dy = seg[i, 3] - y0
        if not (math.isfinite(x0) and math.isfinite(y0) and math.isfinite(dx) and math.isfinite(dy)):
            continue
        n = int(math.ceil(max(abs(dx), abs(dy)))) + 1
        for j in range(n):
            t = j / (n - 1) if n > 1 else 0.0
            c = int(math.floor(x0 + t * dx))
            r = int(math.floor(y0 + t * dy))
            if 0 <= r < H and 0 <= c < W:
                for k in range(C):
                    img[r, c, k] = cols[i, k] if k < nc else 255
