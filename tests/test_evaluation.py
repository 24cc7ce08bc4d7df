"""The comparison (``learning.evaluation``, ``scripts/evaluate.py``): sound tuning, outputs people can open."""

from __future__ import annotations

import csv
import dataclasses
import math
import os
import sqlite3
import stat
import sys
from pathlib import Path

import numpy as np
import pytest

from learning import evaluation as E
from learning.evaluation import report
from planners import planner_names
from planners.maps.generators import SHIFTED_SEED0, SHIFTED_SIZES, TEST_SEED0
from planners.tools.benchmark import Run, write_runs_csv

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))
from conftest import load_script  # noqa: E402
from test_benchmark_log import read_benchmark_log, runs_table  # noqa: E402
from test_comparison import _results  # noqa: E402


def _load_evaluate():
    return load_script("evaluate")


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _run(family, split, sampler, its, solved=True, planner="RRT", query="q", seed=0) -> Run:
    """A run of ``sampler``: a spec (labelled from it and recorded as JSON), or a bare label."""
    spec = sampler.to_json() if isinstance(sampler, E.SamplerSpec) else ""
    label = E.sampler_label(sampler) if isinstance(sampler, E.SamplerSpec) else sampler
    return Run(map=family, query=query, split=split, planner=planner, sampler=label, seed=seed, solved=solved,
               iterations=its, lower_bound=10, candidates=its, collision_checks=3 * its, wall_time=its * 1e-5,
               us_per_iteration=10.0, path_cost=40.0 if solved else math.inf, forward_passes=0, vertices=its // 2,
               sampler_spec=spec)


# --- point 7a: the best goal bias is chosen soundly, on the tuning split only -------------------------

def test_best_bias_is_never_worse_than_uniform_on_the_tuning_split():
    runs = [_run("rooms", "tuning", E.bias_spec(0), i) for i in (900, 1000, 1100)]
    runs += [_run("rooms", "tuning", E.bias_spec(b), i + k * 100) for k, b in enumerate(E.GOAL_BIASES)
             for i in (1000, 1100, 1200)]
    assert E.best_bias(runs) == {("rooms", "RRT"): 0.0}
    rows = E.summarize(runs + [_run("rooms", "test", "uniform", 5), _run("rooms", "test", "policy", 4)],
                       E.best_bias(runs))
    assert [r["sampler"] for r in rows if r["_sampler"] == "uniform"] == ["uniform (best)"]


def test_best_bias_never_looks_at_the_test_split():
    runs = [_run("maze", "tuning", E.bias_spec(b), i) for b, i in ((0, 900), (0.1, 500), (0.5, 800))]
    runs += [_run("maze", "test", E.bias_spec(b), i) for b, i in ((0, 10), (0.1, 900), (0.5, 5))]
    assert E.best_bias(runs) == {("maze", "RRT"): 0.1}


def test_tuning_runs_cover_uniform_and_every_bias_on_tuning_queries_only():
    qs = E.generated_queries(["forest"], 64, n_test=2, n_tune=3)
    tasks = E.tuning_tasks(qs, "RRT")
    assert {t.query.split for t in tasks} == {"tuning"}
    assert all(t.query.key < TEST_SEED0 for t in tasks)
    assert sorted({t.sampler_label for t in tasks}) == sorted(["uniform", *(f"goal_bias={b:g}" for b in E.GOAL_BIASES)])
    assert {E.spec_bias(t.sampler) for t in tasks} == set(E.TUNING_BIASES)
    assert len(tasks) == 3 * (1 + len(E.GOAL_BIASES))


def test_policy_batch_is_tuned_on_generated_tuning_queries_only():
    qs = E.generated_queries(["forest", "maze"], 64, n_test=2, n_tune=3) + E.shifted_queries(["forest"], 2)
    tasks = E.policy_tuning_tasks(qs, "RRT", "p.zip")
    assert {t.query.split for t in tasks} == {"tuning"} and not any(t.query.shifted for t in tasks)
    assert sorted({t.sampler_label for t in tasks}) == sorted(E.policy_sampler(b) for b in E.POLICY_BATCHES)
    assert {t.sampler for t in tasks} == {E.policy_spec("p.zip", b) for b in E.POLICY_BATCHES}
    assert len(tasks) == 2 * 3 * len(E.POLICY_BATCHES) * E.POLICY_TUNING_SEEDS


