"""RRT*'s cost convergence, a part of the one comparison: iterations to come within 5% and 1% of the best known cost.

The comparison's RRT* rows stop at the first solution; this part runs RRT* (and Informed RRT*) on every test
query to a budget of iterations and records each run's best cost as it falls (``Run.progress``, read every
``every`` iterations; the OMPL logs carry it as progress properties, as OMPL's RRT* reports them). The best known
cost of a query is the lowest final cost any compared run reached on it within the budget (the grid's shortest
path ends at the goal's centre and a run ends in the goal ball, so it is no fair reference). A run that never
comes within a target counts at the budget.

The rows: uniform RRT*, RRT* with the goal bias chosen on the tuning split, Informed RRT* (its own informed
sampling, the registry's ``informed``), and RRT* with each
route encoder, the shipped one computed lazily (``route_lazy``: the straight line to the first solution unless it
takes too long), its ablation and the exact reference (``make_sampler`` names, handed to RRT* as they are, which
binds each to its rule for RRT*). ``Comparison(convergence=BUDGET)`` adds the part (``scripts/evaluate.py
--convergence``); ``ConvergencePart`` is a :class:`~learning.evaluation.comparison.Part` like any other.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from learning.evaluation.protocol import PartQuery, Protocol
from learning.evaluation.roster import EXACT_ROUTE, ROUTE_ABLATION, Task, bias_spec
from learning.evaluation.tables import group_of
from learning.samplers.registry import SamplerSpec
from planners import make_planner
from planners.tools.benchmark import Run, markdown_table, progress_json, progress_points

#: How close to the best known cost the part measures (5% and 1%).
CONVERGENCE_TARGETS = (0.05, 0.01)
#: RRT* iterations per run, and how often the best cost is read.
BUDGET, EVERY = 3000, 25
#: The learned row must reach within 5% in at most this share of uniform RRT*'s and the tuned goal bias's iterations.
VS_BASELINES = 0.5
#: The row label of Informed RRT* (uniform sampling inside its informed set), and of the tuned goal bias (its spec
#: records the bias of each map set).
INFORMED, GOAL_BIAS = "Informed RRT*", "goal bias (tuned)"


@dataclass(frozen=True)
class ConvergenceProtocol(Protocol):
    """How a convergence run is made: RRT* runs its whole budget (``max_iterations``), its cost read every ``every``."""

    max_iterations: int = BUDGET
    every: int = EVERY

    def planner(self, name: str, problem, sampler, seed: int):
        planner = make_planner(name, problem, extension_step=self.step, sampler=sampler, seed=seed)
        return planner, self.max_iterations

    def solve(self, planner, cap: int, query=None):
        """The whole budget in steps of ``every`` iterations (how a run is split never changes it).

        Each fall of the best cost is one progress point: seconds since the solve began, iterations so far, the cost.
        """
        t0, done, best, points = time.perf_counter(), 0, math.inf, []
        r = None
        while done < cap:
            n = min(self.every, cap - done)
            r = planner.solve(max_iterations=n)
            done += n
            if r.cost < best:
                best = r.cost
                points.append((time.perf_counter() - t0, r.iterations, r.cost))
        return r, progress_json(points)


@dataclass(frozen=True)
class ConvergenceQuery(PartQuery):
    """A test query of the comparison, run for cost: its map set is the query's with `` (RRT* cost)`` added."""

    SUFFIX = " (RRT* cost)"


