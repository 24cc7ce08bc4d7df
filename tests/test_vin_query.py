"""The route encoder's query after its convolutions in one compiled call (``learning.models.vin_query``), against the
same steps made one by one through the checked functions it stands for.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from learning.models.cell_head import cell_head_at, cell_head_field
from learning.models.vin_query import NO_WORK, blocked_cells, query_field, single_mark
from planners.maps.gridsearch import MOVES, incoming_prices, move_cost_field, reaches_block


def _problem(rng, h, w, block, channels, wall_share):
    """A query's arrays: cells of 0 and 1 (some blocks with no free cell), one goal block, prices and head weights."""
    cells = (rng.random((block * block + 1, h, w)) < 0.3).astype(np.float32)
    cells[:block * block, rng.random((h, w)) < 0.15] = 1.0  # blocks with no free cell
    cells[block * block] = 0.0
    cells[block * block, rng.integers(h), rng.integers(w)] = 1.0
    costs = rng.uniform(0.5, 3.0, (8, h, w)).astype(np.float32)
    costs[rng.random((8, h, w)) < wall_share] = 40.0  # learned walls: above the caps
    gate = rng.random((8, h, w)) < 0.85
    pre = rng.normal(size=(channels, h, w)).astype(np.float32)
    head = (rng.normal(size=(channels, 8)).astype(np.float32), rng.normal(size=(block * block, channels)).astype(
        np.float32), rng.normal(size=block * block).astype(np.float32))
    return cells, costs, gate, pre, head


def _one_by_one(cells, block, costs, pre, gate, most, head, unreached, start, scale, limit):
    """``RouteVIN.compiled_field``'s steps as the checked functions make them: the search with the learned walls (caps
    ``most``; None: none), the start's cell head, the search without them where it is shut, the whole head."""
    k = block * block
    walls, goal = cells[:k].min(0) > 0.5, cells[k] > 0.5
    v = move_cost_field(costs, goal, walls, unreached, open_moves=gate, most=most)
    opened = False
    if start is not None and most is not None:
        value = cell_head_at(v, pre, *head, block, 4.0, unreached, start)
        if float(np.float64(value) * scale) >= limit:
            v = move_cost_field(costs, goal, walls, unreached, open_moves=gate)
            opened = True
    return cell_head_field(v, pre, *head, block, 4.0, unreached), opened


@settings(max_examples=60, deadline=None)
@given(h=st.integers(1, 10), w=st.integers(1, 10), block=st.sampled_from([1, 2]), channels=st.integers(1, 5),
       seed=st.integers(0, 2**16), wall_share=st.sampled_from([0.0, 0.3, 0.7]), check=st.booleans(),
       unreached=st.sampled_from([1e6, 60.0]), capped=st.booleans(), shuts=st.sampled_from([0.25, 4.0]))
def test_one_compiled_call_gives_the_checked_steps_field_and_answer_bit_for_bit(h, w, block, channels, seed, wall_share,
                                                                              check, unreached, capped, shuts):
    # unreached 60: no route's sum is sure to stay far below it, so the walk's shortcut gives way to the search; a
    # limit of 4 times it: even an unreached start is not shut, so the search with the walls runs after the walk
    rng = np.random.default_rng(seed)
    cells, costs, gate, pre, head = _problem(rng, h, w, block, channels, wall_share)
    most = np.full(8, 32.0, dtype=np.float32) * np.array([np.hypot(*m) for m in MOVES], dtype=np.float32)
    start = (int(rng.integers(h * block)), int(rng.integers(w * block))) if check else None
    scale, limit = 0.5, shuts * unreached
    want, was_opened = _one_by_one(cells, block, costs, pre, gate, most if capped else None, head,
                                   np.float32(unreached), start, scale, limit)
    out = np.full((h * block, w * block), np.nan, dtype=np.float32)
    opened = query_field(cells, block, costs, pre, gate, most, capped, *head, np.float32(4.0), np.float32(unreached),
                         check, *(start or (0, 0)), scale, limit, *NO_WORK, out)
    assert opened == was_opened and np.array_equal(out, want)


@settings(max_examples=60, deadline=None)
@given(h=st.integers(1, 12), w=st.integers(1, 12), seed=st.integers(0, 2**16), wall_share=st.floats(0.0, 0.9))
def test_the_walk_reaches_a_block_exactly_where_the_search_gives_it_a_value(h, w, seed, wall_share):
    rng = np.random.default_rng(seed)
    costs = rng.uniform(0.5, 3.0, (8, h, w)).astype(np.float32)
    costs[rng.random((8, h, w)) < wall_share] = 40.0
    gate = rng.random((8, h, w)) < 0.8
    goal, walls = rng.random((h, w)) < 0.05, rng.random((h, w)) < 0.2
    goal[rng.integers(h), rng.integers(w)] = True
    most = np.full(8, 20.0, dtype=np.float32)
    v = move_cost_field(costs, goal, walls, 1e6, open_moves=gate, most=most)
    inc = np.empty((h * w, 8), dtype=np.float32)
    incoming_prices(costs, np.float32(1e6), gate, most, inc)
    seen = np.empty(h * w, dtype=np.uint8)
    for r in range(h):
        for c in range(w):
            assert reaches_block(inc, goal, walls, np.float32(1e6), r, c, seen) == (v[r, c] < 1e6)


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 2), channels=st.integers(2, 6), h=st.integers(1, 12), w=st.integers(1, 12),
       seed=st.integers(0, 2**16), odd=st.sampled_from([None, 0.3, np.nan, -0.0]), dtype=st.sampled_from(["f4", "f8"]))
def test_the_compiled_map_flags_and_goal_mark_are_numpys(n, channels, h, w, seed, odd, dtype):
    rng = np.random.default_rng(seed)
    cells = (rng.random((n, channels, h, w)) < 0.4).astype(dtype)
    if odd is not None:
        cells[0, 0, rng.integers(h), rng.integers(w)] = odd  # a value other than 0 or 1: the key takes the bytes
    k = int(rng.integers(1, channels))
    blocked = cells[:, :k] >= 0.5
    flags = np.empty(blocked.size, dtype=bool)
    assert blocked_cells(cells, k, flags) == np.array_equal(cells[:, :k], blocked)
    assert np.array_equal(flags, blocked.ravel())
    plane = cells[0, k]
    marked = np.flatnonzero(plane > 0.5)
    assert single_mark(plane) == (marked[0] if len(marked) == 1 else -1)
