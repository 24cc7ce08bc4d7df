"""Executing runs: one run per task, on a local process pool or Ray, with what workers need passed in once."""

from __future__ import annotations

import math
import time
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass, field

from learning.evaluation.protocol import Protocol
from learning.evaluation.roster import Task
from learning.samplers.registry import USER, ModelCache
from learning.samplers.route import FieldCache, RouteSampler
from planners import Problem
from planners.base.planner import compile_seconds
from planners.base.registry import planner_class
from planners.base.samplers import draw_classical_in_loops
from planners.tools.benchmark import Run
from planners.tools.parallel import Backend, make_backend


class ProblemCache:
    """The problems of the last ``size`` queries one process met, so that the runs of a query share one build.

    Without it every run rebuilds its problem (a generated map from its family, seed and size), which on
    the comparison's maps costs about as much as the run. A problem is immutable (frozen, read-only
    arrays), so runs can share it; a run's wall time never included the build. Tasks come grouped by
    query, so a few recent queries cover nearly every run. The cache travels empty (pickled for a
    worker, it starts empty there).
    """

    def __init__(self, size: int = 32) -> None:
        self.size = size
        self._problems: OrderedDict = OrderedDict()

    def get(self, query, protocol: Protocol, scenarios: dict) -> Problem:
        """``protocol.problem(query, scenarios)``, built once while ``query`` is among the last ``size`` met."""
        problem = self._problems.get(query)
        if problem is None:
            problem = self._problems[query] = protocol.problem(query, scenarios)
            if len(self._problems) > self.size:
                self._problems.popitem(last=False)
        else:
            self._problems.move_to_end(query)
        return problem

    def __len__(self) -> int:
        return len(self._problems)

    def __getstate__(self) -> dict:
        return {"size": self.size}

    def __setstate__(self, state: dict) -> None:
        self.__init__(state["size"])


@dataclass
class RunContext:
    """What every run needs, shipped once to each worker: the protocol and what was loaded for the runs.

    ``models`` holds the route encoders, policies and users' samplers (loaded once, so workers on other
    machines need none of the files); ``scenarios`` the MovingAI scenarios by ``(directory, map, tolerance)``.
    Generated maps travel as (family, seed, size) and are rebuilt, once per query while it is among the
    last ones a worker met (``problems``, which travels empty).

    ``fields`` keeps the route encoder's fields in each worker (it travels empty), so the runs of one
    query that differ only by planner seed run the encoder once. ``batch_fields``: when a worker meets a
    query whose field it lacks, it computes it together with those of the next queries of the same sampler
    (up to ``prefill`` of them, in task order; ``route_queries``, set by ``shared_context``) in one batch
    of passes. None: so on a GPU, and one query at a time on the CPU, where a batch of several queries may
    round differently from one query alone (the CPU's iteration counts stay those of one query at a time).
    Each run's wall time still includes its query's field: the time of its passes, or its share of a
    batch's, where it was computed before the run (``RouteSampler.reused_seconds``): the evaluation takes
    less time, and a run reports what its query costs (with its share of a batch where batched).
    """

    protocol: Protocol
    models: ModelCache = field(default_factory=ModelCache)
    scenarios: dict = field(default_factory=dict)
    fields: FieldCache = field(default_factory=FieldCache)
    batch_fields: bool | None = None
    prefill: int = 64
    route_queries: dict = field(default_factory=dict)
    problems: ProblemCache = field(default_factory=ProblemCache)

    def problem(self, query) -> Problem:
        """The problem of ``query`` under the protocol, from ``problems`` where it was built recently."""
        return self.problems.get(query, self.protocol, self.scenarios)

    def forget_queries(self) -> None:
        """Forget every query's field and what the route encoders keep of each map (the models stay loaded).

        After an untimed warm-up: no timed run then reuses the warm-up's field, which carries the one-off cost of a
        process's first pass (tens of milliseconds), nor finds its map's parts kept.
        """
        self.fields = FieldCache(self.fields.max_bytes)
        self.models.forget_maps()


