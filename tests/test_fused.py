"""``planners.fused``: a compiled sampler's draws inside RRT's loop, the refill schedule and the growing floor."""

from __future__ import annotations

import numba as nb
import numpy as np
import pytest

from planners import RRT, OccupancyGrid, Problem, RRTConnect, SamplerBase
from planners.fused import CHUNK, FIRST_REFILL, fuse_rrt, growing_floor, next_double, refill_size, rng_address, rrt_loop


@nb.njit(cache=True)
def _uniform_draw(state, vertices, n, best_vertex, best_distance, iteration, rng, pts, anchored):
    low, high, calls = state
    calls[0] += 1
    for k in range(pts.shape[0]):
        for d in range(pts.shape[1]):
            pts[k, d] = low[d] + (high[d] - low[d]) * next_double(rng)


@nb.njit(cache=True)
def _uniform_loop(budget, state, buffers, rng, loop):
    return rrt_loop(budget, _uniform_draw, state, buffers, rng, loop)


class _FusedUniform(SamplerBase):
    """``UniformSampler``'s draws, ``batch`` at a time, through ``planners.fused``."""

    def __init__(self, batch: int) -> None:
        self.batch = batch

    def _setup(self) -> None:
        self.state = (self.low, self.high, np.zeros(1, dtype=np.int64))

    def draw(self, rng, n, view):
        pts = np.empty((min(n, self.batch), 2))
        _uniform_draw(self.state, view.vertices, view.num_vertices, view.best_vertex, view.best_distance,
                      view.iteration, rng_address(rng), pts, np.zeros(0, np.int8))
        return pts

    def fuse(self, planner):
        return fuse_rrt(planner, _uniform_loop, self.state, self.batch)


@pytest.fixture(scope="module")
def walled():
    grid = np.zeros((40, 40), bool)
    grid[:30, 20] = True
    return Problem(OccupancyGrid(grid, 1.0), [2.5, 2.5], [37.5, 2.5])


@pytest.mark.parametrize("batch", [1, 100, 5000])
def test_a_fused_draw_runs_what_the_draws_run_at_the_planners_refill_schedule(walled, batch):
    runs = []
    for fused in (True, False):
        sampler = _FusedUniform(batch)
        if not fused:
            sampler.fuse = lambda planner: None
        planner = RRT(walled, step_size=2.0, sampler=sampler, seed=4)
        assert (planner._fused is not None) == fused
        for _ in range(3):
            planner.step()
        planner.solve(max_iterations=77)
        r = planner.solve(max_iterations=20000)
        runs.append((r.iterations, r.num_vertices, r.path.tobytes(), int(planner.sampler.state[2][0])))
    assert runs[0] == runs[1] and runs[0][0] > 200  # same samples, same number of draws
    # other planners never fuse: RRT-Connect draws through draw()
    assert RRTConnect(walled, step_size=2.0, sampler=_FusedUniform(batch), seed=4)._fused is None


def test_the_refill_schedule_doubles_from_the_first_refill_up_to_a_chunk():
    sizes = [refill_size(k) for k in range(40)]
    assert sizes[0] == FIRST_REFILL and sizes[-1] == CHUNK
    assert all(b in (a, 2 * a) for a, b in zip(sizes, sizes[1:], strict=False))


def test_the_uniform_floor_grows_with_the_time_stalled_up_to_its_maximum():
    assert growing_floor(0.05, 0.5, 200, 199) == 0.05
    assert growing_floor(0.05, 0.5, 200, 400) == pytest.approx(0.1)
    assert growing_floor(0.05, 0.5, 200, 10**6) == 0.5
