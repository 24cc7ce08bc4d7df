"""Measurement helpers behind ``scripts/benchmark_planners.py``: run planners, time them, tabulate."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass

import numpy as np

from planners.algorithms.prm import PRM, LazyPRM
from planners.algorithms.rrt import RRT, RRTConnect
from planners.algorithms.rrtstar import RRTStar
from planners.base.planner import Planner
from planners.base.problem import Problem
from planners.base.samplers import GoalBiasedSampler, UniformSampler
from planners.datastructures import nn as nn_index
from planners.datastructures.nn import NearestNeighbors


@dataclass
class Record:
    """One planning run."""

    map: str
    query: str
    planner: str
    solved: bool
    iterations: int
    time: float
    us_per_iteration: float
    cost: float
    collision_checks: int
    num_vertices: int
    seed: int


#: The planners the benchmark compares, by label: a factory (problem, step, seed) -> Planner.
PLANNERS: dict[str, Callable[[Problem, float, int], Planner]] = {
    "RRT": lambda p, step, seed: RRT(p, step_size=step, sampler=UniformSampler(), seed=seed),
    "RRT+goal0.05": lambda p, step, seed: RRT(p, step_size=step, sampler=GoalBiasedSampler(0.05), seed=seed),
    "RRTConnect": lambda p, step, seed: RRTConnect(p, step_size=step, seed=seed),
    "RRTstar": lambda p, step, seed: RRTStar(p, step_size=step, sampler=GoalBiasedSampler(0.05), seed=seed,
                                             stop_on_first_solution=True),
    "PRM": lambda p, step, seed: PRM(p, seed=seed),
    "LazyPRM": lambda p, step, seed: LazyPRM(p, seed=seed),
}


def run_one(problem: Problem, label: str, *, step: float, seed: int, max_iterations: int,
            map_name: str = "") -> Record:
    """Solve ``problem`` with planner ``label`` of ``PLANNERS`` and record the run."""
    planner = PLANNERS[label](problem, step, seed)
    r = planner.solve(max_iterations=max_iterations)
    its = r.first_solution_iteration if r.solved and r.first_solution_iteration is not None else r.iterations
    return Record(map_name or problem.name, problem.name, label, r.solved, int(its), r.time,
                  r.time / max(r.iterations, 1) * 1e6, r.cost, r.collision_checks, r.num_vertices, seed)


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
        args = (nn._P, nn._perm, nn._split, nn._box, len(nn))
        nn_index.time_queries(*args, qs[:10], nn._m)
        t = time.perf_counter()
        nn_index.time_queries(*args, qs, nn._m)
        t_index = (time.perf_counter() - t) / queries
        P = points[:n]
        t = time.perf_counter()
        for q in qs[:200]:
            np.argmin(((P - q) ** 2).sum(axis=1))
        t_brute = (time.perf_counter() - t) / 200
        rows.append({"vertices": n, "index_us": t_index * 1e6, "numpy_scan_us": t_brute * 1e6})
    return rows


def summarize(records: Sequence[Record], by: Sequence[str] = ("map", "planner")) -> list[dict]:
    """Aggregate runs per group: success rate, medians, total time per iteration."""
    groups: dict[tuple, list[Record]] = {}
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
            "us_per_iteration": sum(r.time for r in rs) / max(its, 1) * 1e6,
            "median_cost": float(np.median([r.cost for r in solved])) if solved else float("nan"),
            "median_checks": float(np.median([r.collision_checks for r in rs])),
        })
    return rows


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


def records_to_dicts(records: Iterable[Record]) -> list[dict]:
    """The records as plain dicts (one per run), e.g. for a CSV writer."""
    return [asdict(r) for r in records]
