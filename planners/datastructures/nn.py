"""Compiled nearest-neighbour index: a forest of static k-d trees (Bentley-Saxe logarithmic method).

Why this structure: an incremental k-d tree degenerates when points arrive in spatial order (an RRT
growing down a corridor inserts them almost sorted), and a uniform bucket grid scans empty cells when
the tree is small and the query far away. Here points are kept in insertion order; the first
``CHUNK * (n // CHUNK)`` of them are covered by balanced k-d trees over contiguous index ranges whose
sizes are the binary digits of ``n // CHUNK`` (times ``CHUNK``), and the last ``n % CHUNK`` form a
tail that is scanned directly. Inserting is amortised O(log^2 n), a query O(log^2 n), in any
dimension and for the L1, L2 and L-infinity metrics.

A query searches every tree, and on a large index the smaller trees cost as much as the largest: at 60,000
points of a 6-DoF tree the forest's six trees take about twice as long as one tree over them all. So from
``BIG_FROM`` chunks on, the leading ``TOP_BITS`` binary digits of ``n // CHUNK`` are one tree (``_big_chunks``),
rebuilt whole each time they change (four times per doubling of the index: about twice the forest's building),
and the digits below it are the forest's trees after it; below ``BIG_FROM`` chunks, and up to the first rebuild
after it, the layout is the forest's alone.

The level layout is a pure function of ``n``, so the index state is just ``points[:n]``, ``perm`` and
``split``: ``perm[a:b]`` stores the implicit tree of range ``[a, b)`` (the median of every sub-range
sits at its middle position) and ``split[mid]`` the dimension that node splits on.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from planners.kernels.space import METRIC_L1, METRIC_L2, METRIC_LINF, OVERLOAD_JIT, compiled_only

CHUNK = 64
LEAF = 16
STACK = 256
#: From this many chunks (32,768 points) on, the leading ``TOP_BITS`` digits of the chunk count form one tree.
BIG_FROM = 1 << 9
TOP_BITS = 3


# --- one metric's building blocks ----------------------------------------------------------------
# Each is small and branch-free and inlined (numba's ``inline="always"``) into the traversals that
# ``_traversals`` makes for its metric, so every traversal is compiled with its metric built in (with a
# run-time metric the distance loops keep their branches and queries run 3-5x slower) and inlining
# one metric's few lines costs little compilation.


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _rdist_l2(q, P, j):
    """Reduced distance (squared for L2) from ``q`` to point ``P[j]``."""
    s = 0.0
    for i in range(q.shape[0]):
        d = q[i] - P[j, i]
        s += d * d
    return s


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _rdist_l1(q, P, j):
    s = 0.0
    for i in range(q.shape[0]):
        s += abs(q[i] - P[j, i])
    return s


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _rdist_linf(q, P, j):
    s = 0.0
    for i in range(q.shape[0]):
        d = abs(q[i] - P[j, i])
        if d > s:
            s = d
    return s


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _box_gap(q, box, i, d):
    """How far ``q`` lies outside the bounding box stored at position ``i`` along dimension ``d``."""
    dim = q.shape[0]
    v = q[d]
    lo = box[i, d]
    hi = box[i, dim + d]
    return lo - v if v < lo else (v - hi if v > hi else 0.0)


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _box_l2(q, box, i):
    """Reduced distance from ``q`` to the bounding box stored at position ``i``."""
    s = 0.0
    for d in range(q.shape[0]):
        e = _box_gap(q, box, i, d)
        s += e * e
    return s


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _box_l1(q, box, i):
    s = 0.0
    for d in range(q.shape[0]):
        s += _box_gap(q, box, i, d)
    return s


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _box_linf(q, box, i):
    s = 0.0
    for d in range(q.shape[0]):
        e = _box_gap(q, box, i, d)
        if e > s:
            s = e
    return s


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _square(x):
    return x * x


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _abs(x):
    return abs(x)


def to_reduced(metric, d):
    """A distance in the units the index compares (squared for L2, which saves the square roots)."""
    return d * d if metric == METRIC_L2 else d


def from_reduced(metric, r):
    """The distance back from ``to_reduced``'s units."""
    return np.sqrt(r) if metric == METRIC_L2 else r


@nb.njit(**OVERLOAD_JIT)
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


@nb.njit(cache=True, no_cfunc_wrapper=True)
def _big_chunks(m):
    """The chunks the one large tree covers, ``[0, CHUNK * result)``, for ``m`` chunks: 0 below ``BIG_FROM``, else
    ``m`` with all but its leading ``TOP_BITS`` binary digits cleared.
    """
    if m < BIG_FROM:
        return 0
    s = 0
    while (m >> s) >= (1 << TOP_BITS):
        s += 1
    return (m >> s) << s