def test_best_policy_batch_sums_log_medians_and_breaks_ties_towards_the_larger_batch():
    def runs(batch, forest, maze, split="tuning"):
        return [_run(f, split, E.policy_spec("p.zip", batch), its) for f, its in (("forest", forest), ("maze", maze))]

    # batch 2 halves forest and loses a little on maze: the log sum weighs both families alike
    best, score = E.best_policy_batch(runs(8, 100, 400) + runs(2, 50, 500) + runs(1, 50, 800))
    assert best == 2 and score[2] == pytest.approx(np.log(50) + np.log(500))
    # within the tie margin the larger batch wins (fewer forward passes); beyond it, the lower score
    assert E.best_policy_batch(runs(8, 100, 400) + runs(2, 100, 399))[0] == 8
    assert E.best_policy_batch(runs(8, 100, 400) + runs(2, 100, 390))[0] == 2
    # test-split runs are never looked at
    assert E.best_policy_batch(runs(8, 100, 400) + runs(2, 10, 10, split="test"))[0] == 8
    with pytest.raises(ValueError, match="no tuning runs"):
        E.best_policy_batch(runs(2, 10, 10, split="test"))


def test_shifted_maps_are_test_only_with_their_own_seeds_and_sizes():
    qs = E.shifted_queries(["forest", "maze"], n_test=7)
    assert len(qs) == 14 and {q.split for q in qs} == {"test"} and all(q.shifted for q in qs)
    assert {q.map_set for q in qs} == {"forest (shifted)", "maze (shifted)"}
    assert [q.size for q in qs if q.family == "maze"] == [SHIFTED_SIZES[i % len(SHIFTED_SIZES)] for i in range(7)]
    assert all(q.key >= SHIFTED_SEED0 for q in qs)
    # nothing tunes on them: neither goal bias nor the ablation
    assert E.tuning_tasks(qs, "RRT") == [] and E.constant_tuning_tasks(qs, "RRT", E.Protocol(), 8) == []
    problem = E.Protocol().problem(qs[1])
    assert problem.name == f"forest-shifted-{SHIFTED_SIZES[1]}-{SHIFTED_SEED0 + 1}"
    assert problem.world.shape == (SHIFTED_SIZES[1],) * 2


def test_shifted_map_sets_keep_their_familys_tuned_settings():
    qs = E.generated_queries(["forest", "rooms"], 64, 1, 1) + E.shifted_queries(["forest"], 1)
    tuned = {("forest", "RRT"): 0.2, ("forest", "PRM"): 0.05, ("rooms", "RRT"): 0.01}
    assert E.tuned_for_shifted(tuned, qs) == tuned | {("forest (shifted)", "RRT"): 0.2,
                                                      ("forest (shifted)", "PRM"): 0.05}
    # and the ablation's test runs on the shifted maps take that setting
    tasks = E.constant_test_tasks(qs, "RRT", E.Protocol(), 8, E.tuned_for_shifted({("forest", "RRT"): 0.7}, qs),
                                  seeds=2)
    assert [(t.query.map_set, t.sampler.param("frontier"), t.sampler_label, t.seed) for t in tasks] == [
        ("forest", 0.7, E.CONSTANT, s) for s in (0, 1)] + [("forest (shifted)", 0.7, E.CONSTANT, s) for s in (0, 1)]


def test_every_registered_sampler_has_one_label_and_the_roster_carries_the_exact_reference():
    from learning.samplers.registry import sampler_names

    labels = {name: E.sampler_label(E.SamplerSpec.of(name)) for name in sampler_names()}
    assert len(set(labels.values())) == len(labels)
    assert labels["goal_bias"] == "goal_bias=0.05" and labels["expert"] == E.EXPERT
    assert labels["exact_route"] == E.EXACT_ROUTE == "exact_route"
    assert E.sampler_label(E.policy_spec("p.zip", 2)) == E.policy_sampler(2)
    assert E.sampler_label(E.SamplerSpec.user("mine", "m:f")) == "mine"
    protocol = E.Protocol(step=3.0)
    fixed = E.fixed_specs(protocol, "r.pt", {"mine": "m:f"})
    assert E.SamplerSpec.of("exact_route", step_size=3.0) in fixed
    assert all(s.param("step_size") == 3.0 for s in fixed if s.name not in ("uniform", "goal_bias", "user"))
    assert not {"expert", "exact_route"} & {s.name for s in E.fixed_specs(protocol, "r.pt", {}, references=False)}
    qs = E.generated_queries(["forest"], 64, n_test=2, n_tune=1) + E.shifted_queries(["forest"], 1)
    tasks = E.evaluation_tasks(qs, "RRT", fixed, seeds=2)
    exact = {(t.query.map_set, t.seed) for t in tasks if t.sampler_label == E.EXACT_ROUTE}
    assert exact == {(m, s) for m in ("forest", "forest (shifted)") for s in (0, 1)}


