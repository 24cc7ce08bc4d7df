"""Compiled nearest-neighbour index: a forest of static k-d trees (Bentley-Saxe logarithmic method).

Why this structure: an incremental k-d tree degenerates when points arrive in spatial order (an RRT
growing down a corridor inserts them almost sorted), and a uniform bucket grid scans empty cells when
the tree is small and the query far away. Here points are kept in insertion order; the first
``CHUNK * (n // CHUNK)`` of them are covered by balanced k-d trees over contiguous index ranges whose
sizes are the binary digits of ``n // CHUNK`` (times ``CHUNK``), and the last ``n % CHUNK`` form a
tail that is scanned directly. Inserting is amortised O(log^2 n), a query O(log^2 n), in any
dimension and for the L1, L2 and L-infinity metrics.

The level layout is a pure function of ``n``, so the index state is just ``points[:n]``, ``perm`` and
``split``: ``perm[a:b]`` stores the implicit tree of range ``[a, b)`` (the median of every sub-range
sits at its middle position) and ``split[mid]`` the dimension that node splits on.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from planners.kernels.space import METRIC_L1, METRIC_L2, METRIC_LINF

CHUNK = 64
LEAF = 16
STACK = 256


@nb.njit(cache=True, inline="always")
def rdist(metric, a, b):
    """Reduced distance: squared for L2, plain for L1 and L-infinity."""
    s = 0.0
    if metric == METRIC_L2:
        for i in range(a.shape[0]):
            d = a[i] - b[i]
            s += d * d
    elif metric == METRIC_L1:
        for i in range(a.shape[0]):
            s += abs(a[i] - b[i])
    else:
        for i in range(a.shape[0]):
            d = abs(a[i] - b[i])
            if d > s:
                s = d
    return s


@nb.njit(cache=True, inline="always")
def to_reduced(metric, d):
    """A distance in the units the index compares (squared for L2, which saves the square roots)."""
    return d * d if metric == METRIC_L2 else d


@nb.njit(cache=True, inline="always")
def from_reduced(metric, r):
    """The distance back from ``to_reduced``'s units."""
    return np.sqrt(r) if metric == METRIC_L2 else r


@nb.njit(cache=True, inline="always")
def box_rdist(metric, q, box, i):
    """Reduced distance from ``q`` to the bounding box stored at position ``i``."""
    dim = q.shape[0]
    s = 0.0
    for d in range(dim):
        v = q[d]
        lo = box[i, d]
        hi = box[i, dim + d]
        e = lo - v if v < lo else (v - hi if v > hi else 0.0)
        if metric == METRIC_L2:
            s += e * e
        elif metric == METRIC_L1:
            s += e
        elif e > s:
            s = e
    return s


