"""``scripts/experiments/split_blocks.py``: the share of blocks a wall splits into pieces."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import load_script
from hypothesis import given, settings
from hypothesis import strategies as st


@pytest.mark.experiments
def test_pieces_are_four_connected_and_a_split_block_is_counted():
    script = load_script("experiments/split_blocks")
    assert script.pieces(np.array([[True, False], [False, True]])) == 2  # a diagonal does not join
    assert script.pieces(np.array([[True, True], [False, True]])) == 1
    assert script.pieces(np.zeros((3, 3), bool)) == 0
    obstacles = np.zeros((4, 8), bool)
    obstacles[:, 1] = True  # a wall down the first block of 4: free cells on both sides of it
    obstacles[:, 4:] = True  # the second block is all wall: not counted
    assert script.split_share(obstacles, 4) == (1, 1)
    assert script.split_share(obstacles, 2) == (4, 0)  # at 2 cells the wall runs along block edges


@pytest.mark.experiments
@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_a_block_without_walls_is_one_piece_and_pieces_never_exceed_free_cells(seed):
    script = load_script("experiments/split_blocks")
    free = np.random.default_rng(seed).random((4, 4)) < 0.6
    assert script.pieces(np.ones((4, 4), bool)) == 1
    assert script.pieces(free) <= free.sum()
    assert (script.pieces(free) == 0) == (not free.any())
