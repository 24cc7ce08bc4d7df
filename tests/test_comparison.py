"""The comparison as a library call (``learning.evaluation.compare``): the short summary, findings, other planners."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest
from conftest import load_script

from learning import evaluation as E
from learning.evaluation import report
from learning.sb3_defaults import RIGID_ID
from planners import planner_names
from planners.tools.benchmark import Run

ROOT = Path(__file__).resolve().parents[1]


def _run(family: str, sampler: str, its: int, planner: str = "RRT", query: str = "q", solved: bool = True,
         ms: float = 1.0) -> Run:
    return Run(map=family, query=query, split="test", planner=planner, sampler=sampler, seed=0, solved=solved,
               iterations=its, lower_bound=10, candidates=its, collision_checks=3 * its, wall_time=ms / 1e3,
               us_per_iteration=10.0, path_cost=40.0 if solved else math.inf, forward_passes=0, vertices=its // 2)


def _results(medians: dict[str, tuple[int, int]], routes: dict | None = None, planners: dict | None = None):
    """Results over forest and its shifted set: each sampler's iterations there, 3 queries each."""
    runs = []
    for sampler, (own, shifted) in medians.items():
        for fam, base in (("forest", own), ("forest (shifted)", shifted)):
            runs += [_run(fam, sampler, base + d, query=f"q{d}", ms=base / 10) for d in (-1, 0, 1)]
    for spec, its in ((E.SamplerSpec.of("uniform"), 900), (E.bias_spec(0.05), 800)):  # the tuning: 0.05 wins
        runs.append(Run(**{**_run("forest", E.sampler_label(spec), its).__dict__, "split": "tuning",
                           "sampler_spec": spec.to_json()}))
    for (planner, sampler), its in (planners or {}).items():
        runs += [_run("forest", sampler, its + d, planner, query=f"q{d}") for d in (-1, 0, 1)]
    queries = [E.Query("forest", 0, 64, "test"), E.Query("forest", 1, 64, "test", shifted=True)]
    comparison = E.Comparison(queries, E.Protocol(), routes=routes or {})
    return E.Results(comparison, runs, batch=2, batch_scores={2: 1.0}, constants={}, unseen=[])


def test_the_short_table_has_one_row_per_sampler_and_a_few_columns():
    res = _results({"uniform": (900, 1000), "goal_bias=0.05": (800, 900), "policy": (300, 350),
                    "constant (tuned)": (280, 400), E.ROUTE: (50, 60), E.ROUTE_ABLATION: (150, 200),
                    E.EXACT_ROUTE: (48, 55), E.EXPERT: (40, 45)})
    rows = res.glance()
    assert [r["sampler"] for r in rows] == ["uniform", "best goal bias", "policy", "policy ablation", E.ROUTE,
                                            E.ROUTE_ABLATION, "exact route reference", "expert"]
    assert list(rows[0]) == ["sampler", "generated", "shifted", "time per query", "success"]
    route = next(r for r in rows if r["sampler"] == E.ROUTE)
    assert route["generated"] == "50" and route["shifted"] == "60" and route["success"] == "100%"
    lines = report.findings(res)
    # the numbers come from the runs: the route encoder's ratios to its ablation, the policy's loss on shifted
    assert any(f"{E.ROUTE} needs 0.33 (generated), 0.30 (shifted)" in line and "pays on every group" in line
               for line in lines)
    assert any("policy needs 1.07 (generated), 0.88 (shifted)" in line and "does not pay on generated" in line
               for line in lines)
    assert any(line.startswith("Fewest median iterations") and f"generated: {E.ROUTE} (50" in line for line in lines)
    assert any("fastest is route encoder" in line for line in lines)


@pytest.mark.parametrize("mine, verdict", [((80, 90), "loses to the shipped route encoder"),
                                           ((40, 50), "beats the shipped route encoder"),
                                           ((40, 90), "neither beats nor loses")])
