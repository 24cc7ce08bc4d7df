"""The k-d forest against brute force, across dimensions, metrics, sizes and duplicates."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planners import NearestNeighbors

ORD = {"euclidean": 2, "manhattan": 1, "chebyshev": np.inf}


@settings(max_examples=50)  # numba compiles each dimension and metric it meets: most of this test's time
@given(
    dim=st.integers(1, 9),
    n=st.integers(0, 700),
    metric=st.sampled_from(sorted(ORD)),
    coarse=st.booleans(),
    seed=st.integers(0, 2**31),
)
def test_queries_match_brute_force(dim, n, metric, coarse, seed):
    rng = np.random.default_rng(seed)
    pts = rng.random((n, dim)) * 10
    if coarse:  # many exact ties and duplicates
        pts = np.round(pts)
    nn = NearestNeighbors(dim, metric, capacity=8)
    for chunk in np.array_split(pts, 3):
        if len(chunk):
            nn.add(chunk)
    assert len(nn) == n
    for q in rng.random((10, dim)) * 12 - 1:
        d = np.linalg.norm(pts - q, ord=ORD[metric], axis=1) if n else np.empty(0)
        i, dist = nn.nearest(q)
        if n == 0:
            assert i == -1 and dist == np.inf
            continue
        assert dist == pytest.approx(d.min(), abs=1e-9)
        assert d[i] == pytest.approx(d.min(), abs=1e-9)
        idx, dk = nn.nearest_k(q, 5)
        assert np.allclose(dk, np.sort(d)[:5])
        assert np.allclose(d[idx], dk)
        r = np.sort(d)[min(n - 1, 7)] + 1e-7
        assert np.array_equal(nn.nearest_r(q, r), np.flatnonzero(d <= r))


def test_bad_input():
    with pytest.raises(ValueError, match="metric"):
        NearestNeighbors(2, "cosine")
    nn = NearestNeighbors(2)
    with pytest.raises(ValueError, match="2 columns"):
        nn.add(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="finite"):
        nn.add([[0.0, np.nan]])
    with pytest.raises(ValueError, match=r"shape \(2,\)"):
        nn.nearest([1.0, 2.0, 3.0])


def test_points_view_is_read_only():
    nn = NearestNeighbors(2)
    nn.add([[1.0, 2.0], [3.0, 4.0]])
    assert nn.points.tolist() == [[1.0, 2.0], [3.0, 4.0]]
    with pytest.raises(ValueError):
        nn.points[0, 0] = 5.0


def test_nearest_many_matches_one_query_at_a_time():
    rng = np.random.default_rng(5)
    nn = NearestNeighbors(3)
    nn.add(rng.random((500, 3)))
    qs = rng.random((200, 3))
    assert nn.nearest_many(qs).tolist() == [nn.nearest(q)[0] for q in qs]
    with pytest.raises(ValueError, match=r"shape \(m, 3\)"):
        nn.nearest_many(qs[:, :2])
    assert NearestNeighbors(2).nearest_many(np.zeros((2, 2))).tolist() == [-1, -1]


def _build_depth_first(P, perm, split, box, lo, hi):
    """The k-d build as a depth-first walk with a stack, in Python: the reference for the level-by-level one."""
    from planners.datastructures import nn as index

    perm[lo:hi] = np.arange(lo, hi)
    dim = P.shape[1]
    todo = [(lo, hi)]
    while todo:
        a, b = todo.pop()
        if b - a <= index.LEAF:
            continue
        mid = (a + b) // 2
        spread = -1.0
        for d in range(dim):
            v = P[perm[a:b], d]
            box[mid, d], box[mid, dim + d] = v.min(), v.max()
            if v.max() - v.min() > spread:
                spread, split[mid] = v.max() - v.min(), d
        index._select.py_func(P, perm, a, b, mid, split[mid])
        todo += [(a, mid), (mid + 1, b)]


@given(dim=st.integers(1, 4), n=st.integers(1, 600), coarse=st.booleans(), seed=st.integers(0, 2**31))
def test_the_level_by_level_build_makes_the_depth_first_trees(dim, n, coarse, seed):
    rng = np.random.default_rng(seed)
    pts = rng.random((n, dim)) * 10
    if coarse:
        pts = np.round(pts)
    nn = NearestNeighbors(dim, capacity=8)
    nn.add(pts)
    perm = np.zeros_like(nn._perm)
    split = np.zeros_like(nn._split)
    box = np.zeros_like(nn._box)
    for k in range(1, n + 1):  # the builds insert makes as the points arrive
        perm[k - 1] = k - 1
        if k % 64 == 0:
            size = 64
            while (k // size) % 2 == 0:
                size *= 2
            _build_depth_first(nn._P, perm, split, box, k - size, k)
    assert np.array_equal(perm[:n], nn._perm[:n])
    assert np.array_equal(split[:n], nn._split[:n]) and np.array_equal(box[:n], nn._box[:n])


def test_a_compiled_only_function_refuses_python_and_runs_its_source_as_py_func():
    from planners.datastructures import nn as index

    P, perm, split, box = np.zeros((4, 2)), np.zeros(4, np.int64), np.zeros(4, np.int64), np.zeros((4, 4))
    with pytest.raises(NotImplementedError, match="compiled code only"):
        index.insert(P, perm, split, box, 0)
    assert index.insert.py_func(P, perm, split, box, 0) == 1 and perm[0] == 0


@pytest.mark.parametrize("dim, metric, coarse", [(2, "euclidean", False), (3, "manhattan", True),
                                                 (9, "euclidean", False), (6, "chebyshev", True)])
def test_a_large_index_with_its_leading_trees_merged_matches_brute_force(dim, metric, coarse):
    """Past ``BIG_FROM`` chunks the leading trees are one (rebuilt at 640, 768, 896 and 1,024 chunks here)."""
    from planners.datastructures.nn import BIG_FROM, CHUNK

    rng = np.random.default_rng(dim)
    n = 1100 * CHUNK + 37  # past four rebuilds of the large tree, with a forest and a tail after it
    assert n > 2 * BIG_FROM * CHUNK
    pts = rng.random((n, dim)) * 10
    if coarse:  # ties and duplicates
        pts = np.round(pts * 3)
    nn = NearestNeighbors(dim, metric, capacity=8)
    for chunk in np.array_split(pts, 5):
        nn.add(chunk)
    for q in rng.random((25, dim)) * 12 - 1:
        d = np.linalg.norm(pts - q, ord=ORD[metric], axis=1)
        i, dist = nn.nearest(q)
        assert dist == pytest.approx(d.min(), abs=1e-9) and d[i] == pytest.approx(d.min(), abs=1e-9)
        idx, dk = nn.nearest_k(q, 6)
        assert np.allclose(dk, np.sort(d)[:6]) and np.allclose(d[idx], dk)
        r = np.sort(d)[11] + 1e-7
        assert np.array_equal(nn.nearest_r(q, r), np.flatnonzero(d <= r))