def test_a_run_takes_its_protocol_models_and_scenarios_from_its_context_alone(tmp_path):
    from learning.evaluation import mapsets, protocol, runner
    from learning.models.route_net import load_route_net
    from learning.samplers.route import SHIPPED

    for module in (runner, protocol, mapsets):  # no per-process caches for workers to fill
        assert not [n for n, v in vars(module).items() if isinstance(v, dict) and n.isupper() and n != "QUICK"
                    and not n.startswith("PART")], module.__name__
    q = E.generated_queries(["forest"], 64, 1, 0)[0]
    nowhere = str(tmp_path / "not-there.pt")  # the encoder comes from the context, never from this path
    spec = E.SamplerSpec.of("route", path=nowhere, step_size=4.0)
    models = E.ModelCache()
    models.routes[nowhere] = load_route_net(SHIPPED)
    context = E.RunContext(E.Protocol(max_iterations=1500), models)
    assert E.shared_context([E.Task(q, "RRT", spec, 0)], context) is context and len(models.routes) == 1
    got = E.run_one(E.Task(q, "RRT", spec, 0), context)
    shipped = E.run_one(E.Task(q, "RRT", E.SamplerSpec.of("route", path=str(SHIPPED), step_size=4.0), 0),
                        E.RunContext(E.Protocol(max_iterations=1500)))
    assert (got.iterations, got.solved, got.sampler) == (shipped.iterations, shipped.solved, E.ROUTE)
    assert E.spec_of(got) == spec and got.lower_bound == shipped.lower_bound
    # the cap is the context's protocol's
    capped = E.run_one(E.Task(q, "RRT", E.SamplerSpec.of("uniform"), 0), E.RunContext(E.Protocol(max_iterations=3)))
    assert capped.iterations <= 3


def test_the_runs_of_a_query_share_one_problem_and_run_as_on_a_fresh_build(monkeypatch):
    """A worker builds a recent query's problem once; its runs are those of a fresh build per run."""
    import pickle

    from learning.evaluation.runner import ProblemCache

    builds = []
    build = E.Protocol.problem
    monkeypatch.setattr(E.Protocol, "problem", lambda self, q, cache=None: builds.append(q) or build(self, q, cache))
    qs = E.generated_queries(["forest", "maze"], 64, 2, 0)
    specs = (E.SamplerSpec.of("uniform"), E.bias_spec(0.05))
    tasks = [E.Task(q, "RRT", s, seed) for q in qs for s in specs for seed in range(2)]
    context = E.RunContext(E.Protocol(max_iterations=2000), problems=ProblemCache(size=2))
    runs = [E.run_one(t, context) for t in tasks]
    assert builds == qs and len(context.problems) == 2  # one build per query, the last two kept
    assert context.problem(qs[-1]) is context.problem(qs[-1]) and builds == qs
    context.problem(qs[0])  # no longer among the last two: built again
    assert builds == [*qs, qs[0]]
    fresh = [E.run_one(t, E.RunContext(E.Protocol(max_iterations=2000))) for t in tasks]
    assert [(r.iterations, r.solved, r.path_cost, r.vertices) for r in runs] == \
        [(r.iterations, r.solved, r.path_cost, r.vertices) for r in fresh]
    shipped = pickle.loads(pickle.dumps(context))  # a worker gets the context without the problems
    assert len(shipped.problems) == 0 and shipped.problems.size == 2

def test_a_spec_column_round_trips_as_json_never_parsed_from_the_label(tmp_path):

    specs = [E.bias_spec(0.1), E.constant_spec(0.3, E.Protocol(), 2), E.policy_spec("p.zip", 8),
             E.SamplerSpec.user("mine", "m:f"), E.SamplerSpec.of("exact_route", step_size=4.0)]
    # labels that say nothing of the parameters: the tuning reads the spec column, not the label
    runs = [dataclasses.replace(_run("forest", "tuning", s, 100 + i), sampler=f"label {i}")
            for i, s in enumerate(specs)]
    write_runs_csv(runs, tmp_path / "runs.csv")
    with (tmp_path / "runs.csv").open(newline="") as f:
        back = [E.SamplerSpec.from_json(r["sampler_spec"]) for r in csv.DictReader(f)]
    assert back == specs
    assert E.best_bias(runs) == {("forest", "RRT"): 0.1} and E.best_constant(runs) == {("forest", "RRT"): 0.3}


def test_the_protocol_holds_the_defaults_and_quick_keeps_the_tuning_split():
    full, quick = E.Protocol(), E.Protocol().quick()
    assert (full.step, full.tolerance, full.max_iterations) == (4.0, 4.0, 20_000)
    assert (quick.tuning_maps, quick.tuning_scenarios) == (full.tuning_maps, full.tuning_scenarios)
    assert quick.maps < full.maps and quick.seeds < full.seeds
    ev = _load_evaluate()
    args = ev.parse_args(["--quick"])
    assert (args.maps, args.shifted_maps, args.scenarios, args.seeds) == (
        quick.maps, quick.shifted_maps, quick.scenarios, quick.seeds)
    assert (args.step, args.tolerance, args.max_iterations) == (full.step, full.tolerance, full.max_iterations)
    with pytest.raises(dataclasses.FrozenInstanceError):
        full.step = 2.0


