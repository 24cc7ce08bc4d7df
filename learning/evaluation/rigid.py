"""Planners x samplers on a set of 6-DoF rigid-body scenes: rows of iterations, success, collision checks and time.

The planners are the seed project's set-ups on the box body (``planners.worlds.rigid3d``), with the
sampler swapped in:

* ``RRT``: step 0.01 of the workspace's longest side, goal distance 1.0, at most 20,000 iterations
  (the seed set-up's 5% goal bias is the ``goal_bias`` sampler here);
* ``RRTConnect``: the same step, at most 20,000 iterations;
* ``PRM``: k = 3 nearest neighbours, Dijkstra on the roadmap, at most 5,000 samples.

The samplers are names of the one registry (``learning.samplers.registry.make_sampler``); the
default list holds the samplers of the 6-DoF comparison: ``uniform``, ``goal_bias``, OMPL's
``gaussian`` and ``bridge_test``, OB-PRM's ``obstacle_based``, ``rigid_workspace_route`` (the exact
workspace route of the body's centre with uniform orientations: the no-learning ablation), the learned
``rigid_route`` and its own ablation, and ``rigid_expert``, the privileged reference that samples along a solution
long runs found before the run (``learning.references.rigid_expert``): how much room a sampler has.

Every run is seeded. A row counts a run's collision checks as the planner's plus those the sampler
made to place its samples (Gaussian, bridge test, obstacle-based), and its time from building the
planner (a sampler's per-scene preparation, such as the route search, included) to the end of the
solve, one-off compilation left out. ``summarize`` gives per planner and sampler the success rate and
the medians, an unsolved run counting at its iteration cap (as the 2-D comparison does).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from learning.evaluation.protocol import Protocol
from learning.samplers.registry import REFERENCES
from planners import PRM, RRT, Problem, RRTConnect, solve_with_restarts
from planners.base.fileio import InputError
from planners.base.planner import compile_seconds
from planners.worlds.rigid3d import PRM_SETUP, RRT_SETUP, seed_step
from planners.worlds.rigid_scenes import MeshSceneSet, RigidSceneSet, SceneQuery

#: The planners of the comparison, and their iteration caps (PRM: samples).
PLANNERS = ("RRT", "RRTConnect", "PRM")
CAPS = {"RRT": RRT_SETUP["max_iterations"], "RRTConnect": RRT_SETUP["max_iterations"], "PRM": PRM_SETUP["samples"]}
#: The samplers compared unless told otherwise (registry names).
SAMPLERS = ("uniform", "goal_bias", "gaussian", "bridge_test", "obstacle_based", "rigid_workspace_route",
            "rigid_route_ablation", "rigid_route", "rigid_expert")


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


def planner_setup(name: str, problem: Problem) -> tuple[Problem, dict]:
    """The seed set-up of planner ``name`` on ``problem``: the query as it plans it and ``make_planner``'s arguments."""
    if name not in PLANNERS:
        raise InputError(f"unknown rigid-body planner {name!r}; choose from {', '.join(PLANNERS)}")
    if name == "PRM":
        return problem.with_query(problem.start, problem.goal, metric="cossin"), \
            {"k": PRM_SETUP["k"], "search": PRM_SETUP["search"]}
    p = problem.with_query(problem.start, problem.goal, metric="cossin", goal_tolerance=RRT_SETUP["goal_distance"])
    return p, {"step_size": seed_step(problem.world)}


def build_planner(name: str, problem: Problem, sampler, seed: int):
    """The seed set-up of planner ``name`` on ``problem`` with ``sampler``: ``(planner, iteration cap)``."""
    p, kwargs = planner_setup(name, problem)
    cls = {"PRM": PRM, "RRT": RRT, "RRTConnect": RRTConnect}[name]
    return cls(p, sampler=sampler, seed=seed, **kwargs), CAPS[name]


