"""The comparison as one library call: ``compare(Comparison(...), out)``, which ``scripts/evaluate.py`` wraps.

A :class:`Comparison` says what is compared on what (the queries of every map set, the protocol, the
policy, the route encoders, users' samplers, other planners, parts of its own); :func:`compare` runs it
and returns :class:`Results`, which hold every run and write the output set. As with Stable-Baselines3's
``evaluate_policy(model, env)``, the settings are plain arguments and the result is data::

    from learning import evaluation as E
    queries = E.default_queries(families=["maze"], maps=5, tuning_maps=5, shifted_maps=0, unseen_maps=0)
    results = E.compare(E.Comparison(queries, E.Protocol(seeds=1)), processes=2)   # in memory
    results.glance()                        # the short table summary.md opens with, as rows
    results.write("results/mine")           # summary.md, details.md, runs.csv, figures, OMPL logs

Given ``out``, ``compare`` holds ``out``'s lock, journals every finished run in ``<out>.partial/``
(``resume`` continues a journal, ``fresh`` discards one; a journal of other settings or files is refused)
and writes the output set when every run is done. Without ``out`` the runs are kept in memory only.

The phases, each journaled: (1) the goal-bias and policy-batch tuning runs beside the test runs of every sampler
that needs no tuned setting (RRT; the lazy route among them); (2) the policy at its tuned batch and the ablation's
tuning; (3) the ablation at its tuned settings; (4) with ``other_planners``: the goal-bias tuning of each tree
planner on the tuning split, then (5) every other planner on every test set with uniform sampling, its classical
option (the goal bias tuned for the set for a tree; OB-PRM's obstacle-based sampling for a roadmap), the policy,
each route encoder, the shipped one computed lazily (``route_lazy``), its ablation, the exact reference and users'
samplers, as the registry builds them (``make_sampler`` names handed to the planner as they are), except OB-PRM,
which runs with its own obstacle-based sampling only (handed another sampler it is PRM with it); (6) with
``convergence``: RRT*'s cost convergence on every test query (``learning.evaluation.convergence``), with
``later_queries``: later queries on each roadmap built for a test query (``learning.evaluation.later_queries``), then
each :class:`Part`.

A **part** plugs a comparison of another kind into the same call, journal and output set (the 6-DoF
scene sets, ``learning.evaluation.rigid.RigidPart``): any object with ``name``, ``protocol`` (how its runs are
made: a :class:`~learning.evaluation.protocol.Protocol` whose ``planner`` builds each run's planner and cap),
``tasks()`` (its :class:`~learning.evaluation.roster.Task` list, queries that answer ``problem(movingai_dir,
tolerance, cache)``, ``map_set``, ``split`` and ``size``) and ``report(runs)`` returning a :class:`PartReport`
(a Markdown section for ``details.md`` and sentences for ``summary.md``). Its runs join ``runs.csv`` and
the OMPL logs; the 2D tables and figures leave them out.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, runtime_checkable
from typing import Protocol as TypingProtocol

from learning.evaluation.journal import Interrupted, Journal, run_phase, work_folder
from learning.evaluation.mapsets import UnseenQuery, pooled_tuned, unseen_queries
from learning.evaluation.protocol import (
    Protocol,
    generated_queries,
    movingai_maps,
    movingai_queries,
    shifted_queries,
    tuned_for_shifted,
)
from learning.evaluation.roster import (
    EXACT_ROUTE,
    LAZY_ROUTE,
    ROUTE,
    ROUTE_ABLATION,
    Task,
    bias_spec,
    evaluation_tasks,
    fixed_specs,
    policy_spec,
)
from learning.evaluation.runner import RunContext, worker_init
from learning.evaluation.tables import MOVINGAI_POOL
from learning.evaluation.tuning import (
    TUNING_BIASES,
    best_bias,
    best_constant,
    best_policy_batch,
    constant_test_tasks,
    constant_tuning_tasks,
    policy_tuning_tasks,
    pooled,
    tuning_tasks,
)
from learning.samplers.lazy_route import LAZY_FAMILIES
from learning.samplers.registry import ModelCache, SamplerSpec
from planners.base.registry import planner_class
from planners.maps.generators import FAMILIES
from planners.tools.benchmark import Run
from planners.tools.parallel import Backend, make_backend


@dataclass
class PartReport:
    """What a :class:`Part` adds to the outputs: a Markdown section of ``details.md``, sentences of ``summary.md``.

    ``protocol`` is filled in with the part's where its report leaves it out.
    """

    markdown: str
    findings: list[str] = field(default_factory=list)
    protocol: Protocol | None = None  # how the part's runs were made (its OMPL logs' settings); the part's own


@runtime_checkable
class Part(TypingProtocol):
    """A comparison of another kind run inside :func:`compare` (see the module docstring)."""

    name: str
    protocol: Protocol

    def tasks(self) -> Sequence[Task]: ...

    def report(self, runs: Sequence[Run]) -> PartReport: ...


def is_roadmap(planner: str) -> bool:
    """Whether ``planner`` builds a roadmap (its step is the longest edge): PRM, Lazy-PRM, OB-PRM."""
    return planner_class(planner).step_parameter == "max_edge_length"


def default_queries(families: Sequence[str] = FAMILIES, size: int | None = None, maps: int | None = None,
                    tuning_maps: int | None = None, shifted_maps: int | None = None, unseen_maps: int | None = None,
                    movingai_dir: str | Path | None = None, movingai_maps: Sequence[str] = (),
                    scenarios: int | None = None, tuning_scenarios: int | None = None,
                    tolerance: float | None = None, cache: dict | None = None) -> list:
    """The default map sets' tuning and test queries; each count defaults to :class:`Protocol`'s.

    The generated families at ``size`` (test and tuning seeds), their shifted variants, the MovingAI maps
    ``movingai_maps`` in ``movingai_dir`` (none without a folder), and the unseen families.
    """
    d = Protocol()
    size = d.size if size is None else size
    tolerance = d.tolerance if tolerance is None else tolerance
    queries: list = generated_queries(families, size, d.maps if maps is None else maps,
                                      d.tuning_maps if tuning_maps is None else tuning_maps)
    queries += shifted_queries(families, d.shifted_maps if shifted_maps is None else shifted_maps)
    if movingai_dir is not None and movingai_maps:
        queries += movingai_queries(str(movingai_dir), movingai_maps, d.scenarios if scenarios is None else scenarios,
                                    d.tuning_scenarios if tuning_scenarios is None else tuning_scenarios, tolerance,
                                    cache)
    return queries + unseen_queries(size, d.unseen_maps if unseen_maps is None else unseen_maps)


@dataclass
class Comparison:
    """What is compared, on what (see the module docstring); :func:`compare` runs it.

    ``queries``: the tuning and test queries of every map set (:func:`default_queries`, or
    ``mapsets.map_set_queries``). ``route``: the encoder run as the "route encoder"; ``routes``: users'
    encoders by name, run beside it (each labelled by its name). ``samplers``: users' ``NAME=SPEC``
    samplers. ``families``: the generated families whose tuning maps, pooled, tune the unseen families.
    ``other_planners``: planner names run beside RRT on every test set. ``references``: run the expert
    and the exact route reference. ``convergence``: RRT*'s iterations budget for the convergence part
    (``learning.evaluation.convergence``; 0: not run). ``later_queries``: later queries per test query on the
    roadmap built for it, for each roadmap planner among ``other_planners`` (PRM where none is;
    ``learning.evaluation.later_queries``; 0: not run). ``map_set``: the user's map set the queries come from (for the
    record). ``models`` and ``cache``: what is loaded already (models, MovingAI scenarios, map sets).
    """

    queries: Sequence
    protocol: Protocol = field(default_factory=Protocol)
    policy: str | None = None
    route: str | None = None
    routes: Mapping[str, str] = field(default_factory=dict)
    samplers: Mapping[str, str] = field(default_factory=dict)
    families: Sequence[str] = FAMILIES
    other_planners: Sequence[str] = ()
    references: bool = True
    device: str = "auto"
    map_set: Any = None
    parts: Sequence[Part] = ()
    convergence: int = 0
    later_queries: int = 0
    models: ModelCache = field(default_factory=ModelCache)
    cache: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        from learning.models.shipped import SHIPPED_POLICY
        from learning.samplers.route import SHIPPED

        self.policy = str(SHIPPED_POLICY if self.policy is None else self.policy)
        self.route = str(SHIPPED if self.route is None else self.route)
        self.routes = dict(self.routes)
        self.samplers = dict(self.samplers)
        self.other_planners = list(self.other_planners)

    def route_specs(self) -> dict[str, SamplerSpec]:
        """Every route encoder by label: the route encoder, then each of ``routes``."""
        step, device = self.protocol.step, self.device
        return {label: SamplerSpec.of("route", path=path, step_size=step, device=device)
                for label, path in {ROUTE: self.route, **self.routes}.items()}

    def field_specs(self) -> dict[str, SamplerSpec]:
        """The route field's samplers by label: each route encoder, its ablation, the exact reference (if asked)."""
        step = self.protocol.step
        out = {**self.route_specs(), ROUTE_ABLATION: SamplerSpec.of("route_ablation", step_size=step)}
        if self.references:
            out[EXACT_ROUTE] = SamplerSpec.of("exact_route", step_size=step)
        return out

    def lazy_spec(self) -> SamplerSpec:
        """The shipped encoder computed lazily (``route_lazy``), at the protocol's step."""
        return SamplerSpec.of("route_lazy", path=self.route, step_size=self.protocol.step, device=self.device)

    def run(self, backend: Backend, journal=None, log: Callable[[str], None] = print) -> Results:
        """Every phase's runs on ``backend``, journaled in ``journal`` (None: kept in memory); the results."""
        t0 = time.perf_counter()
        journal = _MemoryJournal() if journal is None else journal
        self.planned = 0
        protocol, policy, queries = self.protocol, self.policy, list(self.queries)
        context = RunContext(protocol, self.models, self.cache)

        def phase(tasks: Sequence[Task], name: str, ctx: RunContext = context) -> list[Run]:
            tasks = list(dict.fromkeys(tasks))  # one run per task, however it was reached
            self.planned += len(tasks)
            return run_phase(tasks, ctx, backend, journal, name)

        if not queries:  # parts alone (e.g. only 6-DoF scene sets): no 2D phases
            return Results(self, [], None, {}, {}, [], self._run_parts(phase),
                           minutes=(time.perf_counter() - t0) / 60, processes=str(backend.workers))
        users = dict(self.samplers)
        extra_routes = {label: spec for label, spec in self.route_specs().items() if label != ROUTE}
        fixed = fixed_specs(protocol, self.route, users, references=self.references, device=self.device)
        unseen = sorted({q.map_set for q in queries if isinstance(q, UnseenQuery)})
        # first what needs no tuned setting, beside the tuning runs of goal bias and of the policy's batch
        tasks = tuning_tasks(queries, "RRT") + policy_tuning_tasks(queries, "RRT", policy)
        tasks += evaluation_tasks(queries, "RRT", fixed, protocol.seeds)
        for label, spec in extra_routes.items():
            tasks += evaluation_tasks(queries, "RRT", [spec], protocol.seeds, label)
        log(f"{len(tasks)} RRT runs on {len(queries)} queries ({backend.workers} workers)")
        runs = phase(tasks, "tuning and fixed samplers")
        batch, batch_scores = best_policy_batch(runs)
        # then the policy at its tuned batch, and the ablation's tuning at that batch (it decides as often)
        tasks = constant_tuning_tasks(queries, "RRT", protocol, batch)
        tasks += evaluation_tasks(queries, "RRT", [policy_spec(policy, batch)], protocol.seeds, "policy")
        log(f"policy batch {batch} (tuned); {len(tasks)} RRT runs of the policy and of the ablation's tuning")
        runs += phase(tasks, "policy and ablation tuning")
        # a shifted map set has no tuning split of its own: it keeps its family's tuned settings; an unseen
        # family takes those tuned on the generated families' tuning maps pooled
        constants = tuned_for_shifted(best_constant(runs), queries)
        constants.update(pooled_tuned(runs, self.families, best_constant, unseen))
        # the ablation (the policy's action classes, constant distribution) on the test split, at the frontier
        # probability its tuning runs chose for each map set; labelled as one sampler whatever that probability
        tasks = constant_test_tasks(queries, "RRT", protocol, batch, constants, protocol.seeds)
        log(f"{len(tasks)} RRT runs of the constant-distribution ablation at its tuned settings")
        runs += phase(tasks, "policy ablation")
        runs += self._other_planners(queries, runs, batch, unseen, phase, log)
        parts = self._run_parts(phase, [*self._convergence_part(queries, runs, unseen),
                                        *self._later_queries_part(queries)])
        return Results(self, runs, batch, batch_scores, constants, unseen, parts,
                       minutes=(time.perf_counter() - t0) / 60, processes=str(backend.workers))

    def _run_parts(self, phase, extra: Sequence[Part] = ()) -> dict:
        """Phase (6): each part's tasks (``extra``, then ``parts``) under its own protocol; {name: (runs, report)}."""
        parts = {}
        for part in [*extra, *self.parts]:
            part_runs = phase(list(part.tasks()), part.name, RunContext(part.protocol, self.models, self.cache))
            report = part.report(part_runs)
            if report.protocol is None:
                report.protocol = part.protocol
            parts[part.name] = (part_runs, report)
        return parts

    def _tuned_biases(self, runs, queries, unseen) -> dict[tuple[str, str], float]:
        """The goal bias chosen on the tuning split per (map set, planner), shifted and unseen sets included."""
        tuned = tuned_for_shifted(best_bias(runs), queries)
        tuned.update(pooled_tuned(runs, self.families, best_bias, unseen))
        return tuned

    def _convergence_part(self, queries, runs, unseen) -> list[Part]:
        """RRT*'s convergence part, where ``convergence`` asks for it.

        Its goal bias is the one chosen on the tuning split for RRT* where RRT* ran among the other planners, else
        RRT's.
        """
        if not self.convergence:
            return []
        from learning.evaluation.convergence import ConvergencePart, ConvergenceProtocol

        tuned = self._tuned_biases(runs, queries, unseen)
        sets = {q.map_set for q in queries}
        biases = {m: tuned.get((m, "RRTstar"), tuned.get((m, "RRT"), 0.05)) for m in sets}
        p = self.protocol
        protocol = ConvergenceProtocol(step=p.step, tolerance=p.tolerance, max_iterations=int(self.convergence),
                                       seeds=p.seeds, movingai_dir=p.movingai_dir)
        fields = {**self.field_specs(), LAZY_ROUTE: self.lazy_spec()}
        return [ConvergencePart(queries, protocol, biases, fields, movingai_maps(queries))]

    def _later_queries_part(self, queries) -> list[Part]:
        """The later-queries part, where ``later_queries`` asks for it.

        Uniform sampling, each route encoder, its ablation and the exact reference (OB-PRM: its own sampling) on each
        roadmap planner.
        """
        if not self.later_queries:
            return []
        from learning.evaluation.later_queries import LaterQueriesPart, LaterQueriesProtocol

        samplers = {"uniform": SamplerSpec.of("uniform"), **self.field_specs()}
        p = self.protocol
        protocol = LaterQueriesProtocol(step=p.step, tolerance=p.tolerance, max_iterations=p.max_iterations,
                                        seeds=p.seeds, movingai_dir=p.movingai_dir, later=int(self.later_queries))
        planners = [q for q in self.other_planners if is_roadmap(q)] or ["PRM"]
        return [LaterQueriesPart(queries, planners, samplers, protocol, movingai_maps(queries))]

    def _other_planners(self, queries, runs, batch, unseen, phase, log) -> list[Run]:
        """Phases (4) and (5): every other planner on every test set (see the module docstring)."""
        if not self.other_planners:
            return []
        trees = [p for p in self.other_planners if not is_roadmap(p)]
        tune = [t for p in trees for t in tuning_tasks(queries, p)]
        out = phase(tune, "other planners: goal bias tuning") if tune else []
        tuned = self._tuned_biases(runs + out, queries, unseen)
        routes = self.route_specs()
        learned = [spec for label, spec in self.field_specs().items() if label not in routes]  # ablation, reference
        lazy = self.lazy_spec()
        tasks = []
        for planner in self.other_planners:
            for q in queries:
                if q.split != "test":
                    continue
                classical = (SamplerSpec.of("obstacle_based") if is_roadmap(planner)
                             else bias_spec(tuned.get((q.map_set, planner), TUNING_BIASES[2])))
                if is_roadmap(planner) and planner_class(planner).own_sampler:
                    # OB-PRM is PRM with obstacle-based sampling: handed another sampler it is PRM with that
                    # sampler, whose rows PRM's runs are; it runs with its own sampling only
                    tasks.append(Task(q, planner, classical, 0))
                    continue
                for spec in (SamplerSpec.of("uniform"), classical, *learned):
                    tasks.append(Task(q, planner, spec, 0))
                tasks.append(Task(q, planner, policy_spec(self.policy, batch), 0, "policy"))
                for label, spec in routes.items():
                    tasks.append(Task(q, planner, spec, 0, label if label != ROUTE else ""))
                if planner_class(planner).family in LAZY_FAMILIES:
                    tasks.append(Task(q, planner, lazy, 0))
                tasks += [Task(q, planner, SamplerSpec.user(n, s), 0) for n, s in self.samplers.items()]
        log(f"{len(tasks)} runs of {', '.join(self.other_planners)} on every test set")
        return out + phase(tasks, "other planners")


