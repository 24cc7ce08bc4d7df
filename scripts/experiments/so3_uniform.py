"""Uniform orientations for the 6-DoF body: uniform Euler angles against rotations uniform over SO(3), on tuning scenes.

    PYTHONPATH=$PWD python scripts/experiments/so3_uniform.py --scenes 6 --seeds 2

A uniform sample of the rigid body draws its Euler angles uniformly in ``[-pi, pi)^3``. With
``H = Ry(ty) Rx(tx) Rz(tz)`` that is not uniform over rotations: relative to the Haar measure its density
grows as ``1 / |cos tx|``, so rotations near ``tx = +-pi/2`` are drawn far too often and those near
``tx = 0`` (where the scenes' starts and goals lie) about 0.64 times as often as uniform. OMPL samples
rotations uniformly (uniform unit quaternions). ``HaarSampler`` keeps the positions and draws the rotation
from a uniform unit quaternion, written as Euler angles on either of the two covers of the angle box
(``(tx, ty, tz)`` or ``(pi - tx, ty + pi, tz + pi)``, the same rotation) with probability 1/2 each.

Runs RRT-Connect with uniform sampling and RRT with goal bias 0.05, each with today's angles and with
``HaarSampler``, the seed set-ups, on the tuning part of the box scene set (never validation or test, never
an OMPL.app problem), and prints success and median iterations (an unsolved run at its cap) per row.
"""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np

from planners.base.samplers import SamplerBase


def haar_euler(rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` rotations uniform over SO(3), as ``(tx, ty, tz)`` with ``H = Ry(ty) Rx(tx) Rz(tz)``, either cover."""
    u1, u2, u3, cover = rng.random((4, n))
    # Shoemake's uniform unit quaternion (w, x, y, z)
    a, b = np.sqrt(1.0 - u1), np.sqrt(u1)
    x, y = a * np.sin(2 * math.pi * u2), a * np.cos(2 * math.pi * u2)
    z, w = b * np.sin(2 * math.pi * u3), b * np.cos(2 * math.pi * u3)
    r02, r12, r22 = 2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)
    r10, r11 = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z)
    tx = np.arcsin(np.clip(-r12, -1.0, 1.0))
    ty, tz = np.arctan2(r02, r22), np.arctan2(r10, r11)
    other = cover < 0.5
    tx = np.where(other, math.pi - tx, tx)
    ty, tz = np.where(other, ty + math.pi, ty), np.where(other, tz + math.pi, tz)
    wrap = lambda t: (t + math.pi) % (2 * math.pi) - math.pi  # noqa: E731
    return np.stack([wrap(tx), wrap(ty), wrap(tz)], axis=1)


class HaarSampler(SamplerBase):
    """Positions uniform in the box, rotations uniform over SO(3) (``haar_euler``), the goal with ``goal_bias``."""

    def __init__(self, goal_bias: float = 0.0) -> None:
        self.goal_bias = float(goal_bias)

    def draw(self, rng, n, view):
        u = rng.random((n, 4))
        pts = np.empty((n, 6))
        pts[:, :3] = self.low[:3] + (self.high[:3] - self.low[:3]) * u[:, 1:]
        pts[:, 3:] = haar_euler(rng, n)
        pts[u[:, 0] < self.goal_bias] = self.problem.goal
        return pts


def check_conversion() -> None:
    """The Euler angles ``haar_euler`` writes give back the quaternion's rotation, on both covers."""
    from planners.worlds.rigid3d import rotation_matrix

    rng = np.random.default_rng(0)
    angles = haar_euler(rng, 200)
    for t in angles:
        R = rotation_matrix(*t)
        assert np.allclose(R @ R.T, np.eye(3)) and abs(np.linalg.det(R) - 1) < 1e-9
    a = angles[0]
    same = np.array([math.pi - a[0], a[1] + math.pi, a[2] + math.pi])
    assert np.allclose(rotation_matrix(*a), rotation_matrix(*same))
    # uniform over rotations: the rotation angle's density is (1 - cos t) / pi, mean pi / 2 + 2 / pi
    R = np.stack([rotation_matrix(*t) for t in haar_euler(rng, 20000)])
    ang = np.arccos(np.clip((np.trace(R, axis1=1, axis2=2) - 1) / 2, -1, 1))
    assert abs(ang.mean() - (math.pi / 2 + 2 / math.pi)) < 0.02, ang.mean()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", type=int, default=6, help="tuning scenes per training family")
    ap.add_argument("--seeds", type=int, default=2)
    args = ap.parse_args(argv)
    if args.scenes < 1 or args.seeds < 1:
        ap.error(f"--scenes and --seeds must be at least 1, got {args.scenes} and {args.seeds}")

    from learning.evaluation.rigid import build_planner
    from planners.base.samplers import GoalBiasedSampler, UniformSampler
    from planners.worlds.rigid_scenes import RigidSceneSet

    check_conversion()
    scenes = RigidSceneSet(counts={"tuning": args.scenes}, test_only=())
    rows = {
        ("RRTConnect", "uniform angles"): UniformSampler,
        ("RRTConnect", "uniform rotations"): HaarSampler,
        ("RRT", "goal bias 0.05, uniform angles"): lambda: GoalBiasedSampler(0.05),
        ("RRT", "goal bias 0.05, uniform rotations"): lambda: HaarSampler(0.05),
    }
    results: dict[tuple, list[tuple[bool, int]]] = {k: [] for k in rows}
    families: dict[tuple, dict[str, list[int]]] = {k: {} for k in rows}
    for query in scenes.queries("tuning"):
        problem = scenes.problem(query)
        for (planner, label), make in rows.items():
            for seed in range(args.seeds):
                pl, cap = build_planner(planner, problem, make(), seed)
                r = pl.solve(max_iterations=cap)
                results[(planner, label)].append((bool(r.solved), int(r.iterations) if r.solved else cap))
                families[(planner, label)].setdefault(query.family, []).append(int(r.solved))
    print("| planner | sampling | success | median iterations | solved by family |\n|---|---|---|---|---|")
    for (planner, label), rs in results.items():
        fam = ", ".join(f"{f} {sum(v)}/{len(v)}" for f, v in sorted(families[(planner, label)].items()))
        print(f"| {planner} | {label} | {sum(s for s, _ in rs)}/{len(rs)} | {np.median([i for _, i in rs]):,.0f} | "
              f"{fam} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