def test_quick_run_tunes_on_the_full_runs_tuning_split():
    ev = _load_evaluate()
    quick, full = ev.parse_args(["--quick"]), ev.parse_args([])
    assert (quick.tuning_maps, quick.tuning_scenarios) == (full.tuning_maps, full.tuning_scenarios)
    assert quick.maps < full.maps  # it is still the quick form


def test_a_missing_or_bad_route_encoder_is_refused_before_any_run(tmp_path, capsys):
    ev = _load_evaluate()
    (tmp_path / "bad.pt").write_bytes(b"not a torch file")
    for path, needle in ((tmp_path / "missing.pt", "does not exist"), (tmp_path / "bad.pt", "bad.pt")):
        with pytest.raises(SystemExit) as exc:
            ev.parse_args(["--route", str(path)])
        assert exc.value.code == 2 and "--route" in (err := capsys.readouterr().err) and needle in err


def test_tuned_bias_beats_or_ties_uniform_on_real_tuning_maps():
    """The real tuning runs of the quick form, on narrow passages: the choice is not worse than uniform."""
    n_tune = _load_evaluate().parse_args(["--quick"]).tuning_maps
    qs = E.generated_queries(["narrow_passage"], 128, n_test=0, n_tune=n_tune)
    runs = E.run_all(E.tuning_tasks(qs, "RRT"), E.Protocol(), 1, progress=False)
    b = E.best_bias(runs)[("narrow_passage", "RRT")]

    def median(sampler):
        return np.median([r.iterations if r.solved else math.inf for r in runs if r.sampler == sampler])

    assert median(E.bias_sampler(b)) <= median("uniform")
    assert median(E.bias_sampler(b)) == min(median(E.bias_sampler(x)) for x in E.TUNING_BIASES)


# --- point 7c: files get normal permissions; titles are not clipped -----------------------------------

def test_runs_csv_has_umask_permissions(tmp_path):
    path = tmp_path / "out" / "runs.csv"
    write_runs_csv([_run("forest", "test", "uniform", 12)], path)
    assert stat.S_IMODE(path.stat().st_mode) == 0o666 & ~_umask()
    assert path.read_text().splitlines()[0].startswith("map,query,split,planner,sampler")
    assert [p.name for p in path.parent.iterdir()] == ["runs.csv"]


def _clipped(fig) -> list[str]:
    """What of ``fig`` is drawn (partly) outside it: the suptitle, axes titles, or an axes with its
    tick labels, axis labels and legend (``get_tightbbox`` counts only the ticks that are drawn)."""
    renderer = fig.canvas.get_renderer()
    box = fig.bbox
    items = [("suptitle", fig._suptitle)] if fig._suptitle is not None else []
    for i, ax in enumerate(fig.axes):
        items += [(f"axes {i} title {t.get_text()!r}", t) for t in (ax.title, ax._left_title, ax._right_title)
                  if t.get_text()]
        items.append((f"axes {i} with its labels and legend", ax))
    out = []
    for name, artist in items:
        e = artist.get_tightbbox(renderer) if artist in fig.axes else artist.get_window_extent(renderer)
        if e.x0 < box.x0 - 0.5 or e.x1 > box.x1 + 0.5 or e.y0 < box.y0 - 0.5 or e.y1 > box.y1 + 0.5:
            out.append(name)
    return out


def _plot_runs(families):
    runs = []
    for fam in families:
        for s, base in (("uniform", 2000), ("goal_bias=0.05", 1500), ("goal_bias=0.01", 1400), ("policy", 300),
                        ("expert (reference)", 60)):
            runs += [_run(fam, "test", s, base + 37 * i, query=f"q{i}") for i in range(8)]
    biases = {(f, "RRT"): 0.01 for f in families}
    return runs, E.summarize(runs, biases), biases


@pytest.mark.parametrize("families", [["narrow_passage"], ["MovingAI (all)", "bugtrap", "forest", "maze",
                                                             "narrow_passage", "rooms"]])
def test_plot_text_is_inside_the_figure_and_legend_off_the_bars(families):
    from matplotlib.patches import Rectangle

    runs, rows, biases = _plot_runs(families)
    for fig in (E.ecdf_figure(runs, biases), E.medians_figure(runs, rows, biases)):
        fig.canvas.draw()
        assert _clipped(fig) == []
        assert fig.get_suptitle() or all(ax.get_title() for ax in fig.axes)
    renderer = fig.canvas.get_renderer()  # the bar chart: a grid, each sampler named on the first column's axis
    ax = fig.axes[0]
    names = [t for t in ax.get_yticklabels() if t.get_text()]
    bars = [p for p in ax.patches if isinstance(p, Rectangle) and p.get_width() > 0]
    assert {t.get_text() for t in names} >= {"uniform", "policy", "expert"}
    assert bars and not any(t.get_window_extent(renderer).overlaps(b.get_window_extent(renderer))
                            for t in names for b in bars)
    groups = {"narrow_passage": 1, "MovingAI (all)": 2}[families[0]]  # generated, and MovingAI beside it
    assert len(fig.axes) == 2 * groups and any("time" in a.get_title() for a in fig.axes)
    width, height = fig.get_size_inches() * fig.dpi
    assert width / height < 3  # a grid a screen shows whole, not one long strip