@compiled_only
def build(P, perm, split, box, lo, hi):
    """Build the implicit k-d tree of points [lo, hi); ``box[mid]`` gets each subtree's bounds.

    Level by level: node ``j`` of a level is found by halving [lo, hi) along the bits of ``j``, so no
    stack is needed (each node reorders only its own range, so the order of the nodes of one level
    does not matter).
    """
    for i in range(lo, hi):
        perm[i] = i
    dim = P.shape[1]
    level = 0
    more = True
    while more:
        more = False
        for j in range(1 << level):
            a = lo
            b = hi
            for k in range(level - 1, -1, -1):
                mid = (a + b) // 2
                if (j >> k) & 1:
                    a = mid + 1
                else:
                    b = mid
            if b - a <= LEAF:
                continue
            more = True
            mid = (a + b) // 2
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
                box[mid, d] = mn
                box[mid, dim + d] = mx
                if mx - mn > best_spread:
                    best_spread = mx - mn
                    best_sd = d
            split[mid] = best_sd
            _select(P, perm, a, b, mid, split[mid])  # an int64 (best_sd starts as a literal 0: a second compilation)
        level += 1


@compiled_only
def insert(P, perm, split, box, n):
    """Index point ``n`` (already written to ``P[n]``); returns the new count ``n + 1``."""
    perm[n] = n
    n += 1
    if n % CHUNK == 0:
        m = n // CHUNK
        if _big_chunks(m) != _big_chunks(m - 1):  # the large tree's digits changed: it takes every chunk
            build(P, perm, split, box, 0, n)
            return n
        # the forest's rule below it: the new chunk merges the trailing trees its carry reaches
        size = CHUNK
        while m % 2 == 0:
            m //= 2
            size *= 2
        build(P, perm, split, box, n - size, n)
    return n


@nb.njit(cache=True, no_cfunc_wrapper=True)
def _heap_push(hd, hi, cnt, k, d, idx):
    """Bounded max-heap of (reduced distance, index) with at most k entries; returns the count.

    A call, not inlined: its body inlined at the traversal's two offers doubled the k-nearest query's
    compilation (LLVM inlines the call where it pays).
    """
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


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _offer_knn(hd, hi, cnt, k, d, idx, r):
    """The ``k`` nearest: keep ``idx`` in the bounded heap if among the ``k`` nearest so far; returns the count."""
    return _heap_push(hd, hi, cnt, k, d, idx)


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def _offer_radius(hd, hi, cnt, k, d, idx, r):
    """Radius search: append ``idx`` if it lies within reduced radius ``r``; returns the count."""
    if d <= r:
        hi[cnt] = idx
        cnt += 1
    return cnt


