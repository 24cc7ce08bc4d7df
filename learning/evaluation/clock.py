"""Time to solution: the route sampler against the fastest way this library (and OMPL) plans the same query.

A user waits for a path, so the route sampler is held to the clock as well as to iterations. On every query of
a map set (the test split), in one process and one thread, each of these plans the query with the same planner
seeds, their runs interleaved query by query so a drift in the machine's speed hits all alike:

- RRT with the route encoder (``route``), its ablation (``route_ablation``), and the exact reference
  (``exact_route``: the same sampler on the grid search's cost-to-go, which costs a grid search per query);
- RRT, RRT-Connect and PRM with the lazy route sampler (``route_lazy``: the straight line, or the planner's
  uniform sampling, first, the encoder's field once that has not solved within a budget that grows with the map's area);
- RRT with the goal bias tuned for the set on its tuning split (as the comparison tunes it);
- RRT-Connect and PRM with their own (uniform) sampling;
- with OMPL's Python bindings installed, OMPL's RRT-Connect (``planners.tools.ompl_bridge``).

A run's time runs from the planner's start to its first solution, the sampler's per-query work included (the
encoder's pass, a grid search): ``learning.evaluation.run_one``'s wall time. A method's time is its median time to
solution (``solution_ms``): an unsolved run never reached a solution, so it counts as never, and where half the runs
or more are unsolved the median is not reached (the time those runs took is no time to a solution: a method that
gives up quickly at its iteration cap is not a fast one). "Fastest" is the fastest median of the tuned goal bias,
RRT-Connect, PRM and the exact reference that solve more than half their runs; the
targets are the route sampler's median at most ``AT_MOST`` times it on every set, and at most ``WHERE_SLOW`` times
it wherever that median is above ``SLOW_MS``, and, over every test query pooled, at most ``OMPL_AT_MOST`` times
OMPL's RRT-Connect; the lazy route sampler, with each planner, is held to the same targets.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence

import numpy as np

from learning.evaluation.protocol import Protocol
from learning.evaluation.roster import Task, bias_spec
from learning.evaluation.runner import RunContext, run_one
from learning.samplers.registry import SamplerSpec
from planners.tools.benchmark import Run

#: The method labels of a clock comparison, in table order: (label, planner).
ROUTE, ABLATION, EXACT = "RRT + route encoder", "RRT + route ablation", "RRT + exact route"
LAZY, LAZY_CONNECT, LAZY_PRM = "RRT + lazy route", "RRT-Connect + lazy route", "PRM + lazy route"
TUNED, CONNECT, PRM = "RRT + tuned goal bias", "RRT-Connect", "PRM"
OMPL_CONNECT = "OMPL RRT-Connect"
#: The classical options the route sampler is timed against: the fastest median among them.
CLASSICAL = (TUNED, CONNECT, PRM, EXACT)
#: The targets (see the module docstring).
AT_MOST, WHERE_SLOW, SLOW_MS, OMPL_AT_MOST = 1.2, 0.5, 5.0, 0.5
#: The learned methods held to the targets, and the prefix of their columns and verdict keys.
LEARNED = {ROUTE: "", LAZY: "lazy ", LAZY_CONNECT: "lazy connect ", LAZY_PRM: "lazy prm "}
#: The pooled row's name.
POOLED = "all test sets pooled"


def clock_tasks(queries: Sequence, protocol: Protocol, route: str, biases: dict, seeds: int) -> list[Task]:
    """Every method on every test query at planner seeds ``0 .. seeds-1``, interleaved query by query.

    ``biases`` maps (map set, "RRT") to the goal bias tuned for it (sets without one take 0.05, OMPL's default).
    """
    step = protocol.step
    fixed = [(ROUTE, "RRT", SamplerSpec.of("route", path=route, step_size=step, device="cpu")),
             (ABLATION, "RRT", SamplerSpec.of("route_ablation", step_size=step)),
             (EXACT, "RRT", SamplerSpec.of("exact_route", step_size=step)),
             (LAZY, "RRT", SamplerSpec.of("route_lazy", path=route, step_size=step, device="cpu")),
             (CONNECT, "RRTConnect", SamplerSpec.of("uniform")),
             (LAZY_CONNECT, "RRTConnect", SamplerSpec.of("route_lazy", path=route, step_size=step, device="cpu")),
             (PRM, "PRM", SamplerSpec.of("uniform")),
             (LAZY_PRM, "PRM", SamplerSpec.of("route_lazy", path=route, step_size=step, device="cpu"))]
    tasks = []
    for q in queries:
        if q.split != "test":
            continue
        tuned = (TUNED, "RRT", bias_spec(biases.get((q.map_set, "RRT"), 0.05)))
        for seed in range(seeds):
            tasks += [Task(q, planner, spec, seed, label) for label, planner, spec in (*fixed[:4], tuned, *fixed[4:])]
    return tasks


def run_clock(tasks: Sequence[Task], context: RunContext, *, ompl: bool = False,
              progress: Callable[[int, int], None] | None = None) -> list[Run]:
    """Run ``tasks`` here, one after another in this process (a timing: no workers), with OMPL's RRT-Connect.

    With ``ompl``, OMPL's RRT-Connect plans each (query, seed) right after the last of our methods on it. The
    first query's runs go once untimed before (compiled kernels loaded, the encoder's first pass made), then the
    context forgets that query's field and map (``RunContext.forget_queries``), so no one-off cost lands in a timed
    run and the first query's runs pay its pass as every other query's do.
    """
    runs: list[Run] = []
    done: set = set()
    first = tasks[0].query if tasks else None
    for task in (t for t in tasks if t.query == first and t.seed == tasks[0].seed):  # warm-up, untimed
        run_one(task, context)
        if ompl:
            ompl_run(task, context)
    context.forget_queries()  # the first query's timed runs pay its pass in full, not the warm-up's one-off cost
    for i, task in enumerate(tasks):
        runs.append(run_one(task, context))
        key = (task.query, task.seed)
        last = i + 1 == len(tasks) or (tasks[i + 1].query, tasks[i + 1].seed) != key
        if ompl and last and key not in done:
            done.add(key)
            runs.append(ompl_run(task, context))
        if progress is not None:
            progress(i + 1, len(tasks))
    return runs


def ompl_run(task: Task, context: RunContext) -> Run:
    """OMPL's RRT-Connect on ``task``'s query and seed, timed from its start to its first solution."""
    from planners.tools import ompl_bridge

    protocol = context.protocol
    problem = context.problem(task.query)
    t0 = time.perf_counter()
    o = ompl_bridge.OmplGridPlanner(problem, "RRTConnect", step_size=protocol.step, seed=task.seed)
    r = o.run(protocol.max_iterations)
    wall = time.perf_counter() - t0
    return Run(map=task.query.map_set, query=problem.name, split="test", planner="OMPL RRTConnect", sampler="OMPL",
               seed=task.seed, solved=r.solved, iterations=int(r.iterations),
               lower_bound=problem.iteration_lower_bound(protocol.step), candidates=int(r.iterations),
               collision_checks=-1, wall_time=wall, us_per_iteration=wall / max(r.iterations, 1) * 1e6,
               path_cost=r.cost if r.solved else math.inf, forward_passes=0, vertices=int(r.num_vertices))


def _method(run: Run) -> str:
    return OMPL_CONNECT if run.sampler == "OMPL" else run.sampler


def solution_ms(runs: Sequence[Run]) -> float:
    """The median time to solution of ``runs`` in ms: the time by which half of them had solved.

    An unsolved run counts as never solving (infinitely long), so where half the runs or more are unsolved the
    median is not reached: inf.
    """
    return float(np.median([r.wall_time * 1e3 if r.solved else math.inf for r in runs]))


def _cell(runs: Sequence[Run]) -> str:
    """A method's table cell: its median time to solution (ms) and the share solved; where that median is not
    reached, "> " the median time its runs took.
    """
    ms, solved = solution_ms(runs), f"{np.mean([r.solved for r in runs]):.0%}"
    if math.isfinite(ms):
        return f"{ms:.3g} ({solved})"
    return f"> {np.median([r.wall_time for r in runs]) * 1e3:.3g} ({solved})"


def clock_table(runs: Sequence[Run], order: Sequence[str] = ()) -> tuple[list[dict], dict]:
    """Per map set (in ``order``, then the rest), and pooled: each method's median ms per query and success.

    Returns (rows, verdict): each row holds "map set", per method its median time to solution in ms (``_cell``)
    with the share solved in brackets, "fastest classical", and for each learned method (``LEARNED``, its prefix
    before each name) "route / fastest" and "target" ("holds" or "fails"); the verdict holds the counts of sets
    ("sets", "slow sets") and, per learned method, of those meeting each target ("held", "slow held") and, where
    OMPL ran, the pooled ratio to OMPL's RRT-Connect ("pooled / OMPL RRT-Connect"); and, taking the best learned
    method per set, the count of sets where one of them holds the targets ("any held") and the sets where none does
    ("none held", in table order). Where no classical option solves
    more than half the runs, a learned method that does holds its targets (it is faster than every one of them), and
    one that does not fails them.
    """
    by: dict[str, dict[str, list[Run]]] = {}
    for r in runs:
        if r.split == "test":
            for name in (r.map, POOLED):
                by.setdefault(name, {}).setdefault(_method(r), []).append(r)
    names = [m for m in order if m in by] + sorted(set(by) - set(order) - {POOLED}) + [POOLED]
    methods = [m for m in (ROUTE, LAZY, LAZY_CONNECT, LAZY_PRM, ABLATION, EXACT, TUNED, CONNECT, PRM, OMPL_CONNECT)
               if any(m in v for v in by.values())]
    rows, slow_total = [], 0
    verdict: dict = {"sets": len(names) - 1, "slow sets": 0, "any held": 0, "none held": []}
    for prefix in LEARNED.values():
        verdict |= {f"{prefix}held": 0, f"{prefix}slow held": 0, f"{prefix}pooled / OMPL RRT-Connect": math.nan}
    for name in names:
        cell = by[name]
        ms = {m: solution_ms(cell[m]) for m in methods if m in cell}
        row: dict = {"map set": name}
        for m in methods:
            row[m] = _cell(cell[m]) if m in cell else "-"
        classical = {m: ms[m] for m in CLASSICAL if m in ms}
        if classical:
            fastest = min(classical, key=classical.__getitem__)
            best = classical[fastest]  # inf where no classical option solves more than half the runs
            slow = best > SLOW_MS
            row["fastest classical"] = (f"{fastest} ({best:.3g} ms)" if math.isfinite(best) else
                                        "none solves more than half")
            slow_total += slow and name != POOLED
        held_here = False
        for learned, prefix in LEARNED.items():
            if learned in ms and classical:
                ratio = ms[learned] / max(best, 1e-9) if math.isfinite(ms[learned]) else math.inf
                ok = ratio <= AT_MOST and (not slow or ratio <= WHERE_SLOW)
                row |= {f"{prefix}route / fastest": f"{ratio:.2f}",
                        f"{prefix}target": ("holds" if ok else "fails") + (
                            f" (<= {WHERE_SLOW:g}: above {SLOW_MS:g} ms)" if slow else f" (<= {AT_MOST:g})")}
                if name != POOLED:
                    verdict[f"{prefix}held"] += ok
                    verdict[f"{prefix}slow held"] += slow and ratio <= WHERE_SLOW
                    held_here = held_here or ok
            if name == POOLED and learned in ms and OMPL_CONNECT in ms:
                verdict[f"{prefix}pooled / OMPL RRT-Connect"] = ratio = ms[learned] / max(ms[OMPL_CONNECT], 1e-9)
                row[f"{prefix}route / OMPL RRT-Connect"] = f"{ratio:.2f}"
        if name != POOLED:
            verdict["any held"] += held_here
            if not held_here:
                verdict["none held"].append(name)
        rows.append(row)
    verdict["slow sets"] = slow_total
    return rows, verdict


def side_class(side: int) -> str:
    """The map-size class of a map whose larger side is ``side`` cells (the report's rows)."""
    return next((f"up to {top}" for top in (64, 128, 256) if side <= top), "above 256")


def fastest_by_size(runs: Sequence[Run], sides: dict[str, int]) -> list[dict]:
    """Which method plans fastest, by map size, over every test query: each method's median time to solution
    (``solution_ms``, ``_cell``).

    ``sides`` maps a run's query (its problem's name) to its map's larger side in cells.
    """
    classes: dict[str, dict[str, list[Run]]] = {}
    for r in runs:
        if r.split == "test" and r.query in sides:
            classes.setdefault(side_class(sides[r.query]), {}).setdefault(_method(r), []).append(r)
    out = []
    for name in ("up to 64", "up to 128", "up to 256", "above 256"):
        if name not in classes:
            continue
        med = {m: solution_ms(v) for m, v in classes[name].items()}
        best = min(med, key=med.__getitem__)
        out.append({"map side": name, "runs": len(classes[name][best]),
                    "fastest": best if math.isfinite(med[best]) else "none solves more than half",
                    **{f"{m} ms": _cell(v) for m, v in classes[name].items()}})
    return out