@dataclass
class ConvergencePart:
    """RRT*'s convergence on the comparison's test queries (see the module docstring).

    ``biases``: the goal bias chosen on the tuning split per map set (0.05, OMPL's default, where none was);
    ``fields``: the route field's samplers by label (each route encoder, its ablation, the exact reference:
    ``Comparison.field_specs``; the lazy route); ``movingai_maps``: the MovingAI map sets (pooled as one group in
    the report).
    """

    queries: Sequence
    protocol: ConvergenceProtocol = field(default_factory=ConvergenceProtocol)
    biases: Mapping[str, float] = field(default_factory=dict)
    fields: Mapping[str, SamplerSpec] = field(default_factory=dict)
    movingai_maps: Sequence[str] = ()
    name: str = "RRT* convergence"

    def setups(self, map_set: str) -> list[tuple[str, str, SamplerSpec]]:
        """(label, planner, sampler spec) of every row on ``map_set``."""
        bias = self.biases.get(map_set, 0.05)
        rows = [("uniform", "RRTstar", SamplerSpec.of("uniform")),
                (GOAL_BIAS, "RRTstar", bias_spec(bias)),
                (INFORMED, "InformedRRTstar", SamplerSpec.of("informed"))]
        return rows + [(label, "RRTstar", spec) for label, spec in self.fields.items()]

    def tasks(self) -> list[Task]:
        return [Task(ConvergenceQuery(q), planner, spec, seed, label)
                for q in self.queries if q.split == "test"
                for label, planner, spec in self.setups(q.map_set) for seed in range(self.protocol.seeds)]

    def report(self, runs: Sequence[Run]):
        from learning.evaluation.comparison import PartReport

        rows = convergence_rows(runs, self.protocol.max_iterations, self.movingai_maps)
        by_set = convergence_rows(runs, self.protocol.max_iterations, self.movingai_maps, by_group=False)
        held = targets(rows, "group") + targets(by_set)
        text = (f"RRT* and Informed RRT* run {self.protocol.max_iterations:,} iterations on every test query "
                f"({self.protocol.seeds} seed(s)), the best cost read every {self.protocol.every} iterations; the best "
                "known cost of a query is the lowest any of these runs reached. Median iterations to come within 5% "
                "and 1% of it (a run that never does counts at the budget), the share of runs that do, and the "
                "median final cost over the best known:\n\n" + markdown_table(_printable(rows)) + "\n\nBy map set:\n\n"
                + markdown_table(_printable(by_set)))
        if held:
            text += ("\n\nThe learned field against uniform RRT* and the tuned goal bias (iterations to within 5%, at "
                     f"most {VS_BASELINES:g}x both; a baseline that never gets there counts at the budget, so its "
                     "ratio is an upper bound), per group, then per map set:\n\n" + markdown_table(held))
        return PartReport(text, findings(rows, held))


def best_known(runs: Sequence[Run]) -> dict[tuple[str, str], float]:
    """Per (map set, query): the lowest final cost any run reached (inf where none solved it)."""
    out: dict[tuple[str, str], float] = {}
    for r in runs:
        key = (r.map, r.query)
        out[key] = min(out.get(key, math.inf), r.path_cost)
    return out


def iterations_within(run: Run, reference: float, share: float) -> float:
    """The iterations after which ``run``'s best cost (``Run.progress``) was within ``share`` of ``reference``.

    inf where it never was (or ``reference`` is unknown).
    """
    if not math.isfinite(reference):
        return math.inf
    for _, iterations, cost in progress_points(run):
        if cost <= reference * (1.0 + share):
            return float(iterations)
    return math.inf


def convergence_rows(runs: Sequence[Run], budget: int, movingai_maps: Sequence[str] = (), *,
                     by_group: bool = True, shares: Sequence[float] = CONVERGENCE_TARGETS) -> list[dict]:
    """Per group (or map set) and row label: runs, and per target the success share and median iterations.

    ``final_over_best``: the median of each run's final cost over its query's best known (runs without a path
    count as inf; queries no run solved are left out of it, nan where that leaves none).
    """
    best = best_known(runs)
    cells: dict[tuple[str, str], list[Run]] = {}
    for r in runs:
        where = ConvergenceQuery.map_set_of(r)
        where = group_of(where, movingai_maps) if by_group else where
        cells.setdefault((where, r.sampler), []).append(r)
    out = []
    for (where, label), rs in cells.items():
        row: dict = {"group" if by_group else "map set": where, "sampler": label, "runs": len(rs)}
        for share in shares:
            its = [iterations_within(r, best[(r.map, r.query)], share) for r in rs]
            row[f"success_{share:g}"] = float(np.mean(np.isfinite(its)))
            row[f"iterations_{share:g}"] = float(np.median(np.minimum(its, budget)))
        ratios = [r.path_cost / best[(r.map, r.query)] for r in rs if math.isfinite(best[(r.map, r.query)])]
        row["final_over_best"] = float(np.median(ratios)) if ratios else math.nan
        out.append(row)
    return out


