"""RRT*'s cost-order sort gives numba's ``np.argsort`` order exactly, ties included."""

from __future__ import annotations

import numba as nb
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from planners.kernels.rrtstar import SORT_STACK, argsort_into


@nb.njit
def _numba_argsort(a):
    return np.argsort(a)


@settings(max_examples=300, deadline=None)
@given(
    n=st.integers(0, 90),
    spread=st.sampled_from([1, 3, 20, 10**6]),  # few distinct values: many ties
    with_inf=st.booleans(),
    seed=st.integers(0, 2**31),
)
def test_matches_numba_argsort(n, spread, with_inf, seed):
    rng = np.random.default_rng(seed)
    a = rng.integers(0, spread, n).astype(np.float64) / 7.0
    if with_inf and n:
        a[rng.random(n) < 0.2] = np.inf
    padded = np.concatenate([a, rng.random(5)])  # only the first n entries count
    order = np.full(len(padded), -1, dtype=np.int64)
    argsort_into(padded, n, order, np.empty(2 * SORT_STACK, dtype=np.int64))
    np.testing.assert_array_equal(order[:n], _numba_argsort(a))


def test_sorted_and_reversed_runs():
    for a in (np.arange(200.0), np.arange(200.0)[::-1].copy(), np.zeros(200), np.tile([2.0, 1.0], 100)):
        order = np.empty(len(a), dtype=np.int64)
        argsort_into(a, len(a), order, np.empty(2 * SORT_STACK, dtype=np.int64))
        np.testing.assert_array_equal(order, _numba_argsort(a))