class _MemoryJournal:
    """A journal that keeps finished runs in memory only (``compare`` without ``out``)."""

    def __init__(self) -> None:
        self.done: dict[str, Run] = {}

    def add(self, key: str, run: Run) -> None:
        self.done[key] = run


class ComparisonInterrupted(Interrupted):
    """Stopped by a signal: ``kept`` finished runs of ``planned`` so far are in the journal at ``journal``."""

    def __init__(self, status: int, kept: int, planned: int, journal: Path | None) -> None:
        super().__init__(status)
        self.kept, self.planned, self.journal = kept, planned, journal


def compare(comparison: Comparison, out: str | Path | None = None, *, backend: str | Backend = "local",
            processes: int = 1, address: str | None = None, resume: bool = False, fresh: bool = False,
            settings: dict | None = None, log: Callable[[str], None] = print) -> Results:
    """Run ``comparison`` and return its results; given ``out``, journaled there and written as one output set.

    ``backend``: "local" (``processes`` workers), "ray" (at ``address``) or a ``Backend``. ``settings``:
    what decides the runs, recorded in the journal's header (with the content hashes of the files the
    runs read, as ``journal.file_digests`` gives them under ``"inputs"``); ``resume`` refuses a journal of
    other settings. ``log`` receives one line per phase and what the journal did.

    Raises:
        InputError: The journal refuses (see ``journal.Journal``); ``LockedError`` where another run holds ``out``.
        ComparisonInterrupted: SIGINT (``KeyboardInterrupt``) or a SIGTERM turned into ``Interrupted``; the
            journal keeps every finished run and ``out`` is unchanged.
    """
    from planners.base.fileio import run_lock

    journal, owned = None, None
    lock = run_lock(out) if out is not None else None
    if lock is not None:
        lock.__enter__()
    try:
        if out is not None:
            journal = Journal(work_folder(out), settings or {}, resume=resume, fresh=fresh)
            if journal.resumed:
                log(f"resuming: {journal.resumed} finished runs from {journal.path}")
            elif resume:
                log(f"--resume: no finished runs in {journal.path}; starting from the first run")
            if journal.discarded:
                log(f"--fresh: discarded the {journal.discarded} finished runs of {journal.path}")
        if isinstance(backend, str):
            local = backend == "local"
            backend = owned = make_backend(backend, processes=processes, address=address, worker_init=worker_init)
        try:
            results = comparison.run(backend, journal, log)
            if owned is not None and not local:
                results.processes = "several"
        except (KeyboardInterrupt, Interrupted) as exc:
            status = exc.status if isinstance(exc, Interrupted) else 130
            kept = len(journal.done) if journal is not None else 0
            raise ComparisonInterrupted(status, kept, getattr(comparison, "planned", 0) or kept,
                                        None if journal is None else journal.path) from None
        if out is not None:
            results.write(out, {**(settings or {}), "out": str(out)})
            journal.remove()
        return results
    finally:
        if owned is not None:
            owned.close()
        if journal is not None:
            journal.close()
        if lock is not None:
            lock.__exit__(None, None, None)


