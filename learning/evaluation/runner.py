"""Executing runs: one run per task, on a local process pool or Ray, with what workers need passed in once."""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

from learning.evaluation.protocol import Protocol
from learning.evaluation.roster import Task
from learning.samplers.registry import USER, ModelCache
from planners import make_planner
from planners.base.registry import planner_class
from planners.tools.benchmark import Run
from planners.tools.parallel import Backend, make_backend


@dataclass
class RunContext:
    """What every run needs, shipped once to each worker: the protocol and what was loaded for the runs.

    ``models`` holds the route encoders, policies and users' samplers (loaded once, so workers on other
    machines need none of the files); ``scenarios`` the MovingAI scenarios by ``(directory, map, tolerance)``.
    Generated maps travel as (family, seed, size) and are rebuilt.
    """

    protocol: Protocol
    models: ModelCache = field(default_factory=ModelCache)
    scenarios: dict = field(default_factory=dict)


def run_one(task: Task, context: RunContext) -> Run:
    """Execute one run (a top-level function so workers can receive it) under ``context``'s protocol."""
    protocol = context.protocol
    problem = protocol.problem(task.query, context.scenarios)
    sampler = task.sampler.build(context.models)
    # iterations to the first solution: anytime planners stop there too
    anytime = {"stop_on_first_solution": True} if planner_class(task.planner).anytime else {}
    t0 = time.perf_counter()  # wall time includes binding the sampler (the policy's per-map setup)
    planner = make_planner(task.planner, problem, extension_step=protocol.step, sampler=sampler, seed=task.seed,
                           **anytime)
    r = planner.solve(max_iterations=protocol.max_iterations)
    wall = time.perf_counter() - t0
    its = r.first_solution_iteration if r.solved else r.iterations
    return Run(map=task.query.map_set, query=problem.name, split=task.query.split, planner=task.planner,
               sampler=task.sampler_label, seed=task.seed, solved=r.solved, iterations=int(its),
               lower_bound=problem.iteration_lower_bound(protocol.step), candidates=r.candidates,
               collision_checks=r.collision_checks, wall_time=wall, us_per_iteration=wall / max(r.iterations, 1) * 1e6,
               path_cost=r.cost if r.solved else math.inf,
               forward_passes=int(getattr(planner.sampler, "forward_passes", 0)), vertices=int(r.num_vertices),
               sampler_spec=task.sampler.to_json())


def shared_context(tasks: Sequence[Task], protocol: Protocol | RunContext) -> RunContext:
    """The context of ``tasks``: every file they name loaded once here, shipped once to each worker.

    Given a :class:`RunContext`, what it holds is kept and what ``tasks`` need more is loaded into it
    (and it is returned); given a :class:`Protocol`, a new context is made. Building each task's
    sampler once loads its weights; MovingAI scenarios are loaded for its queries. Users' samplers are
    left to each worker's first run (a user's object need not survive pickling).
    """
    context = protocol if isinstance(protocol, RunContext) else RunContext(protocol)
    for spec in dict.fromkeys(t.sampler for t in tasks):
        if getattr(spec, "name", None) != USER:
            spec.build(context.models)
    for query in dict.fromkeys(t.query for t in tasks if not t.query.size):
        context.protocol.problem(query, context.scenarios)
    return context


def worker_init() -> None:
    """One torch thread per worker: the workers share the machine's cores between them."""
    import torch

    torch.set_num_threads(1)


def run_all(tasks: Sequence[Task], protocol: Protocol | RunContext, backend: Backend | int = 1,
            progress: bool = True) -> list[Run]:
    """Run ``tasks`` under ``protocol`` on ``backend`` (or on that many local processes), in task order.

    Given a :class:`RunContext`, its loaded models and scenarios are reused (and added to).
    """
    if isinstance(backend, int):
        backend = make_backend("local", processes=backend, worker_init=worker_init)
    return backend.map(run_one, list(tasks), context=shared_context(tasks, protocol), progress=progress, desc="runs")


def run_on_backend_args(tasks: Sequence[Task], protocol: Protocol | RunContext, args) -> list[Run]:
    """A script's one batch of runs: ``run_all`` on a backend made from its ``add_backend_arguments`` flags.

    No progress bar; the backend is closed afterwards.
    """
    backend = make_backend(args.backend, processes=args.processes, address=args.address, worker_init=worker_init)
    try:
        return run_all(tasks, protocol, backend, progress=False)
    finally:
        backend.close()
