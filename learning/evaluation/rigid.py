"""Planners x samplers on a set of 6-DoF rigid-body scenes: rows of iterations, success, collision checks and time.

The planners are the seed project's set-ups on the box body (``planners.worlds.rigid3d``), with the
sampler swapped in:

* ``RRT``: step 0.01 of the workspace's longest side, goal distance 1.0, at most 20,000 iterations
  (the seed set-up's 5% goal bias is the ``goal_bias`` sampler here);
* ``RRTConnect``: the same step, at most 20,000 iterations;
* ``PRM``: k = 3 nearest neighbours, Dijkstra on the roadmap, at most 5,000 samples.

The samplers are names of the one registry (``learning.samplers.registry.make_sampler``); the
default list holds the references of the 6-DoF comparison: ``uniform``, ``goal_bias``, OMPL's
``gaussian`` and ``bridge_test``, OB-PRM's ``obstacle_based``, and ``rigid_workspace_route`` (the exact
workspace route of the body's centre with uniform orientations: the no-learning ablation).

Every run is seeded. A row counts a run's collision checks as the planner's plus those the sampler
made to place its samples (Gaussian, bridge test, obstacle-based), and its time from building the
planner (a sampler's per-scene preparation, such as the route search, included) to the end of the
solve, one-off compilation left out. ``summarize`` gives per planner and sampler the success rate and
the medians, an unsolved run counting at its iteration cap (as the 2-D comparison does).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass

import numpy as np

from planners import PRM, RRT, Problem, RRTConnect
from planners.base.fileio import InputError
from planners.base.planner import compile_seconds
from planners.worlds.rigid3d import PRM_SETUP, RRT_SETUP
from planners.worlds.rigid_scenes import MeshSceneSet, RigidSceneSet, SceneQuery

#: The planners of the comparison, and their iteration caps (PRM: samples).
PLANNERS = ("RRT", "RRTConnect", "PRM")
CAPS = {"RRT": RRT_SETUP["max_iterations"], "RRTConnect": RRT_SETUP["max_iterations"], "PRM": PRM_SETUP["samples"]}
#: The samplers compared unless told otherwise (registry names).
SAMPLERS = ("uniform", "goal_bias", "gaussian", "bridge_test", "obstacle_based", "rigid_workspace_route")


@dataclass(frozen=True)
class RigidRow:
    """One run: which scene, planner, sampler and seed, and what it cost."""

    scene: str
    family: str
    part: str
    planner: str
    sampler: str
    seed: int
    solved: bool
    iterations: int
    cap: int
    collision_checks: int
    sampler_checks: int
    candidates: int
    time: float

    def as_dict(self) -> dict:
        return asdict(self)


def build_planner(name: str, problem: Problem, sampler, seed: int):
    """The seed set-up of planner ``name`` on ``problem`` with ``sampler``: ``(planner, iteration cap)``."""
    if name not in PLANNERS:
        raise InputError(f"unknown rigid-body planner {name!r}; choose from {', '.join(PLANNERS)}")
    world = problem.world
    if name == "PRM":
        p = problem.with_query(problem.start, problem.goal, metric="cossin")
        return PRM(p, k=PRM_SETUP["k"], search=PRM_SETUP["search"], sampler=sampler, seed=seed), CAPS[name]
    step = RRT_SETUP["step_fraction"] * float(np.max(world.high3 - world.low3))
    p = problem.with_query(problem.start, problem.goal, metric="cossin", goal_tolerance=RRT_SETUP["goal_distance"])
    cls = RRT if name == "RRT" else RRTConnect
    return cls(p, step_size=step, sampler=sampler, seed=seed), CAPS[name]


def run_one(problem: Problem, planner: str, sampler: str, seed: int, *, params: dict | None = None,
            scene: SceneQuery | None = None, max_iterations: int | None = None) -> RigidRow:
    """One seeded run of ``planner`` with the registry's ``sampler`` (``params`` its parameters) on ``problem``."""
    from learning.samplers.registry import make_sampler

    made = make_sampler(sampler, **(params or {}))
    c0, t0 = compile_seconds(), time.perf_counter()
    pl, cap = build_planner(planner, problem, made, seed)
    cap = cap if max_iterations is None else min(cap, max_iterations)
    result = pl.solve(max_iterations=cap)
    elapsed = time.perf_counter() - t0 - (compile_seconds() - c0)
    sampler_checks = int(getattr(pl.sampler, "checks", 0))
    checks = int(result.collision_checks) + sampler_checks  # these planners leave the sampler's checks out
    return RigidRow(scene=problem.name if scene is None else scene.name,
                    family="" if scene is None else scene.family, part="" if scene is None else scene.part,
                    planner=planner, sampler=sampler, seed=int(seed), solved=bool(result.solved),
                    iterations=int(result.iterations), cap=int(cap), collision_checks=checks,
                    sampler_checks=sampler_checks, candidates=int(result.candidates), time=float(elapsed))


