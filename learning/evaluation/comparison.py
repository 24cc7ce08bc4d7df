"""The comparison: iterations-to-solution of the learned sampler against uniform and goal bias.

Every run is one planner on one query with one sampler and one seed. Goal bias is swept; the bias
reported as "best" for a family is chosen on a separate tuning split (other map seeds, or other
MovingAI scenarios of the same maps), never on the evaluated queries, from a grid that includes
uniform sampling (bias 0), so the "best" bias is never worse than uniform on the tuning split. The
policy's batch (samples per decision) is chosen on the generated families' tuning maps too
(:func:`best_policy_batch`), and the constant-distribution ablation decides as often. Shifted
map sets (each family's ``generate(..., shifted=True)`` maps) are test-only: they keep the settings
tuned on their family's tuning split. The
privileged expert is a reference, not a competitor: it reads the map's geodesic distance field.

Results are written as a CSV of runs, a Markdown summary, plots, and OMPL benchmark logs
(:func:`write_ompl_logs`) that OMPL's ``ompl_benchmark_statistics.py`` and Planner Arena open.
"""

from __future__ import annotations

import math
import re
import textwrap
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from learning.samplers.ablation import FRONTIER_GRID, ConstantGuidedSampler
from planners import GoalBiasedSampler, Problem, Sampler, UniformSampler, load_movingai_scenarios, make_planner
from planners.base.fileio import InputError
from planners.base.registry import planner_class
from planners.maps.generators import SHIFTED_SEED0, SHIFTED_SIZES, TEST_SEED0, TUNING_SEED0, generate
from planners.tools.benchmark import OMPL_RUN_PROPERTIES, Run, ompl_run_values
from planners.tools.benchmark_log import PlannerRuns, experiment_name, write_log
from planners.tools.parallel import Backend, make_backend

GOAL_BIASES = (0.01, 0.05, 0.1, 0.2, 0.5)
#: The grid the best goal bias is chosen from: uniform sampling (bias 0) and the sweep.
TUNING_BIASES = (0.0, *GOAL_BIASES)


@dataclass(frozen=True)
class Query:
    """A problem reference that worker processes can rebuild cheaply."""

    family: str  # generated family or MovingAI map name
    key: int  # generator seed, or scenario index
    size: int  # generated size (0 for MovingAI)
    split: str  # "test" or "tuning"
    shifted: bool = False  # the family's shifted generator (test split only)

    @property
    def map_set(self) -> str:
        """The map set this query is reported under: the family, its shifted variant, or the MovingAI map."""
        return shifted_name(self.family) if self.shifted else self.family

    def problem(self, movingai_dir: str | None, tolerance: float) -> Problem:
        if self.size:
            return generate(self.family, self.key, self.size, goal_tolerance=tolerance, shifted=self.shifted)
        return _scenarios(movingai_dir, self.family, tolerance)[self.key]


def shifted_name(family: str) -> str:
    """The map-set name of ``family``'s shifted test maps."""
    return f"{family} (shifted)"


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


def bias_sampler(bias: float) -> str:
    """The sampler name of goal bias ``bias``: ``"uniform"`` for 0, else ``"goal_bias=<bias>"``."""
    return "uniform" if bias == 0 else f"goal_bias={bias:g}"


def _sampler_bias(name: str) -> float | None:
    """The goal bias of sampler ``name`` (0 for uniform), or None for other samplers."""
    if name == "uniform":
        return 0.0
    if name.startswith("goal_bias="):
        return float(name.split("=")[1])
    return None


#: The test-split name of the ablation's runs, each at the frontier probability tuned for its map set.
CONSTANT = "constant (tuned)"


def constant_sampler(frontier: float) -> str:
    """The sampler name of the constant-distribution ablation at frontier probability ``frontier``."""
    return f"constant={frontier:g}"


#: Name prefix of the privileged ablation whose frontier knows the geodesic distance (``learning.references.expert``).
GEODESIC_FRONTIER = "geodesic frontier="


#: Name prefixes of the privileged corridor references (``learning.references.expert.CorridorSampler``): the share of
#: samples drawn from the exact near-shortest-path corridor follows, the rest come from uniform sampling or
#: the straight-line follower.
CORRIDOR_UNIFORM, CORRIDOR_FOLLOWER = "corridor+uniform=", "corridor+follower="


def _sampler_constant(name: str) -> float | None:
    return float(name.split("=")[1]) if name.startswith("constant=") else None


def constant_tuning_tasks(queries: Sequence[Query], planner: str, cfg: dict) -> list[tuple]:
    """Runs that tune the ablation: every frontier probability of ``FRONTIER_GRID`` on every tuning query."""
    return [(q, planner, constant_sampler(p), 0, cfg) for q in queries if q.split == "tuning" for p in FRONTIER_GRID]