# --- the main job end to end: every output present, normal permissions, OMPL logs Planner Arena reads --

def test_evaluate_writes_results_people_can_open(tmp_path, capsys):
    ev = _load_evaluate()
    out = tmp_path / "evaluation"
    (out / "ompl").mkdir(parents=True)
    (out / "ompl" / "stale.log").write_text("an earlier run's map set")
    rc = ev.main(["--families", "forest", "--size", "64", "--maps", "2", "--tuning-maps", "2", "--seeds", "1",
                  "--shifted-maps", "1", "--no-unseen", "--movingai-maps", "--other-planners", "none",
                  "--processes", "1", "--max-iterations", "3000", "--out", str(out)])
    assert rc == 0
    files = sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file())
    assert files == ["MANIFEST.json", "details.md", "ecdf-time.png", "ecdf.png", "map-sets.json", "medians.png",
                     "ompl/forest.log", "ompl/forest_shifted.log", "runs.csv", "summary.md"]
    mode = 0o666 & ~_umask()
    assert {p: stat.S_IMODE((out / p).stat().st_mode) for p in files} == dict.fromkeys(files, mode)
    conn = sqlite3.connect(":memory:")
    rows = runs_table(conn, read_benchmark_log((out / "ompl" / "forest.log").read_text(), conn))
    samplers = ["uniform", *(f"goal bias {b:g}" for b in E.GOAL_BIASES), "policy", E.FOLLOWER, E.ROUTE,
                E.LAZY_ROUTE, E.ROUTE_ABLATION, "expert (reference)", E.EXACT_ROUTE, E.CONSTANT]
    assert sorted({r["planner"] for r in rows}) == sorted(f"RRT {s}" for s in samplers)
    short = (out / "summary.md").read_text()  # the short table and the findings; every wide table in details.md
    assert "## At a glance" in short and "## Findings" in short and "(details.md)" in short
    glance = short.split("## At a glance")[1].split("## Findings")[0]
    assert "| sampler | generated | shifted | time per query | success |" in glance
    assert all(len(line.split("|")) == 7 for line in glance.splitlines() if line.startswith("|"))
    assert "route encoder needs" in short and "On the clock the fastest is" in short
    summary = (out / "details.md").read_text()
    assert "## The policy's batch, tuned" in summary and "Chosen: **" in summary
    clock = summary.split("## Time to solution at a glance")[1].split("\n## ")[0]
    assert "route encoder" in clock and " ms" in clock and clock.count("**") == 2 * 2  # the fastest of 2 sets
    assert "Loading a model is paid once" in clock and "route encoder " in clock.split("left out")[1]
    assert f"policy/{E.FOLLOWER}" in summary and f"{E.FOLLOWER}/lower_bound" in summary
    assert f"## Targets for the {E.ROUTE}" in summary and f"{E.ROUTE} / {E.ROUTE_ABLATION} <= 0.5" in summary
    assert len(rows) == 2 * len(samplers)  # the test split only: 2 maps x 1 seed per sampler
    csv_runs = [ln.split(",") for ln in (out / "runs.csv").read_text().splitlines()[1:]]
    test_its = sorted(int(r[7]) for r in csv_runs if r[2] == "test" and r[0] == "forest")
    assert sorted(r["iterations"] for r in rows) == test_its
    assert all(r["graph_states"] >= 1 and r["time"] > 0 for r in rows)
    assert conn.execute("SELECT runcount FROM experiments").fetchone()[0] == 2
    # the shifted maps have a log of their own, with every sampler (the baselines at the family's tuning)
    shifted = runs_table(conn, read_benchmark_log((out / "ompl" / "forest_shifted.log").read_text(), conn))
    assert sorted({r["planner"] for r in shifted}) == sorted(f"RRT {s}" for s in samplers)
    assert sorted(r["iterations"] for r in shifted) == sorted(
        int(r[7]) for r in csv_runs if r[0] == "forest (shifted)")
    # every run records its sampler as data: the spec builds the sampler its label names
    with (out / "runs.csv").open(newline="") as f:
        records = list(csv.DictReader(f))
    specs = {r["sampler"]: E.SamplerSpec.from_json(r["sampler_spec"]) for r in records if r["sampler"] != E.CONSTANT}
    assert all(E.sampler_label(spec) == label for label, spec in specs.items() if label != "policy")
    assert specs["policy"].name == "policy" and specs["policy"].param("batch") in E.POLICY_BATCHES
    assert {r["map"] for r in records if r["sampler"] == E.CONSTANT} == {"forest", "forest (shifted)"}
    # the exact cost-to-go reference at the route encoder's settings, on every map set's test queries
    assert specs[E.EXACT_ROUTE] == E.SamplerSpec.of("exact_route", step_size=4.0)
    assert {r["map"] for r in records if r["sampler"] == E.EXACT_ROUTE and r["split"] == "test"} == {
        "forest", "forest (shifted)"}
    # so the room to it, and the share learning closes, are shown for every map set
    room = summary[summary.index("## How much of the room"):summary.index("## Targets for carrying")]
    assert "| forest |" in room and "| forest (shifted) |" in room and "No exact reference ran" not in room
    assert "not measured (no exact reference ran)" not in summary


