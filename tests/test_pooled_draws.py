"""``draw_pooled``: the pool side shared by the Gaussian, bridge-test and obstacle-based samplers, and its deadline.

A stand-in for a compiled sampler (``run``) makes a sample from an attempt whose first uniform is
below ``p``, so what it returns is known from the generator's stream alone.
"""

from __future__ import annotations

import numpy as np
import pytest

from planners.algorithms.obprm import ObstacleBasedSampler
from planners.base.samplers import (
    FIRST_SLICE_ATTEMPTS,
    BridgeTestSampler,
    DrawInterrupted,
    GaussianSampler,
    draw_pooled,
)
from planners.kernels.state import S_CHECKS, S_PENDING, S_POS
from planners.maps.generators import generate

PER = 3  # uniforms an attempt reads


def coin_run(p: float, calls: list[int] | None = None):
    """An attempt pool loop in Python: an attempt makes a sample (its uniforms) when its first is below ``p``."""

    def run(u, n, out, cand, state):
        if calls is not None:
            calls.append(len(u) // PER)
        pos, pending, m = int(state[S_POS]), int(state[S_PENDING]), 0
        while m < n and pos + PER <= len(u):
            a, pos, pending = pos, pos + PER, pending + 1
            state[S_CHECKS] += 1
            if u[a] < p:
                out[m] = u[a:a + PER]
                cand[m], pending, m = pending, 0, m + 1
        state[S_POS], state[S_PENDING] = pos, pending
        return m

    return run


def expected(seed: int, n: int, p: float) -> tuple[np.ndarray, np.ndarray]:
    """The first ``n`` samples of the stream, and the attempts behind each."""
    u = np.random.default_rng(seed).random(PER * 100_000).reshape(-1, PER)
    hits = np.flatnonzero(u[:, 0] < p)[:n]
    return u[hits], np.diff(np.concatenate([[-1], hits]))


def test_samples_follow_the_stream_whatever_the_pool_sizes():
    want, attempts = expected(3, 200, 0.05)
    for rate in (0.01, 1.0, 20.0, 500.0):  # pools far too small (many of them) to far too large
        calls = []
        got = draw_pooled(np.random.default_rng(3), 200, PER, PER, rate, coin_run(0.05, calls))
        np.testing.assert_array_equal(got.points, want)
        np.testing.assert_array_equal(got.candidates, attempts)
        assert got.count == 200 and got.pending == 0 and got.checks == attempts.sum()
        assert got.rate == 0.5 * rate + 0.5 * attempts.sum() / 200  # the estimate moves halfway to this draw's
        assert rate > 1 or len(calls) > 1  # small estimates: a sample's attempts span pools


def test_attempts_caps_the_pool_at_what_the_samples_wanted_can_use():
    calls = []
    draw_pooled(np.random.default_rng(0), 4, PER, PER, 1000.0, coin_run(1.0, calls), attempts=5)
    assert calls == [5 * 4]


def test_a_spent_budget_stops_the_draw_and_leaves_its_attempts_pending():
    calls = []
    got = draw_pooled(np.random.default_rng(0), 3, PER, PER, 4.0, coin_run(0.0, calls), budget=1000)
    assert got.count == 0 and got.pending == 1000 and sum(calls) == 1000
    assert got.rate == 4.0  # no sample: nothing to learn the rate from
    # attempts after the last sample are charged to it
    got = draw_pooled(np.random.default_rng(0), 10, PER, PER, 4.0, coin_run(0.001, calls), budget=700)
    assert 0 < got.count < 10 and got.pending > 0
    assert got.candidates[:got.count].sum() == 700


def test_a_deadline_slices_the_pools_without_changing_the_samples():
    for rate in (0.5, 4.0, 200.0):
        plain = np.random.default_rng(5)
        want = draw_pooled(plain, 150, PER, PER, rate, coin_run(0.05))
        calls = []
        rng = np.random.default_rng(5)
        got = draw_pooled(rng, 150, PER, PER, rate, coin_run(0.05, calls), deadline=lambda: False)
        np.testing.assert_array_equal(got.points, want.points)
        np.testing.assert_array_equal(got.candidates, want.candidates)
        assert (got.count, got.pending, got.checks, got.rate) == (want.count, want.pending, want.checks, want.rate)
        assert rng.random() == plain.random()  # the generator is left where the plain draw leaves it
        assert calls[0] == FIRST_SLICE_ATTEMPTS  # the first slice is small, whatever the pool


def test_a_passed_deadline_interrupts_the_draw():
    asked = []

    def deadline():
        asked.append(1)
        return len(asked) > 3  # past from the fourth slice on

    with pytest.raises(DrawInterrupted):
        draw_pooled(np.random.default_rng(0), 10_000, PER, PER, 4.0, coin_run(0.05), deadline=deadline)
    assert len(asked) == 4


@pytest.mark.parametrize("make", [ObstacleBasedSampler, GaussianSampler, BridgeTestSampler])
def test_the_compiled_samplers_draw_the_same_under_a_deadline_that_does_not_pass(make):
    problem = generate("forest", seed=3, size=64)
    plain, timed = make().bind(problem), make().bind(problem)
    timed.set_deadline(float("inf"), lambda: 0.0)
    rng_a, rng_b = np.random.default_rng(11), np.random.default_rng(11)
    for n in (64, 128, 256):
        a, b = plain.draw(rng_a, n, None), timed.draw(rng_b, n, None)
        np.testing.assert_array_equal(a.points, b.points)
        np.testing.assert_array_equal(a.candidates, b.candidates)
    assert plain.checks == timed.checks > 0
    assert rng_a.random() == rng_b.random()


def test_a_sampler_past_its_deadline_stops_its_draw():
    problem = generate("forest", seed=3, size=64)
    s = ObstacleBasedSampler().bind(problem)
    s.set_deadline(1.0, lambda: 2.0)
    assert s.past_deadline()
    with pytest.raises(DrawInterrupted):
        s.draw(np.random.default_rng(0), 64, None)
    s.set_deadline(None)
    assert not s.past_deadline() and len(s.draw(np.random.default_rng(0), 64, None).points) == 64