def _query(rdist, box_rdist, plane_rdist, offer, knn):
    """The k-nearest (``knn``) or within-radius traversal of one metric, with its ``offer`` (``_offer_knn`` or
    ``_offer_radius``) built in; inlined into ``nearest_k_*`` / ``nearest_r_*``.
    """

    def query(P, perm, split, box, n, q, k, r, hd, hi):
        """The ``k`` nearest (``knn``: a bounded max-heap of ``k`` in ``hd, hi``) or all points within reduced
        radius ``r`` (appended to ``hi``); returns how many are held. ``offer`` records a candidate.
        """
        st = np.empty(2 * STACK, dtype=np.int64)
        sb = np.empty(STACK)
        cnt = 0
        full = (n // CHUNK) * CHUNK
        for i in range(full, n):
            cnt = offer(hd, hi, cnt, k, rdist(q, P, i), i, r)
        m = n // CHUNK
        big = _big_chunks(m)
        rest = m - big  # the forest's trees after the large one
        start = 0
        bit = 63  # 63: the large tree, then the forest's trees, largest first
        while bit >= 0:
            if (big if bit == 63 else (rest >> bit) & 1):
                size = big * CHUNK if bit == 63 else CHUNK << bit
                st[0] = start
                st[1] = start + size
                sb[0] = box_rdist(q, box, start + size // 2)
                sp = 1
                while sp > 0:
                    sp -= 1
                    a = st[2 * sp]
                    b = st[2 * sp + 1]
                    bound = sb[sp]
                    # bounds strictly above the limit (k nearest: at it too) cannot contribute
                    if knn:
                        lim = hd[0] if cnt == k else np.inf
                        if bound >= lim:
                            continue
                    elif bound > r:
                        continue
                    if b - a <= LEAF:
                        for i in range(a, b):
                            idx = perm[i]
                            cnt = offer(hd, hi, cnt, k, rdist(q, P, idx), idx, r)
                        continue
                    mid = (a + b) // 2
                    idx = perm[mid]
                    cnt = offer(hd, hi, cnt, k, rdist(q, P, idx), idx, r)
                    sd = split[mid]
                    diff = q[sd] - P[idx, sd]
                    plane = plane_rdist(diff)
                    lb = plane if diff > 0.0 else 0.0
                    lb = box_rdist(q, box, (a + mid) // 2) if mid - a > LEAF else (lb if lb > bound else bound)
                    rb = plane if diff < 0.0 else 0.0
                    rb = box_rdist(q, box, (mid + 1 + b) // 2) if b - mid - 1 > LEAF else (rb if rb > bound else bound)
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

    return nb.njit(inline="always")(query)


def _traversals(rdist, box_rdist, plane_rdist, name):
    """The nearest, k-nearest and within-radius traversals of one metric, compiled with it built in.

    ``rdist(q, P, j)``: reduced distance to a point; ``box_rdist(q, box, i)``: to a stored bounding
    box; ``plane_rdist(diff)``: to a splitting plane ``diff`` away.
    """

    def nearest(P, perm, split, box, n, q, st, sb, *ignored):
        # one stack holds every range still to search: first the tail (its perm is the identity) as a
        # leaf, then each tree's root, largest tree first; a range's entry in ``sb`` bounds its distance
        best = np.inf
        bi = -1
        m = n // CHUNK
        big = _big_chunks(m)
        rest = m - big  # the forest's trees after the large one
        sp = 0
        start = m * CHUNK
        bit = 0
        while bit <= 62 and (rest >> bit) != 0:
            if (rest >> bit) & 1:
                size = CHUNK << bit
                start -= size
                st[2 * sp] = start
                st[2 * sp + 1] = start + size
                sb[sp] = box_rdist(q, box, start + size // 2)
                sp += 1
            bit += 1
        if big:
            st[2 * sp] = 0
            st[2 * sp + 1] = big * CHUNK
            sb[sp] = box_rdist(q, box, big * CHUNK // 2)
            sp += 1
        st[2 * sp] = m * CHUNK
        st[2 * sp + 1] = n
        sb[sp] = 0.0
        sp += 1
        while sp > 0:
            sp -= 1
            bound = sb[sp]
            if bound >= best:
                continue
            a = st[2 * sp]
            b = st[2 * sp + 1]
            if b - a <= LEAF or a >= m * CHUNK:
                for i in range(a, b):
                    idx = perm[i]
                    d = rdist(q, P, idx)
                    if d < best:
                        best = d
                        bi = idx
                continue
            mid = (a + b) // 2
            idx = perm[mid]
            d = rdist(q, P, idx)
            if d < best:
                best = d
                bi = idx
            sd = split[mid]
            diff = q[sd] - P[idx, sd]
            plane = plane_rdist(diff)
            # a child's lower bound: its box distance if it has a box, else the split-plane bound
            lb = plane if diff > 0.0 else 0.0
            lb = box_rdist(q, box, (a + mid) // 2) if mid - a > LEAF else (lb if lb > bound else bound)
            rb = plane if diff < 0.0 else 0.0
            rb = box_rdist(q, box, (mid + 1 + b) // 2) if b - mid - 1 > LEAF else (rb if rb > bound else bound)
            # the farther child goes on the stack first, so the nearer one is searched first
            if lb < rb or (lb == rb and diff < 0.0):
                fa, fb, fbound, na, nb, nbound = mid + 1, b, rb, a, mid, lb
            else:
                fa, fb, fbound, na, nb, nbound = a, mid, lb, mid + 1, b, rb
            if fbound < best:
                st[2 * sp] = fa
                st[2 * sp + 1] = fb
                sb[sp] = fbound
                sp += 1
            if nbound < best:
                st[2 * sp] = na
                st[2 * sp + 1] = nb
                sb[sp] = nbound
                sp += 1
        return bi, best

    query_k = _query(rdist, box_rdist, plane_rdist, _offer_knn, True)
    query_r = _query(rdist, box_rdist, plane_rdist, _offer_radius, False)

    def nearest_k(P, perm, split, box, n, q, k, out_idx, out_d):
        if k <= 0 or n == 0:
            return 0
        hd = np.empty(k)
        hi = np.empty(k, dtype=np.int64)
        cnt = query_k(P, perm, split, box, n, q, k, 0.0, hd, hi)
        # nearest first: a stable insertion sort of the heap by distance, the order argsort(kind="mergesort")
        # gives (k is small, and numba's merge sort costs a second of compilation)
        order = np.empty(cnt, dtype=np.int64)
        for j in range(cnt):
            d = hd[j]
            i = j
            while i > 0 and hd[order[i - 1]] > d:
                order[i] = order[i - 1]
                i -= 1
            order[i] = j
        for j in range(cnt):
            out_idx[j] = hi[order[j]]
            out_d[j] = np.sqrt(hd[order[j]]) if l2 else hd[order[j]]
        return cnt

    def nearest_r(P, perm, split, box, n, q, radius, out_idx):
        hd = np.empty(1)
        return query_r(P, perm, split, box, n, q, 0, radius * radius if l2 else radius, hd, out_idx)

    l2 = plane_rdist is _square
    out = []
    for f, what in ((nearest, "nearest_into"), (nearest_k, "nearest_k"), (nearest_r, "nearest_r")):
        f.__name__ = f.__qualname__ = f"{what}_{name}"
        f.__doc__ = f"``{what}`` for the {name} metric."
        out.append(nb.njit(cache=True, no_cfunc_wrapper=True)(f))
    return tuple(out)


# One compiled function per metric and query, so a kernel that knows its metric when it is compiled
# (see ``planners.kernels.space.Space``) compiles that metric's traversal only.
nearest_l2, nearest_k_l2, nearest_r_l2 = _traversals(_rdist_l2, _box_l2, _square, "l2")
nearest_l1, nearest_k_l1, nearest_r_l1 = _traversals(_rdist_l1, _box_l1, _abs, "l1")
nearest_linf, nearest_k_linf, nearest_r_linf = _traversals(_rdist_linf, _box_linf, _abs, "linf")

#: Per-metric entry points by metric code, for callers that pick one when they are compiled.
BY_METRIC = {
    METRIC_L2: (nearest_l2, nearest_k_l2, nearest_r_l2),
    METRIC_L1: (nearest_l1, nearest_k_l1, nearest_r_l1),
    METRIC_LINF: (nearest_linf, nearest_k_linf, nearest_r_linf),
}


@nb.njit(cache=True, no_cfunc_wrapper=True)
def nearest_into(P, perm, split, box, n, q, metric, st, sb):
    """(index, reduced distance) of the nearest of the first ``n`` points; (-1, inf) if n == 0.

    The planners' hot path: a dedicated traversal with the best distance held in a register, and
    caller-owned scratch stacks ``st`` (2 * STACK ints) and ``sb`` (STACK floats). ``metric`` picks
    one of the per-metric traversals (``BY_METRIC``); a kernel that knows its metric calls that one.
    """
    if metric == METRIC_L2:
        return nearest_l2(P, perm, split, box, n, q, st, sb)
    if metric == METRIC_L1:
        return nearest_l1(P, perm, split, box, n, q, st, sb)
    return nearest_linf(P, perm, split, box, n, q, st, sb)


@nb.njit(cache=True, no_cfunc_wrapper=True)
def nearest(P, perm, split, box, n, q, metric):
    """``nearest_into`` with its own scratch stacks."""
    st = np.empty(2 * STACK, dtype=np.int64)
    sb = np.empty(STACK)
    return nearest_into(P, perm, split, box, n, q, metric, st, sb)


@nb.njit(cache=True, no_cfunc_wrapper=True)
def nearest_k(P, perm, split, box, n, q, metric, k, out_idx, out_d):
    """The ``min(k, n)`` nearest points, nearest first; returns how many were written."""
    if metric == METRIC_L2:
        return nearest_k_l2(P, perm, split, box, n, q, k, out_idx, out_d)
    if metric == METRIC_L1:
        return nearest_k_l1(P, perm, split, box, n, q, k, out_idx, out_d)
    return nearest_k_linf(P, perm, split, box, n, q, k, out_idx, out_d)


@nb.njit(cache=True, no_cfunc_wrapper=True)
def nearest_r(P, perm, split, box, n, q, metric, radius, out_idx):
    """Indices of all points within ``radius`` (inclusive), unordered; ``out_idx`` holds >= n."""
    if metric == METRIC_L2:
        return nearest_r_l2(P, perm, split, box, n, q, radius, out_idx)
    if metric == METRIC_L1:
        return nearest_r_l1(P, perm, split, box, n, q, radius, out_idx)
    return nearest_r_linf(P, perm, split, box, n, q, radius, out_idx)


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
        self._n = _insert_rows(self._P, self._perm, self._split, self._box, self._n, pts)

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


@nb.njit(cache=True, no_cfunc_wrapper=True)
def _insert_rows(P, perm, split, box, n, rows):
    """Write each row of ``rows`` to ``P[n]``, ``P[n + 1]``, ... and index it; returns the new count."""
    for i in range(rows.shape[0]):
        for j in range(rows.shape[1]):
            P[n, j] = rows[i, j]
        n = insert(P, perm, split, box, n)
    return n


@nb.njit(cache=True, no_cfunc_wrapper=True)
def nearest_many(P, perm, split, box, n, qs, metric, out):
    """``out[i]``: the nearest point to ``qs[i]``, every query in one compiled loop."""
    st = np.empty(2 * STACK, dtype=np.int64)
    sb = np.empty(STACK)
    for i in range(qs.shape[0]):
        out[i], _ = nearest_into(P, perm, split, box, n, qs[i], metric, st, sb)
