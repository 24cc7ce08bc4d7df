"""Obstacle-based PRM (OB-PRM): roadmap samples placed near obstacle boundaries.

``ObstacleBasedSampler`` draws a colliding configuration, picks a random direction and steps out of
the obstacle to the first free configuration, so every sample it makes hugs an obstacle. Narrow
passages are lined by obstacle boundary, so they get far more samples than uniform sampling gives
them (their share of the boundary, not of the area). ``OBPRM`` is ``PRM`` with that sampler, and
``compare_prm_variants`` measures PRM, Lazy-PRM and OB-PRM on walls with gaps of several widths and
on an open forest map (behind ``scripts/obprm_compare.py``).

N. M. Amato, O. B. Bayazit, L. K. Dale, C. Jones, D. Vallejo, "OBPRM: an obstacle-based PRM for 3D
workspaces", WAFR 1998; N. M. Amato, Y. Wu, "A randomized roadmap method for path and manipulation
planning", ICRA 1996, doi:10.1109/ROBOT.1996.503582.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence

import numpy as np

from planners.algorithms.prm import DEFAULT_K, PRM
from planners.base.fileio import check_int
from planners.base.problem import Problem
from planners.base.registry import make_planner, planner_class, register_planner
from planners.base.samplers import SampleBatch, Sampler, SamplerBase, draw_pooled
from planners.kernels import obprm as obprm_kernels
from planners.maps.generators import generate
from planners.worlds.grid import OccupancyGrid

#: Without an explicit ``max_distance``: this fraction of the sampling box's diagonal (grids: one cell).
DEFAULT_DISTANCE_FRACTION = 0.005
#: Attempts per requested sample after which ``draw`` gives up on obstacle-based samples.
MAX_ATTEMPTS_PER_SAMPLE = 1000


def _positive(label: str, v) -> float:
    try:
        f = float(v)
    except (TypeError, ValueError):
        raise ValueError(f"{label} must be a positive finite number, got {v!r}") from None
    if isinstance(v, bool) or not math.isfinite(f) or f <= 0:
        raise ValueError(f"{label} must be a positive finite number, got {v!r}")
    return f


class ObstacleBasedSampler(SamplerBase):
    """OB-PRM's sampler: free configurations within ``max_distance`` of an obstacle.

    Each sample is, with probability ``uniform_fraction``, a plain uniform sample from the box
    (uniform samples keep the roadmap probabilistically complete and cover open space), and
    otherwise obstacle-based. For an obstacle-based sample the sampler draws uniform candidates: a
    free one is discarded; from
    a colliding one the sampler walks along a uniformly random direction in steps of ``walk_step``
    until the first free configuration (an attempt whose walk leaves the box is discarded), then
    bisects between that configuration and the last colliding one until they are at most
    ``max_distance`` apart, and returns the free end. Every obstacle-based sample is therefore
    collision-free and within ``max_distance`` (Euclidean, in state coordinates) of a colliding
    configuration: a point of an obstacle, or of the world's boundary (a grid's outside counts as
    blocked). The bound is the sampler's resolution; no sample is ever farther out.

    Every attempt counts as a candidate (``SampleBatch.candidates``), discarded ones included, and
    the sampler's own validity checks are counted in ``checks`` (``OBPRM`` adds them to its
    ``collision_checks``). Attempts are drawn in batches and run in compiled code; all randomness
    comes from the generator passed to ``draw``, and each attempt reads a fixed number of uniforms,
    so the samples do not depend on batch sizes. Works on any world through its compiled ``kernel``
    (``OccupancyGrid``, ``GeometricWorld``, rigid-body worlds, whose walk runs in state coordinates).

    Under a planner's time limit (``SamplerBase.set_deadline``) a draw runs its attempts in short
    compiled slices and stops at the deadline (``DrawInterrupted``; the planner undoes it), so a
    refill of many samples among meshes cannot carry a solve past its limit.

    If a requested batch finds no obstacle-based sample within ``MAX_ATTEMPTS_PER_SAMPLE`` attempts
    per requested sample (a world without obstacles), one uniform sample is returned instead, so a
    planner always makes progress.

    Args:
        max_distance: Distance bound of the samples to the nearest colliding configuration; None
            means one cell on an ``OccupancyGrid`` and ``0.005`` x the box diagonal elsewhere.
        uniform_fraction: Probability in [0, 1] that a sample is plain uniform.
        walk_step: Step of the walk out of the obstacle; None means ``max_distance``. A coarser step
            costs fewer checks in thick obstacles (then bisection refines to ``max_distance``) but
            can step over free gaps thinner than itself.
    """

    def __init__(self, max_distance: float | None = None, *, uniform_fraction: float = 0.1,
                 walk_step: float | None = None) -> None:
        self.max_distance = None if max_distance is None else _positive("max_distance", max_distance)
        self.walk_step = None if walk_step is None else _positive("walk_step", walk_step)
        try:
            frac = float(uniform_fraction)
        except (TypeError, ValueError):
            frac = float("nan")
        if isinstance(uniform_fraction, bool) or not (0.0 <= frac <= 1.0):
            raise ValueError(f"uniform_fraction must lie in [0, 1], got {uniform_fraction!r}")
        self.uniform_fraction = frac

    def _setup(self) -> None:
        world = self.problem.world
        diag = float(np.linalg.norm(self.high - self.low))
        if self.max_distance is not None:
            dist = self.max_distance
        elif isinstance(world, OccupancyGrid):
            dist = world.resolution
        else:
            dist = DEFAULT_DISTANCE_FRACTION * diag
        walk = self.walk_step if self.walk_step is not None else dist
        self.distance = dist  # the bound actually guaranteed, after defaults
        self._walk = walk
        self._refine = max(0, math.ceil(math.log2(walk / dist) - 1e-12)) if walk > dist else 0
        self._max_walk = int(math.ceil(diag / walk)) + 1
        self._kernel = world.kernel
        self._per = int(obprm_kernels.per_attempt(self.problem.dim))
        self._rate = 4.0  # running estimate of attempts per sample, sizes the uniform pools
        self.checks = 0

    def draw(self, rng, n, view):
        """Up to ``n`` samples (fewer only when the attempt budget runs out), with candidates per sample."""
        got = draw_pooled(rng, n, self.problem.dim, self._per, self._rate, self._attempts,
                          budget=MAX_ATTEMPTS_PER_SAMPLE * n,
                          deadline=self.deadline_check())
        self.checks += got.checks
        self._rate = got.rate
        out, cand, m = got.points, got.candidates, got.count
        if m == 0:  # nothing near an obstacle: fall back to one uniform sample
            out[0] = self._uniform(rng.random(self.problem.dim))
            cand[0] = got.pending + 1
            return SampleBatch(out[:1], None, cand[:1])
        return SampleBatch(out[:m], None, cand[:m])

    def _attempts(self, u, n, out, cand, state):
        return obprm_kernels.ob_samples(self._kernel, self.low, self.high, u, n, self.uniform_fraction, self._walk,
                                        self._refine, self._max_walk, out, cand, state)

    def __repr__(self) -> str:
        dist = "default" if self.max_distance is None else f"{self.max_distance:g}"
        return f"ObstacleBasedSampler(max_distance={dist}, uniform_fraction={self.uniform_fraction:g})"


@register_planner
class OBPRM(PRM):
    """Obstacle-based PRM: ``PRM`` sampling with ``ObstacleBasedSampler`` by default.

    ``iterations`` counts samples (roadmap attempts), ``candidates`` the sampler's attempts behind
    them, and ``collision_checks`` includes the sampler's own checks, so the cost of finding
    samples near obstacles is not hidden.

    N. M. Amato, O. B. Bayazit, L. K. Dale, C. Jones, D. Vallejo, "OBPRM: an obstacle-based PRM for
    3D workspaces", WAFR 1998.

    Args:
        problem: The planning problem.
        max_distance: As ``ObstacleBasedSampler``.
        uniform_fraction: As ``ObstacleBasedSampler``.
        walk_step: As ``ObstacleBasedSampler``.
        max_edge_length, k, connection, radius: As ``PRM``.
        sampler: Another sampler instead (then the three sampler arguments must stay unset).
        seed: Seed of the planner's generator.
    """

    name = "OBPRM"
    own_sampler = True

    def __init__(self, problem: Problem, *, max_distance: float | None = None, uniform_fraction: float = 0.1,
                 walk_step: float | None = None, max_edge_length: float | None = None, k: int = DEFAULT_K,
                 connection: str = "knn", radius: float | None = None, sampler: Sampler | None = None,
                 seed: int | None = None) -> None:
        if sampler is None:
            sampler = ObstacleBasedSampler(max_distance, uniform_fraction=uniform_fraction, walk_step=walk_step)
        elif max_distance is not None or walk_step is not None or uniform_fraction != 0.1:
            raise ValueError("give either sampler or the ObstacleBasedSampler arguments, not both")
        super().__init__(problem, max_edge_length=max_edge_length, k=k, connection=connection, radius=radius,
                         sampler=sampler, seed=seed)

    def clear(self) -> None:
        """As ``Planner.clear``; the sampler's check count restarts too."""
        self._sampler_checks = 0  # checks of samplers bound for earlier queries
        super().clear()

    def query(self, start, goal, *, max_iterations: int | None = 0, time_limit: float | None = None,
              name: str | None = None):
        """As ``PRM.query``; the sampler's checks so far stay counted."""
        self._sampler_checks += int(getattr(self.sampler, "checks", 0))
        return super().query(start, goal, max_iterations=max_iterations, time_limit=time_limit, name=name)

    @property
    def collision_checks(self) -> int:
        """The roadmap's validity checks plus those the sampler made to place its samples."""
        return super().collision_checks + self._sampler_checks + int(getattr(self.sampler, "checks", 0))


