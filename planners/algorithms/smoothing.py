"""Path post-processing: greedy simplification and random shortcutting.

Both keep the first and last states, only ever replace a stretch of path by a collision-free
straight motion, and never make a path longer.
"""

from __future__ import annotations

import numpy as np

from planners.base.problem import Problem
from planners.kernels.space import interpolate


def _as_path(path, problem: Problem) -> np.ndarray:
    path = np.array(path, dtype=np.float64).reshape(-1, problem.dim)
    if len(path) == 0:
        raise ValueError("path is empty")
    return path


def simplify(path, problem: Problem) -> np.ndarray:
    """Greedy line-of-sight: from each kept state jump to the farthest later state visible from it."""
    path = _as_path(path, problem)
    world = problem.world
    out = [path[0]]
    i = 0
    while i < len(path) - 1:
        j = len(path) - 1
        while j > i + 1 and not world.check_motion(path[i], path[j]):
            j -= 1
        out.append(path[j])
        i = j
    return np.array(out)


def shortcut(path, problem: Problem, *, seed: int = 0, attempts: int = 200) -> np.ndarray:
    """Random shortcutting between points anywhere on the path (as OMPL's PathSimplifier).

    Each attempt picks two random arc-length positions, and if the straight motion between them is
    collision-free and shorter, replaces the stretch between them.
    """
    path = _as_path(path, problem)
    if attempts < 0:
        raise ValueError(f"attempts must be >= 0, got {attempts}")
    rng = np.random.default_rng(seed)
    world = problem.world
    kind = problem.space[0]
    pa = np.empty(problem.dim)
    pb = np.empty(problem.dim)
    for _ in range(attempts):
        if len(path) < 3:
            break
        seg = np.array([problem.distance(a, b) for a, b in zip(path[:-1], path[1:], strict=True)])
        cum = np.concatenate([[0.0], np.cumsum(seg)])
        total = cum[-1]
        if total <= 0:
            break
        s, t = np.sort(rng.random(2) * total)
        ia = min(int(np.searchsorted(cum, s, side="right")) - 1, len(seg) - 1)
        ib = min(int(np.searchsorted(cum, t, side="right")) - 1, len(seg) - 1)
        if ib <= ia:
            continue
        interpolate(kind, path[ia], path[ia + 1], (s - cum[ia]) / seg[ia] if seg[ia] > 0 else 0.0, pa)
        interpolate(kind, path[ib], path[ib + 1], (t - cum[ib]) / seg[ib] if seg[ib] > 0 else 0.0, pb)
        if problem.distance(pa, pb) >= t - s - 1e-12 or not world.check_motion(pa, pb):
            continue
        path = np.concatenate([path[: ia + 1], [pa.copy(), pb.copy()], path[ib + 1 :]])
        # drop repeated states created when a cut lands on a vertex
        keep = np.ones(len(path), dtype=bool)
        keep[1:] = np.any(path[1:] != path[:-1], axis=1)
        path = path[keep]
    return path


def smooth(path, problem: Problem, *, seed: int = 0, attempts: int = 200) -> np.ndarray:
    """``simplify``, then ``shortcut``, then ``simplify`` again."""
    path = simplify(path, problem)
    path = shortcut(path, problem, seed=seed, attempts=attempts)
    return simplify(path, problem)
