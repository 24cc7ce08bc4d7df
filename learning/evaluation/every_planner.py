"""The route field with every planner: iterations, checks and success per planner and sampler, and RRT*'s convergence.

``make_sampler("route")`` (and ``"route_ablation"``, ``"exact_route"``) handed to any planner takes that
planner's rule (``learning.samplers.route_rules``). ``compare_planners`` runs each planner with its default
sampling, its classical option, the learned field, its ablation and the exact reference on the same queries;
``convergence`` measures how many iterations RRT* takes to come within 5% and 1% of the best known cost, and
``later_queries`` whether a roadmap built for one query serves others.

Map sets (``planner_maps``): ``validation`` (the five families' validation maps, the only ones settings are
chosen on), and the held-apart ``shifted`` and ``unseen`` test maps and ``movingai`` test scenarios.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from learning.evaluation.convergence import BUDGET, CONVERGENCE_TARGETS, EVERY, ConvergenceProtocol, convergence_rows
from learning.evaluation.later_queries import other_queries
from learning.samplers.registry import ModelCache, make_sampler
from planners import Problem, make_planner
from planners.base.samplers import draw_classical_in_loops
from planners.maps.generators import FAMILIES, SHIFTED_SEED0, SHIFTED_SIZES, VALIDATION_SEED0, generate
from planners.maps.unseen import UNSEEN_FAMILIES, UNSEEN_SEED0, generate_unseen
from planners.tools.benchmark import MAX_ITERATIONS, STEP, TOLERANCE, Run

#: Validation maps take seeds from here on (``scripts/experiments/vin_validation.py``'s block).
VALIDATION_OFFSET = 500
#: The planners compared, each with its classical option: (label, planner, sampler name or None for the
#: planner's own sampling, sampler parameters).
CLASSICAL = {
    "RRTConnect": ("goal bias 0.05", "RRTConnect", "goal_bias", {"bias": 0.05}),
    "PRM": ("OB-PRM", "OBPRM", None, {}),
    "LazyPRM": ("OB-PRM", "OBPRM", None, {}),
    "RRTstar": ("goal bias 0.05", "RRTstar", "goal_bias", {"bias": 0.05}),
}
#: Anytime planners: ``compare_planners`` stops them at their first solution.
ANYTIME = ("RRTstar", "InformedRRTstar")
#: The field's samplers of every row: learned, its ablation, the exact reference.
FIELD_SAMPLERS = ("route", "route_ablation", "exact_route")
#: Map sets of ``planner_maps``.
MAP_SETS = ("validation", "shifted", "unseen", "movingai")


def planner_maps(which: str, n: int, *, size: int = 128, tolerance: float = TOLERANCE) -> dict[str, list[Problem]]:
    """``n`` queries per family of the map set ``which`` (``MAP_SETS``), by family.

    ``validation``: the five families at ``size``, seeds from ``VALIDATION_SEED0 + VALIDATION_OFFSET``;
    ``shifted``: their shifted generators (sides cycling through ``SHIFTED_SIZES``); ``unseen``: the unseen
    families at ``size``; ``movingai``: ``n`` test scenarios of each of the comparison's MovingAI maps
    (``protocol.MOVINGAI_MAPS``, those in ``planners.movingai_dir()``), pooled as one set.
    """
    if which == "validation":
        return {f: [generate(f, VALIDATION_SEED0 + VALIDATION_OFFSET + i, size, goal_tolerance=tolerance)
                    for i in range(n)] for f in FAMILIES}
    if which == "shifted":
        return {f"{f} (shifted)": [generate(f, SHIFTED_SEED0 + i, SHIFTED_SIZES[i % len(SHIFTED_SIZES)],
                                            goal_tolerance=tolerance, shifted=True) for i in range(n)]
                for f in FAMILIES}
    if which == "unseen":
        return {f"{f} (unseen)": [generate_unseen(f, UNSEEN_SEED0 + i, size, goal_tolerance=tolerance)
                                  for i in range(n)] for f in UNSEEN_FAMILIES}
    if which == "movingai":
        from planners.maps.movingai import movingai_dir

        from .protocol import MOVINGAI_MAPS, movingai_queries

        directory = str(movingai_dir())
        have = [m for m in MOVINGAI_MAPS if any(Path(directory).glob(f"{m}*.scen"))]
        cache: dict = {}
        return {"MovingAI (pooled)": [q.problem(directory, tolerance, cache)
                                      for q in movingai_queries(directory, have, n, 0, tolerance, cache)]}
    raise ValueError(f"map set {which!r}: choose from {', '.join(MAP_SETS)}")


@dataclass(frozen=True)
class Setup:
    """One row of the comparison: a label, the planner, and its sampler (None: the planner's own).

    ``make``, where given, builds the sampler instead of the registry (a sampler at other settings, when tuning).
    """

    label: str
    planner: str
    sampler: str | None
    params: tuple[tuple[str, object], ...] = ()
    make: Callable[[], object] | None = None

    def build(self, models: ModelCache | None = None):
        """A fresh sampler of this row, or None for the planner's own."""
        if self.make is not None:
            return self.make()
        return None if self.sampler is None else make_sampler(self.sampler, models=models, **dict(self.params))


def setups_for(planner: str) -> list[Setup]:
    """The rows of ``planner``: its default sampling, its classical option, the field's three samplers."""
    label, name, sampler, params = CLASSICAL[planner]
    return [Setup("uniform", planner, None), Setup(label, name, sampler, tuple(params.items()))] + [
        Setup(s, planner, s) for s in FIELD_SAMPLERS]


def run_setup(setup: Setup, problem: Problem, seed: int, *, max_iterations: int = MAX_ITERATIONS,
              step: float = STEP, models: ModelCache | None = None, sampler=None) -> dict:
    """One run of ``setup`` on ``problem``: solved, iterations, candidates, checks, cost, time (sampler set-up in).

    ``sampler`` replaces the setup's (a sampler object, e.g. at other settings while tuning).
    """
    if sampler is None:
        sampler = setup.build(models)
    extra = {"stop_on_first_solution": True} if setup.planner in ANYTIME else {}
    draw_classical_in_loops(problem)  # whatever the install compiled before: the same timing
    t0 = time.perf_counter()
    planner = make_planner(setup.planner, problem, extension_step=step, sampler=sampler, seed=seed, **extra)
    r = planner.solve(max_iterations=max_iterations)
    wall = time.perf_counter() - t0
    # the iteration of the first solution: an RRT* stopping at it finishes the batch of samples it holds
    return {"setup": setup.label, "planner": setup.planner, "query": problem.name, "seed": seed, "solved": r.solved,
            "iterations": r.first_solution_iteration if r.solved else max_iterations, "candidates": r.candidates,
            "checks": r.collision_checks, "cost": r.cost, "time_s": wall, "compile_s": planner.compile_time,
            "lower_bound": problem.iteration_lower_bound(step)}


def summarize_runs(runs: Sequence[dict]) -> dict:
    """Success share and medians (an unsolved run counts at its budget) of ``runs`` of one row.

    ``lower_bound``: the median of the queries' iteration lower bounds (``Problem.iteration_lower_bound``; nan
    where no query knows its shortest path).
    """
    bounds = [r["lower_bound"] for r in runs if r.get("lower_bound") is not None]
    return {"runs": len(runs), "success": float(np.mean([r["solved"] for r in runs])),
            "lower_bound": float(np.median(bounds)) if bounds else math.nan,
            "iterations": float(np.median([r["iterations"] for r in runs])),
            "checks": float(np.median([r["checks"] for r in runs])),
            "time_ms": 1e3 * float(np.median([r["time_s"] - r["compile_s"] for r in runs]))}


def compare_planners(maps: dict[str, list[Problem]], planners: Sequence[str] = tuple(CLASSICAL), *,
                     seeds: Sequence[int] = (0, 1), max_iterations: int = MAX_ITERATIONS, step: float = STEP,
                     progress: Callable[[str], None] | None = None) -> tuple[list[dict], list[dict]]:
    """Every planner's rows (``setups_for``) on every map set of ``maps``: ``(rows, runs)``.

    A row: ``map``, ``planner``, ``sampler`` and ``summarize_runs``'s figures, over every query and seed.
    RRT* runs to its first solution here (``convergence`` measures its cost); the time leaves one-off
    compilation out and includes the sampler's set-up (the encoder's passes).
    """
    models = ModelCache()
    rows, runs = [], []
    for name, problems in maps.items():
        for planner in planners:
            for setup in setups_for(planner):
                mine = [run_setup(setup, p, s, max_iterations=max_iterations, step=step, models=models)
                        for p in problems for s in seeds]
                runs += [{"map": name, **r} for r in mine]
                rows.append({"map": name, "planner": planner, "sampler": setup.label, **summarize_runs(mine)})
                if progress is not None:
                    progress(format_row(rows[-1]))
    return rows, runs


def format_row(row: dict) -> str:
    """One printed line of a row of ``compare_planners``."""
    return (f"{row['map']:24s} {row['planner']:11s} {row['sampler']:15s} success {row['success']:5.2f}  "
            f"iterations {row['iterations']:8.0f}  checks {row['checks']:8.0f}  time {row['time_ms']:7.1f} ms  "
            f"lower bound {row['lower_bound']:5.0f}")


def convergence(maps: dict[str, list[Problem]], setups: Sequence[Setup], *, seeds: Sequence[int] = (0, 1),
                budget: int = BUDGET, chunk: int = EVERY, step: float = STEP,
                targets: Sequence[float] = CONVERGENCE_TARGETS) -> list[dict]:
    """Iterations RRT* variants take to come within each of ``targets`` of the best known cost.

    Each run is made as the comparison's convergence part makes it (``ConvergenceProtocol``: ``budget``
    iterations, the cost read every ``chunk``) and measured by the same rule (``convergence_rows``): the best
    known cost of a query is the lowest any run of any setup reached on it within ``budget``; a run that never
    gets there counts at ``budget``. Rows: ``map``, ``sampler``, ``runs``, the success share and median
    iterations per target, and the median cost at ``budget`` over the best known.
    """
    protocol = ConvergenceProtocol(step=step, max_iterations=budget, every=chunk)
    models = ModelCache()
    runs = []
    for name, problems in maps.items():
        for p in problems:
            for s in setups:
                for seed in seeds:
                    draw_classical_in_loops(p)  # as run_one does before its timer: whatever the install compiled
                    planner, cap = protocol.planner(s.planner, p, s.build(models), seed)
                    r, progress = protocol.solve(planner, cap)
                    runs.append(Run(map=name, query=p.name, split="test", planner=s.planner, sampler=s.label,
                                    seed=seed, solved=r.solved, iterations=r.first_solution_iteration or cap,
                                    lower_bound=-1, candidates=r.candidates, collision_checks=r.collision_checks,
                                    wall_time=r.time, us_per_iteration=r.time / max(r.iterations, 1) * 1e6,
                                    path_cost=r.cost, forward_passes=0, vertices=r.num_vertices, progress=progress))
    rows = convergence_rows(runs, budget, by_group=False, shares=targets)
    return [{"map": row.pop("map set"), **row} for row in rows]


def rrtstar_setups() -> list[Setup]:
    """RRT*'s rows of ``convergence``: uniform, goal bias, Informed RRT*, the field's three samplers."""
    return [Setup("uniform", "RRTstar", None), Setup("goal bias 0.05", "RRTstar", "goal_bias", (("bias", 0.05),)),
            Setup("informed", "InformedRRTstar", None)] + [Setup(s, "RRTstar", s) for s in FIELD_SAMPLERS]


def later_queries(maps: dict[str, list[Problem]], setups: Sequence[Setup], *, queries: int = 3,
                  seeds: Sequence[int] = (0, 1), max_iterations: int = MAX_ITERATIONS,
                  step: float = STEP) -> list[dict]:
    """Whether a roadmap built for one query serves others: the samples each later query adds.

    Each roadmap planner of ``setups`` solves the map's own query, then answers ``queries`` more on the same
    roadmap (``PRM.query``; ``other_queries``), the sampler bound afresh to each (the field's corridor moves to
    the new query). Rows: ``map``, ``sampler``, the median samples of the first query (``first``) and of the
    later ones (``later``; an unanswered one counting at ``max_iterations``), their mean (``later_mean``), the
    share of later queries the roadmap answered with no new sample (``served``), and their ``success``.
    """
    models = ModelCache()
    rows = []
    for name, problems in maps.items():
        for setup in setups:
            first, later = [], []
            for i, p in enumerate(problems):
                pairs = other_queries(p, queries, seed=i)
                for seed in seeds:
                    planner = make_planner(setup.planner, p, extension_step=step, sampler=setup.build(models),
                                           seed=seed)
                    r = planner.solve(max_iterations=max_iterations)
                    first.append(r.iterations if r.solved else max_iterations)
                    for s, g in pairs:
                        r = planner.query(s, g, max_iterations=max_iterations)
                        later.append((r.iterations if r.solved else max_iterations, r.solved))
            rows.append({"map": name, "sampler": setup.label, "first": float(np.median(first)),
                         "later": float(np.median([n for n, _ in later])),
                         "later_mean": float(np.mean([n for n, _ in later])),
                         "served": float(np.mean([n == 0 and ok for n, ok in later])),
                         "success": float(np.mean([ok for _, ok in later]))})
    return rows
