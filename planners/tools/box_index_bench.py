"""What a pose check costs among many boxes, with the spatial index and with a full scan, and whether time limits hold.

Behind ``scripts/benchmark_boxes.py``. The scenes are ``random_box_world``: ``n`` small boxes strewn over
a 100-unit cube, the seed project's 10 x 5 x 2.5 body; every figure is seeded.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from planners.base.problem import Problem
from planners.kernels import rigid as rigid_kernels
from planners.worlds.rigid3d import RigidBodyWorld, box_body

#: Side of the cubic workspace of the benchmark scenes.
SIZE = 100.0


def random_box_world(n: int, seed: int = 0, *, sides=(0.5, 2.0), delta: float = 0.5) -> RigidBodyWorld:
    """``n`` boxes with sides uniform in ``sides`` at uniform places in a 100-unit cube, the 10 x 5 x 2.5 body."""
    rng = np.random.default_rng(seed)
    corner = rng.uniform(0.0, SIZE, (n, 3))
    boxes = np.hstack([corner, corner + rng.uniform(*sides, (n, 3))])
    return RigidBodyWorld(boxes, box_body(10, 5, 2.5), low=(0, 0, 0), high=(SIZE, SIZE, SIZE), delta=delta)


@dataclass(frozen=True)
class PoseCost:
    """Microseconds per pose check (a compiled loop over ``poses`` poses), indexed and by a full scan."""

    boxes: int
    poses: int
    indexed_us: float
    scan_us: float
    disagreements: int


def pose_check_cost(n: int, poses: int = 20_000, seed: int = 0) -> PoseCost:
    """The cost of one pose check among ``n`` boxes (``random_box_world``), with the world's index and without.

    Both run the same compiled check on the same seeded poses (margin ``delta / 2``, as a motion
    check asks); ``disagreements`` counts poses where the two answers differ (always 0).
    """
    world = random_box_world(n, seed)
    k = world.kernel
    rng = np.random.default_rng(seed + 1)
    qs = np.column_stack([rng.uniform(6, SIZE - 6, (poses, 3)), rng.uniform(-np.pi, np.pi, (poses, 3))])
    margin = 0.5 * world.delta
    out = {}
    for label, params in (("indexed", k.params), ("scan", k.params[:rigid_kernels.N_PLAIN])):
        answers = np.empty(poses, dtype=np.bool_)
        rigid_kernels.states_clear(k.geom, k.grid, k.body, params, qs[:10], margin, answers[:10])  # compile
        t0 = time.perf_counter()
        rigid_kernels.states_clear(k.geom, k.grid, k.body, params, qs, margin, answers)
        out[label] = ((time.perf_counter() - t0) / poses * 1e6, answers)
    return PoseCost(n, poses, out["indexed"][0], out["scan"][0], int(np.sum(out["indexed"][1] != out["scan"][1])))


def time_limit_overrun(planner: str, n: int, time_limit: float = 1.0, delta: float = 0.003, seed: int = 0) -> float:
    """Seconds ``planner`` (a registered name) takes under ``time_limit`` among ``n`` boxes at ``delta``."""
    from planners.base.registry import make_planner

    world = random_box_world(n, seed, delta=delta)
    rng = np.random.default_rng(seed + 2)
    ends = []
    while len(ends) < 2:
        q = np.concatenate([rng.uniform(6, SIZE - 6, 3), rng.uniform(-np.pi, np.pi, 3)])
        if world.is_valid(q):
            ends.append(q)
    problem = Problem(world, ends[0], ends[1], goal_tolerance=1.0)
    make_planner(planner, problem, seed=seed).solve(max_iterations=5)  # compile outside the timing
    t0 = time.perf_counter()
    make_planner(planner, problem, seed=seed).solve(time_limit=time_limit)
    return time.perf_counter() - t0
