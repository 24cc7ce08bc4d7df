"""The comparison: iterations-to-solution of the learned sampler against uniform and goal bias.

Every run is one planner on one query with one sampler and one seed. Goal bias is swept; the bias
reported as "best" for a family is chosen on a separate tuning split (other map seeds, or other
MovingAI scenarios of the same maps), never on the evaluated queries. The privileged expert is a
reference, not a competitor: it reads the map's geodesic distance field.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from learning.training import TEST_SEED0, TUNING_SEED0, lower_bound
from planners import PRM, RRT, GoalBiasedSampler, Problem, RRTStar, UniformSampler, load_movingai_scenarios
from planners.generators import generate

GOAL_BIASES = (0.01, 0.05, 0.1, 0.2, 0.5)
PLANNERS = {"RRT": RRT, "RRTstar": RRTStar, "PRM": PRM}


@dataclass(frozen=True)
class Query:
    """A problem reference that worker processes can rebuild cheaply."""

    family: str  # generated family or MovingAI map name
    key: int  # generator seed, or scenario index
    size: int  # generated size (0 for MovingAI)
    split: str  # "test" or "tuning"

    def problem(self, movingai_dir: str | None, tolerance: float) -> Problem:
        if self.size:
            return generate(self.family, self.key, self.size, goal_tolerance=tolerance)
        return _scenarios(movingai_dir, self.family, tolerance)[self.key]


_SCEN_CACHE: dict = {}


def _scenarios(directory: str, name: str, tolerance: float) -> list[Problem]:
    key = (directory, name, tolerance)
    if key not in _SCEN_CACHE:
        d = Path(directory)
        scen = next((p for p in sorted(d.glob(f"{name}*.scen"))
                     if p.name.split(".")[0].replace("-random-1", "") == name), None)
        if scen is None:
            raise FileNotFoundError(f"no scenario file for MovingAI map {name!r} in {d}")
        ps = [p for p in load_movingai_scenarios(scen, goal_tolerance=tolerance)
              if p.distance(p.start, p.goal) > tolerance]
        _SCEN_CACHE[key] = sorted(ps, key=lambda p: (-p.reference_length, p.name))
    return _SCEN_CACHE[key]


def generated_queries(families: Sequence[str], size: int, n_test: int, n_tune: int) -> list[Query]:
    """``n_test`` test and ``n_tune`` tuning maps per family, on their disjoint seed ranges."""
    return ([Query(f, TEST_SEED0 + i, size, "test") for f in families for i in range(n_test)]
            + [Query(f, TUNING_SEED0 + i, size, "tuning") for f in families for i in range(n_tune)])


def movingai_queries(directory: str, maps: Sequence[str], n_test: int, n_tune: int, tolerance: float) -> list[Query]:
    """The longest half of each map's scenarios, alternately assigned to the test and tuning splits."""
    out = []
    for m in maps:
        ps = _scenarios(directory, m, tolerance)
        half = max(2, len(ps) // 2)
        stride = max(1, half // (2 * max(n_test, n_tune)))
        picks = list(range(0, half, stride))
        out += [Query(m, i, 0, "test") for i in picks[0::2][:n_test]]
        out += [Query(m, i, 0, "tuning") for i in picks[1::2][:n_tune]]
    return out


@dataclass
class Run:
    """One planning run (a row of the raw CSV)."""

    family: str
    query: str
    split: str
    planner: str
    sampler: str
    seed: int
    solved: bool
    iterations: int
    lower_bound: int
    candidates: int
    collision_checks: int
    wall_time: float
    path_cost: float
    forward_passes: int


def _sampler(name: str, policy_path: str | None, step: float):
    if name == "uniform":
        return UniformSampler()
    if name.startswith("goal_bias="):
        return GoalBiasedSampler(float(name.split("=")[1]))
    if name == "policy":
        return _policy(policy_path)
    if name == "expert (reference)":
        from learning.expert import ExpertSampler

        return ExpertSampler(step)
    raise ValueError(f"unknown sampler {name!r}")


_POLICY: dict = {}


def _policy(path: str):
    if path not in _POLICY:
        from learning.policy_sampler import PolicySampler

        _POLICY[path] = PolicySampler.load(path)
    return _POLICY[path]


def run_one(task: tuple) -> Run:
    """Execute one run (a top-level function so worker processes can receive it)."""
    query, planner_name, sampler_name, seed, cfg = task
    problem = query.problem(cfg["movingai_dir"], cfg["tolerance"])
    sampler = _sampler(sampler_name, cfg["policy"], cfg["step"])
    cls = PLANNERS[planner_name]
    t0 = time.perf_counter()  # wall time includes binding the sampler (the policy's per-map setup)
    if cls is PRM:
        planner = PRM(problem, sampler=sampler, seed=seed)
    elif cls is RRTStar:
        planner = RRTStar(problem, step_size=cfg["step"], sampler=sampler, seed=seed, stop_on_first_solution=True)
    else:
        planner = RRT(problem, step_size=cfg["step"], sampler=sampler, seed=seed)
    r = planner.solve(max_iterations=cfg["max_iterations"])
    wall = time.perf_counter() - t0
    its = r.first_solution_iteration if r.solved else r.iterations
    return Run(query.family, problem.name, query.split, planner_name, sampler_name, seed, r.solved, int(its),
               lower_bound(problem, cfg["step"]), r.candidates, r.collision_checks, wall,
               r.cost if r.solved else math.inf, int(getattr(planner.sampler, "forward_passes", 0)))


def run_all(tasks: list[tuple], processes: int, progress: bool = True) -> list[Run]:
    """Run tasks, in parallel over local processes when ``processes > 1``, with a progress bar."""
    from tqdm.auto import tqdm

    if processes <= 1:
        return [run_one(t) for t in tqdm(tasks, desc="runs", disable=not progress)]
    import multiprocessing as mp

    ctx = mp.get_context("spawn")  # fresh interpreters: no inherited locks or thread pools
    # one thread per worker: BLAS and OpenMP pools started in every worker would spin on the cores the
    # other workers are timing runs on; the variables must be set before a worker imports numpy
    saved = {k: os.environ.get(k) for k in _THREAD_VARS}
    os.environ.update(dict.fromkeys(_THREAD_VARS, "1"))
    try:
        with ctx.Pool(processes, initializer=_worker_init) as pool:
            return list(tqdm(pool.imap(run_one, tasks, chunksize=4), total=len(tasks), desc="runs",
                             disable=not progress))
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def _worker_init() -> None:
    import torch

    torch.set_num_threads(1)


def pooled(runs: Sequence[Run], name: str, families: Sequence[str]) -> list[Run]:
    """Copies of the runs on ``families`` relabelled as one family ``name`` (e.g. all MovingAI maps).

    The best bias is then tuned, and the summary taken, over the pool as a whole.
    """
    from dataclasses import replace

    keep = set(families)
    return [replace(r, family=name) for r in runs if r.family in keep]


def best_bias(runs: Sequence[Run]) -> dict[tuple[str, str], float]:
    """Per (family, planner): the goal bias with the lowest median iterations on the tuning split."""
    out = {}
    groups: dict = {}
    for r in runs:
        if r.split == "tuning" and r.sampler.startswith("goal_bias="):
            groups.setdefault((r.family, r.planner, r.sampler), []).append(r.iterations if r.solved else math.inf)
    for (fam, planner, sampler), its in groups.items():
        med = float(np.median(its))
        key = (fam, planner)
        if key not in out or med < out[key][1]:
            out[key] = (float(sampler.split("=")[1]), med)
    return {k: v[0] for k, v in out.items()}


def bootstrap_mean_ci(x: np.ndarray, rng: np.random.Generator, n: int = 2000) -> tuple[float, float]:
    """95% percentile-bootstrap interval of the mean."""
    if len(x) == 0:
        return (math.nan, math.nan)
    means = x[rng.integers(0, len(x), (n, len(x)))].mean(axis=1)
    return float(np.percentile(means, 2.5)), float(np.percentile(means, 97.5))


def summarize(runs: Sequence[Run], biases: dict, seed: int = 0) -> list[dict]:
    """One row per (family, planner, sampler) on the test split.

    Goal-bias rows are the default 0.05, the tuned best, and (for completeness) the rest of the sweep.
    """
    rng = np.random.default_rng(seed)
    test = [r for r in runs if r.split == "test"]
    groups: dict = {}
    for r in test:
        groups.setdefault((r.family, r.planner, r.sampler), []).append(r)
    rows = []
    for (fam, planner, sampler), rs in sorted(groups.items()):
        its = np.array([r.iterations for r in rs], dtype=float)
        solved = np.array([r.solved for r in rs])
        lb = np.array([r.lower_bound for r in rs], dtype=float)
        label = sampler
        if sampler.startswith("goal_bias="):
            b = float(sampler.split("=")[1])
            tags = [t for t, ok in (("default", b == 0.05), ("best", biases.get((fam, planner)) == b)) if ok]
            label = f"goal bias {b:g}" + (f" ({', '.join(tags)})" if tags else "")
        lo, hi = bootstrap_mean_ci(its, rng)
        q1, med, q3 = np.percentile(its, [25, 50, 75])
        rows.append({
            "family": fam, "planner": planner, "sampler": label, "runs": len(rs),
            "success": float(solved.mean()),
            "median_iterations": float(med), "iqr": f"{q1:.0f}-{q3:.0f}",
            "mean_iterations": float(its.mean()), "mean_ci95": f"{lo:.0f}-{hi:.0f}",
            "ratio_to_lower_bound": float(np.median(its / lb)),
            "median_candidates": float(np.median([r.candidates for r in rs])),
            "median_checks": float(np.median([r.collision_checks for r in rs])),
            "median_wall_ms": float(np.median([r.wall_time for r in rs]) * 1e3),
            "median_cost": float(np.median([r.path_cost for r in rs if r.solved])) if solved.any() else math.nan,
            "median_forward_passes": float(np.median([r.forward_passes for r in rs])),
            "_sampler": sampler,
        })
    return rows


def headline(rows: Sequence[dict], biases: dict) -> list[dict]:
    """Per family (RRT): policy vs best-tuned goal bias, with the target checks."""
    out = []
    by = {(r["family"], r["planner"], r["_sampler"]): r for r in rows}
    for fam in sorted({r["family"] for r in rows}):
        b = biases.get((fam, "RRT"))
        pol = by.get((fam, "RRT", "policy"))
        gb = by.get((fam, "RRT", f"goal_bias={b:g}")) if b is not None else None
        uni = by.get((fam, "RRT", "uniform"))
        ref = by.get((fam, "RRT", "expert (reference)"))
        if pol is None or gb is None:
            continue
        out.append({
            "family": fam, "best_bias": b,
            "uniform_median": uni["median_iterations"] if uni else math.nan,
            "best_bias_median": gb["median_iterations"], "policy_median": pol["median_iterations"],
            "expert_median": ref["median_iterations"] if ref else math.nan,
            "policy/best_bias": pol["median_iterations"] / max(gb["median_iterations"], 1e-9),
            "policy_success": pol["success"], "best_bias_success": gb["success"],
            "policy_wall_ms": pol["median_wall_ms"], "best_bias_wall_ms": gb["median_wall_ms"],
        })
    return out


def save_plots(runs: Sequence[Run], rows: Sequence[dict], biases: dict, out_dir: Path,
               planner: str = "RRT") -> list[Path]:
    """ECDF of iterations-to-solution per sampler for each family, and bars of means with 95% CIs."""
    from planners.plotting import new_figure, save_figure

    test = [r for r in runs if r.split == "test" and r.planner == planner]
    fams = sorted({r.family for r in test})
    if not fams:
        return []
    cols = min(4, len(fams))
    nrows = math.ceil(len(fams) / cols)
    fig = new_figure((4.2 * cols, 3.4 * nrows))
    shown = lambda fam: ["uniform", "goal_bias=0.05", f"goal_bias={biases.get((fam, planner), 0.05):g}", "policy",  # noqa: E731
                         "expert (reference)"]
    for i, fam in enumerate(fams):
        ax = fig.add_subplot(nrows, cols, i + 1)
        # fixed colours per role, so panels where the best bias is the default 0.05 read the same
        best_s = f"goal_bias={biases.get((fam, planner), 0.05):g}"
        colors = {"uniform": "C0", best_s: "C2", "goal_bias=0.05": "C1", "policy": "C3", "expert (reference)": "0.4"}
        for s in dict.fromkeys(shown(fam)):
            its = np.sort([r.iterations if r.solved else math.inf for r in test if r.family == fam and r.sampler == s])
            if len(its) == 0:
                continue
            label = s.replace("goal_bias=", "goal bias ") + (" (best)" if s == best_s else "")
            style = {"linestyle": "--"} if s.startswith("expert") else {}
            ax.step(its, np.arange(1, len(its) + 1) / len(its), where="post", label=label, color=colors[s], **style)
        ax.set_xscale("log")
        ax.set_title(fam)
        ax.set_xlabel("iterations to solution")
        ax.set_ylabel("fraction solved")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6)
    p1 = save_figure(fig, out_dir / "ecdf.png", dpi=110)
    fig = new_figure((max(6.0, 1.6 * len(fams)), 3.6))
    ax = fig.add_subplot(1, 1, 1)
    sel = [("uniform", "uniform"), ("best goal bias", None), ("policy", "policy")]
    width = 0.8 / len(sel)
    for j, (label, s) in enumerate(sel):
        means, errs = [], []
        for fam in fams:
            key = s or f"goal_bias={biases.get((fam, planner), 0.05):g}"
            r = next((x for x in rows if x["family"] == fam and x["planner"] == planner and x["_sampler"] == key), None)
            if r is None:
                means.append(math.nan)
                errs.append((0, 0))
                continue
            lo, hi = (float(v) for v in r["mean_ci95"].split("-"))
            means.append(r["mean_iterations"])
            errs.append((r["mean_iterations"] - lo, hi - r["mean_iterations"]))
        x = np.arange(len(fams)) + (j - 1) * width
        ax.bar(x, means, width, yerr=np.array(errs).T, capsize=3, label=label)
    ax.set_xticks(np.arange(len(fams)), fams, rotation=30, ha="right")
    ax.set_yscale("log")
    ax.set_ylabel("mean iterations (95% CI)")
    ax.legend()
    p2 = save_figure(fig, out_dir / "means.png", dpi=110)
    return [p1, p2]


def write_csv(runs: Sequence[Run], path: Path) -> None:
    """Every run as a CSV row, written whole or not at all."""
    import csv
    import io
    import tempfile

    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(asdict(runs[0])))
    w.writeheader()
    w.writerows(asdict(r) for r in runs)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}-")
    with os.fdopen(fd, "w") as f:
        f.write(buf.getvalue())
    os.replace(tmp, path)