def test_the_summary_says_plainly_whether_a_users_encoder_loses_to_the_shipped_one(mine, verdict):
    res = _results({"uniform": (900, 1000), "goal_bias=0.05": (800, 900), E.ROUTE: (50, 60),
                    E.ROUTE_ABLATION: (150, 200), "mine": mine}, routes={"mine": "mine.pt"})
    text = report.summary_markdown(res)
    line = next(ln for ln in text.splitlines() if "Your encoder mine" in ln)
    assert verdict in line
    assert ("Use the shipped one." in line) == (verdict.startswith("loses"))
    assert "Your route encoders, beside the shipped one: `mine`: `mine.pt`" in text
    assert "| mine |" in text.split("## Findings")[0]  # a row of the short table


def test_other_planners_are_tabled_with_samples_checks_success_and_time_and_named_in_a_finding():
    res = _results({"uniform": (900, 1000), "goal_bias=0.05": (800, 900), E.ROUTE: (50, 60),
                    E.ROUTE_ABLATION: (150, 200)},
                   planners={("PRM", "uniform"): 300, ("PRM", E.OBSTACLE_BASED): 200, ("PRM", E.ROUTE): 900})
    rows = report.other_planner_rows(res)
    prm = {r["sampler"]: r for r in rows if r["planner"] == "PRM"}
    assert set(prm) == {"uniform", E.OBSTACLE_BASED, E.ROUTE}
    assert prm[E.OBSTACLE_BASED]["median iterations (samples)"] == "200" and prm[E.ROUTE]["median checks"] == "2700"
    assert list(prm["uniform"]) == ["planner", "sampler", "sets", "runs", "median iterations (samples)",
                                    "median checks", "success", "median time"]
    line = next(ln for ln in report.findings(res) if ln.startswith("With PRM"))
    assert f"{E.OBSTACLE_BASED} (200)" in line and f"the {E.ROUTE} needs 900, 4.50 times {E.OBSTACLE_BASED}" in line
    assert "## Other planners" in report.details_markdown(res)


def test_a_roadmap_takes_obstacle_based_sampling_and_a_tree_its_goal_bias():
    assert [E.is_roadmap(p) for p in ("PRM", "LazyPRM", "OBPRM", "RRTConnect", "RRTstar")] == [
        True, True, True, False, False]
    spec = E.SamplerSpec.of("obstacle_based")
    assert E.sampler_label(E.SamplerSpec.from_json(spec.to_json())) == E.OBSTACLE_BASED
    assert type(spec.build()).__name__ == "ObstacleBasedSampler"


def test_route_name_file_adds_an_encoder_and_a_bare_file_still_replaces_the_shipped_one(tmp_path, capsys):
    from learning.samplers.route import SHIPPED

    ev = load_script("evaluate")
    args = ev.parse_args(["--route", f"mine={SHIPPED}", "--out", str(tmp_path / "a")])
    assert args.route == SHIPPED and args.extra_routes == {"mine": SHIPPED}
    assert f"--route mine={SHIPPED}" in args.inputs and "extra_routes" in ev._settings(args)
    comparison = ev.comparison_of(args)
    assert set(comparison.route_specs()) == {E.ROUTE, "mine"}
    args = ev.parse_args(["--route", str(SHIPPED), "--out", str(tmp_path / "b")])
    assert args.route == SHIPPED and args.extra_routes == {} and "extra_routes" not in ev._settings(args)
    for argv, needle in ((["--route", "uniform=x.pt"], "taken"), (["--route", f"a={SHIPPED}", "--route",
                                                                    f"a={SHIPPED}"], "given twice"),
                         (["--route", "mine=/no/such.pt"], "/no/such.pt")):
        with pytest.raises(SystemExit) as exc:
            ev.parse_args([*argv, "--out", str(tmp_path / "c")])
        assert exc.value.code == 2 and needle in capsys.readouterr().err
    assert ev.parse_args(["--other-planners", "all", "--out", str(tmp_path / "d")]).other_planners == [
        p for p in planner_names() if p != "RRT"]


