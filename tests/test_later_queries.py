"""Later queries on one roadmap as a part of the one comparison (``learning.evaluation.later_queries``)."""

from __future__ import annotations

import csv

from conftest import load_script

from learning import evaluation as E
from learning.evaluation.journal import Journal
from learning.evaluation.later_queries import (
    LaterQueriesPart,
    LaterQueriesProtocol,
    LaterQuery,
    later_query_rows,
    other_queries,
)
from learning.samplers.registry import make_sampler
from planners import make_planner


def test_the_part_answers_later_queries_on_the_roadmap_its_own_run_builds(tmp_path):
    query = E.Query("forest", 1_000_000, 64, "test")
    protocol = LaterQueriesProtocol(step=4.0, max_iterations=3000, seeds=1, later=2)
    samplers = {"uniform": E.SamplerSpec.of("uniform"), E.ROUTE_ABLATION: E.SamplerSpec.of("route_ablation")}
    part = LaterQueriesPart([query, E.Query("forest", 1_000_001, 64, "tuning")], ["PRM", "OBPRM"], samplers, protocol)
    assert isinstance(part, E.Part)
    out = tmp_path / "out"
    res = E.compare(E.Comparison([], parts=[part]), out, log=lambda line: None)
    runs, rep = res.parts[part.name]
    # PRM with each sampler, OB-PRM with its own sampling only; two later queries each, test split only
    assert sorted((r.planner, r.sampler) for r in runs) == sorted(
        [("PRM", "uniform")] * 2 + [("PRM", E.ROUTE_ABLATION)] * 2 + [("OBPRM", E.OBSTACLE_BASED)] * 2)
    assert {r.map for r in runs} == {"forest (later queries)"}
    problem = query.problem("", protocol.tolerance)
    pairs = other_queries(problem, 2, LaterQuery(query, 1).seed)
    for k, (start, goal) in enumerate(pairs, 1):  # the same samples as the roadmap built and asked by hand
        prm = make_planner("PRM", problem, extension_step=4.0, sampler=make_sampler("uniform"), seed=0)
        prm.solve(max_iterations=3000)
        want = prm.query(start, goal, max_iterations=3000)
        got = next(r for r in runs if r.sampler == "uniform" and r.query.endswith(f"later {k}"))
        assert got.solved == want.solved and got.iterations == want.iterations and got.path_cost == want.cost
        assert got.lower_bound == -1 and prm.problem.iteration_lower_bound(4.0) is None  # its shortest path unknown
    journal = Journal(tmp_path / "journal", {}, resume=False)  # a resumed run reads these runs back as they were
    for i, r in enumerate(runs):
        journal.add(str(i), r)
    journal.close()
    again = Journal(tmp_path / "journal", {}, resume=True)
    assert [again.done[str(i)] for i in range(len(runs))] == runs
    again.close()
    rows = later_query_rows(runs, protocol.max_iterations, by_group=False)
    assert {(r["planner"], r["queries"]) for r in rows} == {("PRM", 2), ("OBPRM", 2)}
    assert all(0.0 <= r["served"] <= r["success"] <= 1.0 for r in rows)
    assert "served as built" in rep.markdown and rep.findings[0].startswith("A PRM roadmap built for one query")
    csv_rows = list(csv.DictReader((out / "runs.csv").open()))
    assert len({r["query"] for r in csv_rows}) == 2  # each later query under its own name
    assert (out / "ompl" / "forest_later_queries.log").is_file()


def test_evaluate_takes_later_queries_as_a_flag(tmp_path):
    ev = load_script("evaluate")
    args = ev.parse_args(["--out", str(tmp_path / "a"), "--later-queries"])
    assert args.later_queries == 3
    assert "later_queries" not in ev._settings(ev.parse_args(["--out", str(tmp_path / "a")]))
    comparison = ev.comparison_of(ev.parse_args(["--out", str(tmp_path / "b"), "--quick", "--movingai-maps",
                                                 "--other-planners", "LazyPRM", "RRTConnect", "--later-queries", "2"]))
    (part,) = comparison._later_queries_part(comparison.queries)
    assert part.planners == ["LazyPRM"] and part.protocol.later == 2
