"""A map read coarser where that keeps its passages (``planners.maps.coarsen``)."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from planners.maps import coarsen
from planners.maps.coarsen import block_any, coarsest_keeping, free_at, keeps_passages
from planners.maps.gridsearch import free_components
from planners.worlds.grid import resample_obstacles


def corridors(side: int, width: int) -> np.ndarray:
    """A comb of one-cell walls ``width`` cells apart, each open at alternate ends: one winding corridor."""
    g = np.zeros((side, side), bool)
    for i, r in enumerate(range(width, side - 1, width + 1)):
        g[r, :] = True
        g[r, (side - width if i % 2 else 0):(side if i % 2 else width)] = False
    return g


@given(seed=st.integers(0, 2**32 - 1), k=st.sampled_from([2, 3, 4, 8]), h=st.integers(1, 40), w=st.integers(1, 40))
def test_block_any_is_resample_obstacles_at_a_whole_factor(seed, k, h, w):
    g = np.random.default_rng(seed).random((h, w)) < 0.2
    padded = np.zeros((-(-h // k) * k, -(-w // k) * k), bool)  # beyond the map: free
    padded[:h, :w] = g
    blocks = padded.reshape(padded.shape[0] // k, k, padded.shape[1] // k, k).any(axis=(1, 3))
    assert np.array_equal(block_any(g, k), blocks) and np.array_equal(resample_obstacles(g, k), blocks)


def test_a_winding_corridor_keeps_its_passages_up_to_its_width():
    g = corridors(128, 15)
    assert keeps_passages(g, block_any(g, 2), 2) and keeps_passages(g, block_any(g, 4), 4)
    assert coarsest_keeping(g, 8) == 8  # corridors one coarse cell wide, every turn open
    assert coarsest_keeping(g, 1) == 1 and coarsest_keeping(g, 2) == 2


def test_a_gap_between_two_obstacles_that_closes_is_seen():
    g = np.zeros((32, 32), bool)
    g[16, :15] = True
    g[16, 16:] = True  # one wall with a gap at column 15: two obstacles (the left one and the right one meet the edge)
    g[16, 0] = g[16, 31] = False  # neither touches the edge: two pieces apart from the outside
    assert not keeps_passages(g, block_any(g, 2), 2)  # the gap's coarse cell is blocked: the pieces merge


def test_a_mouth_an_obstacle_closes_on_itself_is_seen():
    g = np.zeros((32, 32), bool)
    g[8:24, 8] = g[8:24, 23] = g[23, 8:24] = True  # a U open at the top, its mouth closed by a bar with a gap
    g[8, 8:15] = g[8, 16:24] = True
    assert free_components(g).max() == 0  # one free region, the inside joined through the gap at column 15
    assert not keeps_passages(g, block_any(g, 2), 2)  # the gap closes: the inside falls apart from the outside


def test_a_pocket_that_vanishes_is_no_passage():
    g = np.zeros((32, 32), bool)
    g[10:13, 10:13] = True
    g[11, 11] = False  # a free cell walled in: no route reaches it either way
    assert keeps_passages(g, block_any(g, 2), 2)


@given(seed=st.integers(0, 2**32 - 1), k=st.sampled_from([2, 4]), density=st.sampled_from([0.02, 0.05, 0.15]))
def test_kept_passages_keep_which_free_coarse_cells_connect(seed, k, density):
    rng = np.random.default_rng(seed)
    g = np.zeros((48, 48), bool)
    for _ in range(int(density * 60)):  # bars of random lengths, so that some maps keep their passages
        r, c, n = rng.integers(0, 48), rng.integers(0, 48), rng.integers(1, 20)
        if rng.random() < 0.5:
            g[r, c:c + n] = True
        else:
            g[r:r + n, c] = True
    coarse = block_any(g, k)
    if not keeps_passages(g, coarse, k):
        return
    fine, lab = free_components(g), free_components(coarse)
    free = np.argwhere(~coarse)
    for (i, j), (a, b) in zip(free[:-1], free[1:], strict=True):
        assert (lab[i, j] == lab[a, b]) == (fine[i * k, j * k] == fine[a * k, b * k])


def test_free_at_halves_until_the_cells_lie_in_free_coarse_cells():
    g = corridors(64, 15)
    assert free_at(g, 4, [(0, 0), (63, 63)]) == 4
    wall = int(np.argwhere(g[:, 20])[0][0])  # a wall's row; the cell beside it shares a coarse cell with it at 2
    assert free_at(g, 4, [(wall - 1 if wall % 2 else wall + 1, 20)]) == 1


def test_the_answers_of_recent_maps_are_kept(monkeypatch):
    monkeypatch.setattr(coarsen, "_KEPT", type(coarsen._KEPT)())
    g = corridors(64, 15)
    k = coarsest_keeping(g, 8)
    calls = []
    monkeypatch.setattr(coarsen, "_coarsest", lambda *a: calls.append(a) or 1)
    assert coarsest_keeping(g.copy(), 8) == k and not calls  # the same cells: kept
    assert coarsest_keeping(~g, 8) == 1 and calls  # other cells: scanned


@pytest.mark.parametrize("name", ["maze512-32-0"])
def test_a_movingai_maze_reads_four_times_coarser(movingai, name):
    from planners.maps.readers import read_movingai

    g = read_movingai(movingai / f"{name}.map").obstacles
    assert coarsest_keeping(g, 4) == 4
