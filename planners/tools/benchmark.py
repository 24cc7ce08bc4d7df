"""Measurement helpers behind ``scripts/benchmark_planners.py``: run planners, time them, tabulate."""

from __future__ import annotations

import csv
import io
import json
import math
import os
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, fields

import numpy as np

from planners.algorithms.rrt import RRT
from planners.base.fileio import atomic_write_text
from planners.base.planner import Planner
from planners.base.problem import Problem
from planners.base.registry import make_planner
from planners.base.samplers import GoalBiasedSampler, UniformSampler, draw_classical_in_loops
from planners.datastructures.nn import NearestNeighbors
from planners.tools.parallel import Backend, LocalBackend

#: The comparison's planning settings, in map cells: RRT's extension step, the goal tolerance and the
#: iteration cap (unsolved runs count as the cap). ``learning.evaluation.Protocol`` holds them with the
#: comparison's split sizes; scripts without learning take them from here.
STEP, TOLERANCE, MAX_ITERATIONS = 4.0, 4.0, 20_000


@dataclass
class Run:
    """One planning run: a row of every ``runs.csv`` (evaluation and planner benchmark) and of every OMPL log.

    Counts a planner does not report are -1 (OMPL's collision checks, a benchmark's lower bound).
    """

    map: str  # the map set: a generated family, a MovingAI map, a benchmark map
    query: str  # the problem's name
    split: str  # "test" or "tuning"
    planner: str  # the configuration's label in tables and logs
    sampler: str
    seed: int
    solved: bool
    iterations: int  # to the first solution; the cap when unsolved
    lower_bound: int  # ``Problem.iteration_lower_bound``, -1 when unknown
    candidates: int  # samples drawn (a planner may draw several per iteration)
    collision_checks: int
    wall_time: float  # seconds: the solve (benchmarks), or the bind and the solve less compiling (evaluation)
    us_per_iteration: float
    path_cost: float  # inf when unsolved
    forward_passes: int  # a learned sampler's network evaluations
    vertices: int
    sampler_spec: str = ""  # the sampler's name and parameters as JSON (evaluation runs), "" where not recorded
    progress: str = ""  # an anytime run's best cost as it fell: JSON ``[[time, iterations, cost], ...]`` or ""
    compile_time: float = 0.0  # seconds numba spent compiling (or loading cached code) in the run, not in wall_time


#: Per-run properties of the OMPL logs: (OMPL property, type, ``Run`` field).
OMPL_RUN_PROPERTIES = (
    ("time", "REAL", "wall_time"),
    ("solved", "BOOLEAN", "solved"),
    ("iterations", "INTEGER", "iterations"),
    ("graph states", "INTEGER", "vertices"),
    ("collision checks", "INTEGER", "collision_checks"),
    ("candidates", "INTEGER", "candidates"),
    ("solution length", "REAL", "path_cost"),
    ("lower bound", "INTEGER", "lower_bound"),
    ("forward passes", "INTEGER", "forward_passes"),
    ("time per iteration", "REAL", "us_per_iteration"),
    ("seed", "INTEGER", "seed"),
)


#: Progress properties of the OMPL logs, in the order of ``Run.progress``'s points (OMPL's ``Benchmark`` puts
#: ``time`` first; RRT*'s own progress properties are ``iterations`` and ``best cost``).
OMPL_PROGRESS_PROPERTIES = (("time", "REAL"), ("iterations", "INTEGER"), ("best cost", "REAL"))


def progress_json(points: Sequence[tuple[float, int, float]]) -> str:
    """``Run.progress`` of ``points`` ((seconds, iterations, best cost) each; an infinite cost is written null)."""
    return json.dumps([[round(float(t), 6), int(i), float(c) if np.isfinite(c) else None] for t, i, c in points],
                      separators=(",", ":"))


def progress_points(run: Run) -> list[tuple[float, int, float]]:
    """``run.progress`` read back: (seconds, iterations, best cost) per point, inf where no path was known."""
    if not run.progress:
        return []
    return [(float(t), int(i), math.inf if c is None else float(c)) for t, i, c in json.loads(run.progress)]