def constant_test_tasks(queries: Sequence[Query], planner: str, cfg: dict, best: dict, seeds: int) -> list[tuple]:
    """The ablation on the test split, at the frontier probability tuned for each query's map set."""
    return [(q, planner, constant_sampler(best[(q.map_set, planner)]), seed, cfg) for q in queries
            if q.split == "test" and (q.map_set, planner) in best for seed in range(seeds)]


#: The policy's batches (samples per decision; the training batch is 8) tried on the tuning split.
POLICY_BATCHES = (8, 2, 1)
#: Planner seeds per tuning query for the batch: one choice for every map set deserves more than one seed.
POLICY_TUNING_SEEDS = 3
#: In the sum of log medians: batches within 1% of one family's median of the lowest count as tied.
BATCH_TIE = 0.01


def policy_sampler(batch: int) -> str:
    """The sampler name of the policy deciding every ``batch`` samples (a tuning run)."""
    return f"policy batch={batch}"


def _sampler_policy_batch(name: str) -> int | None:
    return int(name.split("=")[1]) if name.startswith("policy batch=") else None


def policy_tuning_tasks(queries: Sequence[Query], planner: str, cfg: dict,
                        batches: Sequence[int] = POLICY_BATCHES, seeds: int = POLICY_TUNING_SEEDS) -> list[tuple]:
    """Runs that choose the policy's batch: every batch on every generated family's tuning query.

    MovingAI scenarios are left out, so the choice does not depend on whether those maps are at hand.
    """
    return [(q, planner, policy_sampler(b), s, cfg) for q in queries if q.split == "tuning" and q.size
            for b in batches for s in range(seeds)]


def best_policy_batch(runs: Sequence[Run]) -> tuple[int, dict[int, float]]:
    """(chosen batch, sum of log median iterations per batch) from ``policy_tuning_tasks``' runs.

    The score sums, over map sets, the log of the median iterations (unsolved runs count as the cap),
    so every family weighs the same whatever its scale. Batches within :data:`BATCH_TIE` of the lowest
    score are tied and the largest of them wins: it takes fewer forward passes.
    """
    groups: dict = {}
    for r in runs:
        b = _sampler_policy_batch(r.sampler)
        if r.split == "tuning" and b is not None:
            groups.setdefault(b, {}).setdefault(r.map, []).append(r.iterations)
    if not groups:
        raise ValueError("no tuning runs of the policy's batches")
    score = {b: float(sum(np.log(np.median(its)) for its in fams.values())) for b, fams in groups.items()}
    low = min(score.values())
    return max(b for b, v in score.items() if v <= low + BATCH_TIE), score


def tuning_tasks(queries: Sequence[Query], planner: str, cfg: dict) -> list[tuple]:
    """Runs that choose the best goal bias: every bias of :data:`TUNING_BIASES` on every tuning query."""
    return [(q, planner, bias_sampler(b), 0, cfg) for q in queries if q.split == "tuning" for b in TUNING_BIASES]


def generated_queries(families: Sequence[str], size: int, n_test: int, n_tune: int) -> list[Query]:
    """``n_test`` test and ``n_tune`` tuning maps per family, on their disjoint seed ranges."""
    return ([Query(f, TEST_SEED0 + i, size, "test") for f in families for i in range(n_test)]
            + [Query(f, TUNING_SEED0 + i, size, "tuning") for f in families for i in range(n_tune)])


def shifted_queries(families: Sequence[str], n_test: int) -> list[Query]:
    """``n_test`` test maps per family from its shifted generator, sides cycling through ``SHIFTED_SIZES``.

    There is no shifted tuning split: baselines keep the setting tuned on the family's own tuning
    maps (:func:`tuned_for_shifted`), as the policy keeps what it learned on the family's training maps.
    """
    return [Query(f, SHIFTED_SEED0 + i, SHIFTED_SIZES[i % len(SHIFTED_SIZES)], "test", shifted=True)
            for f in families for i in range(n_test)]


def tuned_for_shifted(tuned: dict[tuple[str, str], float], queries: Sequence[Query]) -> dict[tuple[str, str], float]:
    """``tuned`` (per (map set, planner)) with each shifted map set given its family's tuned setting."""
    out = dict(tuned)
    for fam in {q.family for q in queries if q.shifted}:
        for (map_set, planner), value in tuned.items():
            if map_set == fam:
                out[(shifted_name(fam), planner)] = value
    return out