def evaluate_rigid(scene_set: RigidSceneSet | MeshSceneSet, part: str, *, planners: Sequence[str] = PLANNERS,
                   samplers: Sequence[str] = SAMPLERS, seeds: Iterable[int] = (0,),
                   sampler_params: dict[str, dict] | None = None, max_iterations: int | None = None,
                   progress: Callable[[RigidRow], None] | None = None) -> list[RigidRow]:
    """Every planner with every sampler on every scene of ``part`` of ``scene_set``, once per seed.

    Args:
        scene_set: The scenes (``RigidSceneSet``, or the test-only ``MeshSceneSet``).
        part: ``validation``, ``tuning`` or ``test`` (a mesh set: ``test``).
        planners: Names from ``PLANNERS``.
        samplers: Registry names.
        seeds: Planner seeds; each run's seed is this seed (the scene fixes the rest).
        sampler_params: Parameters by sampler name (``make_sampler(name, **params)``).
        max_iterations: Lower every planner's cap to this (quick looks; the seed set-ups' caps otherwise).
        progress: Called with each row as it is made.

    Returns:
        The rows, scene by scene, then planner, sampler and seed.
    """
    from learning.samplers.registry import sampler_names

    for name in planners:
        if name not in PLANNERS:
            raise InputError(f"unknown rigid-body planner {name!r}; choose from {', '.join(PLANNERS)}")
    known = set(sampler_names())
    for name in samplers:
        if name not in known:
            raise InputError(f"unknown sampler {name!r}; choose from {', '.join(sorted(known))}")
    seeds = list(seeds)
    params = sampler_params or {}
    rows = []
    for query in scene_set.queries(part):
        problem = scene_set.problem(query)
        for planner in planners:
            for sampler in samplers:
                for seed in seeds:
                    row = run_one(problem, planner, sampler, seed, params=params.get(sampler), scene=query,
                                  max_iterations=max_iterations)
                    rows.append(row)
                    if progress is not None:
                        progress(row)
    return rows


def summarize(rows: Sequence[RigidRow], by: Sequence[str] = ("planner", "sampler")) -> list[dict]:
    """Per group of ``by``: runs, solved, success rate, and medians of iterations, checks and time.

    An unsolved run counts at its iteration cap, and with the time it spent.
    """
    groups: dict[tuple, list[RigidRow]] = {}
    for r in rows:
        groups.setdefault(tuple(getattr(r, k) for k in by), []).append(r)
    out = []
    for key, rs in groups.items():
        its = [r.iterations if r.solved else r.cap for r in rs]
        out.append({**dict(zip(by, key, strict=True)), "runs": len(rs), "solved": sum(r.solved for r in rs),
                    "success": sum(r.solved for r in rs) / len(rs), "median_iterations": float(np.median(its)),
                    "median_checks": float(np.median([r.collision_checks for r in rs])),
                    "median_time": float(np.median([r.time for r in rs]))})
    return out


def format_table(summary: Sequence[dict], by: Sequence[str] = ("planner", "sampler")) -> str:
    """``summarize``'s rows as a Markdown table."""
    head = [*by, "runs", "success", "median iterations", "median checks", "median time (s)"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for s in summary:
        cells = [str(s[k]) for k in by] + [str(s["runs"]), f"{s['solved']}/{s['runs']}",
                                           f"{s['median_iterations']:,.0f}", f"{s['median_checks']:,.0f}",
                                           f"{s['median_time']:.2f}"]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)