@pytest.mark.slow
def test_other_planners_run_every_registry_sampler_beside_their_classical_option(tmp_path, capsys):
    from learning.samplers.route import SHIPPED

    out = tmp_path / "out"
    rc = load_script("evaluate").main([
        "--families", "forest", "--size", "64", "--maps", "1", "--tuning-maps", "1", "--seeds", "1",
        "--shifted-maps", "0", "--no-unseen", "--movingai-maps", "--other-planners", "PRM", "RRTConnect", "OBPRM",
        "--route", f"mine={SHIPPED}", "--max-iterations", "1500", "--convergence", "200", "--later-queries", "1",
        "--processes", "1", "--out", str(out)])
    assert rc == 0
    rows = list(csv.DictReader((out / "runs.csv").open()))
    # the two parts: RRT*'s cost on the test query, later queries on both roadmap planners, in their own map sets
    cost = [r for r in rows if r["map"] == "forest (RRT* cost)"]
    assert {r["sampler"] for r in cost} == {"uniform", "goal bias (tuned)", "Informed RRT*", E.ROUTE, "mine",
                                            E.LAZY_ROUTE, E.ROUTE_ABLATION, E.EXACT_ROUTE}
    assert any(r["progress"] for r in cost)
    later = [r for r in rows if r["map"] == "forest (later queries)"]
    assert {r["planner"] for r in later} == {"PRM", "OBPRM"} and all(r["query"].endswith("later 1") for r in later)
    details = (out / "details.md").read_text()
    assert "## RRT* convergence" in details and "## Later queries on one roadmap" in details
    rows = [r for r in rows if r not in cost and r not in later]
    got = {(r["planner"], r["sampler"]) for r in rows if r["split"] == "test"}
    for planner, classical in (("PRM", E.OBSTACLE_BASED), ("RRTConnect", None)):
        want = {"uniform", "policy", E.ROUTE, "mine", E.LAZY_ROUTE, E.ROUTE_ABLATION, E.EXACT_ROUTE}
        assert {(planner, s) for s in want} <= got
        if classical:
            assert (planner, classical) in got
    assert any(p == "RRTConnect" and s.startswith("goal_bias=") for p, s in got) or ("RRTConnect", "uniform") in got
    # OB-PRM handed another sampler is PRM with it: it runs with its own obstacle-based sampling only
    assert {(p, s) for p, s in got if p == "OBPRM"} == {("OBPRM", E.OBSTACLE_BASED)}
    assert ("RRT", E.LAZY_ROUTE) in got  # RRT's own rows: the lazy route beside the route encoder
    assert {r["split"] for r in rows if r["planner"] == "RRTConnect"} == {"tuning", "test"}
    summary = (out / "summary.md").read_text()
    assert "Your encoder mine" in summary and "With PRM" in summary and "| mine |" in summary
    assert "## Other planners" in (out / "details.md").read_text()


class _OnePart:
    """The smallest part: uniform RRT on one small generated map, under a protocol of its own."""

    name = "a part of its own"

    def __init__(self) -> None:
        self.protocol = E.Protocol(max_iterations=400, seeds=1)

    def tasks(self):
        q = E.Query("forest", 1_000_000, 32, "test")
        return [E.Task(q, "RRT", E.SamplerSpec.of("uniform"), seed) for seed in (0, 1)]

    def report(self, runs):
        return E.PartReport(f"{len(runs)} runs of the part.\n", [f"the part ran {len(runs)} runs"])


def test_a_part_plugs_into_the_same_call_journal_and_output_set(tmp_path):
    part = _OnePart()
    assert isinstance(part, E.Part)
    out = tmp_path / "out"
    res = E.compare(E.Comparison([], parts=[part]), out, log=lambda line: None)
    runs, rep = res.parts[part.name]
    assert len(runs) == 2 and all(r.map == "forest" for r in runs) and not res.runs
    assert "- a part of its own: the part ran 2 runs" in (out / "summary.md").read_text()
    assert "## a part of its own\n\n2 runs of the part." in (out / "details.md").read_text()
    rows = list(csv.DictReader((out / "runs.csv").open()))
    assert len(rows) == 2 and (out / "ompl" / "forest.log").is_file()
    assert not (tmp_path / "out.partial").exists()  # the journal is removed once the set is written