def _printable(rows: Sequence[dict]) -> list[dict]:
    out = []
    for r in rows:
        p = {k: v for k, v in r.items() if not k.startswith(("iterations_", "success_", "final"))}
        for share in CONVERGENCE_TARGETS:
            p[f"within {share:.0%}: iterations (share)"] = (f"{r[f'iterations_{share:g}']:,.0f} "
                                                           f"({r[f'success_{share:g}']:.2f})")
        p["final / best"] = f"{r['final_over_best']:.3f}"
        out.append(p)
    return out


def _learned(label: str) -> bool:
    """Whether a row is a learned field (a route encoder): neither a classical row, the ablation nor the reference."""
    return label not in ("uniform", GOAL_BIAS, INFORMED, ROUTE_ABLATION, EXACT_ROUTE)


def targets(rows: Sequence[dict], key: str = "map set", share: float = 0.05) -> list[dict]:
    """Per ``key`` (``"group"`` or ``"map set"``) and learned row: its iterations to within ``share`` over baselines'.

    The baselines: uniform RRT* and the tuned goal bias.
    """
    cells = {(r[key], r["sampler"]): r for r in rows}
    out = []
    for (where, label), r in cells.items():
        if not _learned(label):
            continue
        uniform = cells.get((where, "uniform"))
        bias = cells.get((where, GOAL_BIAS))
        if uniform is None or bias is None:
            continue
        its = f"iterations_{share:g}"
        vs_u, vs_b = r[its] / uniform[its], r[its] / bias[its]
        out.append({"per": key, "where": where, "sampler": label, "iterations": f"{r[its]:,.0f}",
                    "/ uniform": f"{vs_u:.2f}", "/ tuned goal bias": f"{vs_b:.2f}",
                    "held": "yes" if max(vs_u, vs_b) <= VS_BASELINES else "**no**"})
    return out


def findings(rows: Sequence[dict], held: Sequence[dict]) -> list[str]:
    """Sentences for ``summary.md``: each learned row against uniform RRT* per group, and the targets held."""
    out = []
    groups = dict.fromkeys(r["group"] for r in rows)
    for label in dict.fromkeys(r["sampler"] for r in rows if _learned(r["sampler"])):
        parts = []
        for g in groups:
            cell = {r["sampler"]: r for r in rows if r["group"] == g}
            if label in cell and "uniform" in cell:
                parts.append(f"{cell[label]['iterations_0.05']:,.0f} against {cell['uniform']['iterations_0.05']:,.0f} "
                             f"({g})")
        if parts:
            out.append(f"RRT* with the {label} comes within 5% of the best known cost in a median of "
                       + ", ".join(parts) + " iterations against uniform RRT*.")
    for per, noun in (("group", "groups"), ("map set", "map sets")):
        mine = [h for h in held if h["per"] == per]
        if mine:
            missed = [f"{h['where']} ({h['/ uniform']}x uniform)" for h in mine if h["held"] != "yes"]
            out.append(f"The learned field's RRT* convergence target (at most {VS_BASELINES:g}x uniform's and the "
                       f"tuned goal bias's iterations to within 5%) holds on {len(mine) - len(missed)} of {len(mine)} "
                       f"{noun}"
                       + (f"; not on {', '.join(missed)}." if missed else "."))
    return out
