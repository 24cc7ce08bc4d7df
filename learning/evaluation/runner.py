"""Executing runs: one run per task, on a local process pool or Ray, with what workers need loaded once."""

from __future__ import annotations

import math
import time
from collections.abc import Sequence

from learning.evaluation.protocol import SCENARIO_CACHE, scenarios
from learning.evaluation.roster import (
    CORRIDOR_FOLLOWER,
    CORRIDOR_UNIFORM,
    FOLLOWER,
    GEODESIC_FRONTIER,
    ROUTE,
    ROUTE_ABLATION,
    sampler_policy_batch,
)
from learning.samplers.registry import make_sampler, user_sampler
from planners import make_planner
from planners.base.registry import planner_class
from planners.tools.benchmark import Run
from planners.tools.parallel import Backend, make_backend


_USER: dict = {}


def _sampler(name: str, cfg: dict):
    """The sampler a task names, built from the registry (``learning.samplers.registry``) with the run's step."""
    if name in cfg.get("user_samplers", {}):
        spec = cfg["user_samplers"][name]
        if spec not in _USER:  # once per process: a model is loaded once, not per run
            _USER[spec] = user_sampler(spec)
        return _USER[spec]
    policy_path, step = cfg["policy"], cfg["step"]
    if name == "uniform":
        return make_sampler("uniform")
    if name.startswith("constant="):  # decides as often as the policy does: only the distribution differs
        return make_sampler("policy_ablation", frontier=float(name.split("=")[1]), step_size=step,
                            batch=cfg.get("policy_batch", 8))
    if name.startswith("goal_bias="):
        return make_sampler("goal_bias", bias=float(name.split("=")[1]))
    if name == "policy":  # at the batch tuned on the tuning split (the checkpoint's own before tuning)
        return _policy(policy_path, cfg.get("policy_batch"))
    if name.startswith("policy batch="):
        return _policy(policy_path, int(name.split("=")[1]))
    if name == FOLLOWER:
        return make_sampler("follower", step_size=step)
    if name == ROUTE:
        from learning.samplers.route import shipped_sampler

        return shipped_sampler(_route_net(cfg["route"]), step)  # the encoder loaded once per process
    if name == ROUTE_ABLATION:
        return make_sampler("route_ablation", step_size=step)
    if name == "expert (reference)":
        return make_sampler("expert", step_size=step)
    if name.startswith((CORRIDOR_UNIFORM, CORRIDOR_FOLLOWER)):
        from learning.references.expert import CorridorSampler

        base = make_sampler("uniform" if name.startswith(CORRIDOR_UNIFORM) else "follower",
                            **({} if name.startswith(CORRIDOR_UNIFORM) else {"step_size": step}))
        return CorridorSampler(float(name.split("=")[1]), base)
    if name.startswith(GEODESIC_FRONTIER):
        from learning.references.expert import GeodesicFrontierSampler

        return GeodesicFrontierSampler(float(name.split("=")[1]), step_size=step)
    raise ValueError(f"unknown sampler {name!r}")


_POLICY: dict = {}


_ROUTE: dict = {}


def _route_net(path: str):
    if path not in _ROUTE:
        from learning.models.route_net import load_route_net

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
        SCENARIO_CACHE.update(context.get("scenarios", {}))
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
    policies, routes, loaded = {}, {}, {}
    for query, _, sampler, _, cfg in tasks:
        if sampler == ROUTE:
            routes[cfg["route"]] = _route_net(cfg["route"])
        if sampler == "policy" or sampler.startswith("policy batch="):
            batch = cfg.get("policy_batch") if sampler == "policy" else sampler_policy_batch(sampler)
            policies[cfg["policy"], batch] = _policy(cfg["policy"], batch)
        if not query.size:
            key = (cfg["movingai_dir"], query.family, cfg["tolerance"])
            loaded[key] = scenarios(*key)
    return {"policies": policies, "routes": routes, "scenarios": loaded}


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