@nb.njit(cache=True, inline="always")
def child_bound(metric, q, box, a, b, plane, parent):
    """Lower bound for subtree [a, b): its box distance if it has one, else the split-plane bound."""
    if b - a > LEAF:
        return box_rdist(metric, q, box, (a + b) // 2)
    return plane if plane > parent else parent


@nb.njit(cache=True)
def _select(P, perm, lo, hi, k, sd):
    """Reorder perm[lo:hi] so perm[k] holds the k-th smallest P[., sd], smaller left, larger right."""
    left = lo
    right = hi - 1
    while left < right:
        m = (left + right) // 2
        a = P[perm[left], sd]
        b = P[perm[m], sd]
        c = P[perm[right], sd]
        if a > b:
            a, b = b, a
        if b > c:
            b = c
        pivot = a if a > b else b
        i = left
        j = right
        while i <= j:
            while P[perm[i], sd] < pivot:
                i += 1
            while P[perm[j], sd] > pivot:
                j -= 1
            if i <= j:
                t = perm[i]
                perm[i] = perm[j]
                perm[j] = t
                i += 1
                j -= 1
        if k <= j:
            right = j
        elif k >= i:
            left = i
        else:
            break


@nb.njit(cache=True)
def build(P, perm, split, box, lo, hi):
    """Build the implicit k-d tree of points [lo, hi); ``box[mid]`` gets each subtree's bounds."""
    for i in range(lo, hi):
        perm[i] = i
    dim = P.shape[1]
    st = np.empty(2 * STACK, dtype=np.int64)
    sp = 0
    st[0] = lo
    st[1] = hi
    sp = 1
    while sp > 0:
        sp -= 1
        a = st[2 * sp]
        b = st[2 * sp + 1]
        if b - a <= LEAF:
            continue
        best_sd = 0
        best_spread = -1.0
        for d in range(dim):
            mn = np.inf
            mx = -np.inf
            for i in range(a, b):
                v = P[perm[i], d]
                if v < mn:
                    mn = v
                if v > mx:
                    mx = v
            box[(a + b) // 2, d] = mn
            box[(a + b) // 2, dim + d] = mx
            if mx - mn > best_spread:
                best_spread = mx - mn
                best_sd = d
        mid = (a + b) // 2
        _select(P, perm, a, b, mid, best_sd)
        split[mid] = best_sd
        st[2 * sp] = a
        st[2 * sp + 1] = mid
        sp += 1
        st[2 * sp] = mid + 1
        st[2 * sp + 1] = b
        sp += 1


@nb.njit(cache=True)
def insert(P, perm, split, box, n):
    """Index point ``n`` (already written to ``P[n]``); returns the new count ``n + 1``."""
    perm[n] = n
    n += 1
    if n % CHUNK == 0:
        m = n // CHUNK
        size = CHUNK
        while m % 2 == 0:
            m //= 2
            size *= 2
        build(P, perm, split, box, n - size, n)
    return n


@nb.njit(cache=True, inline="always")
def _heap_push(hd, hi, cnt, k, d, idx):
    """Bounded max-heap of (reduced distance, index) with at most k entries; returns the count."""
    if cnt < k:
        i = cnt
        cnt += 1
        while i > 0:
            p = (i - 1) // 2
            if hd[p] >= d:
                break
            hd[i] = hd[p]
            hi[i] = hi[p]
            i = p
        hd[i] = d
        hi[i] = idx
        return cnt
    if d >= hd[0]:
        return cnt
    i = 0
    while True:
        c = 2 * i + 1
        if c >= cnt:
            break
        if c + 1 < cnt and hd[c + 1] > hd[c]:
            c += 1
        if hd[c] <= d:
            break
        hd[i] = hd[c]
        hi[i] = hi[c]
        i = c
    hd[i] = d
    hi[i] = idx
    return cnt


MODE_NEAREST = 0
MODE_KNN = 1
MODE_RADIUS = 2


@nb.njit(cache=True, inline="always")
def _offer(mode, d, idx, hd, hi, cnt, k, r):
    """Record candidate ``idx`` at reduced distance ``d``; returns the updated count."""
    if mode == MODE_NEAREST:
        if d < hd[0]:
            hd[0] = d
            hi[0] = idx
            return 1
        return cnt
    if mode == MODE_KNN:
        return _heap_push(hd, hi, cnt, k, d, idx)
    if d <= r:
        hi[cnt] = idx
        cnt += 1
    return cnt


@nb.njit(cache=True, inline="always")
def _prune_at(mode, hd, cnt, k, r):
    """Bounds strictly above this (radius: above r) cannot contribute."""
    if mode == MODE_NEAREST:
        return hd[0]
    if mode == MODE_KNN:
        return hd[0] if cnt == k else np.inf
    return r


@nb.njit(cache=True, inline="always")
def query(P, perm, split, box, n, q, metric, mode, k, r, hd, hi, st, sb):
    """One traversal serving all three queries over the first ``n`` points.

    ``mode`` is MODE_NEAREST (result in ``hd[0], hi[0]``; ``hd[0]`` must start at +inf; used only by
    tests to cross-check ``nearest_into``), MODE_KNN
    (bounded max-heap of ``k`` in ``hd, hi``) or MODE_RADIUS (indices within reduced radius ``r``
    appended to ``hi``). Returns the number of results held. ``st`` / ``sb`` are scratch stacks of
    sizes ``2 * STACK`` and ``STACK``.
    """
    cnt = 0
    full = (n // CHUNK) * CHUNK
    for i in range(full, n):
        cnt = _offer(mode, rdist(metric, q, P[i]), i, hd, hi, cnt, k, r)
    m = n // CHUNK
    start = 0
    bit = 62
    while bit >= 0:
        if (m >> bit) & 1:
            size = CHUNK << bit
            st[0] = start
            st[1] = start + size
            sb[0] = box_rdist(metric, q, box, start + size // 2)
            sp = 1
            while sp > 0:
                sp -= 1
                a = st[2 * sp]
                b = st[2 * sp + 1]
                bound = sb[sp]
                lim = _prune_at(mode, hd, cnt, k, r)
                if bound > lim or (mode != MODE_RADIUS and bound == lim):
                    continue
                if b - a <= LEAF:
                    for i in range(a, b):
                        idx = perm[i]
                        cnt = _offer(mode, rdist(metric, q, P[idx]), idx, hd, hi, cnt, k, r)
                    continue
                mid = (a + b) // 2
                idx = perm[mid]
                cnt = _offer(mode, rdist(metric, q, P[idx]), idx, hd, hi, cnt, k, r)
                sd = split[mid]
                diff = q[sd] - P[idx, sd]
                plane = diff * diff if metric == METRIC_L2 else abs(diff)
                lb = child_bound(metric, q, box, a, mid, plane if diff > 0.0 else 0.0, bound)
                rb = child_bound(metric, q, box, mid + 1, b, plane if diff < 0.0 else 0.0, bound)
                # push the farther child first so the nearer one is searched first; on a tie
                # (equal bounds) the side of the splitting plane that holds q is the nearer one
                if lb < rb or (lb == rb and diff < 0.0):
                    st[2 * sp] = mid + 1
                    st[2 * sp + 1] = b
                    sb[sp] = rb
                    sp += 1
                    st[2 * sp] = a
                    st[2 * sp + 1] = mid
                    sb[sp] = lb
                    sp += 1
                else:
                    st[2 * sp] = a
                    st[2 * sp + 1] = mid
                    sb[sp] = lb
                    sp += 1
                    st[2 * sp] = mid + 1
                    st[2 * sp + 1] = b
                    sb[sp] = rb
                    sp += 1
            start += size
        bit -= 1
    return cnt


@nb.njit(cache=True, inline="always")
def _nearest_impl(P, perm, split, box, n, q, metric, st, sb):
    best = np.inf
    bi = -1
    full = (n // CHUNK) * CHUNK
    for i in range(full, n):
        d = rdist(metric, q, P[i])
        if d < best:
            best = d
            bi = i
    m = n // CHUNK
    start = 0
    bit = 62
    while bit >= 0:
        if (m >> bit) & 1:
            size = CHUNK << bit
            st[0] = start
            st[1] = start + size
            sb[0] = box_rdist(metric, q, box, start + size // 2)
            sp = 1
            while sp > 0:
                sp -= 1
                bound = sb[sp]
                if bound >= best:
                    continue
                a = st[2 * sp]
                b = st[2 * sp + 1]
                if b - a <= LEAF:
                    for i in range(a, b):
                        idx = perm[i]
                        d = rdist(metric, q, P[idx])
                        if d < best:
                            best = d
                            bi = idx
                    continue
                mid = (a + b) // 2
                idx = perm[mid]
                d = rdist(metric, q, P[idx])
                if d < best:
                    best = d
                    bi = idx
                sd = split[mid]
                diff = q[sd] - P[idx, sd]
                plane = diff * diff if metric == METRIC_L2 else abs(diff)
                lb = child_bound(metric, q, box, a, mid, plane if diff > 0.0 else 0.0, bound)
                rb = child_bound(metric, q, box, mid + 1, b, plane if diff < 0.0 else 0.0, bound)
                if lb < rb or (lb == rb and diff < 0.0):
                    if rb < best:
                        st[2 * sp] = mid + 1
                        st[2 * sp + 1] = b
                        sb[sp] = rb
                        sp += 1
                    if lb < best:
                        st[2 * sp] = a
                        st[2 * sp + 1] = mid
                        sb[sp] = lb
                        sp += 1
                else:
                    if lb < best:
                        st[2 * sp] = a
                        st[2 * sp + 1] = mid
                        sb[sp] = lb
                        sp += 1
                    if rb < best:
                        st[2 * sp] = mid + 1
                        st[2 * sp + 1] = b
                        sb[sp] = rb
                        sp += 1
            start += size
        bit -= 1
    return bi, best


@nb.njit(cache=True)
def nearest_into(P, perm, split, box, n, q, metric, st, sb):
    """(index, reduced distance) of the nearest of the first ``n`` points; (-1, inf) if n == 0.

    The planners' hot path: a dedicated traversal with the best distance held in a register, and
    caller-owned scratch stacks ``st`` (2 * STACK ints) and ``sb`` (STACK floats). Each metric gets
    its own inlined copy with the metric a compile-time constant: with a runtime metric the
    distance loops keep their branches and queries run 3-5x slower.
    """
    if metric == METRIC_L2:
        return nearest_l2(P, perm, split, box, n, q, st, sb)
    if metric == METRIC_L1:
        return nearest_l1(P, perm, split, box, n, q, st, sb)
    return nearest_linf(P, perm, split, box, n, q, st, sb)


# One compiled function per metric, so a kernel that knows its metric when it is compiled (see
# ``planners.kernels.space.Space``) compiles the traversal once rather than three times.
@nb.njit(cache=True)
def nearest_l2(P, perm, split, box, n, q, st, sb):
    """``nearest_into`` for the L2 metric."""
    return _nearest_impl(P, perm, split, box, n, q, METRIC_L2, st, sb)


@nb.njit(cache=True)
def nearest_l1(P, perm, split, box, n, q, st, sb):
    """``nearest_into`` for the L1 metric."""
    return _nearest_impl(P, perm, split, box, n, q, METRIC_L1, st, sb)


@nb.njit(cache=True)
def nearest_linf(P, perm, split, box, n, q, st, sb):
    """``nearest_into`` for the L-infinity metric."""
    return _nearest_impl(P, perm, split, box, n, q, METRIC_LINF, st, sb)


@nb.njit(cache=True)
def nearest(P, perm, split, box, n, q, metric):
    """``nearest_into`` with its own scratch stacks."""
    st = np.empty(2 * STACK, dtype=np.int64)
    sb = np.empty(STACK)
    return nearest_into(P, perm, split, box, n, q, metric, st, sb)


@nb.njit(cache=True)
def nearest_k(P, perm, split, box, n, q, metric, k, out_idx, out_d):
    """The ``min(k, n)`` nearest points, nearest first; returns how many were written."""
    if metric == METRIC_L2:
        return nearest_k_l2(P, perm, split, box, n, q, k, out_idx, out_d)
    if metric == METRIC_L1:
        return nearest_k_l1(P, perm, split, box, n, q, k, out_idx, out_d)
    return nearest_k_linf(P, perm, split, box, n, q, k, out_idx, out_d)


@nb.njit(cache=True, inline="always")
def _nearest_k_impl(P, perm, split, box, n, q, metric, k, out_idx, out_d):
    if k <= 0 or n == 0:
        return 0
    hd = np.empty(k)
    hi = np.empty(k, dtype=np.int64)
    st = np.empty(2 * STACK, dtype=np.int64)
    sb = np.empty(STACK)
    cnt = query(P, perm, split, box, n, q, metric, MODE_KNN, k, 0.0, hd, hi, st, sb)
    order = np.argsort(hd[:cnt], kind="mergesort")
    for j in range(cnt):
        out_idx[j] = hi[order[j]]
        out_d[j] = from_reduced(metric, hd[order[j]])
    return cnt


@nb.njit(cache=True)
def nearest_k_l2(P, perm, split, box, n, q, k, out_idx, out_d):
    """``nearest_k`` for the L2 metric (one compiled function per metric, as ``nearest_l2``)."""
    return _nearest_k_impl(P, perm, split, box, n, q, METRIC_L2, k, out_idx, out_d)


@nb.njit(cache=True)
def nearest_k_l1(P, perm, split, box, n, q, k, out_idx, out_d):
    """``nearest_k`` for the L1 metric."""
    return _nearest_k_impl(P, perm, split, box, n, q, METRIC_L1, k, out_idx, out_d)


@nb.njit(cache=True)
def nearest_k_linf(P, perm, split, box, n, q, k, out_idx, out_d):
    """``nearest_k`` for the L-infinity metric."""
    return _nearest_k_impl(P, perm, split, box, n, q, METRIC_LINF, k, out_idx, out_d)


@nb.njit(cache=True)
def nearest_r(P, perm, split, box, n, q, metric, radius, out_idx):
    """Indices of all points within ``radius`` (inclusive), unordered; ``out_idx`` holds >= n."""
    if metric == METRIC_L2:
        return nearest_r_l2(P, perm, split, box, n, q, radius, out_idx)
    if metric == METRIC_L1:
        return nearest_r_l1(P, perm, split, box, n, q, radius, out_idx)
    return nearest_r_linf(P, perm, split, box, n, q, radius, out_idx)


@nb.njit(cache=True, inline="always")
def _nearest_r_impl(P, perm, split, box, n, q, metric, radius, out_idx):
    hd = np.empty(1)
    st = np.empty(2 * STACK, dtype=np.int64)
    sb = np.empty(STACK)
    return query(P, perm, split, box, n, q, metric, MODE_RADIUS, 0, to_reduced(metric, radius), hd, out_idx, st, sb)


@nb.njit(cache=True)
def nearest_r_l2(P, perm, split, box, n, q, radius, out_idx):
    """``nearest_r`` for the L2 metric."""
    return _nearest_r_impl(P, perm, split, box, n, q, METRIC_L2, radius, out_idx)


@nb.njit(cache=True)
def nearest_r_l1(P, perm, split, box, n, q, radius, out_idx):
    """``nearest_r`` for the L1 metric."""
    return _nearest_r_impl(P, perm, split, box, n, q, METRIC_L1, radius, out_idx)


@nb.njit(cache=True)
def nearest_r_linf(P, perm, split, box, n, q, radius, out_idx):
    """``nearest_r`` for the L-infinity metric."""
    return _nearest_r_impl(P, perm, split, box, n, q, METRIC_LINF, radius, out_idx)


#: Per-metric entry points by metric code, for callers that pick one when they are compiled.
BY_METRIC = {
    METRIC_L2: (nearest_l2, nearest_k_l2, nearest_r_l2),
    METRIC_L1: (nearest_l1, nearest_k_l1, nearest_r_l1),
    METRIC_LINF: (nearest_linf, nearest_k_linf, nearest_r_linf),
}


_METRICS = {"euclidean": METRIC_L2, "manhattan": METRIC_L1, "chebyshev": METRIC_LINF}


class NearestNeighbors:
    """Growable nearest-neighbour index over points in R^d (the planners' own index, for direct use).

    Args:
        dim: Point dimension.
        metric: ``"euclidean"``, ``"manhattan"`` or ``"chebyshev"``.
        capacity: Initial capacity; the index grows by doubling.
    """

    def __init__(self, dim: int, metric: str = "euclidean", capacity: int = 1024) -> None:
        if dim < 1:
            raise ValueError(f"dim must be >= 1, got {dim}")
        if metric not in _METRICS:
            raise ValueError(f"metric must be one of {sorted(_METRICS)}, got {metric!r}")
        self.dim = dim
        self.metric = metric
        self._m = _METRICS[metric]
        self._n = 0
        cap = max(int(capacity), CHUNK)
        self._P = np.empty((cap, dim))
        self._perm = np.empty(cap, dtype=np.int64)
        self._split = np.zeros(cap, dtype=np.int64)
        self._box = np.zeros((cap, 2 * dim))

    def __len__(self) -> int:
        return self._n

    @property
    def points(self) -> np.ndarray:
        """Read-only view of the indexed points, in insertion order."""
        v = self._P[: self._n]
        v.flags.writeable = False
        return v

    def add(self, points: np.ndarray) -> None:
        """Add one point (d,) or many (m, d)."""
        pts = np.atleast_2d(np.asarray(points, dtype=np.float64))
        if pts.shape[1] != self.dim or not np.all(np.isfinite(pts)):
            raise ValueError(f"points must be finite with {self.dim} columns, got shape {pts.shape}")
        need = self._n + len(pts)
        if need > len(self._P):
            cap = max(need, 2 * len(self._P))
            for name in ("_P", "_perm", "_split", "_box"):
                old = getattr(self, name)
                new = np.zeros((cap,) + old.shape[1:], dtype=old.dtype)
                new[: self._n] = old[: self._n]
                setattr(self, name, new)
        for p in pts:
            self._P[self._n] = p
            self._n = insert(self._P, self._perm, self._split, self._box, self._n)

    def _q(self, q: np.ndarray) -> np.ndarray:
        q = np.asarray(q, dtype=np.float64)
        if q.shape != (self.dim,):
            raise ValueError(f"query must have shape ({self.dim},), got {q.shape}")
        return q

    def nearest(self, q: np.ndarray) -> tuple[int, float]:
        """(index, distance) of the nearest point; (-1, inf) when empty."""
        i, r = nearest(self._P, self._perm, self._split, self._box, self._n, self._q(q), self._m)
        return int(i), float(from_reduced(self._m, r)) if i >= 0 else float("inf")

    def nearest_many(self, qs: np.ndarray) -> np.ndarray:
        """Index of the nearest point to each row of ``qs`` (-1 when empty), all in one compiled loop."""
        qs = np.ascontiguousarray(qs, dtype=np.float64)
        if qs.ndim != 2 or qs.shape[1] != self.dim:
            raise ValueError(f"queries must have shape (m, {self.dim}), got {qs.shape}")
        out = np.empty(len(qs), dtype=np.int64)
        nearest_many(self._P, self._perm, self._split, self._box, self._n, qs, self._m, out)
        return out

    def nearest_k(self, q: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Indices and distances of the ``k`` nearest points, nearest first."""
        idx = np.empty(max(k, 0), dtype=np.int64)
        dist = np.empty(max(k, 0))
        c = nearest_k(self._P, self._perm, self._split, self._box, self._n, self._q(q), self._m, k, idx, dist)
        return idx[:c], dist[:c]

    def nearest_r(self, q: np.ndarray, radius: float) -> np.ndarray:
        """Sorted indices of all points within ``radius``."""
        out = np.empty(max(self._n, 1), dtype=np.int64)
        c = nearest_r(self._P, self._perm, self._split, self._box, self._n, self._q(q), self._m, float(radius), out)
        return np.sort(out[:c])


@nb.njit(cache=True)
def nearest_many(P, perm, split, box, n, qs, metric, out):
    """``out[i]``: the nearest point to ``qs[i]``, every query in one compiled loop."""
    st = np.empty(2 * STACK, dtype=np.int64)
    sb = np.empty(STACK)
    for i in range(qs.shape[0]):
        out[i], _ = nearest_into(P, perm, split, box, n, qs[i], metric, st, sb)
