"""Where the 6-DoF room is: the privileged expert's positions against its orientations, on validation scenes.

    PYTHONPATH=$PWD python scripts/experiments/rigid_room.py --scenes 4 --seeds 2

``rigid_expert`` (``learning.references.rigid_expert``) samples along a solution that long runs found: its
positions and its orientations. The no-learning ablation ``rigid_route_ablation`` samples positions along the
centred workspace route with uniform angles. Two probes split the room between them:

* ``expert positions, uniform angles``: the expert's draw with every orientation uniform;
* ``route positions, expert angles``: the ablation's positions, each (but the goal's, and a tenth kept uniform)
  turned to the orientation of the solution state nearest to it in position, with the expert's 0.1 rad of noise;
* ``route positions, expert angles snapped to a class``: the same, turned instead to the axis-aligned orientation
  nearest the solution's (the orientation model's six classes with the box's symmetry): what the model's classes
  could give if it always named the solution's class (with the solution's own rotation among the class's four,
  or, ``the same, ...``, one at random, the one nearest the nearer end's orientation, or each route point's
  nearest the previous point's, chained from the nearer end's orientation or from the start's all along);
* ``route positions, the nearer end's axis-aligned rotation``: no solution and no model: every turned sample takes
  the axis-aligned rotation nearest the orientation of the query's end (start or goal) nearer to it.

Runs these samplers (and ``rigid_route``, the learned sampler) with RRT-Connect and RRT, or PRM (``--planners``; the
seed set-ups) on the validation or tuning part of the box scene set (never test, never OMPL.app) and prints success
and median iterations (PRM: samples; an unsolved run at its cap) per row.
A look at where learning has room, not a choice of any setting.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from learning.references.rigid_expert import RigidExpertSampler, nearest_cover
from learning.samplers.registry import make_sampler
from learning.samplers.rigid_route import rotation_chain
from planners.base.samplers import SamplerBase
from planners.guidance.rigid_orientation import (
    class_rotations,
    euler_from_matrices,
    nearer_end,
    nearest_class,
    small_rotations,
)
from planners.worlds.mesh import rotation_matrices


class ExpertPositions(RigidExpertSampler):
    """``rigid_expert`` with every orientation uniform: what its positions alone give."""

    def draw(self, rng, n, view):
        pts = super().draw(rng, n, view)
        n = len(pts)  # a draw that follows the trees returns fewer
        goal = np.all(pts == self.problem.goal, axis=1)
        angles = self._uniform(rng.random((n, self.problem.dim)))[:, 3:]
        pts[~goal, 3:] = angles[~goal]
        return pts


class EndAngles(SamplerBase):
    """The ablation's positions, turned to the axis-aligned rotation nearest the nearer end's: no solution, no model."""

    def __init__(self, uniform_share: float = 0.1, angle_noise: float = 0.1, follow: float = 0.0) -> None:
        self.uniform_share, self.angle_noise, self.follow = float(uniform_share), float(angle_noise), float(follow)

    def _setup(self) -> None:
        self.positions = make_sampler("rigid_route_ablation", follow=self.follow).bind(self.problem)
        ends = rotation_matrices(np.stack([self.problem.start[3:], self.problem.goal[3:]]))
        cls, sym = nearest_class(ends)
        self.targets = class_rotations()[cls, sym]

    def draw(self, rng, n, view):
        pts = self.positions.draw(rng, n, view)
        n = len(pts)  # a draw that follows the trees returns fewer
        u = rng.random((n, 4))
        turn = ~np.all(pts == self.problem.goal, axis=1) & (u[:, 0] >= self.uniform_share)
        if turn.any():
            near_goal = nearer_end(pts[turn], self.problem.start, self.problem.goal)
            z = rng.standard_normal((int(turn.sum()), 3))
            pts[turn, 3:] = euler_from_matrices(small_rotations(self.angle_noise * z) @ self.targets[near_goal])
        return pts


def chain_rotations(route: np.ndarray, states: np.ndarray, problem, start_only: bool = False) -> np.ndarray:
    """Per route point, an axis-aligned rotation of the solution's class there, each the nearest to the one before.

    ``rigid_route``'s ``rotation_chain`` with the class at a route point the nearest solution state's (not the
    model's): from the start's orientation forward and from the goal's backward, each point taking the chain from the
    end nearer along the route, or (``start_only``) the chain from the start everywhere.
    """
    near = ((route[:, None, :] - states[None, :, :3]) ** 2).sum(axis=2).argmin(axis=1)
    cls = nearest_class(rotation_matrices(states[near, 3:]))[0]
    ends = rotation_matrices(np.stack([problem.start[3:], problem.goal[3:]]))
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(route, axis=0), axis=1))])
    return rotation_chain(class_rotations(), cls, ends, arc, start_only=start_only)


class ExpertAngles(SamplerBase):
    """The ablation's positions, turned to the nearest solution state's orientation: what its angles alone give.

    ``snap``: the axis-aligned orientation (of the six classes' 24, ``class_rotations``) nearest the solution's
    instead: what the orientation model's classes could give if it always picked the solution's class.
    """

    def __init__(self, uniform_share: float = 0.1, angle_noise: float = 0.1, snap: bool = False,
                 symmetry: str = "solution", follow: float = 0.0) -> None:
        self.uniform_share, self.angle_noise, self.snap = float(uniform_share), float(angle_noise), bool(snap)
        self.symmetry, self.follow = symmetry, float(follow)

    def _setup(self) -> None:
        self.positions = make_sampler("rigid_route_ablation", follow=self.follow).bind(self.problem)
        self.expert = RigidExpertSampler().bind(self.problem)
        if self.symmetry in ("chain", "chain from the start") and self.expert.states is not None:
            self.route, self.chain = self.positions.route, chain_rotations(
                self.positions.route, self.expert.states, self.problem, self.symmetry == "chain from the start")

    def draw(self, rng, n, view):
        pts = self.positions.draw(rng, n, view)
        n = len(pts)  # a draw that follows the trees returns fewer
        states = self.expert.states
        if states is None:
            return pts
        u = rng.random((n, 4))
        turn = ~np.all(pts == self.problem.goal, axis=1) & (u[:, 0] >= self.uniform_share)
        if turn.any():
            d = ((pts[turn, None, :3] - states[None, :, :3]) ** 2).sum(axis=2)
            base = states[d.argmin(axis=1), 3:]
            z = rng.standard_normal((int(turn.sum()), 3))
            target = rotation_matrices(base)
            if self.snap:  # the nearest of the 24 axis-aligned rotations
                rots = class_rotations()
                cls, sym = nearest_class(target)
                if self.symmetry == "random":  # the class's rotation drawn among its four, as the sampler does
                    sym = rng.integers(4, size=len(cls))
                elif self.symmetry == "ends":  # the class's rotation nearest the start's or the goal's, the nearer end
                    ends = rotation_matrices(np.stack([self.problem.start[3:], self.problem.goal[3:]]))
                    near_goal = nearer_end(pts[turn], self.problem.start, self.problem.goal)
                    sym = np.einsum("nsij,nij->ns", rots[cls], ends[near_goal]).argmax(axis=1)
                elif self.symmetry.startswith("chain"):  # nearest the chained rotation at the nearest route point
                    j = ((pts[turn, None, :3] - self.route[None, :, :]) ** 2).sum(axis=2).argmin(axis=1)
                    sym = np.einsum("nsij,nij->ns", rots[cls], self.chain[j]).argmax(axis=1)
                target = rots[cls, sym]
            R = small_rotations(self.angle_noise * z) @ target
            pts[turn, 3:] = nearest_cover(euler_from_matrices(R), base)
        return pts


def main(argv=None) -> int:
    from learning.evaluation.rigid import build_planner
    from planners.worlds.rigid_scenes import TRAINING_FAMILIES, RigidSceneSet

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenes", type=int, default=4, help="validation scenes per family")
    ap.add_argument("--seeds", type=int, default=2, help="planner seeds per scene")
    ap.add_argument("--planners", nargs="+", default=["RRTConnect", "RRT"], choices=["RRTConnect", "RRT", "PRM"],
                    help="planners at their seed set-ups (PRM: samples, not iterations)")
    ap.add_argument("--part", default="validation", choices=["validation", "tuning"])
    ap.add_argument("--only", nargs="+", help="run only these rows (sampler names as printed)")
    ap.add_argument("--families", nargs="+", default=list(TRAINING_FAMILIES), choices=TRAINING_FAMILIES,
                    help="scene families (default every training family)")
    ap.add_argument("--follow", type=float, default=0.0, metavar="F",
                    help="the route samples of the ablation's positions (and of rigid_route, and the expert's along "
                         "its solution) in windows of F body radii about the trees' reach (rigid_route's follow); "
                         "default 0: along the whole route, as the runs the docs quote drew them")
    args = ap.parse_args(argv)
    if args.scenes < 1 or args.seeds < 1:
        ap.error("--scenes and --seeds must be at least 1")
    if not args.follow >= 0:
        ap.error(f"--follow must be at least 0, got {args.follow:g}")
    f = args.follow
    samplers = {"rigid_route_ablation": lambda: make_sampler("rigid_route_ablation", follow=f),
                "expert positions, uniform angles": lambda: ExpertPositions(follow=f),
                "route positions, expert angles": lambda: ExpertAngles(follow=f),
                "route positions, expert angles snapped to a class": lambda: ExpertAngles(snap=True, follow=f),
                "the same, the class's rotation at random": lambda: ExpertAngles(snap=True, symmetry="random",
                                                                                  follow=f),
                "the same, the class's rotation nearest the nearer end's": lambda: ExpertAngles(
                    snap=True, symmetry="ends", follow=f),
                "the same, the class's rotation chained from the nearer end": lambda: ExpertAngles(
                    snap=True, symmetry="chain", follow=f),
                "the same, the class's rotation chained from the start": lambda: ExpertAngles(
                    snap=True, symmetry="chain from the start", follow=f),
                "route positions, the nearer end's axis-aligned rotation": lambda: EndAngles(follow=f),
                "rigid_route": lambda: make_sampler("rigid_route", follow=f),
                "rigid_expert": lambda: RigidExpertSampler(follow=f)}
    scenes = RigidSceneSet(tuple(args.families), (), {args.part: args.scenes})
    if args.only:
        unknown = sorted(set(args.only) - set(samplers))
        if unknown:
            ap.error(f"--only: unknown rows {unknown}; choose from {sorted(samplers)}")
        samplers = {k: v for k, v in samplers.items() if k in args.only}
    every = scenes.queries(args.part)
    queries = [q for fam in scenes.families for q in [v for v in every if v.family == fam][:args.scenes]]
    rows: dict[tuple[str, str], list[tuple[bool, int]]] = {}
    for q in queries:
        problem = scenes.problem(q)
        for planner in args.planners:
            for name, make in samplers.items():
                for seed in range(args.seeds):
                    pl, cap = build_planner(planner, problem, make(), seed)
                    r = pl.solve(max_iterations=cap)
                    its = int(r.iterations if r.solved else cap)
                    rows.setdefault((planner, name), []).append((bool(r.solved), its))
        print(f"  {q.family} {q.seed} done", file=sys.stderr, flush=True)
    print("| planner | sampler | success | median iterations |\n|---|---|---|---|")
    for (planner, name), rs in rows.items():
        print(f"| {planner} | {name} | {sum(s for s, _ in rs)}/{len(rs)} | {np.median([i for _, i in rs]):,.0f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