def movingai_queries(directory: str, maps: Sequence[str], n_test: int, n_tune: int, tolerance: float) -> list[Query]:
    """The longest half of each map's scenarios, alternately assigned to the test and tuning splits.

    ``n_test`` test and ``n_tune`` tuning scenarios per map (fewer where a map has too few).
    """
    out = []
    for m in maps:
        ps = _scenarios(directory, m, tolerance)
        half = max(2, len(ps) // 2)
        stride = max(1, half // (2 * max(n_test, n_tune)))
        picks = list(range(0, half, stride))
        out += [Query(m, i, 0, "test") for i in picks[0::2][:n_test]]
        out += [Query(m, i, 0, "tuning") for i in picks[1::2][:n_tune]]
    return out


#: Sampler names the comparison defines itself; a user sampler takes another name.
#: The strongest sampler without learning we know: ``learning.samplers.route.RouteSampler`` on the straight-line
#: distance (one step ahead of the vertex nearest the goal; the frontier after 4 iterations without progress).
FOLLOWER = "straight-line follower"
#: The shipped route encoder (``learning.samplers.route.shipped_sampler``) and its ablation, the same sampler
#: with the straight-line distance in place of the encoder's field (``learning.samplers.route.shipped_ablation``).
ROUTE, ROUTE_ABLATION = "route encoder", "route ablation"
BUILTIN_SAMPLERS = ("uniform", "policy", FOLLOWER, ROUTE, ROUTE_ABLATION, "expert (reference)")


def parse_user_sampler(arg: str) -> tuple[str, str]:
    """``NAME=SPEC`` from the command line, checked: the name and the spec (see :func:`user_sampler`)."""
    name, sep, spec = arg.partition("=")
    name, spec = name.strip(), spec.strip()
    if not sep or not name or not spec:
        raise InputError(f"--sampler {arg!r}: expected NAME=SPEC, e.g. mine=user_ppo.zip@SamplerGym/RRT-Forest-v0 "
                         "or mine=my_module:make_sampler")
    if name in BUILTIN_SAMPLERS or name.startswith("goal_bias=") or "," in name:
        raise InputError(f"--sampler {arg!r}: the name {name!r} is taken or has a comma; choose another")
    return name, spec


def user_sampler(spec: str):
    """The sampler a spec names.

    ``MODEL.zip@ENV_ID[@OPTION...]``: an SB3 model trained on that SamplerGym id (``SB3Sampler``);
    options are ``stochastic`` (draw actions from the policy's distribution; default deterministic),
    ``algo=NAME``, or env kwargs ``key=value`` (the ones the model was trained with; values read as
    JSON where they parse, else as strings). ``module:callable``: ``callable()`` returns a ``Sampler``.
    """
    import importlib
    import json

    if "@" in spec:
        from learning.samplers.sb3 import SB3Sampler

        path, env_id, *options = spec.split("@")
        kwargs: dict = {"deterministic": True}
        for opt in options:
            key, sep, value = opt.partition("=")
            if opt in ("stochastic", "deterministic"):
                kwargs["deterministic"] = opt == "deterministic"
            elif sep and key:
                try:
                    kwargs[key] = json.loads(value)
                except ValueError:
                    kwargs[key] = value
            else:
                raise InputError(f"sampler spec {spec!r}: option {opt!r} is not stochastic, deterministic or key=value")
        return SB3Sampler(path, env_id, **kwargs)
    module, sep, attr = spec.partition(":")
    if not sep or not module or not attr:
        raise InputError(f"sampler spec {spec!r}: expected MODEL.zip@ENV_ID or module:callable")
    try:
        factory = getattr(importlib.import_module(module), attr)
    except (ImportError, AttributeError) as exc:
        raise InputError(f"sampler spec {spec!r}: {type(exc).__name__}: {exc}") from None
    try:
        sampler = factory()
    except Exception as exc:  # noqa: BLE001 - the user's code: whatever it raises, name the spec
        raise InputError(f"sampler spec {spec!r}: {attr}() raised {type(exc).__name__}: {exc}") from None
    if not isinstance(sampler, Sampler):
        raise InputError(f"sampler spec {spec!r}: {attr}() returned a {type(sampler).__name__}, not a Sampler "
                         "(an object with bind(problem) and draw(rng, n, view))")
    return sampler


_USER: dict = {}


def _sampler(name: str, cfg: dict):
    if name in cfg.get("user_samplers", {}):
        spec = cfg["user_samplers"][name]
        if spec not in _USER:  # once per process: a model is loaded once, not per run
            _USER[spec] = user_sampler(spec)
        return _USER[spec]
    policy_path, step = cfg["policy"], cfg["step"]
    if name == "uniform":
        return UniformSampler()
    if name.startswith("constant="):  # decides as often as the policy does: only the distribution differs
        return ConstantGuidedSampler(float(name.split("=")[1]), step_size=step, batch=cfg.get("policy_batch", 8))
    if name.startswith("goal_bias="):
        return GoalBiasedSampler(float(name.split("=")[1]))
    if name == "policy":  # at the batch tuned on the tuning split (the checkpoint's own before tuning)
        return _policy(policy_path, cfg.get("policy_batch"))
    if name.startswith("policy batch="):
        return _policy(policy_path, int(name.split("=")[1]))
    if name == FOLLOWER:
        from learning.samplers.route import RouteSampler

        return RouteSampler(None, step_size=step)
    if name == ROUTE:
        from learning.samplers.route import shipped_sampler

        return shipped_sampler(_route_net(cfg["route"]), step)
    if name == ROUTE_ABLATION:
        from learning.samplers.route import shipped_ablation

        return shipped_ablation(step)
    if name == "expert (reference)":
        from learning.references.expert import ExpertSampler

        return ExpertSampler(step)
    if name.startswith((CORRIDOR_UNIFORM, CORRIDOR_FOLLOWER)):
        from learning.references.expert import CorridorSampler
        from learning.samplers.route import RouteSampler

        base = UniformSampler() if name.startswith(CORRIDOR_UNIFORM) else RouteSampler(None, step_size=step)
        return CorridorSampler(float(name.split("=")[1]), base)
    if name.startswith(GEODESIC_FRONTIER):
        from learning.references.expert import GeodesicFrontierSampler

        return GeodesicFrontierSampler(float(name.split("=")[1]), step_size=step)
    raise ValueError(f"unknown sampler {name!r}")


_POLICY: dict = {}
_ROUTE: dict = {}


def _route_net(path: str):
    if path not in _ROUTE:
        from learning.samplers.route import load_route_net

        _ROUTE[path] = load_route_net(path)
    return _ROUTE[path]


def _policy(path: str, batch: int | None = None):
    if (path, batch) not in _POLICY:
        from learning.samplers.policy import PolicySampler

        _POLICY[path, batch] = PolicySampler.load(path, batch=batch)
    return _POLICY[path, batch]


def run_one(task: tuple, context: dict | None = None) -> Run:
    """Execute one run (a top-level function so workers can receive it).

    ``context`` (:func:`shared_context`) holds what every run needs loaded (the policy, MovingAI
    scenarios); without it they are loaded here, once per process.
    """
    query, planner_name, sampler_name, seed, cfg = task
    if context:
        _POLICY.update(context.get("policies", {}))
        _ROUTE.update(context.get("routes", {}))
        _SCEN_CACHE.update(context.get("scenarios", {}))
    problem = query.problem(cfg["movingai_dir"], cfg["tolerance"])
    sampler = _sampler(sampler_name, cfg)
    # iterations to the first solution: anytime planners stop there too
    anytime = {"stop_on_first_solution": True} if planner_class(planner_name).anytime else {}
    t0 = time.perf_counter()  # wall time includes binding the sampler (the policy's per-map setup)
    planner = make_planner(planner_name, problem, extension_step=cfg["step"], sampler=sampler, seed=seed, **anytime)
    r = planner.solve(max_iterations=cfg["max_iterations"])
    wall = time.perf_counter() - t0
    its = r.first_solution_iteration if r.solved else r.iterations
    return Run(map=query.map_set, query=problem.name, split=query.split, planner=planner_name, sampler=sampler_name,
               seed=seed, solved=r.solved, iterations=int(its), lower_bound=problem.iteration_lower_bound(cfg["step"]),
               candidates=r.candidates, collision_checks=r.collision_checks, wall_time=wall,
               us_per_iteration=wall / max(r.iterations, 1) * 1e6, path_cost=r.cost if r.solved else math.inf,
               forward_passes=int(getattr(planner.sampler, "forward_passes", 0)), vertices=int(r.num_vertices))


def shared_context(tasks: Sequence[tuple]) -> dict:
    """What the runs of ``tasks`` need loaded, loaded once here and shipped once to each worker.

    The policy checkpoint, the route encoder and the MovingAI scenarios travel as loaded objects, so
    workers on other machines need none of the files; generated maps travel as (family, seed, size)
    and are rebuilt.
    """
    policies, routes, scenarios = {}, {}, {}
    for query, _, sampler, _, cfg in tasks:
        if sampler == ROUTE:
            routes[cfg["route"]] = _route_net(cfg["route"])
        if sampler == "policy" or sampler.startswith("policy batch="):
            batch = cfg.get("policy_batch") if sampler == "policy" else _sampler_policy_batch(sampler)
            policies[cfg["policy"], batch] = _policy(cfg["policy"], batch)
        if not query.size:
            key = (cfg["movingai_dir"], query.family, cfg["tolerance"])
            scenarios[key] = _scenarios(*key)
    return {"policies": policies, "routes": routes, "scenarios": scenarios}


def worker_init() -> None:
    """One torch thread per worker: the workers share the machine's cores between them."""
    import torch

    torch.set_num_threads(1)


def run_all(tasks: list[tuple], backend: Backend | int = 1, progress: bool = True) -> list[Run]:
    """Run tasks on ``backend`` (or on that many local processes), in task order, with a progress bar."""
    if isinstance(backend, int):
        backend = make_backend("local", processes=backend, worker_init=worker_init)
    context = shared_context(tasks) if backend.workers > 1 else None
    return backend.map(run_one, tasks, context=context, progress=progress, desc="runs")


def run_on_backend_args(tasks: list[tuple], args) -> list[Run]:
    """A script's one batch of runs: ``run_all`` on a backend made from its ``add_backend_arguments`` flags.

    No progress bar; the backend is closed afterwards.
    """
    backend = make_backend(args.backend, processes=args.processes, address=args.address, worker_init=worker_init)
    try:
        return run_all(tasks, backend, progress=False)
    finally:
        backend.close()


def pooled(runs: Sequence[Run], name: str, families: Sequence[str]) -> list[Run]:
    """Copies of the runs on ``families`` relabelled as one family ``name`` (e.g. all MovingAI maps).

    The best bias is then tuned, and the summary taken, over the pool as a whole.
    """
    from dataclasses import replace

    keep = set(families)
    return [replace(r, map=name) for r in runs if r.map in keep]


def best_bias(runs: Sequence[Run]) -> dict[tuple[str, str], float]:
    """Per (family, planner): the goal bias with the lowest median iterations on the tuning split.

    Uniform runs count as bias 0, so the choice is never worse than uniform on the tuning split
    (0 is returned where uniform is best). Test-split runs are never looked at.
    """
    return _best_on_tuning(runs, _sampler_bias)


def best_constant(runs: Sequence[Run]) -> dict[tuple[str, str], float]:
    """Per (family, planner): the ablation's frontier probability with the lowest median on the tuning split."""
    return _best_on_tuning(runs, _sampler_constant)


def _best_on_tuning(runs: Sequence[Run], value_of) -> dict[tuple[str, str], float]:
    out: dict = {}
    groups: dict = {}
    for r in runs:
        b = value_of(r.sampler)
        if r.split == "tuning" and b is not None:
            groups.setdefault((r.map, r.planner, b), []).append(r.iterations if r.solved else math.inf)
    # ascending bias: a tie keeps the smaller bias, the one nearer uniform
    for (fam, planner, b), its in sorted(groups.items(), key=lambda kv: kv[0][2]):
        med = float(np.median(its))
        key = (fam, planner)
        if key not in out or med < out[key][1]:
            out[key] = (b, med)
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
        groups.setdefault((r.map, r.planner, r.sampler), []).append(r)
    rows = []
    for (fam, planner, sampler), rs in sorted(groups.items()):
        its = np.array([r.iterations for r in rs], dtype=float)
        solved = np.array([r.solved for r in rs])
        lb = np.array([r.lower_bound for r in rs], dtype=float)
        label = sampler
        b = _sampler_bias(sampler)
        if b is not None:
            tags = [t for t, ok in (("default", b == 0.05), ("best", biases.get((fam, planner)) == b)) if ok]
            label = ("uniform" if b == 0 else f"goal bias {b:g}") + (f" ({', '.join(tags)})" if tags else "")
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


def headline(rows: Sequence[dict], biases: dict, extra: Sequence[str] = (),
             constants: dict | None = None) -> list[dict]:
    """Per family (RRT): policy vs best-tuned goal bias and vs the tuned constant-distribution ablation.

    ``constants`` holds the ablation's tuned frontier probability per (family, planner) (missing for a
    pooled row, whose maps each have their own). ``extra`` samplers (user samplers) get the same
    median, ratio, success and wall-time columns.
    """
    out = []
    by = {(r["family"], r["planner"], r["_sampler"]): r for r in rows}
    for fam in sorted({r["family"] for r in rows}):
        b = biases.get((fam, "RRT"))
        pol = by.get((fam, "RRT", "policy"))
        gb = by.get((fam, "RRT", bias_sampler(b))) if b is not None else None
        uni = by.get((fam, "RRT", "uniform"))
        ref = by.get((fam, "RRT", "expert (reference)"))
        if pol is None or gb is None:
            continue
        out.append({
            "family": fam, "best_bias": b,
            "uniform_median": uni["median_iterations"] if uni else math.nan,
            "best_bias_median": gb["median_iterations"], "policy_median": pol["median_iterations"],
            "expert_median": ref["median_iterations"] if ref else math.nan,
            "policy/lower_bound": pol["ratio_to_lower_bound"],
            "expert/lower_bound": ref["ratio_to_lower_bound"] if ref else math.nan,
            "expert/best_bias": ref["median_iterations"] / max(gb["median_iterations"], 1e-9) if ref else math.nan,
            "expert_success": ref["success"] if ref else math.nan,
            "policy/best_bias": pol["median_iterations"] / max(gb["median_iterations"], 1e-9),
            "policy_success": pol["success"], "best_bias_success": gb["success"],
            "policy_wall_ms": pol["median_wall_ms"], "best_bias_wall_ms": gb["median_wall_ms"],
        })
        if constants is not None:
            c = by.get((fam, "RRT", CONSTANT))
            out[-1].update({
                "best_constant": constants.get((fam, "RRT"), "per map"),
                "constant_median": c["median_iterations"] if c else math.nan,
                "policy/constant": pol["median_iterations"] / max(c["median_iterations"], 1e-9) if c else math.nan,
                "expert/constant": (ref["median_iterations"] / max(c["median_iterations"], 1e-9)
                                    if c and ref else math.nan),
                "constant_success": c["success"] if c else math.nan,
                "constant_wall_ms": c["median_wall_ms"] if c else math.nan,
            })
        for name in extra:
            u = by.get((fam, "RRT", name))
            out[-1].update({
                f"{name}_median": u["median_iterations"] if u else math.nan,
                f"{name}/best_bias": u["median_iterations"] / max(gb["median_iterations"], 1e-9) if u else math.nan,
                f"policy/{name}": pol["median_iterations"] / max(u["median_iterations"], 1e-9) if u else math.nan,
                f"{name}/lower_bound": u["ratio_to_lower_bound"] if u else math.nan,
                f"{name}_success": u["success"] if u else math.nan,
                f"{name}_wall_ms": u["median_wall_ms"] if u else math.nan,
            })
    return out


#: Name of the row that pools every MovingAI map.
MOVINGAI_POOL = "MovingAI (all)"

#: Issue 18's targets for the learned sampler (RRT, test split): its median iterations at most these
#: multiples of the tuned ablation's, the best goal bias's and the iteration lower bound; and on every
#: MovingAI map at least this success rate.
TARGETS = {"policy/constant": 0.5, "policy/best_bias": 0.5, "policy/lower_bound": 4.0, "movingai_success": 0.9}


def target_check(head: Sequence[dict], movingai_maps: Sequence[str], sampler: str = "policy",
                 ablation: str = "constant") -> tuple[list[dict], int, int]:
    """Which of :data:`TARGETS` ``sampler`` meets, per map set of ``headline`` rows; (rows, met, total).

    Generated map sets (in-distribution and shifted) and the pooled MovingAI row are checked against
    ``ablation`` (the sampler with its learning removed; the policy's is the constant distribution),
    the best goal bias (a ratio counts only with success at least as high as the baseline's) and wall
    time; generated sets also against the lower bound; every MovingAI map against the success floor.
    ``sampler`` is "policy" or an ``extra`` sampler of ``headline``. With ``sampler="expert"`` the
    privileged reference is held to the same iteration and success targets (not wall time: its grid
    search is what the others may not run), which says which targets perfect route knowledge can
    reach at all.
    """
    t, s = TARGETS, sampler
    c_const = f"{s} / {ablation} <= {t['policy/constant']:g}"
    c_bias = f"{s} / best bias <= {t['policy/best_bias']:g}"
    c_lb, c_wall = f"{s} / lower bound <= {t['policy/lower_bound']:g}", "wall time / best bias's <= 1"
    c_maps = f"every map solved in >= {t['movingai_success']:.0%}"

    def ratio(value: float, limit: float, ok_success: bool = True) -> tuple[str, bool]:
        ok = value <= limit and ok_success
        return f"{value:.2f} " + ("yes" if ok else "no" if value > limit else "no (success)"), ok

    rows, met, total = [], 0, 0
    for h in sorted(head, key=lambda h: h["family"] == MOVINGAI_POOL or h["family"] in movingai_maps):
        fam = h["family"]
        # a single MovingAI map has no pooled row (``evaluate.py`` pools two or more): it stands for the set
        real_world = fam == MOVINGAI_POOL or (fam in movingai_maps and len(movingai_maps) == 1)
        if (fam in movingai_maps and not real_world) or math.isnan(h.get(f"{s}/best_bias", math.nan)):
            continue  # a single map of a pooled set, or a map set the sampler did not run on
        cells: dict[str, tuple[str, bool]] = {}
        vs = h.get(f"{s}_median", math.nan) / max(h.get(f"{ablation}_median", math.nan), 1e-9)
        if not math.isnan(vs):
            cells[c_const] = ratio(vs, t["policy/constant"], h[f"{s}_success"] >= h[f"{ablation}_success"])
        cells[c_bias] = ratio(h[f"{s}/best_bias"], t["policy/best_bias"], h[f"{s}_success"] >= h["best_bias_success"])
        if not real_world:
            cells[c_lb] = ratio(h[f"{s}/lower_bound"], t["policy/lower_bound"])
        if s != "expert":
            cells[c_wall] = ratio(h[f"{s}_wall_ms"] / max(h["best_bias_wall_ms"], 1e-12), 1.0)
        if real_world:
            by_map = {r["family"]: r[f"{s}_success"] for r in head if r["family"] in movingai_maps}
            short = sorted(m for m, v in by_map.items() if v < t["movingai_success"])
            cells[c_maps] = ("yes" if not short else "no: " + ", ".join(f"{m} {by_map[m]:.2f}" for m in short),
                             not short)
        rows.append({"map set": fam, **{k: text for k, (text, _) in cells.items()}})
        met += sum(ok for _, ok in cells.values())
        total += len(cells)
    columns = ["map set", *(c for c in (c_const, c_bias, c_lb, c_wall, c_maps) if any(c in r for r in rows))]
    return [{c: r.get(c, "") for c in columns} for r in rows], met, total


def _wrap(text: str, width_in: float, fontsize: float) -> str:
    """``text`` wrapped to lines that fit ``width_in`` inches at ``fontsize`` points."""
    # a character of the default sans-serif font averages well under 0.6 em wide
    return textwrap.fill(text, max(12, int(width_in * 72 / (0.6 * fontsize))))


def save_plots(runs: Sequence[Run], rows: Sequence[dict], biases: dict, out_dir: Path,
               planner: str = "RRT", extra: Sequence[str] = ()) -> list[Path]:
    """Write ``ecdf.png`` (:func:`ecdf_figure`) and ``means.png`` (:func:`means_figure`); returns their paths."""
    from planners.viz.plotting import save_figure

    if not any(r.split == "test" and r.planner == planner for r in runs):
        return []
    return [save_figure(ecdf_figure(runs, biases, planner, extra), out_dir / "ecdf.png", dpi=110),
            save_figure(means_figure(runs, rows, biases, planner, extra), out_dir / "means.png", dpi=110)]


def ecdf_figure(runs: Sequence[Run], biases: dict, planner: str = "RRT", extra: Sequence[str] = ()):
    """ECDF of iterations-to-solution per sampler, one panel per family (test split).

    Titles are wrapped to the figure's width and the layout is constrained, so no text is cut off.
    """
    from planners.viz.plotting import new_figure

    test = [r for r in runs if r.split == "test" and r.planner == planner]
    fams = sorted({r.map for r in test})
    cols = min(4, len(fams))
    nrows = math.ceil(len(fams) / cols)
    size = (4.2 * cols, 3.4 * nrows + 0.5)
    fig = new_figure(size)
    fig.suptitle(_wrap(f"{planner} on the test split: fraction of queries solved within n iterations (unsolved "
                       "runs never reach 1); best goal bias tuned on a separate split", size[0], 11), fontsize=11)
    for i, fam in enumerate(fams):
        ax = fig.add_subplot(nrows, cols, i + 1)
        best_s = bias_sampler(biases.get((fam, planner), 0.05))
        # fixed colours per role, so panels where the best bias is the default 0.05 read the same
        colors = {"uniform": "C0", "goal_bias=0.05": "C1", "policy": "C3", "expert (reference)": "0.4"}
        colors.setdefault(best_s, "C2")
        colors.update({name: f"C{4 + i}" for i, name in enumerate(extra)})
        for s in dict.fromkeys(["uniform", "goal_bias=0.05", best_s, "policy", *extra, "expert (reference)"]):
            its = np.sort([r.iterations if r.solved else math.inf for r in test if r.map == fam and r.sampler == s])
            if len(its) == 0:
                continue
            label = s.replace("goal_bias=", "goal bias ") + (" (best)" if s == best_s else "")
            style = {"linestyle": "--"} if s.startswith("expert") else {}
            ax.step(its, np.arange(1, len(its) + 1) / len(its), where="post", label=label, color=colors[s], **style)
        ax.set_xscale("log")
        ax.set_title(_wrap(fam, 4.0, 12))
        ax.set_xlabel("iterations to solution")
        ax.set_ylabel("fraction solved")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6)
    return fig


def means_figure(runs: Sequence[Run], rows: Sequence[dict], biases: dict, planner: str = "RRT",
                 extra: Sequence[str] = ()):
    """Mean iterations-to-solution with 95% bootstrap intervals per family: uniform, best bias, policy.

    The legend sits beside the bars, never over them; the title is wrapped to the figure's width.
    """
    from planners.viz.plotting import new_figure

    fams = sorted({r.map for r in runs if r.split == "test" and r.planner == planner})
    size = (max(6.0, 1.6 * len(fams)) + 1.6, 4.0)
    fig = new_figure(size)
    ax = fig.add_subplot(1, 1, 1)
    ax.set_title(_wrap(f"{planner} on the test split: mean iterations to solution with 95% bootstrap intervals "
                       "(unsolved runs count as the cap)", size[0] - 1.6, 11), fontsize=11)
    sel = [("uniform", "uniform"), ("best goal bias", None), ("policy", "policy"), *((n, n) for n in extra)]
    width = 0.8 / len(sel)
    for j, (label, s) in enumerate(sel):
        means, errs = [], []
        for fam in fams:
            key = s or bias_sampler(biases.get((fam, planner), 0.05))
            r = next((x for x in rows if x["family"] == fam and x["planner"] == planner and x["_sampler"] == key), None)
            if r is None:
                means.append(math.nan)
                errs.append((0, 0))
                continue
            lo, hi = (float(v) for v in r["mean_ci95"].split("-"))
            means.append(r["mean_iterations"])
            errs.append((r["mean_iterations"] - lo, hi - r["mean_iterations"]))
        x = np.arange(len(fams)) + (j - (len(sel) - 1) / 2) * width
        ax.bar(x, means, width, yerr=np.array(errs).T, capsize=3, label=label)
    ax.set_xticks(np.arange(len(fams)), fams, rotation=30, ha="right")
    ax.set_yscale("log")
    ax.set_ylabel("mean iterations (95% CI)")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    return fig


def write_ompl_logs(runs: Sequence[Run], biases: dict, out_dir: Path, cfg: dict) -> list[Path]:
    """One OMPL benchmark log per family (map set) of the test split, under ``out_dir``.

    Each planner and sampler pair is one OMPL planner configuration (e.g. ``RRT goal bias 0.05``);
    ``time`` is the run's wall time, including binding the sampler. Unsolved runs have no solution
    length. The logs open with ``ompl_benchmark_statistics.py out_dir/*.log -d db`` and Planner Arena.
    Tuning-split runs are left out: they choose the best bias, they are not the comparison.
    """
    test = [r for r in runs if r.split == "test"]
    fams: dict = {}
    for r in test:
        fams.setdefault(r.map, {}).setdefault((r.planner, r.sampler), []).append(r)
    paths = []
    for fam, configs in sorted(fams.items()):
        planners = {}
        for (planner, sampler), rs in sorted(configs.items()):
            b = _sampler_bias(sampler)
            name = f"{planner} " + (sampler if b is None else "uniform" if b == 0 else f"goal bias {b:g}")
            settings = {"planner": planner, "sampler": sampler, "step_size": cfg["step"],
                        "goal_tolerance": cfg["tolerance"], "max_iterations": cfg["max_iterations"]}
            if b is not None:
                settings["best_goal_bias_on_tuning_split"] = "yes" if biases.get((fam, planner)) == b else "no"
            if sampler == "policy":
                settings["policy"] = cfg["policy"]
            if sampler in cfg.get("user_samplers", {}):
                settings["spec"] = cfg["user_samplers"][sampler]
            planners[name] = PlannerRuns(settings, [ompl_run_values(r) for r in rs])
        queries = len({r.query for r in configs[next(iter(configs))]})
        setup = (f"SamplerGym comparison on {fam}, test split ({queries} queries, all runs of every sampler on the "
                 f"same queries and seeds). Iterations to first solution, capped at {cfg['max_iterations']}; "
                 f"the best goal bias was chosen on a separate tuning split (for shifted maps, their family's). "
                 f"'time' is wall time in seconds, "
                 f"including binding the sampler to the map. The expert is a privileged reference.")
        stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", fam).strip("_") or "experiment"
        paths.append(write_log(
            out_dir / f"{stem}.log", experiment_name(fam), planners, [(p, t) for p, t, _ in OMPL_RUN_PROPERTIES],
            setup=setup, total_time=sum(r.wall_time for rs in configs.values() for r in rs),
            experiment_properties={"step_size": ("REAL", cfg["step"]), "goal_tolerance": ("REAL", cfg["tolerance"]),
                                   "max_iterations": ("INTEGER", cfg["max_iterations"])}))
    return paths