def ompl_run_values(run: Run) -> dict:
    """``run``'s OMPL log properties; an unreported count (-1) and an unsolved run's length are left empty."""
    values = {p: getattr(run, f) for p, _, f in OMPL_RUN_PROPERTIES}
    for p, kind, _ in OMPL_RUN_PROPERTIES:
        if kind == "INTEGER" and values[p] is not None and values[p] < 0:
            values[p] = None
    return values


def write_runs_csv(runs: Sequence[Run], path: str | os.PathLike) -> None:
    """Every run as a CSV row (the ``Run`` fields), written whole or not at all."""
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=[f.name for f in fields(Run)])
    w.writeheader()
    w.writerows(asdict(r) for r in runs)
    atomic_write_text(path, buf.getvalue())


#: The set-ups the benchmark compares, by label: a registered planner and a factory of its arguments
#: (fresh samplers per run). The step is each run's extension length; roadmaps keep their own.
SETUPS: dict[str, tuple[str, Callable[[], dict]]] = {
    "RRT": ("RRT", lambda: {"sampler": UniformSampler()}),
    "RRT+goal0.05": ("RRT", lambda: {"sampler": GoalBiasedSampler(0.05)}),
    "RRTConnect": ("RRTConnect", dict),
    "RRTstar": ("RRTstar", lambda: {"sampler": GoalBiasedSampler(0.05), "stop_on_first_solution": True}),
    "PRM": ("PRM", dict),
    "LazyPRM": ("LazyPRM", dict),
}


def make_setup(label: str, problem: Problem, *, step: float, seed: int) -> Planner:
    """A fresh planner of the set-up ``label`` of ``SETUPS`` (``step``: the extension length); the classical samplers
    draw inside its compiled loop (``draw_classical_in_loops``), so a timing does not depend on what the install
    compiled before.
    """
    name, arguments = SETUPS[label]
    draw_classical_in_loops(problem)
    return make_planner(name, problem, extension_step=step, seed=seed, **arguments())


def run_one(problem: Problem, label: str, *, step: float, seed: int, max_iterations: int,
            map_name: str = "") -> Run:
    """Solve ``problem`` with the set-up ``label`` of ``SETUPS`` and record the run."""
    planner = make_setup(label, problem, step=step, seed=seed)
    r = planner.solve(max_iterations=max_iterations)
    its = r.first_solution_iteration if r.solved and r.first_solution_iteration is not None else r.iterations
    bound = problem.iteration_lower_bound(step)
    return Run(map=map_name or problem.name, query=problem.name, split="test", planner=label,
               sampler=type(planner.sampler).__name__, seed=seed, solved=r.solved, iterations=int(its),
               lower_bound=-1 if bound is None else bound, candidates=r.candidates,
               collision_checks=r.collision_checks, wall_time=r.time, us_per_iteration=r.time / max(r.iterations,
                                                                                                    1) * 1e6,
               path_cost=r.cost, forward_passes=0, vertices=r.num_vertices)


def _run_task(task: tuple[str, int, str], context: dict) -> Run:
    """``run_one`` for ``(map name, query index, set-up label)`` on ``context["maps"]``: the form a backend ships."""
    name, i, label = task
    return run_one(context["maps"][name][i], label, step=context["step"], seed=i,
                   max_iterations=context["max_iterations"], map_name=name)


def run_all_setups(maps: dict[str, list[Problem]], *, step: float, max_iterations: int,
                   backend: Backend | None = None) -> list[Run]:
    """Every set-up of ``SETUPS`` on every query of ``maps`` (seed = query index), in a fixed order.

    On a ``backend`` the maps go to each worker once; with more than one worker the runs share the
    machine's cores, so their times are not comparable with a serial run's (iterations are identical).
    """
    tasks = [(name, i, label) for name, problems in maps.items() for label in SETUPS for i in range(len(problems))]
    context = {"maps": maps, "step": step, "max_iterations": max_iterations}
    return (backend or LocalBackend()).map(_run_task, tasks, context=context, desc="runs")