@dataclass
class Results:
    """A comparison's runs and what was tuned; tables, findings and the output set are made from them.

    ``runs``: every run of the 2D map sets (tuning and test); ``parts``: each part's runs and report by name.
    """

    comparison: Comparison
    runs: list[Run]
    batch: int | None
    batch_scores: dict
    constants: dict
    unseen: list[str]
    parts: dict = field(default_factory=dict)
    minutes: float = 0.0
    processes: str = "1"

    def __post_init__(self) -> None:
        from learning.evaluation.tables import summarize

        queries = self.comparison.queries
        self.movingai = movingai_maps(queries)
        self.pool = pooled(self.runs, MOVINGAI_POOL, self.movingai) if len(self.movingai) > 1 else []
        best = tuned_for_shifted(best_bias(self.runs + self.pool), queries)
        best.update(pooled_tuned(self.runs, self.comparison.families, best_bias, self.unseen))
        self.best = best
        self.rows = summarize(self.runs + self.pool, best)

    @cached_property
    def wide(self) -> dict:
        """The wide tables of ``details.md``, computed once (``report``)."""
        from learning.evaluation.report import wide_tables

        return wide_tables(self)

    @property
    def all_runs(self) -> list[Run]:
        """Every run, the parts' included (``runs.csv``)."""
        return self.runs + [r for runs, _ in self.parts.values() for r in runs]

    def glance(self) -> list[dict]:
        """The short table ``summary.md`` opens with (``report.glance_short``)."""
        from learning.evaluation.report import glance_short

        return glance_short(self)

    def write(self, out: str | Path, settings: dict | None = None) -> list[Path]:
        """Write the output set to ``out`` as a whole (``planners.base.fileio.output_set``); returns the figures."""
        from learning.evaluation.report import write_outputs

        return write_outputs(self, Path(out), settings or {})

    def printed(self, out: str | Path | None = None) -> str:
        """What the command line prints when the comparison is done (``report.printed``)."""
        from learning.evaluation.report import printed

        return printed(self, out)


__all__ = ["Comparison", "ComparisonInterrupted", "Part", "PartReport", "Results", "compare", "default_queries",
           "is_roadmap"]