def test_evaluate_runs_the_6dof_scene_sets_as_a_part_and_checks_its_flags_first(tmp_path, capsys):
    ev = load_script("evaluate")
    for argv, needle in ((["--rigid-only"], "--rigid-only needs --rigid PART"),
                         (["--rigid", "validation", "--rigid-samplers", "nope"], "unknown sampler 'nope'"),
                         (["--rigid", "validation", "--rigid-scenes", "0"], "--rigid-scenes"),
                         (["--rigid-scenes", "3"], "--rigid-scenes needs --rigid PART"),
                         (["--rigid-sampler", "mine=planners:UniformSampler"], "--rigid-sampler needs --rigid PART"),
                         (["--rigid", "validation", "--rigid-sampler", "uniform=planners:UniformSampler"], "taken"),
                         (["--rigid", "validation", "--rigid-sampler", "mine=nope.zip@" + RIGID_ID], "nope.zip")):
        with pytest.raises(SystemExit) as exc:
            ev.parse_args([*argv, "--out", str(tmp_path / "x")])
        assert exc.value.code == 2 and needle in capsys.readouterr().err
    args = ev.parse_args(["--out", str(tmp_path / "a")])
    assert not any(k.startswith("rigid") for k in ev._settings(args))  # journals of runs without --rigid unchanged
    out = tmp_path / "rigid"
    rc = ev.main(["--rigid", "validation", "--rigid-only", "--rigid-scenes", "1", "--rigid-planners", "RRTConnect",
                  "--rigid-samplers", "uniform", "--rigid-max-iterations", "100", "--processes", "1",
                  "--rigid-sampler", "mine=planners:UniformSampler", "--out", str(out)])
    assert rc == 0
    rows = list(csv.DictReader((out / "runs.csv").open()))
    assert len(rows) == 10 and {r["planner"] for r in rows} == {"RRTConnect"}  # one scene of each training family
    by = {s: sorted((r["query"], r["iterations"], r["solved"]) for r in rows if r["sampler"] == s) for s in
          ("uniform", "mine")}
    assert len(by["mine"]) == 5 and by["mine"] == by["uniform"]  # a user's sampler, labelled by its name
    assert "6-DoF scenes (validation)" in (out / "details.md").read_text()


def test_which_planner_names_the_fewest_iterations_and_the_fastest_per_group_over_every_planner():
    res = _results({"uniform": (900, 1000), "goal_bias=0.05": (800, 900), E.ROUTE: (50, 60),
                    E.ROUTE_ABLATION: (150, 200), E.EXACT_ROUTE: (10, 10)},
                   planners={("PRM", "uniform"): 300, ("PRM", E.ROUTE): 40, ("RRTConnect", "uniform"): 70})
    rows = {r["group"]: r for r in report.which_planner(res)}
    assert set(rows) == {"generated", "shifted"}
    # the exact reference (10) is privileged, not a competitor; PRM's 40 samples are the fewest on generated
    assert rows["generated"]["fewest iterations (roadmaps: samples)"].startswith(f"PRM + {E.ROUTE}: 40 (")
    assert rows["generated"]["fewest iterations (roadmaps: samples)"].endswith("all solved")
    # the planners' runs here take 1 ms each, RRT's a tenth of their iterations in ms: RRT's route encoder at 5 ms
    assert rows["generated"]["fastest to a path"].startswith("PRM + ")
    assert rows["shifted"]["fewest iterations (roadmaps: samples)"].startswith(f"RRT + {E.ROUTE}: 60 (")
    assert "## Which planner and sampler" in report.summary_markdown(res)
    assert report.which_planner(_results({"uniform": (900, 1000), E.ROUTE: (50, 60)})) == []


def test_the_6dof_part_takes_the_reports_ten_scenes_a_family_unless_quick_or_told():
    ev = load_script("evaluate")
    assert ev.parse_args(["--rigid", "test"]).rigid_scenes == 10
    assert ev.parse_args(["--quick", "--rigid", "test"]).rigid_scenes == 2
    assert ev.parse_args(["--quick", "--rigid", "test", "--rigid-scenes", "4"]).rigid_scenes == 4
