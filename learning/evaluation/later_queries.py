"""Later queries on one roadmap, a part of the one comparison: does a roadmap built for one query serve others?

A roadmap planner (PRM, Lazy-PRM, OB-PRM) is built for a test query, then asked ``later`` more queries on the same
map (``other_queries``: free cells joined by a path and a quarter of the map's side apart at least, drawn from the
query's key). Each later query is one run of the comparison: the roadmap is built for the map's query as its own
run builds it (the same seed), then ``PRM.query`` answers the later one, the sampler bound afresh to it (the field's
corridor moves to the new query). A run records the samples the later query added (0: the roadmap as built served
it), its path and its checks; the run's time includes building the roadmap for the first query.

``Comparison(later_queries=K)`` adds the part for every roadmap planner among the other planners
(``scripts/evaluate.py --later-queries``); ``LaterQueriesPart`` is a :class:`~learning.evaluation.comparison.Part`
like any other.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from learning.evaluation.protocol import PartQuery, Protocol
from learning.evaluation.roster import OBSTACLE_BASED, Task
from learning.evaluation.tables import group_of
from learning.samplers.registry import SamplerSpec
from planners import Problem
from planners.tools.benchmark import Run, markdown_table

#: Later queries per test query.
LATER = 3


def other_queries(problem: Problem, k: int, seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """``k`` more (start, goal) pairs on ``problem``'s grid, drawn with ``seed`` (fewer where the map has none).

    Free cell centres joined by a path and a quarter of the map's side apart at least.
    """
    from planners.maps.gridsearch import connected

    grid = problem.world
    free = np.argwhere(~grid.obstacles)
    rng = np.random.default_rng(seed)
    apart = 0.25 * max(grid.height, grid.width)
    out = []
    for _ in range(1000 * k):
        if len(out) == k:
            break
        a, b = free[rng.integers(len(free), size=2)]
        if np.hypot(*(a - b)) >= apart and connected(grid.obstacles, tuple(a), tuple(b)):
            out.append((grid.cell_center(int(a[0]), int(a[1])), grid.cell_center(int(b[0]), int(b[1]))))
    return out


@dataclass(frozen=True)
class LaterQuery(PartQuery):
    """The ``k``-th later query (1, 2, ...) on the roadmap built for a test query of the comparison.

    Its map set is the query's with `` (later queries)`` added; its problem is the one the roadmap is built for.
    """

    k: int
    SUFFIX = " (later queries)"

    @property
    def seed(self) -> int:
        """The seed its pairs are drawn with: the query's key (a generator seed or a scenario index)."""
        return int(self.query.key)


@dataclass(frozen=True)
class LaterQueriesProtocol(Protocol):
    """How a later query's run is made: the roadmap for the map's query, then the ``k``-th of ``later`` more."""

    later: int = LATER

    def solve(self, planner, cap: int, query=None):
        first = planner.solve(max_iterations=cap)
        pairs = other_queries(planner.problem, self.later, query.seed)
        if query.k > len(pairs):  # the map has no such query: the run says so by its name
            return first, ""
        start, goal = pairs[query.k - 1]
        r = planner.query(start, goal, max_iterations=cap, name=f"{planner.problem.name} later {query.k}")
        # the samples this query added: a roadmap stops at the query's first solution
        return replace(r, first_solution_iteration=r.iterations if r.solved else None), ""


@dataclass
class LaterQueriesPart:
    """Later queries on the roadmaps of ``planners`` with each of ``samplers`` (label: spec), ``later`` per query."""

    queries: Sequence
    planners: Sequence[str]
    samplers: dict[str, SamplerSpec]
    protocol: LaterQueriesProtocol = field(default_factory=LaterQueriesProtocol)
    movingai_maps: Sequence[str] = ()
    name: str = "Later queries on one roadmap"

    def tasks(self) -> list[Task]:
        from planners.base.registry import planner_class

        out = []
        for q in self.queries:
            if q.split != "test":
                continue
            for planner in self.planners:
                # OB-PRM runs with its own obstacle-based sampling only (handed another sampler it is PRM with it)
                samplers = ({OBSTACLE_BASED: SamplerSpec.of("obstacle_based")} if planner_class(planner).own_sampler
                            else self.samplers)
                out += [Task(LaterQuery(q, k), planner, spec, seed, label) for label, spec in samplers.items()
                        for k in range(1, self.protocol.later + 1) for seed in range(self.protocol.seeds)]
        return out

    def report(self, runs: Sequence[Run]):
        from learning.evaluation.comparison import PartReport

        rows = later_query_rows(runs, self.protocol.max_iterations, self.movingai_maps)
        text = (f"Each roadmap is built for a test query ({self.protocol.seeds} seed(s)), then answers "
                f"{self.protocol.later} more queries on the same map, the sampler bound afresh to each. Median samples "
                "a later query adds (an unanswered one counts at the cap), their mean, the share of later queries the "
                "roadmap answered as built (no new sample), and the share answered:\n\n"
                + markdown_table(_printable(rows)))
        return PartReport(text, findings(rows))


def later_query_rows(runs: Sequence[Run], cap: int, movingai_maps: Sequence[str] = (), *,
                     by_group: bool = True) -> list[dict]:
    """Per group (or map set), planner and sampler: later queries, median and mean samples added, served, success."""
    cells: dict[tuple[str, str, str], list[Run]] = {}
    for r in runs:
        if " later " not in r.query:  # the map had fewer later queries than asked
            continue
        where = LaterQuery.map_set_of(r)
        where = group_of(where, movingai_maps) if by_group else where
        cells.setdefault((where, r.planner, r.sampler), []).append(r)
    out = []
    for (where, planner, sampler), rs in cells.items():
        added = [r.iterations if r.solved else cap for r in rs]
        out.append({"group" if by_group else "map set": where, "planner": planner, "sampler": sampler,
                    "queries": len(rs), "later": float(np.median(added)), "later_mean": float(np.mean(added)),
                    "served": float(np.mean([r.solved and r.iterations == 0 for r in rs])),
                    "success": float(np.mean([r.solved for r in rs]))})
    return out


def _printable(rows: Sequence[dict]) -> list[dict]:
    return [{**{k: v for k, v in r.items() if k not in ("later", "later_mean", "served", "success")},
             "samples added, median (mean)": f"{r['later']:,.0f} ({r['later_mean']:,.1f})",
             "served as built": f"{r['served']:.2f}", "answered": f"{r['success']:.2f}"} for r in rows]


def findings(rows: Sequence[dict]) -> list[str]:
    """One sentence per planner: the share of later queries served as built, per sampler, over every group."""
    out = []
    for planner in dict.fromkeys(r["planner"] for r in rows):
        mine = [r for r in rows if r["planner"] == planner]
        by_sampler: dict[str, list[tuple[float, int]]] = {}
        for r in mine:
            by_sampler.setdefault(r["sampler"], []).append((r["served"], r["queries"]))
        parts = [f"{s} {sum(v * n for v, n in c) / sum(n for _, n in c):.0%}" for s, c in by_sampler.items()]
        out.append(f"A {planner} roadmap built for one query answers a later query with no new sample: "
                   + ", ".join(parts) + ".")
    return out