def _head(family, **kw):
    row = {"family": family, "policy_median": 40.0, "constant_median": 100.0, "policy/best_bias": 0.3,
           "policy/lower_bound": 3.0, "policy_success": 1.0, "constant_success": 1.0, "best_bias_success": 1.0,
           "policy_wall_ms": 1.0, "best_bias_wall_ms": 2.0}
    return {**row, **kw}


def test_target_check_counts_each_target_and_names_what_misses():
    head = [_head("forest"),
            _head("maze", policy_median=108.0, **{"policy/lower_bound": 10.8}),
            _head("rooms", policy_success=0.9),  # a ratio met with lower success does not count
            _head("32room_000", policy_success=0.0), _head(E.MOVINGAI_POOL, policy_wall_ms=3.0),
            _head("arena", policy_success=1.0)]
    rows, met, total = E.target_check(head, ["arena", "32room_000"])
    assert [r["map set"] for r in rows] == ["forest", "maze", "rooms", E.MOVINGAI_POOL]
    assert total == 4 + 4 + 4 + 4 and met == 4 + 2 + 2 + 2
    assert rows[1]["policy / constant <= 0.5"] == "1.08 no"
    assert rows[2]["policy / best bias <= 0.5"] == "0.30 no (success)"
    assert rows[3]["wall time / best bias's <= 1"] == "1.50 no"
    assert rows[3]["every map solved in >= 90%"] == "no: 32room_000 0.00"
    assert rows[3]["policy / lower bound <= 4"] == "" and list(rows[0]) == [
        "map set", "policy / constant <= 0.5", "policy / best bias <= 0.5", "policy / lower bound <= 4",
        "wall time / best bias's <= 1", "every map solved in >= 90%"]


def test_target_check_holds_the_expert_to_the_iteration_targets_only():
    expert = {"expert_median": 65.0, "expert/best_bias": 0.2, "expert/lower_bound": 1.5, "expert_success": 1.0}
    head = [_head("forest", **expert), _head("maze", **{**expert, "expert_median": 30.0}),
            _head("rooms"),  # no expert run there: not counted
            _head("arena", **{**expert, "expert_success": 0.8}), _head(E.MOVINGAI_POOL, **expert)]
    rows, met, total = E.target_check(head, ["arena", "den312d"], "expert")
    assert [r["map set"] for r in rows] == ["forest", "maze", E.MOVINGAI_POOL]
    assert list(rows[0]) == ["map set", "expert / constant <= 0.5", "expert / best bias <= 0.5",
                             "expert / lower bound <= 4", "every map solved in >= 90%"]  # no wall time
    assert rows[0]["expert / constant <= 0.5"] == "0.65 no" and rows[1]["expert / constant <= 0.5"] == "0.30 yes"
    assert rows[2]["every map solved in >= 90%"] == "no: arena 0.80"
    assert total == 3 + 3 + 3 and met == 2 + 3 + 1


def test_target_check_holds_a_learned_sampler_to_its_own_ablation():
    route = {"route_median": 50.0, "route/best_bias": 0.1, "route/lower_bound": 2.0, "route_success": 1.0,
             "route_wall_ms": 30.0, "ablation_median": 120.0, "ablation_success": 1.0}
    head = [_head("bugtrap", **route), _head("maze", **{**route, "ablation_median": 80.0, "ablation_success": 0.9})]
    rows, met, total = E.target_check(head, [], "route", "ablation")
    assert list(rows[0]) == ["map set", "route / ablation <= 0.5", "route / best bias <= 0.5",
                             "route / lower bound <= 4", "wall time / best bias's <= 1"]
    assert rows[0]["route / ablation <= 0.5"] == "0.42 yes" and rows[1]["route / ablation <= 0.5"] == "0.62 no"
    assert rows[0]["wall time / best bias's <= 1"] == "15.00 no"
    assert total == 4 + 4 and met == 3 + 2