# --- comparison on narrow passages ------------------------------------------------------------------


def wall_with_gap(gap: int, size: int = 128, *, thickness: int | None = None, seed: int = 0,
                  goal_tolerance: float = 2.0) -> Problem:
    """A ``size`` x ``size`` grid split by a wall with one gap ``gap`` cells wide, start and goal on either side.

    The vertical wall (``thickness`` cells, default ``size / 16``) lies at the map's middle; the gap
    is at a random height away from the ends. A few blocks are scattered clear of the wall, and
    start and goal are random free cell centres at least ``size / 8`` from the wall on opposite
    sides. Everything random comes from ``seed``.
    """
    check_int(gap, "gap")
    rng = np.random.default_rng(seed)
    t = thickness if thickness is not None else max(2, size // 16)
    obs = np.zeros((size, size), dtype=bool)
    x0 = size // 2 - t // 2
    obs[:, x0:x0 + t] = True
    y0 = int(rng.integers(size // 8, size - size // 8 - gap + 1))
    obs[y0:y0 + gap, x0:x0 + t] = False
    clear = max(3, size // 16)
    for _ in range(int(rng.integers(4, 9))):
        h, w = (int(v) for v in rng.integers(max(2, size // 40), max(3, size // 12) + 1, size=2))
        r, c = int(rng.integers(0, size - h)), int(rng.integers(0, size - w))
        if c + w <= x0 - clear or c >= x0 + t + clear:
            obs[r:r + h, c:c + w] = True
    grid = OccupancyGrid(obs)

    def pick(c_lo: int, c_hi: int) -> np.ndarray:
        free = np.argwhere(~obs[:, c_lo:c_hi])
        r, c = free[rng.integers(len(free))]
        return grid.cell_center(int(r), int(c) + c_lo)

    margin = size // 8
    return Problem(grid, pick(0, x0 - margin), pick(x0 + t + margin, size), goal_tolerance=goal_tolerance,
                   name=f"wall-gap{gap}-{size}-{seed}")


#: The roadmap planners ``compare_prm_variants`` runs (registered names).
PRM_VARIANTS = ("PRM", "LazyPRM", "OBPRM")


def prm_comparison_maps(seeds: int, size: int = 128, gaps: Sequence[int] = (1, 2, 4, 8)) -> dict[str, list[Problem]]:
    """Walls with a gap of each width in ``gaps`` and open forest maps, ``seeds`` of each."""
    maps = {f"wall-gap{g}": [wall_with_gap(g, size, seed=s) for s in range(seeds)] for g in gaps}
    maps["forest (open)"] = [generate("forest", s, size) for s in range(seeds)]
    return maps


def compare_prm_variants(maps: dict[str, list[Problem]] | None = None, *, seeds: int = 10, size: int = 128,
                         gaps: Sequence[int] = (1, 2, 4, 8), max_iterations: int = 20000,
                         planners: Sequence[str] = PRM_VARIANTS,
                         progress: Callable[[str], None] | None = None) -> tuple[list[dict], list[dict]]:
    """PRM, Lazy-PRM and OB-PRM on narrow-passage maps of several gap widths and an open forest map.

    Every planner solves every query of every map with seed ``i`` for query ``i`` and a budget of
    ``max_iterations`` samples. Medians are over all runs, an unsolved run counting at its budget
    (so a median equals the budget when fewer than half the runs succeed); ``collision_checks``
    include OB-PRM's sampling checks.

    Args:
        maps: Queries per map label; None builds ``prm_comparison_maps(seeds, size, gaps)``.
        seeds: Queries per map when ``maps`` is None.
        size: Map side when ``maps`` is None.
        gaps: Gap widths (cells) when ``maps`` is None.
        max_iterations: Sample budget per run.
        planners: Registered roadmap planner names to run (default ``PRM_VARIANTS``).
        progress: Called with a line of text after each map.

    Returns:
        ``(rows, runs)``: one row per (map, planner) with ``runs``, ``success``,
        ``median_samples``, ``median_candidates``, ``median_checks``, ``median_time_s``; and one dict
        per run.
    """
    if maps is None:
        maps = prm_comparison_maps(seeds, size, gaps)
    for label in planners:
        planner_class(label)  # an unknown name fails here, before any planning
    # load compiled kernels before anything is timed
    first = next(iter(maps.values()))[0]
    for label in planners:
        make_planner(label, first, seed=0).solve(max_iterations=50)
    runs: list[dict] = []
    rows: list[dict] = []
    for name, problems in maps.items():
        for label in planners:
            mine = []
            for i, p in enumerate(problems):
                planner = make_planner(label, p, seed=i)
                t0 = time.perf_counter()
                r = planner.solve(max_iterations=max_iterations)
                wall = time.perf_counter() - t0
                if r.solved and not p.world.path_valid(r.path):  # never expected: flag it loudly
                    raise AssertionError(f"{label} returned an invalid path on {p.name}")
                mine.append({"map": name, "query": p.name, "planner": label, "seed": i, "solved": r.solved,
                             "samples": r.iterations, "candidates": r.candidates,
                             "collision_checks": r.collision_checks, "vertices": r.num_vertices,
                             "cost": r.cost, "time_s": wall})
            runs += mine
            rows.append({
                "map": name, "planner": label, "runs": len(mine),
                "success": float(np.mean([m["solved"] for m in mine])),
                "median_samples": float(np.median([m["samples"] for m in mine])),
                "median_candidates": float(np.median([m["candidates"] for m in mine])),
                "median_checks": float(np.median([m["collision_checks"] for m in mine])),
                "median_time_s": float(np.median([m["time_s"] for m in mine])),
            })
        if progress is not None:
            progress(f"{name}: done")
    return rows, runs
