"""Time to solution: the clock comparison's table, its targets, and the benchmark script end to end."""

from __future__ import annotations

import math

import pytest
from conftest import load_script

from learning.evaluation import clock as C
from planners.tools.benchmark import Run


def _run(map_set: str, method: str, ms: float, solved: bool = True, query: str = "q", seed: int = 0) -> Run:
    planners = {C.CONNECT: "RRTConnect", C.LAZY_CONNECT: "RRTConnect", C.PRM: "PRM", C.LAZY_PRM: "PRM"}
    planner = planners.get(method, "RRT")
    sampler = "OMPL" if method == C.OMPL_CONNECT else method
    return Run(map=map_set, query=query, split="test", planner=planner, sampler=sampler, seed=seed, solved=solved,
               iterations=10, lower_bound=5, candidates=10, collision_checks=10, wall_time=ms / 1e3,
               us_per_iteration=ms * 100, path_cost=1.0 if solved else math.inf, forward_passes=0, vertices=10)


def test_the_table_names_the_fastest_classical_option_and_judges_the_targets():
    times = {"open": {C.ROUTE: 1.1, C.LAZY: 0.95, C.ABLATION: 0.9, C.EXACT: 2.0, C.TUNED: 1.0, C.CONNECT: 3.0,
                      C.PRM: 4.0, C.OMPL_CONNECT: 5.0},
             "winding": {C.ROUTE: 6.0, C.LAZY: 4.0, C.ABLATION: 40.0, C.EXACT: 9.0, C.TUNED: 30.0, C.CONNECT: 12.0,
                         C.PRM: 20.0, C.OMPL_CONNECT: 50.0}}
    runs = [_run(m, k, v, query=f"{m}-{i}") for m, row in times.items() for k, v in row.items() for i in range(3)]
    rows, verdict = C.clock_table(runs, ["winding", "open"])
    assert [r["map set"] for r in rows] == ["winding", "open", C.POOLED]
    winding, open_, pooled = rows
    assert winding["fastest classical"].startswith(C.EXACT) and winding["route / fastest"] == "0.67"
    assert winding["target"].startswith("fails (<= 0.5")  # the fastest takes 9 ms: the route must halve it
    assert open_["fastest classical"].startswith(C.TUNED) and open_["target"] == "holds (<= 1.2)"
    assert open_[C.ROUTE] == "1.1 (100%)"
    assert verdict["held"] == 1 and verdict["sets"] == 2 and verdict["slow sets"] == 1 and verdict["slow held"] == 0
    assert pooled["route / OMPL RRT-Connect"] == f"{verdict['pooled / OMPL RRT-Connect']:.2f}"
    # the lazy route sampler is held to the same targets in its own columns
    assert winding["lazy route / fastest"] == "0.44" and winding["lazy target"].startswith("holds (<= 0.5")
    assert open_["lazy target"] == "holds (<= 1.2)"
    assert verdict["lazy held"] == 2 and verdict["lazy slow held"] == 1
    assert verdict["any held"] == 2 and verdict["none held"] == []  # by the best learned method per set
    assert pooled["lazy route / OMPL RRT-Connect"] == f"{verdict['lazy pooled / OMPL RRT-Connect']:.2f}"