def test_target_check_takes_a_single_movingai_map_for_the_set():
    head = [_head("forest"), _head("den312d", policy_success=0.8, constant_success=0.5, best_bias_success=0.5)]
    rows, met, total = E.target_check(head, ["den312d"])
    assert [r["map set"] for r in rows] == ["forest", "den312d"]
    assert rows[1]["every map solved in >= 90%"] == "no: den312d 0.80" and rows[1]["policy / lower bound <= 4"] == ""
    assert total == 4 + 4 and met == 4 + 3


@pytest.mark.experiments
def test_replication_queries_are_fresh_and_the_script_refuses_unknown_sets(movingai, capsys):
    script = load_script("experiments/replicate_sets")
    protocol = script.PROTOCOL
    shifted = script.fresh_queries("narrow_passage (shifted)", 5, None)
    used = {q.key for q in E.shifted_queries(["narrow_passage"], protocol.shifted_maps)}
    assert len(shifted) == 5 and all(q.shifted and q.split == "test" and q.key not in used for q in shifted)
    assert [q.size for q in shifted] == [SHIFTED_SIZES[(q.key - SHIFTED_SEED0) % len(SHIFTED_SIZES)] for q in shifted]
    own = script.fresh_queries("maze", 3, None)
    assert [q.key for q in own] == [TEST_SEED0 + protocol.maps + i for i in range(3)]
    fresh = script.fresh_queries("maze-32-32-2", 20, movingai)
    taken = {q.key for q in E.movingai_queries(str(movingai), ["maze-32-32-2"], protocol.scenarios,
                                               protocol.tuning_scenarios, protocol.tolerance)}
    half = len(E.protocol.scenarios(str(movingai), "maze-32-32-2", protocol.tolerance)) // 2
    keys = [q.key for q in fresh]
    assert len(set(keys)) == 20 and not set(keys) & taken and max(keys) < half
    with pytest.raises(script.InputError, match="--queries 1000"):
        script.fresh_queries("maze-32-32-2", 1000, movingai)
    assert script.main(["random-32-32-10", "--queries", "2", "--seeds", "1", "--processes", "1",
                        "--movingai", str(movingai)]) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| random-32-32-10 |")]
    assert len(rows) == 1 and "[" in rows[0]
    assert script.main(["no-such-set", "--movingai", str(movingai)]) == 2
    assert "no-such-set" in capsys.readouterr().err
    test = [q for q in E.movingai_queries(str(movingai), ["maze-32-32-2"], protocol.scenarios,
                                          protocol.tuning_scenarios, protocol.tolerance) if q.split == "test"]
    assert script.fresh_queries("maze-32-32-2", 1, movingai, evaluation=True) == test
    assert [q.key for q in script.fresh_queries("maze", 1, None, evaluation=True)] == \
        [TEST_SEED0 + i for i in range(protocol.maps)]


@pytest.mark.experiments
def test_replication_runs_the_next_seeds_and_the_ablation_against_itself(movingai, capsys, tmp_path):
    script = load_script("experiments/replicate_sets")
    out = tmp_path / "runs.csv"
    assert script.main(["random-32-32-10", "--evaluation-queries", "--first-seed", "4", "--seeds", "1", "--again",
                        "--processes", "1", "--movingai", str(movingai), "--csv", str(out)]) == 0
    text = capsys.readouterr().out
    assert "planner seeds 4 to 4" in text and "ablation again / ablation" in text
    rows = list(csv.DictReader(out.open()))
    assert {(r["sampler"], r["seed"]) for r in rows} == {("route ablation", "4"), ("route encoder", "4"),
                                                         ("exact_route", "4"), (script.ABLATION_AGAIN, "5")}
    assert len({r["query"] for r in rows}) == script.PROTOCOL.scenarios
    with pytest.raises(SystemExit) as stop:
        script.main(["random-32-32-10", "--first-seed", "-1"])
    assert stop.value.code == 2 and "--first-seed" in capsys.readouterr().err


def test_the_quick_run_tunes_on_the_full_runs_tuning_scenarios_and_tests_on_the_first_of_its_test_ones(movingai):
    """No MovingAI scenario is tuned on in one form of the comparison and tested in the other."""
    full, quick = E.Protocol(), E.Protocol().quick()
    maps = ["maze-32-32-2", "random-32-32-10"]
    picks = {}
    for name, pr in (("full", full), ("quick", quick)):
        qs = E.movingai_queries(str(movingai), maps, pr.scenarios, pr.tuning_scenarios, pr.tolerance)
        picks[name] = {split: [(q.family, q.key) for q in qs if q.split == split] for split in ("test", "tuning")}
    assert picks["quick"]["tuning"] == picks["full"]["tuning"]
    assert set(picks["quick"]["test"]) < set(picks["full"]["test"])
    assert not set(picks["full"]["test"]) & set(picks["quick"]["tuning"])
    for m in maps:
        full_test = [k for f, k in picks["full"]["test"] if f == m]
        assert [k for f, k in picks["quick"]["test"] if f == m] == full_test[:quick.scenarios]


