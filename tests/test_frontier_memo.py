"""The frontier's kept weights: a sample drawn with the memo of earlier calls is the one a fresh memo draws."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from planners.guidance.frontier import REBASE_ABOVE, REBASE_BELOW, frontier_memo, frontier_sample


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), tau=st.sampled_from([0.05, 0.25, 1.0, 8.0]))
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
        if count == 0:
            continue
        # a fresh memo taking its weights from the same distance draws the same, its running sums bit for bit
        ref = kept[3][0]
        dmin = dist[front[:count]].min()
        assert ref - REBASE_BELOW * tau <= dmin <= ref + REBASE_ABOVE * tau
        fresh = frontier_memo(cells)
        fresh[3][0] = ref
        kb = frontier_sample(front, count, 20, 1.0, np.zeros(2), dist, tau, u_pick, u_xy, b, fresh)
        assert ka == kb
        assert np.array_equal(a[:ka], b[:kb])
        assert np.array_equal(kept[2][:count], fresh[2][:count])
        # and the weights are exp(-(d - d_min) / tau) up to a common factor: the same distribution
        expected = np.cumsum(np.exp(-(dist[front[:count]] - dmin) / tau))
        assert np.allclose(kept[2][:count] / kept[2][count - 1], expected / expected[-1], rtol=1e-12, atol=1e-15)


def test_the_weights_are_taken_again_from_the_lowest_distance_once_it_moves_far():
    dist = np.array([100.0, 50.0, 10.0, 0.0])
    front = np.array([0, 1, 2, 3], dtype=np.int64)
    memo, out = frontier_memo(4), np.empty((1, 2))
    frontier_sample(front, 1, 4, 1.0, np.zeros(2), dist, 0.1, np.array([0.5]), np.full((1, 2), 0.5), out, memo)
    assert memo[3][0] == 100.0  # a fresh memo: from the lowest distance
    frontier_sample(front, 2, 4, 1.0, np.zeros(2), dist, 0.1, np.array([0.5]), np.full((1, 2), 0.5), out, memo)
    assert memo[3][0] == 100.0  # 50 below it: within 600 taus of 0.1
    frontier_sample(front, 4, 4, 1.0, np.zeros(2), dist, 0.1, np.array([0.5]), np.full((1, 2), 0.5), out, memo)
    assert memo[3][0] == 0.0  # 100 below: past 600 taus, taken again
    assert np.isfinite(memo[2][:4]).all() and memo[2][3] > 0
