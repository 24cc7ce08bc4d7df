"""Time limits: one-off compilation is not charged to them, and they hold within TIME_SLICE whatever the input."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import numba
import numpy as np
import pytest
from conftest import REPO
from numba.core.compiler_lock import global_compiler_lock

from planners import (
    OBPRM,
    PRM,
    RRT,
    DrawInterrupted,
    InformedRRTStar,
    LazyPRM,
    OccupancyGrid,
    Problem,
    RRTConnect,
    RRTStar,
    UniformSampler,
    make_planner,
)
from planners.algorithms.obprm import ObstacleBasedSampler
from planners.base.planner import TIME_SLICE, compile_seconds

#: What a timed solve may overrun its limit by here: the stated TIME_SLICE, plus slack for a busy test machine.
MARGIN = TIME_SLICE + 0.05


def walls(n: int, seed: int = 0) -> OccupancyGrid:
    """An n x n map crossed by vertical two-cell walls, each with one two-cell gap: the straight
    optimistic roadmap crosses walls everywhere, so Lazy-PRM needs very many search rounds."""
    rng = np.random.default_rng(seed)
    obs = np.zeros((n, n), dtype=bool)
    for c in range(n // 10, n - 5, n // 10):
        obs[:, c:c + 2] = True
        g = rng.integers(5, n - 5)
        obs[g:g + 2, c:c + 2] = False
    return OccupancyGrid(obs)


def test_compile_seconds_counts_a_real_compilation():
    @numba.njit
    def fresh(x):  # defined here, uncached: its first call compiles
        return np.sort(x)[0] + np.median(x)

    c0, t0 = compile_seconds(), time.perf_counter()
    fresh(np.arange(5.0))
    wall, compiled = time.perf_counter() - t0, compile_seconds() - c0
    assert 0.8 * wall <= compiled <= wall + 1e-6
    c0 = compile_seconds()
    fresh(np.arange(7.0))  # compiled already: nothing more is counted
    assert compile_seconds() == c0


class CompilingSampler(UniformSampler):
    """Uniform, but its first draw spends ``seconds`` inside numba's compiler lock, as a kernel compiling
    on first use does (InformedSampler's, say, whose first call comes with the first solution)."""

    def __init__(self, seconds: float) -> None:
        self.seconds = seconds
        self.compiled = [False]  # shared by the bound copies

    def draw(self, rng, n, view):
        if not self.compiled[0]:
            self.compiled[0] = True
            with global_compiler_lock:
                time.sleep(self.seconds)
        return super().draw(rng, n, view)


@pytest.mark.parametrize("cls", [RRT, RRTConnect, PRM, LazyPRM])
def test_compilation_is_not_charged_to_the_time_limit(cls):
    grid = walls(100)
    problem = Problem(grid, (2.5, 2.5), (97.5, 97.5), goal_tolerance=2.0)
    t0 = time.perf_counter()
    untimed = make_planner(cls.name, problem, extension_step=5.0, seed=3).solve(max_iterations=200_000)
    limit = max(0.3, 3 * (time.perf_counter() - t0))  # ample for the planning, short of the compilation
    assert untimed.solved
    planner = make_planner(cls.name, problem, extension_step=5.0, sampler=CompilingSampler(limit + 0.3), seed=3)
    r = planner.solve(max_iterations=200_000, time_limit=limit)
    assert planner.compile_time >= limit + 0.3
    assert r.solved and r.stop_reason == "solved"
    assert r.iterations == untimed.iterations and r.cost == untimed.cost
    assert r.time >= limit + 0.3  # the wall time still shows it


def test_lazy_prm_search_rounds_respect_the_time_limit():
    # 100,000 roadmap vertices grown untimed; every solve then runs lazy search rounds only. Before
    # rounds were sized by time, one compiled call ran 64 rounds (0.3 s here) past a 0.05 s limit.
    grid = walls(300)
    planner = LazyPRM(Problem(grid, (2.5, 2.5), (297.5, 297.5), goal_tolerance=2.0), seed=0)
    planner.grow(100_000)
    checks = planner.collision_checks
    for _ in range(3):
        # CPU time, not wall time: what the planner controls is the work it does past the deadline; a
        # test worker on the other core can stall this process (the deadline still passes) but not add work
        t0 = time.process_time()
        r = planner.solve(time_limit=0.05)
        elapsed = time.process_time() - t0
        assert r.stop_reason == "time_limit" and not r.solved
        assert elapsed <= 0.05 + MARGIN, f"overran the limit by {elapsed - 0.05:.3f} s of CPU time"
    assert planner.collision_checks > checks  # the rounds did run


def test_lazy_prm_timed_rounds_end_as_untimed():
    # 60 cells: ~6,000 samples and ~2.5 s a solve, some 50 time slices, so the rounds are sized by the
    # clock (9 of them a call at the end, not the 64 of an untimed call). 120 cells took 30 s a solve.
    grid = walls(60, seed=1)
    problem = Problem(grid, (2.5, 2.5), (57.5, 57.5), goal_tolerance=2.0)
    untimed = LazyPRM(problem, seed=2).solve(max_iterations=50_000)
    timed = LazyPRM(problem, seed=2)
    r = timed.solve(max_iterations=50_000, time_limit=60.0)
    assert untimed.solved and r.solved
    assert (r.iterations, r.collision_checks, r.cost) == (untimed.iterations, untimed.collision_checks, untimed.cost)
    np.testing.assert_array_equal(r.path, untimed.path)


@pytest.mark.parametrize("cls", [RRT, RRTConnect, RRTStar, InformedRRTStar, PRM, LazyPRM, OBPRM])
def test_time_limit_holds_on_an_unsolvable_query(cls):
    obs = np.zeros((200, 200), dtype=bool)
    obs[150:160, 150:200] = obs[150:200, 150:160] = True  # the goal's corner is walled off
    problem = Problem(OccupancyGrid(obs), (2.5, 2.5), (190.5, 190.5), goal_tolerance=2.0)
    cls(problem, seed=0).solve(max_iterations=300)  # compiled, as any first use
    planner = cls(problem, seed=0)
    for limit in (0.02, 0.3):
        t0 = time.perf_counter()
        r = planner.solve(time_limit=limit)
        elapsed = time.perf_counter() - t0
        assert r.stop_reason == "time_limit" and not r.solved
        assert limit <= elapsed <= limit + MARGIN


@pytest.mark.slow
def test_first_timed_solve_in_a_fresh_process_with_nothing_compiled(map_png_cold, tmp_path):
    # what a new user sees: an empty numba cache, a 2 s limit. It stopped after 64 iterations.
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba-cache")}
    env.pop("DISPLAY", None)
    p = subprocess.run([sys.executable, str(REPO / "scripts" / "plan.py"), str(map_png_cold), "--start", "5.5", "30.5",
                        "--goal", "90.5", "40.5", "--planner", "informed-rrtstar", "--time-limit", "2",
                        "--out", str(tmp_path / "out"), "--headless", "--no-gif"],
                       capture_output=True, text=True, timeout=600, env=env, cwd=REPO)
    assert p.returncode == 0, p.stdout + p.stderr
    iterations = int(next(line for line in p.stdout.splitlines() if line.startswith("iterations:")).split()[1])
    assert iterations > 2000, p.stdout


@pytest.fixture
def map_png_cold(tmp_path):
    from PIL import Image

    img = np.full((64, 96), 255, dtype=np.uint8)
    img[:, 46:50] = 0
    img[28:34, 46:50] = 255
    path = tmp_path / "floor.png"
    Image.fromarray(img).save(path)
    return path


def test_lazy_prm_keeps_its_adjacency_while_the_roadmap_does_not_grow(monkeypatch):
    # a timed solve of a grown roadmap runs search rounds only: the adjacency is built once for them, and again
    # once the roadmap grows; the runs are those of a planner that builds it for every search
    from planners.kernels import prm as prm_kernels
    from planners.kernels import state as slots

    problem = Problem(walls(60), (2.5, 2.5), (57.5, 57.5), goal_tolerance=2.0)
    planner = LazyPRM(problem, seed=1)
    planner.grow(3000)
    first = planner._adjacency()
    assert planner._adjacency() is first
    planner.grow(10)
    assert planner._adjacency() is not first
    runs = [LazyPRM(problem, seed=s).solve(max_iterations=4000) for s in range(3)]
    monkeypatch.setattr(LazyPRM, "_adjacency", lambda self: prm_kernels.build_csr(
        self._edges, int(self._istate[slots.I_N]), int(self._istate[slots.I_E])))
    again = [LazyPRM(problem, seed=s).solve(max_iterations=4000) for s in range(3)]
    assert any(r.solved for r in runs)
    assert [(r.solved, r.iterations, r.collision_checks, r.cost) for r in runs] == \
        [(r.solved, r.iterations, r.collision_checks, r.cost) for r in again]


class _CutSecondDraw(ObstacleBasedSampler):
    """OB-PRM's sampler whose second draw under a deadline spends part of the stream, then meets the deadline."""

    def __init__(self, draws: list[int]) -> None:
        super().__init__()
        self.draws = draws  # shared by the bound copies

    def draw(self, rng, n, view):
        self.draws.append(n)
        if len(self.draws) == 2:
            rng.random(1000)
            raise DrawInterrupted
        return super().draw(rng, n, view)


def test_a_draw_cut_at_the_deadline_is_undone_and_made_again_on_resuming():
    obs = np.zeros((96, 96), dtype=bool)
    obs[70:75, 60:96] = obs[70:96, 60:65] = True  # the goal's corner is walled off: no solve ends the runs
    problem = Problem(OccupancyGrid(obs), (2.5, 2.5), (90.5, 90.5), goal_tolerance=2.0)
    draws = []
    timed = OBPRM(problem, sampler=_CutSecondDraw(draws), seed=4)
    r = timed.solve(time_limit=60.0)
    assert r.stop_reason == "time_limit" and r.iterations == 64 and draws == [64, 128]  # cut at its second draw
    r = timed.solve(max_iterations=300)
    untimed = OBPRM(problem, seed=4).solve(max_iterations=364)
    assert draws[2] == 128  # the cut draw made again, whole
    assert (r.iterations, r.collision_checks, r.num_vertices) == (364, untimed.collision_checks, untimed.num_vertices)
