"""The route encoder's fields computed once per query: ``FieldCache``, ``RouteSampler(fields=...)`` and the runner."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import learning.evaluation as E
from learning.models.field import FieldEncoder
from learning.models.route_net import RouteNet, load_route_net
from learning.models.route_vin import RouteVIN
from learning.samplers.route import SHIPPED, FieldCache, RouteSampler, shipped_sampler
from planners import RRT
from planners.base.fileio import InputError
from planners.maps.generators import TEST_SEED0, generate


@pytest.fixture(scope="module")
def net() -> RouteNet:
    return load_route_net(SHIPPED)


def _count_passes(monkeypatch) -> list[int]:
    """Patch ``FieldEncoder.predict_many`` and ``predict_reaching`` (every encoder's; ``RouteVIN``'s one pass) to
    record how many queries each call computes (a ``predict_many`` inside a ``predict_reaching`` counted once).
    """
    calls: list[int] = []
    many, reaching, vin_reaching = FieldEncoder.predict_many, FieldEncoder.predict_reaching, RouteVIN.predict_reaching
    inside = []

    def counted(self, queries, *args, **kwargs):
        if not inside:
            calls.append(len(queries))
        return many(self, queries, *args, **kwargs)

    def counted_reaching(original):
        def call(self, *args, **kwargs):
            if not inside:
                calls.append(1)
            inside.append(1)
            try:
                return original(self, *args, **kwargs)
            finally:
                inside.pop()
        return call

    monkeypatch.setattr(FieldEncoder, "predict_many", counted)
    monkeypatch.setattr(FieldEncoder, "predict_reaching", counted_reaching(reaching))
    monkeypatch.setattr(RouteVIN, "predict_reaching", counted_reaching(vin_reaching))
    return calls


def _problems(n: int = 2, size: int = 64):
    return [generate(f, TEST_SEED0 + 3 + i, size) for i, f in zip(range(n), ("bugtrap", "rooms", "maze"), strict=False)]


def test_the_cache_gives_predicts_field_and_runs_the_encoder_once_per_query(net, monkeypatch):
    p = _problems(1)[0]
    obs, goal = p.world.obstacles, p.world.cell_of(p.goal)
    expected = net.predict(obs, goal, 8)
    calls = _count_passes(monkeypatch)
    cache = FieldCache()
    first = cache.get(net, obs, goal, 8)
    assert not first.reused and first.seconds > 0
    first.field[:] = -1.0  # a copy: changing it leaves the kept field alone
    second = cache.get(net, obs.copy(), goal, 8)  # the same map in another array is the same query
    assert np.array_equal(second.field, expected) and calls == [1] and (cache.hits, cache.misses) == (1, 1)
    assert second.reused and second.seconds == first.seconds  # the passes it took, for whoever reuses it
    assert cache.has(net, obs, goal, 8) and not cache.has(net, obs, (goal[0] + 4, goal[1]), 8)
    assert not cache.has(net, obs, goal, 1)
    cache.get(net, obs, goal, 1)
    other = obs.copy()
    other[0, 0] = not other[0, 0]
    cache.get(net, other, goal, 8)
    assert calls == [1, 1, 1] and len(cache) == 3


def test_the_cache_keeps_at_most_its_bytes_least_recently_used_first_and_travels_empty(net):
    a, b = _problems(2)
    one = a.world.obstacles.size * 8
    cache = FieldCache(max_bytes=one)
    cache.get(net, a.world.obstacles, a.world.cell_of(a.goal), 1)
    cache.get(net, b.world.obstacles, b.world.cell_of(b.goal), 1)
    assert len(cache) == 1 and cache.bytes == one and cache.has(net, b.world.obstacles, b.world.cell_of(b.goal), 1)
    tiny = FieldCache(max_bytes=one - 1)  # a field larger than the cache is returned, not kept
    assert np.array_equal(tiny.get(net, a.world.obstacles, a.world.cell_of(a.goal), 1).field,
                          net.predict(a.world.obstacles, a.world.cell_of(a.goal), 1)) and len(tiny) == 0
    copy = pickle.loads(pickle.dumps(cache))
    assert len(copy) == 0 and copy.bytes == 0 and copy.max_bytes == one
    for bad in (-1, 1.5, True, "1"):
        with pytest.raises(InputError, match="max_bytes"):
            FieldCache(max_bytes=bad)


def test_a_second_bind_of_the_same_query_takes_the_kept_field_and_plans_the_same_runs(net, monkeypatch):
    p = _problems(1)[0]
    plain = [RRT(p, step_size=4.0, sampler=shipped_sampler(net, device="cpu"), seed=s).solve(max_iterations=20000)
             for s in (0, 1, 0)]
    calls = _count_passes(monkeypatch)
    sampler = RouteSampler(net, device="cpu", fields=FieldCache(), stuck=1, tau=0.5, lookahead=3.0, sigma=0.5)
    cached = []
    for s in (0, 1, 0):  # each bind is a copy of the sampler sharing its cache
        planner = RRT(p, step_size=4.0, sampler=sampler, seed=s)
        cached.append(planner.solve(max_iterations=20000))
        assert planner.sampler.forward_passes == net.symmetries  # the passes the query's field takes, kept or not
        assert (planner.sampler.reused_seconds > 0) == (len(cached) > 1)  # its time, charged to later runs
    assert calls == [1]
    assert [r.iterations for r in cached] == [r.iterations for r in plain]
    assert all(np.array_equal(a.path, b.path) for a, b in zip(cached, plain, strict=True))


def test_fields_filled_ahead_in_one_batch_match_one_query_at_a_time(net, monkeypatch):
    problems = _problems(3)
    calls = _count_passes(monkeypatch)
    one_by_one = RouteSampler(net, device="cpu", fields=FieldCache())
    assert one_by_one.prefill(problems) == 3 and calls == [1, 1, 1]  # the CPU's default: one query at a time
    batched = RouteSampler(net, device="cpu", fields=FieldCache())
    assert batched.prefill(problems, batch=True) == 3 and calls[3:] == [3]
    assert batched.prefill(problems, batch=True) == 0 and len(calls) == 4  # nothing left to compute
    for p in problems:
        assert batched.has_field(p)
        obs, goal = p.world.obstacles, p.world.cell_of(p.goal)
        exact = net.predict(obs, goal, 8)
        assert np.array_equal(one_by_one.fields.get(net, obs, goal, 8).field, exact)
        np.testing.assert_allclose(batched.fields.get(net, obs, goal, 8).field, exact, rtol=1e-6, atol=1e-6)
    its = [[RRT(p, step_size=4.0, sampler=s, seed=2).solve(max_iterations=20000).iterations for p in problems[:2]]
           for s in (batched, shipped_sampler(net, device="cpu"))]
    assert its[0] == its[1]
    with pytest.raises(InputError, match="fields cache"):
        RouteSampler(net).prefill(problems)
    assert not RouteSampler(None).has_field(problems[0])
    monkeypatch.setenv("SAMPLERGYM_MAX_ROUTE_BLOCKS", "16")  # a map the encoder refuses has no field, and is skipped
    refusing = RouteSampler(net, device="cpu", fields=FieldCache())
    assert not refusing.has_field(problems[0]) and refusing.prefill(problems) == 0


@pytest.mark.parametrize("batch", [None, True])
def test_the_runner_runs_the_encoder_once_per_query_across_seeds(monkeypatch, batch):
    queries = E.generated_queries(["bugtrap"], 64, 2, 0)
    spec = E.SamplerSpec.of("route", path=str(SHIPPED), device="cpu")
    tasks = [E.Task(q, "RRT", spec, seed) for q in queries for seed in range(3)]
    fresh = [E.run_one(t, E.RunContext(E.Protocol(max_iterations=3000))) for t in tasks]
    calls = _count_passes(monkeypatch)
    context = E.shared_context(tasks, E.RunContext(E.Protocol(max_iterations=3000), batch_fields=batch))
    assert context.route_queries == {spec: tuple(queries)}
    runs = [E.run_one(t, context) for t in tasks]
    # CPU default: one pass batch per query; batched (as on a GPU): both queries' fields at the first run
    assert calls == ([2] if batch else [1, 1]) and len(context.fields) == 2
    assert [r.iterations for r in runs] == [r.iterations for r in fresh]
    assert [r.forward_passes for r in runs] == [load_route_net(SHIPPED).symmetries] * len(tasks)
    # every run's wall time includes its query's field, computed in the run or before it
    net = context.models.route_net(str(SHIPPED))
    for q, three in zip(queries, (runs[:3], runs[3:]), strict=True):
        p = context.protocol.problem(q, context.scenarios)
        kept = context.fields.get(net, p.world.obstacles, p.world.cell_of(p.goal), net.symmetries,
                                  start_cell=p.world.cell_of(p.start))
        assert kept.reused and all(r.wall_time >= kept.seconds for r in three)
    assert len(pickle.loads(pickle.dumps(context)).fields) == 0  # each worker fills its own


def test_a_field_s_seconds_leave_numba_s_compiling_out(net, monkeypatch):
    import time

    import planners.base.planner as planner  # the clock that work_clock reads, patched

    p = _problems(1)[0]
    FieldCache().get(net, p.world.obstacles, p.world.cell_of(p.goal), 1)  # its kernels compiled, for real, first
    compiled = [0.0]  # what numba has compiled so far, as the patched clock reads it
    monkeypatch.setattr(planner, "compile_seconds", lambda: compiled[0])
    real = net.predict

    def first_call(*args, **kwargs):  # a kernel's first call: 0.2 s of compiling, then the pass
        time.sleep(0.2)
        compiled[0] += 0.2
        return real(*args, **kwargs)

    monkeypatch.setattr(net, "predict", first_call)
    out = FieldCache().get(net, p.world.obstacles, p.world.cell_of(p.goal), 1)
    assert not out.reused and 0 < out.seconds < 0.15


def test_a_run_s_time_leaves_numba_s_compiling_out_and_records_it(monkeypatch):
    import time

    from learning.evaluation import runner

    ticks = iter([0.0, 0.2])

    def compile_seconds():  # 0.2 s of compiling during the run (slept at its end, so the run's clock sees it)
        t = next(ticks)
        if t:
            time.sleep(t)
        return t

    q = E.generated_queries(["forest"], 64, 1, 0)[0]
    task, context = E.Task(q, "RRT", E.SamplerSpec.of("uniform"), 0), E.RunContext(E.Protocol())
    E.run_one(task, context)  # its kernels compiled, for real, first
    monkeypatch.setattr(runner, "compile_seconds", compile_seconds)
    run = E.run_one(task, context)
    assert run.solved and run.compile_time == pytest.approx(0.2) and 0 < run.wall_time < 0.15