def run_one(problem: Problem, planner: str, sampler: str, seed: int, *, params: dict | None = None,
            scene: SceneQuery | None = None, max_iterations: int | None = None, spec: str | None = None,
            restarts: int = 0) -> RigidRow:
    """One seeded run of ``planner`` with the registry's ``sampler`` (``params`` its parameters) on ``problem``.

    ``spec``: a user's sampler instead (``learning.samplers.registry.user_sampler``: ``MODEL.zip@ENV_ID`` for a
    Stable-Baselines3 model trained on a SamplerGym id, or ``module:callable``), labelled ``sampler`` in the row.
    ``restarts``: a tree planner's run restarts after Luby's sequence times this many iterations
    (``planners.solve_with_restarts``, the cap over all attempts); 0: one run.
    """
    cap = run_cap(planner, max_iterations, restarts)  # before the sampler is made: a bad run costs nothing
    made = make_run_sampler(sampler, params, spec)
    c0, t0 = compile_seconds(), time.perf_counter()
    result, _, sampler_checks = solve_run(problem, planner, made, seed, max_iterations=cap, restarts=restarts)
    elapsed = time.perf_counter() - t0 - (compile_seconds() - c0)
    checks = int(result.collision_checks) + sampler_checks  # these planners leave the sampler's checks out
    return RigidRow(scene=problem.name if scene is None else scene.name,
                    family="" if scene is None else scene.family, part="" if scene is None else scene.part,
                    planner=planner, sampler=sampler, seed=int(seed), solved=bool(result.solved),
                    iterations=int(result.iterations), cap=int(cap), collision_checks=checks,
                    sampler_checks=sampler_checks, candidates=int(result.candidates), time=float(elapsed))


def run_cap(planner: str, max_iterations: int | None = None, restarts: int = 0) -> int:
    """A run's iteration cap: the planner's set-up's, lowered to ``max_iterations``; restarts are refused for PRM."""
    if restarts and planner == "PRM":
        raise InputError("restarts are for the tree planners (RRT, RRTConnect): a roadmap would throw its samples away")
    return CAPS[planner] if max_iterations is None else min(CAPS[planner], max_iterations)


def make_run_sampler(sampler: str, params: dict | None = None, spec: str | None = None):
    """The sampler of a run: the registry's ``sampler`` with ``params``, or a user's ``spec`` (``run_one``)."""
    from learning.samplers.registry import make_sampler, user_sampler

    return user_sampler(spec) if spec is not None else make_sampler(sampler, **(params or {}))


def solve_run(problem: Problem, planner: str, sampler, seed: int, *, max_iterations: int | None = None,
              restarts: int = 0):
    """``run_one``'s solve with a made ``sampler``, untimed: ``(PlanResult, the problem as planned, the sampler's own
    collision checks)``.

    Every run is seeded, so the same arguments give the same run: a row's path (the rows keep none) is had again
    from its scene with a fresh sampler (``make_run_sampler``).
    """
    cap = run_cap(planner, max_iterations, restarts)
    if restarts:
        counted = []
        p, kwargs = planner_setup(planner, problem)
        result = solve_with_restarts(planner, p, seed=seed, unit=restarts, max_iterations=cap, sampler=sampler,
                                     on_attempt=lambda pl: counted.append(int(getattr(pl.sampler, "checks", 0))),
                                     **kwargs)
        return result, p, sum(counted)
    pl, _ = build_planner(planner, problem, sampler, seed)
    result = pl.solve(max_iterations=cap)
    return result, pl.problem, int(getattr(pl.sampler, "checks", 0))


def check_names(planners: Sequence[str], samplers: Sequence[str], users: dict[str, str]) -> None:
    """Refuse, naming it, a planner not in ``PLANNERS``, a sampler the registry has not, or a user's sampler
    (``users``: label -> spec) labelled as a registered one.
    """
    from learning.samplers.registry import sampler_names

    for name in planners:
        if name not in PLANNERS:
            raise InputError(f"unknown rigid-body planner {name!r}; choose from {', '.join(PLANNERS)}")
    known = set(sampler_names())
    for name in samplers:
        if name not in known:
            raise InputError(f"unknown sampler {name!r}; choose from {', '.join(sorted(known))}")
    for name in users:
        if name in known or name in samplers:
            raise InputError(f"user sampler {name!r}: the name is a registered sampler's; choose another")