def test_an_unsolved_run_never_solves_so_a_method_that_gives_up_fast_is_not_the_fastest():
    runs = [_run("m", C.ROUTE, 2.0), _run("m", C.ROUTE, 100.0, solved=False, seed=1), _run("m", C.TUNED, 1.0),
            _run("m", C.TUNED, 1.0, seed=1)]
    rows, verdict = C.clock_table(runs)
    assert rows[0][C.ROUTE] == "> 51 (50%)"  # half unsolved: the median time to solution is not reached
    assert verdict["any held"] == 0 and verdict["none held"] == ["m"]
    assert rows[0]["target"].startswith("fails")
    three = [_run("m", C.ROUTE, ms, solved=ms < 50, seed=i) for i, ms in enumerate((2.0, 3.0, 90.0))]
    assert C.solution_ms(three) == 3.0 and math.isinf(C.solution_ms(three[1:]))
    # every classical option gives up quickly, the route solves slowly: the route is the fastest to a solution
    runs = [_run("m", C.ROUTE, 30.0, seed=i) for i in range(3)] + [
        _run("m", k, 5.0 + i, solved=i == 0, seed=i) for k in (C.TUNED, C.CONNECT, C.PRM, C.EXACT) for i in range(3)]
    rows, verdict = C.clock_table(runs)
    row = rows[0]
    assert row["fastest classical"] == "none solves more than half" and row[C.TUNED] == "> 6 (33%)"
    assert row["target"].startswith("holds") and verdict["held"] == 1 and verdict["slow held"] == 1
    by_size = C.fastest_by_size(runs, {"q": 128})
    assert by_size[0]["fastest"] == C.ROUTE and by_size[0][f"{C.PRM} ms"] == "> 6 (33%)"


def test_the_fastest_by_map_size():
    runs = [_run("a", C.ROUTE, 3.0, query="small"), _run("a", C.PRM, 1.0, query="small"),
            _run("b", C.ROUTE, 30.0, query="big"), _run("b", C.PRM, 60.0, query="big")]
    rows = C.fastest_by_size(runs, {"small": 64, "big": 512})
    assert [(r["map side"], r["fastest"]) for r in rows] == [("up to 64", C.PRM), ("above 256", C.ROUTE)]


def test_the_clock_benchmark_times_every_method_on_the_same_queries(tmp_path, capsys):
    bench = load_script("benchmark_clock")
    out = tmp_path / "clock"
    assert bench.main(["--families", "forest", "--maps", "2", "--tuning-maps", "1", "--seeds", "1", "--no-shifted",
                       "--no-unseen", "--movingai-maps", "--no-ompl", "--processes", "1", "--out", str(out)]) == 0
    text = (out / "clock.md").read_text()
    for method in (C.ROUTE, C.LAZY, C.LAZY_CONNECT, C.LAZY_PRM, C.ABLATION, C.EXACT, C.TUNED, C.CONNECT, C.PRM):
        assert method in text
    lines = (out / "runs.csv").read_text().splitlines()
    assert len(lines) == 1 + 2 * 9  # two queries, one seed, nine methods
    assert "The fastest method by map size" in text and "| up to 128 |" in text
    assert "The best learned method per set: targets held on " in text and " of 1 sets" in text


@pytest.mark.parametrize("flags, named", [(["--maps", "0"], "--maps"), (["--route", "nowhere.pt"], "--route")])
def test_bad_flags_are_refused_before_any_work(tmp_path, capsys, flags, named):
    bench = load_script("benchmark_clock")
    with pytest.raises(SystemExit) as exc:
        bench.main([*flags, "--out", str(tmp_path / "o")])
    assert exc.value.code == 2 and named in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_the_timed_runs_pay_their_query_s_field_not_the_warm_up_s():
    # the untimed warm-up's field carries a process's first pass (tens of ms): a timed run must not be charged it
    from learning import evaluation as E
    from learning.models.shipped import SHIPPED_ROUTE

    protocol = E.Protocol()
    queries = E.generated_queries(["forest"], protocol.size, 1, 0)
    context = E.RunContext(protocol)
    tasks = [t for t in C.clock_tasks(queries, protocol, str(SHIPPED_ROUTE), {}, 2) if t.sampler_label == C.ROUTE]
    runs = C.run_clock(tasks, context)
    assert len(runs) == 2 and all(r.solved for r in runs)
    # the timed runs computed their query's field once (the first seed) and reused it once (the second)
    assert (context.fields.misses, context.fields.hits) == (1, 1)


def test_the_models_forget_their_encoders_kept_maps():
    from learning.samplers.registry import ModelCache

    class Keeps:
        forgot = 0

        def clear_map_cache(self):
            self.forgot += 1

    models = ModelCache()
    models.routes.update({"a": Keeps(), "b": object()})  # an encoder that keeps no maps has nothing to forget
    models.forget_maps()
    assert models.routes["a"].forgot == 1
