"""The frontier's kept weights: a sample drawn with the memo of earlier calls is the one a fresh memo draws."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from planners.guidance.frontier import frontier_memo, frontier_sample


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), tau=st.sampled_from([0.25, 1.0, 8.0]))
def test_kept_weights_draw_what_fresh_ones_draw_as_the_frontier_changes(seed, tau):
    rng = np.random.default_rng(seed)
    cells = 400
    dist = rng.random(cells) * 50
    front = np.empty(cells, dtype=np.int64)
    outside = list(rng.permutation(cells))
    count, kept = 0, frontier_memo(cells)
    for _ in range(60):
        # a tree's update: some cells leave by swapping in the last one, some join at the end
        for _ in range(int(rng.integers(0, 4))):
            if count == 0:
                break
            p = int(rng.integers(0, count))
            outside.append(int(front[p]))
            front[p] = front[count - 1]
            count -= 1
        for _ in range(int(rng.integers(0, 5))):
            if outside:
                front[count] = outside.pop(int(rng.integers(0, len(outside))))
                count += 1
        u_pick, u_xy = rng.random(3), rng.random((3, 2))
        a, b = np.empty((3, 2)), np.empty((3, 2))
        ka = frontier_sample(front, count, 20, 1.0, np.zeros(2), dist, tau, u_pick, u_xy, a, kept)
        fresh = frontier_memo(cells)
        kb = frontier_sample(front, count, 20, 1.0, np.zeros(2), dist, tau, u_pick, u_xy, b, fresh)
        assert ka == kb
        assert np.array_equal(a[:ka], b[:kb])
        assert np.array_equal(kept[2][:count], fresh[2][:count])  # the running sums, bit for bit