def evaluate_rigid(scene_set: RigidSceneSet | MeshSceneSet, part: str, *, planners: Sequence[str] = PLANNERS,
                   samplers: Sequence[str] = SAMPLERS, seeds: Iterable[int] = (0,),
                   sampler_params: dict[str, dict] | None = None, max_iterations: int | None = None,
                   progress: Callable[[RigidRow], None] | None = None,
                   user_samplers: dict[str, str] | None = None, restarts: int = 0) -> list[RigidRow]:
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
        user_samplers: A user's samplers by label (``NAME`` to ``SPEC``, as ``scripts/evaluate.py --sampler
            NAME=SPEC`` takes them: ``learning.samplers.registry.user_sampler``), run after ``samplers``.
        restarts: The tree planners' runs restart by Luby's sequence times this many iterations (``run_one``).

    Returns:
        The rows, scene by scene, then planner, sampler and seed.
    """
    users = dict(user_samplers or {})
    check_names(planners, samplers, users)
    seeds = list(seeds)
    params = sampler_params or {}
    rows = []
    for query in scene_set.queries(part):
        problem = scene_set.problem(query)
        for planner in planners:
            for sampler in [*samplers, *users]:
                for seed in seeds:
                    row = run_one(problem, planner, sampler, seed, params=params.get(sampler), scene=query,
                                  max_iterations=max_iterations, spec=users.get(sampler), restarts=restarts)
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


# --- the scene sets as a part of the one comparison (``learning.evaluation.compare``) ---------------------------

#: The classical options of the 6-DoF comparison and the samplers without learning beyond them (the exact workspace
#: route with uniform angles; ``rigid_route``'s positions with uniform angles): every sampler a part runs that is none
#: of these is a learned sampler, judged against the targets below, against its own ablation where it has one
#: (``ABLATIONS``), else against ``ABLATION``.
CLASSICAL = ("uniform", "goal_bias", "gaussian", "bridge_test", "obstacle_based")
ABLATION = "rigid_workspace_route"
ABLATIONS = {"rigid_route": "rigid_route_ablation"}
NO_LEARNING = (ABLATION, *ABLATIONS.values())
#: The targets of a learned sampler on each scene set, per planner: median iterations at most ``VS_CLASSICAL`` times
#: the best classical option's and ``VS_ABLATION`` times the ablation's, success at least theirs, and median time to
#: solution at most ``TIME_VS_CLASSICAL`` times the best classical option's.
VS_CLASSICAL, VS_ABLATION, TIME_VS_CLASSICAL = 0.3, 0.7, 0.5


@dataclass(frozen=True)
class RigidQuery:
    """A scene of a scene set as a query of the comparison (rebuilt in any worker from its fields).

    ``verify``: the scene set's (``RigidSceneSet.verify``), which decides the scene drawn.
    """

    scene: SceneQuery
    verify: bool = True

    @property
    def map_set(self) -> str:
        """The set its runs are reported under: the family, ``<family> (mesh)``, or ``OMPL.app <problem>`` (each
        problem its own world, so its own set: ``scene_set_of``).
        """
        if self.scene.path:
            return f"OMPL.app {Path(self.scene.path).stem}"
        return f"{self.scene.family} (mesh)" if self.scene.mesh else self.scene.family

    @property
    def split(self) -> str:
        return self.scene.part

    @property
    def size(self) -> int:
        return 0

    def problem(self, movingai_dir: str | None = None, tolerance: float | None = None,
                cache: dict | None = None) -> Problem:
        """The scene (the comparison's tolerance does not apply: the set-ups fix the goal distance)."""
        from planners.worlds.rigid_scenes import mesh_scene, rigid_scene

        q = self.scene
        if q.path:
            from planners.worlds.omplapp import load_omplapp_cfg

            return load_omplapp_cfg(q.path)
        return mesh_scene(q.family, q.seed) if q.mesh else rigid_scene(q.family, q.seed, verify=self.verify)


@dataclass(frozen=True)
class RigidProtocol(Protocol):
    """How a part's runs are made on the scene sets: the seed project's set-ups (``build_planner``).

    ``max_iterations`` lowers every planner's cap (the set-ups' own caps otherwise: RRT and RRT-Connect 20,000,
    PRM 5,000 samples); ``step`` is the set-ups' RRT step on the generated scenes (recorded; the set-ups compute it
    from each workspace).
    """

    step: float = 1.0
    max_iterations: int = CAPS["RRT"]
    seeds: int = 1

    def planner(self, name: str, problem: Problem, sampler, seed: int):
        planner, cap = build_planner(name, problem, sampler, seed)
        return planner, min(cap, self.max_iterations)


@dataclass
class RigidPart:
    """A part of the comparison (``learning.evaluation.Part``): planners x samplers on a part of a scene set.

    Every run is one ``Task`` of the comparison (journaled, resumable, in ``runs.csv`` and the OMPL logs); the
    report is the table per planner and sampler, the table per scene set, and the targets of each learned sampler
    (any sampler that is neither a classical option nor the ablation) marked held or not, scene set by scene set.
    ``users``: a user's samplers by label (``NAME`` to ``SPEC``, ``learning.samplers.registry.user_sampler``; e.g. an
    SB3 model trained on ``SamplerGym/RRT-RigidScenes-v1``), run after ``samplers`` and judged as learned ones.
    """

    scenes: RigidSceneSet | MeshSceneSet
    part: str = "validation"
    planners: Sequence[str] = PLANNERS
    samplers: Sequence[str] = SAMPLERS
    seeds: int = 1
    max_iterations: int | None = None
    name: str = ""
    users: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        check_names(self.planners, self.samplers, self.users)
        self.scenes.queries(self.part)  # refuses a part the set has not, by name
        self.planners, self.samplers = list(self.planners), list(self.samplers)
        self.name = self.name or f"6-DoF scenes ({self.part})"

    @property
    def protocol(self) -> RigidProtocol:
        cap = CAPS["RRT"] if self.max_iterations is None else int(self.max_iterations)
        return RigidProtocol(max_iterations=cap, seeds=self.seeds)

    def tasks(self) -> list:
        from learning.evaluation.roster import Task
        from learning.samplers.registry import SamplerSpec

        verify = bool(getattr(self.scenes, "verify", True))
        specs = [(SamplerSpec.of(s), s) for s in self.samplers]
        specs += [(SamplerSpec.user(name, spec), name) for name, spec in self.users.items()]
        return [Task(RigidQuery(q, verify), planner, spec, seed, label)
                for q in self.scenes.queries(self.part) for planner in self.planners for spec, label in specs
                for seed in range(self.seeds)]

    def rows(self, runs: Sequence) -> list[RigidRow]:
        """The comparison's runs as ``RigidRow`` (an unsolved run's iterations are its cap)."""
        return [RigidRow(scene=r.query, family=r.map, part=r.split, planner=r.planner, sampler=r.sampler,
                         seed=r.seed, solved=r.solved, iterations=r.iterations, cap=r.iterations,
                         collision_checks=r.collision_checks, sampler_checks=0, candidates=r.candidates,
                         time=r.wall_time) for r in runs]

    def report(self, runs: Sequence):
        from learning.evaluation.comparison import PartReport

        rows = self.rows(runs)
        overall = summarize(rows)
        by_set = summarize(rows, ("family", "planner", "sampler"))
        targets = target_rows(by_set)
        text = (f"{self.scenes.describe()}\n\nPart `{self.part}`, {self.seeds} planner seed(s) per scene, the seed "
                "project's set-ups (RRT and RRT-Connect: step 0.01 of the workspace, goal distance 1.0; PRM: k = 3, "
                "Dijkstra); an unsolved run counts at its cap. Checks include the sampler's own; time runs from "
                "building the planner (the sampler's per-scene work included) to the end of the solve.\n\n"
                + format_table(overall) + "\n\nBy scene set:\n\n"
                + format_table(by_set, ("family", "planner", "sampler")))
        if targets:
            text += "\n\n" + targets_markdown(targets)
        return PartReport(text, findings(overall, targets))


def target_rows(by_set: Sequence[dict]) -> list[dict]:
    """Per scene set, planner and learned sampler: its medians against the best classical option and the ablation.

    ``by_set``: ``summarize(rows, ("family", "planner", "sampler"))``. The best classical option is the one of
    fewest median iterations (ties: higher success). Learned: any sampler neither in ``CLASSICAL`` nor the ablation.
    """
    cells = {(s["family"], s["planner"], s["sampler"]): s for s in by_set}
    out = []
    for (family, planner, sampler), s in cells.items():
        if sampler in CLASSICAL or sampler in NO_LEARNING or sampler in REFERENCES:
            continue
        classical = [cells[(family, planner, c)] for c in CLASSICAL if (family, planner, c) in cells]
        ablation = cells.get((family, planner, ABLATIONS.get(sampler, ABLATION)))
        if not classical:
            continue
        best = min(classical, key=lambda c: (c["median_iterations"], -c["success"]))
        row = {"scene set": family, "planner": planner, "sampler": sampler, "best classical": best["sampler"],
               "ablation": ablation["sampler"] if ablation is not None else "",
               "iterations vs classical": s["median_iterations"] / max(best["median_iterations"], 1.0),
               "time vs classical": s["median_time"] / max(best["median_time"], 1e-9),
               "success": f"{s['solved']}/{s['runs']}", "classical success": f"{best['solved']}/{best['runs']}"}
        held = (row["iterations vs classical"] <= VS_CLASSICAL and s["success"] >= best["success"]
                and row["time vs classical"] <= TIME_VS_CLASSICAL)
        if ablation is not None:
            row["iterations vs ablation"] = s["median_iterations"] / max(ablation["median_iterations"], 1.0)
            row["ablation success"] = f"{ablation['solved']}/{ablation['runs']}"
            held = held and row["iterations vs ablation"] <= VS_ABLATION and s["success"] >= ablation["success"]
        row["held"] = held
        out.append(row)
    return out


def scene_set_of(row: RigidRow) -> str:
    """The scene set an ``evaluate_rigid`` row's targets are judged on: its family, ``<family> (mesh)`` for a mesh
    scene (as ``RigidQuery.map_set`` names it), ``OMPL.app <problem>`` for each of OMPL.app's problems (each its own
    world, so each its own set).
    """
    if row.family == "omplapp":
        return f"OMPL.app {row.scene}"
    return f"{row.family} (mesh)" if row.scene.endswith("-mesh") else row.family


def rigid_targets(rows: Sequence[RigidRow]) -> list[dict]:
    """``target_rows`` of ``evaluate_rigid``'s rows, per scene set (``scene_set_of``) and planner: each learned
    sampler's medians against the best classical option and its ablation, ``held`` True or False.

    Empty where the runs hold no learned sampler or no classical option to judge it against.
    """
    labelled = [replace(r, family=scene_set_of(r)) for r in rows]
    return target_rows(summarize(labelled, ("family", "planner", "sampler")))


def targets_markdown(targets: Sequence[dict]) -> str:
    """``target_rows``' rows as a paragraph naming the targets, the table (``held``: yes or no) and a tally."""
    if not targets:
        return ("Targets: none to judge (the runs hold no learned sampler, or no classical option "
                f"({', '.join(CLASSICAL)}) to judge one against).")
    held = sum(bool(t["held"]) for t in targets)
    return ("Targets of each learned sampler, per scene set and planner (iterations at most "
            f"{VS_CLASSICAL:g}x the best classical option's and {VS_ABLATION:g}x the ablation's, success at "
            f"least theirs, time at most {TIME_VS_CLASSICAL:g}x the best classical option's):\n\n"
            + targets_table(targets) + f"\n\nHeld on {held} of {len(targets)} scene sets and planners.")


def targets_table(targets: Sequence[dict]) -> str:
    """``target_rows``' rows as a Markdown table, the ratios to two decimals and ``held`` as yes or no."""
    head = ["scene set", "planner", "sampler", "best classical", "ablation", "iterations vs classical",
            "iterations vs ablation",
            "time vs classical", "success", "classical success", "ablation success", "held"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for t in targets:
        cells = []
        for k in head:
            v = t.get(k, "")
            word = "yes" if v is True else "no" if v is False else str(v)
            cells.append(f"{v:.2f}" if isinstance(v, float) else word)
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def findings(overall: Sequence[dict], targets: Sequence[dict]) -> list[str]:
    """A sentence per planner (the best classical option, the ablation, each learned sampler) and on the targets."""
    out = []
    for planner in dict.fromkeys(s["planner"] for s in overall):
        cells = {s["sampler"]: s for s in overall if s["planner"] == planner}
        classical = [cells[c] for c in CLASSICAL if c in cells]
        parts = []
        if classical:
            best = min(classical, key=lambda c: (c["median_iterations"], -c["success"]))
            parts.append(f"best classical option {best['sampler']} (median {best['median_iterations']:,.0f} "
                         f"iterations, {best['solved']}/{best['runs']} solved)")
        for name, s in cells.items():
            if name in CLASSICAL:
                continue
            role = "no learning" if name in NO_LEARNING else "privileged reference" if name in REFERENCES else "learned"
            parts.append(f"{name} ({role}: median {s['median_iterations']:,.0f}, {s['solved']}/{s['runs']} solved)")
        out.append(f"{planner}: " + "; ".join(parts) + ".")
    if targets:
        held = sum(t["held"] for t in targets)
        out.append(f"The learned sampler's targets hold on {held} of {len(targets)} scene sets and planners.")
    return out


# --- figures: the ECDFs of the runs and a solved passage in 3-D ---------------------------------------------------

#: One colour per sampler of the 6-DoF comparison in every rigid figure (tab10); a user's samplers take
#: ``learning.evaluation.outputs.EXTRA_COLORS`` in turn. The privileged reference is black and dashed.
RIGID_COLORS = {"uniform": "#1f77b4", "goal_bias": "#ff7f0e", "gaussian": "#8c564b", "bridge_test": "#e377c2",
                "obstacle_based": "#bcbd22", "rigid_workspace_route": "#17becf", "rigid_route_ablation": "#9467bd",
                "rigid_route": "#d62728", "rigid_expert": "#000000"}
#: The figures ``save_rigid_figures`` writes: the ECDFs of iterations and of time, and the solved passage.
RIGID_FIGURES = ("ecdf-rigid.png", "ecdf-rigid-time.png", "passage.png")


def rigid_ecdf_figure(rows: Sequence[RigidRow], metric: str = "iterations"):
    """ECDF of iterations to solution per sampler (``metric="time"``: of time to solution), one panel per planner.

    Every run of ``rows`` pooled (all scene sets); an unsolved run counts but is never reached, so a sampler's line
    ends at its success rate. A run's time is ``RigidRow.time``: from building the planner (the sampler's per-scene
    work, a learned sampler's inference included) to the end of the solve. One legend below the panels.
    """
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    from learning.evaluation.outputs import EXTRA_COLORS, ecdf_line, wrap_text
    from planners.viz.plotting import new_figure

    if metric not in ("iterations", "time"):
        raise ValueError(f"metric must be 'iterations' or 'time', got {metric!r}")
    planners = list(dict.fromkeys(r.planner for r in rows))
    samplers = list(dict.fromkeys(r.sampler for r in rows))
    extra = iter(EXTRA_COLORS)
    colors = {s: RIGID_COLORS.get(s) or next(extra, "#7f7f7f") for s in samplers}
    cols = max(1, len(planners))
    size = (4.2 * cols, 4.8)
    fig = new_figure(size)
    scenes = len({r.scene for r in rows})
    within = "n iterations" if metric == "iterations" else "t seconds, the sampler's own work and inference included"
    fig.suptitle(wrap_text(f"6-DoF scenes ({scenes} scenes, every run pooled): fraction of runs solved within {within} "
                       "(unsolved runs never reached)", size[0], 11), fontsize=11)
    handles: dict = {}
    for i, planner in enumerate(planners):
        ax = fig.add_subplot(1, cols, i + 1)
        mine = [r for r in rows if r.planner == planner]
        reached = [r.iterations if metric == "iterations" else r.time for r in mine if r.solved]
        if reached:  # a log axis from below the first solved run to the cap (or the longest run's time)
            end = max(r.cap for r in mine) if metric == "iterations" else max(r.time for r in mine)
            span = (min(reached) / 1.5, max(end, max(reached)) * 1.2)
            for s in samplers:
                vals = [(r.iterations if metric == "iterations" else r.time) if r.solved else None
                        for r in mine if r.sampler == s]
                line = ecdf_line(ax, vals, start=span[0], end=span[1], label=s, color=colors[s],
                                 **({"linestyle": "--"} if s in REFERENCES else {}))
                if line is not None:
                    handles.setdefault(s, line)
            ax.set_xscale("log")
            ax.set_xlim(*span)
            ax.xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
            ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
            ax.xaxis.set_minor_formatter(NullFormatter())
        else:
            ax.text(0.5, 0.5, "no run solved", transform=ax.transAxes, ha="center", va="center")
        ax.set_ylim(0.0, 1.02)
        ax.set_title(planner)
        ax.set_xlabel("iterations to solution" if metric == "iterations" else "time to solution (s)")
        ax.set_ylabel("fraction of runs solved")
        ax.grid(alpha=0.3)
    if handles:
        fig.legend(list(handles.values()), list(handles), loc="outside lower center", ncols=min(5, len(handles)),
                   fontsize=8)
    return fig


def passage_candidates(rows: Sequence[RigidRow]) -> list[RigidRow]:
    """The solved runs in the order ``save_passage`` tries them: ``rigid_route`` first (then a user's or another
    learned sampler, then the rest), a test-only family's scene first, RRT-Connect first, then the lowest seed and
    the runs' order.
    """
    from planners.worlds.rigid_scenes import TEST_ONLY_FAMILIES

    def rank(item):
        k, r = item
        plain = r.sampler in CLASSICAL or r.sampler in NO_LEARNING or r.sampler in REFERENCES
        sampler = 0 if r.sampler == "rigid_route" else 2 if plain else 1
        family = r.family.removesuffix(" (mesh)")
        return (sampler, family not in TEST_ONLY_FAMILIES, r.planner != "RRTConnect", r.seed, k)

    return [r for _, r in sorted(((k, r) for k, r in enumerate(rows) if r.solved), key=rank)]


def _scene_problem(scene_set: RigidSceneSet | MeshSceneSet, row: RigidRow) -> Problem | None:
    """The problem of ``row``'s scene in ``scene_set`` (by the scene's name, else the problem's), or None."""
    queries = scene_set.queries(row.part or "test")
    for q in queries:
        if q.name == row.scene:
            return scene_set.problem(q)
    for q in queries:  # a comparison's rows name the problem (``Run.query``)
        problem = scene_set.problem(q)
        if problem.name == row.scene:
            return problem
    return None


def save_passage(rows: Sequence[RigidRow], scene_set: RigidSceneSet | MeshSceneSet, path, *,
                 sampler_params: dict[str, dict] | None = None, user_samplers: dict[str, str] | None = None,
                 restarts: int = 0, tries: int = 3):
    """A 3-D figure of a solved passage (``planners.viz.plotting3d.plot_scene``) written to ``path``; its path, or
    None where no run solved (or none of the first ``tries`` candidates solves again).

    The rows keep no paths, so the first of ``passage_candidates(rows)`` is solved again from its scene with its
    planner, sampler (``sampler_params``, or ``user_samplers``' spec for a user's label) and seed, up to the
    planner's own cap, and drawn. ``restarts``: as the runs were made (``evaluate_rigid``).
    """
    from learning.samplers.registry import sampler_names
    from planners.viz.plotting import save_figure, wrap_title
    from planners.viz.plotting3d import plot_scene

    params, users = sampler_params or {}, user_samplers or {}
    known = set(sampler_names())
    candidates = [r for r in passage_candidates(rows) if r.sampler in users or r.sampler in known]
    for row in candidates[:tries]:
        problem = _scene_problem(scene_set, row)
        if problem is None:
            continue
        made = make_run_sampler(row.sampler, params.get(row.sampler), users.get(row.sampler))
        result, planned, _ = solve_run(problem, row.planner, made, row.seed,
                                       restarts=0 if row.planner == "PRM" else restarts)
        if not result.solved:
            continue
        fig = plot_scene(planned, result.path, size=(7.0, 7.0))
        ax = fig.axes[0]
        ax.set_title(wrap_title(ax, f"{row.scene}: {row.planner} with {row.sampler}, seed {row.seed} "
                                    f"({int(result.iterations):,} iterations, a path of {len(result.path)} states)"))
        return save_figure(fig, path, dpi=100)
    return None


def save_rigid_figures(rows: Sequence[RigidRow], out_dir, scene_set: RigidSceneSet | MeshSceneSet | None = None,
                       **passage) -> list:
    """Write ``ecdf-rigid.png`` and ``ecdf-rigid-time.png`` (``rigid_ecdf_figure``) and, given the runs'
    ``scene_set`` and a solved run, ``passage.png`` (``save_passage``; ``passage``: its keywords) under ``out_dir``;
    returns the paths written. Nothing where ``rows`` is empty.
    """
    from planners.viz.plotting import save_figure

    out_dir = Path(out_dir)
    if not rows:
        return []
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = [save_figure(rigid_ecdf_figure(rows), out_dir / RIGID_FIGURES[0], dpi=110),
             save_figure(rigid_ecdf_figure(rows, "time"), out_dir / RIGID_FIGURES[1], dpi=110)]
    if scene_set is not None:
        drawn = save_passage(rows, scene_set, out_dir / RIGID_FIGURES[2], **passage)
        if drawn is not None:
            paths.append(drawn)
    return paths
