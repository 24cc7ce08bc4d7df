"""RRT*'s cost convergence as a part of the one comparison (``learning.evaluation.convergence``)."""

from __future__ import annotations

import csv
import math
import sqlite3

import pytest
from conftest import load_script
from test_benchmark_log import read_benchmark_log

from learning import evaluation as E
from learning.evaluation.convergence import (
    GOAL_BIAS,
    ConvergencePart,
    ConvergenceProtocol,
    convergence_rows,
    iterations_within,
    targets,
)
from planners import make_planner
from planners.maps.generators import generate
from planners.tools.benchmark import Run, progress_json, progress_points


def _run(sampler: str, points, query: str = "q", cost: float | None = None) -> Run:
    final = points[-1][2] if points else math.inf
    return Run(map="forest (RRT* cost)", query=query, split="test", planner="RRTstar", sampler=sampler, seed=0,
               solved=bool(points), iterations=points[0][1] if points else 100, lower_bound=-1, candidates=100,
               collision_checks=100, wall_time=0.1, us_per_iteration=1.0, path_cost=final if cost is None else cost,
               forward_passes=0, vertices=50, progress=progress_json(points))


def test_progress_round_trips_and_an_unknown_cost_is_inf():
    run = _run("uniform", [(0.01, 25, math.inf), (0.02, 50, 120.5)])
    assert progress_points(run) == [(0.01, 25, math.inf), (0.02, 50, 120.5)]
    assert progress_points(_run("uniform", [])) == []


def test_iterations_to_within_a_share_of_the_best_known():
    run = _run("uniform", [(0.01, 25, 120.0), (0.02, 50, 104.0), (0.03, 75, 100.5)])
    assert iterations_within(run, 100.0, 0.05) == 50
    assert iterations_within(run, 100.0, 0.01) == 75
    assert iterations_within(run, 100.0, 0.001) == math.inf
    assert iterations_within(run, math.inf, 0.05) == math.inf


def test_rows_take_the_best_known_cost_over_every_run_of_a_query_and_count_misses_at_the_budget():
    runs = [_run("uniform", [(0.1, 100, 130.0), (0.2, 900, 110.0)]),
            _run("route encoder", [(0.1, 50, 104.0), (0.2, 200, 100.0)]),
            _run(GOAL_BIAS, [])]  # never found a path
    rows = {r["sampler"]: r for r in convergence_rows(runs, 1000, by_group=False)}
    assert rows["route encoder"]["iterations_0.05"] == 50 and rows["route encoder"]["iterations_0.01"] == 200
    assert rows["uniform"]["iterations_0.05"] == 1000 and rows["uniform"]["success_0.05"] == 0.0  # 110 > 105
    assert rows["uniform"]["final_over_best"] == pytest.approx(1.1)
    assert rows[GOAL_BIAS]["final_over_best"] == math.inf and rows[GOAL_BIAS]["iterations_0.01"] == 1000
    held = targets(list(rows.values()))
    assert held == [{"per": "map set", "where": "forest", "sampler": "route encoder", "iterations": "50",
                     "/ uniform": "0.05", "/ tuned goal bias": "0.05", "held": "yes"}]
    (group,) = targets(convergence_rows(runs, 1000), "group")
    assert group["where"] == "generated" and group["held"] == "yes"
    assert rows[GOAL_BIAS]["final_over_best"] == math.inf


def test_a_convergence_run_is_one_run_read_every_few_iterations():
    problem = generate("forest", 1_000_000, 32)
    protocol = ConvergenceProtocol(step=2.0, max_iterations=300, every=25)
    planner, cap = protocol.planner("RRTstar", problem, None, 3)
    r, progress = protocol.solve(planner, cap)
    whole = make_planner("RRTstar", problem, extension_step=2.0, seed=3).solve(max_iterations=300)
    assert r.iterations == whole.iterations == 300 and r.cost == whole.cost  # the split never changes the run
    points = progress_points(Run(**{**_run("x", []).__dict__, "progress": progress}))
    assert points and points[-1][2] == r.cost
    assert all(a[0] < b[0] and a[1] < b[1] and a[2] > b[2] for a, b in zip(points, points[1:], strict=False))
    assert all(i % 25 == 0 and i <= 300 for _, i, _ in points)


def test_the_part_runs_every_row_and_writes_its_progress_to_runs_csv_and_the_ompl_logs(tmp_path):
    queries = [E.Query("forest", 1_000_000, 32, "test"), E.Query("forest", 1_000_001, 32, "tuning")]
    protocol = ConvergenceProtocol(step=2.0, max_iterations=200, seeds=1, every=50)
    fields = E.Comparison([], E.Protocol(step=2.0)).field_specs()  # the route encoder, its ablation, the reference
    part = ConvergencePart(queries, protocol, {"forest": 0.1}, fields)
    assert isinstance(part, E.Part)
    out = tmp_path / "out"
    res = E.compare(E.Comparison([], parts=[part]), out, log=lambda line: None)
    runs, rep = res.parts[part.name]
    assert {r.sampler for r in runs} == {"uniform", GOAL_BIAS, "Informed RRT*", E.ROUTE, E.ROUTE_ABLATION,
                                         E.EXACT_ROUTE}
    assert {r.map for r in runs} == {"forest (RRT* cost)"} and {r.split for r in runs} == {"test"}
    assert '"bias":0.1' in next(r for r in runs if r.sampler == GOAL_BIAS).sampler_spec.replace(" ", "")
    assert "within 5%" in rep.markdown and rep.protocol == protocol
    rows = list(csv.DictReader((out / "runs.csv").open()))
    assert all(r["progress"] == run.progress for r, run in zip(rows, runs, strict=True))
    conn = sqlite3.connect(":memory:")
    exp = read_benchmark_log((out / "ompl" / "forest_RRT_cost.log").read_text(), conn)
    assert conn.execute("SELECT max_iterations FROM experiments WHERE id = ?", (exp,)).fetchone()[0] == 200
    points = conn.execute("SELECT count(*) FROM progress").fetchone()[0]
    assert points == sum(len(progress_points(r)) for r in runs) > 0


def test_evaluate_takes_convergence_as_a_flag_and_leaves_old_journals_alone(tmp_path, capsys):
    ev = load_script("evaluate")
    assert ev.parse_args(["--out", str(tmp_path / "a"), "--convergence"]).convergence == 3000
    args = ev.parse_args(["--out", str(tmp_path / "a")])
    assert args.convergence == 0 and "convergence" not in ev._settings(args)
    assert ev.comparison_of(ev.parse_args(["--out", str(tmp_path / "b"), "--convergence", "500", "--quick",
                                           "--movingai-maps"])).convergence == 500
    with pytest.raises(SystemExit) as exc:
        ev.parse_args(["--out", str(tmp_path / "a"), "--convergence", "-1"])
    assert exc.value.code == 2 and "--convergence" in capsys.readouterr().err