def test_quick_keeps_the_other_planners_named_on_the_command_line():
    ev = _load_evaluate()
    assert ev.parse_args(["--quick"]).other_planners == []
    assert ev.parse_args([]).other_planners == ["RRTstar", "PRM"]
    assert ev.parse_args(["--quick", "--other-planners", "PRM"]).other_planners == ["PRM"]
    every = ev.parse_args(["--quick", "--other-planners", "all"]).other_planners
    assert "RRTConnect" in every and "LazyPRM" in every and "RRT" not in every
    assert ev.parse_args(["--other-planners", "none"]).other_planners == []  # the full run's RRT* and PRM left out


def test_other_planners_given_bare_means_every_planner_as_all_does(capsys):
    ev = _load_evaluate()
    every = [p for p in planner_names() if p != "RRT"]
    assert ev.parse_args(["--quick", "--other-planners"]).other_planners == every
    assert ev.parse_args(["--other-planners"]).other_planners == every
    assert ev.parse_args(["--quick", "--other-planners", "all"]).other_planners == every
    assert ev.parse_args(["--quick", "--other-planners", "PRM", "prm", "RRTstar"]).other_planners == ["PRM", "RRTstar"]
    # resolved without a parser: absent, the full run's (none with --quick); bare or all, every one; none, none
    assert ev.other_planners(None) == ev.OTHER_PLANNERS and ev.other_planners(None, quick=True) == []
    assert ev.other_planners([]) == ev.other_planners(["all", "PRM"]) == every
    assert ev.other_planners(["none"], quick=False) == []
    with pytest.raises(SystemExit) as exc:
        ev.parse_args(["--other-planners", "none", "PRM"])
    assert exc.value.code == 2
    assert "--other-planners: none takes no planner beside it" in capsys.readouterr().err


def test_rigid_mesh_runs_the_test_only_mesh_set_and_omplapps_problems_in_the_one_comparison(tmp_path, capsys,
                                                                                          monkeypatch):
    from planners.worlds.rigid_scenes import MeshSceneSet

    ev = _load_evaluate()
    monkeypatch.delenv("SAMPLERGYM_OMPLAPP_DIR", raising=False)
    args = ev.parse_args(["--rigid", "mesh", "--rigid-only", "--rigid-scenes", "1"])
    (part,) = args.parts
    assert isinstance(part.scenes, MeshSceneSet) and part.part == "test" and part.name == "6-DoF mesh scenes (test)"
    assert [q.family for q in part.scenes.queries("test")] == ["hatch", "elbow"]  # no OMPL.app folder: none of it
    for flags, message in ((["--rigid", "test", "--rigid-omplapp", str(tmp_path)], "go with --rigid mesh"),
                           (["--rigid-problems", "Easy"], "needs --rigid PART"),
                           (["--rigid", "mesh", "--rigid-omplapp", str(tmp_path)],
                            f"--rigid-omplapp {tmp_path}: no OMPL.app problems there")):
        with pytest.raises(SystemExit) as exc:
            ev.parse_args(flags)
        assert exc.value.code == 2 and message in capsys.readouterr().err


def test_printed_shows_every_other_planners_rows_and_which_planner_to_take():
    """What the command line prints ends with details.md's "Other planners" and summary.md's "Which planner"."""
    res = _results({"uniform": (900, 1000), "goal_bias=0.05": (800, 900), E.ROUTE: (50, 60),
                    E.ROUTE_ABLATION: (150, 200), E.EXACT_ROUTE: (45, 55)},
                   planners={("PRM", "uniform"): 300, ("PRM", E.OBSTACLE_BASED): 200, ("PRM", E.ROUTE): 90,
                             ("PRM", E.ROUTE_ABLATION): 150, ("PRM", E.EXACT_ROUTE): 80})
    text = report.printed(res, "out")
    others = text.split("Other planners on the test split")[1].split("Which planner and sampler")[0]
    assert report.markdown_table(report.other_planner_rows(res)) in others  # the very table details.md carries
    for sampler, its in (("uniform", 300), (E.OBSTACLE_BASED, 200), (E.ROUTE, 90), (E.ROUTE_ABLATION, 150),
                         (E.EXACT_ROUTE, 80)):
        assert f"| PRM | {sampler} | generated | 3 | {its} |" in others
    which = text.split("Which planner and sampler, per group")[1]
    assert report.markdown_table(report.which_planner(res)) in which
    assert "| generated | RRT + route encoder: 50" in which
    assert "numba's compiling" in text and "none in these runs." in text  # what the run times leave out
    assert text.index("Other planners") < text.index("summary: out/summary.md")
    alone = report.printed(_results({"uniform": (900, 1000), E.ROUTE: (50, 60)}))
    assert "Other planners" not in alone and "Which planner and sampler" not in alone