def run_one(task: Task, context: RunContext) -> Run:
    """Execute one run (a top-level function so workers can receive it) under ``context``'s protocol."""
    protocol = context.protocol
    problem = context.problem(task.query)
    sampler = task.sampler.build(context.models)
    if isinstance(sampler, RouteSampler) and sampler.net is not None and sampler.fields is None \
            and getattr(task.sampler, "name", None) != USER:  # a user's sampler is left as the user made it
        sampler.fields = context.fields
        batch = _batch(sampler, task, problem, context)
        if batch:  # timed per field by the cache, charged below
            sampler.prefill(batch, batch=True)
    # the classical samplers draw in the planners' compiled loops, as the learned ones do (the same runs, sooner)
    draw_classical_in_loops(problem)
    # wall time includes binding the sampler (the policy's per-map setup) and leaves out numba's compiling (a kernel's
    # first call in a process, paid once as loading a model is; time limits leave it out too), which the run records
    c0, t0 = compile_seconds(), time.perf_counter()
    # iterations to the first solution: anytime planners stop there too (Protocol.planner)
    planner, cap = protocol.planner(task.planner, problem, sampler, task.seed)
    r, progress = protocol.solve(planner, cap, task.query)
    answered = planner.problem  # the problem the run answered (a roadmap's later query: not the one it was built for)
    bound = answered.iteration_lower_bound(protocol.step)  # None where its shortest path is unknown: -1 in a Run
    # and the encoder's time for this query's field where it was computed before (kept across seeds, batched)
    compiled = compile_seconds() - c0
    wall = time.perf_counter() - t0 - compiled + float(getattr(planner.sampler, "reused_seconds", 0.0))
    its = r.first_solution_iteration if r.solved else r.iterations
    checks = r.collision_checks
    if not planner_class(task.planner).own_sampler:  # OB-PRM counts its sampler's own checks; others do not
        checks += int(getattr(planner.sampler, "checks", 0))  # e.g. obstacle-based sampling handed to PRM
    return Run(map=task.query.map_set, query=answered.name, split=task.query.split, planner=task.planner,
               sampler=task.sampler_label, seed=task.seed, solved=r.solved, iterations=int(its),
               lower_bound=-1 if bound is None else bound, candidates=r.candidates,
               collision_checks=checks, wall_time=wall, us_per_iteration=wall / max(r.iterations, 1) * 1e6,
               path_cost=r.cost if r.solved else math.inf,
               forward_passes=int(getattr(planner.sampler, "forward_passes", 0)), vertices=int(r.num_vertices),
               sampler_spec=task.sampler.to_json(), progress=progress, compile_time=compiled)


def _batch(sampler: RouteSampler, task: Task, problem: Problem, context: RunContext) -> list[Problem]:
    """Where ``context`` batches fields and ``sampler`` lacks ``problem``'s: it and the next queries' problems.

    (Empty where there is nothing to batch.) Their fields together take at most a quarter of the cache.
    """
    batch = context.batch_fields
    if batch is None:
        batch = next(sampler.net.parameters()).device.type != "cpu"
    if not batch or sampler.has_field(problem):
        return []
    queries = context.route_queries.get(task.sampler, ())
    at = queries.index(task.query) if task.query in queries else len(queries)
    problems, cells = [problem], problem.world.obstacles.size
    for query in queries[at + 1:at + context.prefill]:
        other = context.problem(query)
        cells += other.world.obstacles.size
        if cells * 8 > context.fields.max_bytes // 4:  # the batch's fields stay well within what the cache keeps
            break
        problems.append(other)
    return problems


def shared_context(tasks: Sequence[Task], protocol: Protocol | RunContext) -> RunContext:
    """The context of ``tasks``: every file they name loaded once here, shipped once to each worker.

    Given a :class:`RunContext`, what it holds is kept and what ``tasks`` need more is loaded into it
    (and it is returned); given a :class:`Protocol`, a new context is made. Building each task's
    sampler once loads its weights; MovingAI scenarios are loaded for its queries. Users' samplers are
    left to each worker's first run (a user's object need not survive pickling).
    """
    context = protocol if isinstance(protocol, RunContext) else RunContext(protocol)
    context.route_queries = {}
    for spec in dict.fromkeys(t.sampler for t in tasks):
        if getattr(spec, "name", None) == USER:
            continue
        sampler = spec.build(context.models)
        if isinstance(sampler, RouteSampler) and sampler.net is not None:  # the queries whose fields it batches
            context.route_queries[spec] = tuple(dict.fromkeys(t.query for t in tasks if t.sampler == spec))
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
