"""The roadmap's shortest-path search: A* with a heuristic carried from one search to the next (Adaptive A*)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from planners.kernels import state as slots
from planners.kernels.prm import astar_csr, build_csr
from planners.kernels.space import METRIC_L2, SPACE_RN, make_space


def random_roadmap(rng: np.random.Generator, n: int, k: int):
    """``n`` random points of the unit square, each joined to its ``k`` nearest: points and edge arrays."""
    X = rng.random((n, 2))
    d = np.linalg.norm(X[:, None] - X[None], axis=2)
    pairs = {tuple(sorted((i, int(j)))) for i in range(n) for j in np.argsort(d[i])[1:k + 1]}
    eu = np.array([a for a, _ in sorted(pairs)], dtype=np.int64)
    ev = np.array([b for _, b in sorted(pairs)], dtype=np.int64)
    return X, eu, ev, d[eu, ev].copy()


def path_length(ew, eds) -> float:
    return float(ew[eds].sum()) if len(eds) else np.inf


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 60), k=st.integers(1, 6), rounds=st.integers(1, 12))
def test_searches_that_carry_their_heuristic_find_the_shortest_paths_as_edges_and_vertices_drop(seed, n, k, rounds):
    rng = np.random.default_rng(seed)
    X, eu, ev, ew = random_roadmap(rng, n, k)
    es = np.full(len(eu), slots.EDGE_UNKNOWN, dtype=np.int8)
    vstat = np.full(n, slots.V_UNKNOWN, dtype=np.int8)
    csr = build_csr((eu, ev), n, len(eu))
    space = make_space(SPACE_RN, METRIC_L2, 1.0)
    src, dst = 0, n - 1
    h = np.full(n, -1.0)  # carried over every search, as Lazy-PRM's checks between them drop what fails
    for _ in range(rounds):
        verts, eds = astar_csr(X, csr, ew, es, vstat, src, dst, space, np.bool_(False), np.bool_(True), h)
        fresh = astar_csr(X, csr, ew, es, vstat, src, dst, space, np.bool_(False), np.bool_(False), np.full(n, -1.0))
        assert len(verts) == len(fresh[0])  # a path exactly where Dijkstra's search from scratch finds one
        if not len(verts):
            break
        assert np.isclose(path_length(ew, eds), path_length(ew, fresh[1]), rtol=1e-12)
        assert verts[0] == src and verts[-1] == dst
        assert all(es[e] != slots.EDGE_INVALID for e in eds) and all(vstat[v] != slots.V_INVALID for v in verts)
        assert all({int(eu[e]), int(ev[e])} == {int(a), int(b)} for e, a, b in
                   zip(eds, verts[:-1], verts[1:], strict=True))
        # the heuristic stays a lower bound on the distance to the goal (what keeps the search exact): at most what
        # is left of the shortest path from each of its vertices
        assert h[dst] == 0.0 and np.all(h[verts] <= np.cumsum(np.r_[ew[eds][::-1], 0.0])[::-1] + 1e-9)
        # the checks drop some of the path: an edge, and sometimes an inner vertex
        es[eds[rng.integers(len(eds))]] = slots.EDGE_INVALID
        if len(verts) > 2 and rng.random() < 0.3:
            vstat[verts[rng.integers(1, len(verts) - 1)]] = slots.V_INVALID