def growth_profile(step_fn: Callable[[int], tuple[int, float]], checkpoints: Sequence[int],
                   chunk: int = 2000, max_iterations: int = 2_000_000) -> list[dict]:
    """Per-iteration time in the windows between vertex-count checkpoints.

    ``step_fn(k)`` runs ``k`` more iterations and returns ``(vertices, seconds spent)``.
    """
    rows = []
    total_its, total_t = 0, 0.0
    start_its, start_t = 0, 0.0
    prev = 0
    for target in checkpoints:
        vertices = 0
        while total_its < max_iterations:
            vertices, dt = step_fn(chunk)
            total_its += chunk
            total_t += dt
            if vertices >= target:
                break
        rows.append({"from_vertices": prev, "to_vertices": vertices, "iterations": total_its - start_its,
                     "us_per_iteration": (total_t - start_t) / max(total_its - start_its, 1) * 1e6})
        prev, start_its, start_t = vertices, total_its, total_t
    return rows


def ours_growth_step(problem: Problem, step: float, seed: int) -> Callable[[int], tuple[int, float]]:
    """``step_fn`` for ``growth_profile`` driving our uniform-sampling RRT."""
    draw_classical_in_loops(problem)  # as make_setup's planners draw
    RRT(problem, step_size=step, seed=seed).solve(max_iterations=10)  # load compiled kernels first
    planner = RRT(problem, step_size=step, sampler=UniformSampler(), seed=seed)

    def run(k: int) -> tuple[int, float]:
        t = planner.result().time
        planner.solve(max_iterations=k)
        return planner.num_vertices, planner.result().time - t

    run.planner = planner  # type: ignore[attr-defined]
    return run


def nn_scaling(points: np.ndarray, sizes: Iterable[int], low: np.ndarray, high: np.ndarray, queries: int = 20000,
               seed: int = 0) -> list[dict]:
    """Nearest-neighbour query time (compiled loop, uniform queries in [low, high)) vs a numpy scan."""
    rng = np.random.default_rng(seed)
    rows = []
    for n in sizes:
        if n > len(points):
            break
        nn = NearestNeighbors(points.shape[1])
        nn.add(points[:n])
        qs = low + (high - low) * rng.random((queries, points.shape[1]))
        nn.nearest_many(qs[:10])  # compiled before the clock starts
        t = time.perf_counter()
        nn.nearest_many(qs)
        t_index = (time.perf_counter() - t) / queries
        P = points[:n]
        t = time.perf_counter()
        for q in qs[:200]:
            np.argmin(((P - q) ** 2).sum(axis=1))
        t_brute = (time.perf_counter() - t) / 200
        rows.append({"vertices": n, "index_us": t_index * 1e6, "numpy_scan_us": t_brute * 1e6})
    return rows


def summarize(records: Sequence[Run], by: Sequence[str] = ("map", "planner")) -> list[dict]:
    """Aggregate runs per group: success rate, medians, total time per iteration."""
    groups: dict[tuple, list[Run]] = {}
    for r in records:
        groups.setdefault(tuple(getattr(r, k) for k in by), []).append(r)
    rows = []
    for key, rs in groups.items():
        solved = [r for r in rs if r.solved]
        its = sum(r.iterations for r in rs)
        rows.append({
            **dict(zip(by, key, strict=True)),
            "runs": len(rs),
            "success": len(solved) / len(rs),
            "median_iterations": float(np.median([r.iterations for r in solved])) if solved else float("nan"),
            "us_per_iteration": sum(r.wall_time for r in rs) / max(its, 1) * 1e6,
            "median_cost": float(np.median([r.path_cost for r in solved])) if solved else float("nan"),
            "median_checks": float(np.median([r.collision_checks for r in rs])),
        })
    return rows


def best_ms(call: Callable[[], object], repeat: int) -> float:
    """The least wall time of ``repeat`` calls of ``call`` after one untimed call, in milliseconds."""
    call()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return 1e3 * min(times)


def markdown_table(rows: Sequence[dict], columns: Sequence[str] | None = None, floatfmt: str = ".3g") -> str:
    """A GitHub-flavoured Markdown table of dict rows."""
    if not rows:
        return "(no rows)\n"
    columns = list(columns or rows[0].keys())

    def fmt(v) -> str:
        if isinstance(v, float):
            return format(v, floatfmt) if np.isfinite(v) else ("-" if np.isnan(v) else "inf")
        return str(v)

    lines = ["| " + " | ".join(columns) + " |", "|" + "|".join("---" for _ in columns) + "|"]
    lines += ["| " + " | ".join(fmt(r.get(c, "")) for c in columns) + " |" for r in rows]
    return "\n".join(lines) + "\n"
