"""Planner properties: valid paths, invariants, stepping, resuming, budgets, bad input."""

from __future__ import annotations

from collections import deque

import numba
import numpy as np
import pytest
from conftest import fine_check_path
from hypothesis import given
from hypothesis import strategies as st

from planners import (
    PRM,
    RRT,
    Circle,
    GeometricWorld,
    GoalBiasedSampler,
    InformedRRTStar,
    LazyPRM,
    OccupancyGrid,
    Problem,
    Rectangle,
    RRTConnect,
    RRTStar,
    SampleBatch,
    SamplerBase,
    UniformSampler,
)
from planners.kernels import rrt as rrt_kernels
from planners.kernels.state import I_N, I_SOLVED

ALL = [RRT, RRTConnect, RRTStar, InformedRRTStar, PRM, LazyPRM]


def make(cls, problem, seed=0, step=3.0, **kw):
    if cls in (PRM, LazyPRM):
        return cls(problem, seed=seed, **kw)
    return cls(problem, step_size=step, seed=seed, **kw)


def _bfs_connected(obs, a, b):
    H, W = obs.shape
    seen = np.zeros_like(obs)
    q = deque([a])
    seen[a] = True
    while q:
        r, c = q.popleft()
        if (r, c) == b:
            return True
        for dr, dc in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            rr, cc = r + dr, c + dc
            if 0 <= rr < H and 0 <= cc < W and not obs[rr, cc] and not seen[rr, cc]:
                seen[rr, cc] = True
                q.append((rr, cc))
    return False


def random_problem(seed, size=40, blocks=12, tol=2.0):
    """A random block map with a connected, far-apart query (cell centres)."""
    rng = np.random.default_rng(seed)
    while True:
        obs = np.zeros((size, size), bool)
        for _ in range(blocks):
            r, c = rng.integers(0, size - 4, 2)
            h, w = rng.integers(2, 9, 2)
            obs[r : r + h, c : c + w] = True
        free = np.argwhere(~obs)
        a, b = (tuple(free[i]) for i in rng.choice(len(free), 2, replace=False))
        if np.hypot(a[0] - b[0], a[1] - b[1]) > size / 2 and _bfs_connected(obs, a, b):
            g = OccupancyGrid(obs)
            return Problem(g, g.cell_center(*a), g.cell_center(*b), goal_tolerance=tol)


@pytest.fixture(scope="module")
def open_problem():
    obs = np.zeros((30, 30), bool)
    obs[10:20, 14:16] = True
    g = OccupancyGrid(obs)
    return Problem(g, (2.5, 15.5), (27.5, 15.5), goal_tolerance=1.5)


def check_solution(problem, r):
    assert r.solved
    assert r.path.shape[1] == problem.dim and len(r.path) >= 1
    assert np.array_equal(r.path[0], problem.start)
    assert problem.distance(r.path[-1], problem.goal) <= problem.goal_tolerance + 1e-12
    assert fine_check_path(problem.world, r.path)
    assert r.cost == pytest.approx(problem.path_length(r.path), rel=1e-9, abs=1e-9)
    assert r.first_solution_iteration is not None and r.first_solution_iteration <= r.iterations


@pytest.mark.parametrize("cls", ALL, ids=lambda c: c.name)
@given(seed=st.integers(0, 10**6))
def test_paths_are_valid_on_random_maps(cls, seed):
    p = random_problem(seed)
    planner = make(cls, p, seed=seed)
    # anytime planners spend their whole budget; 3000 iterations include plenty of rewiring
    r = planner.solve(max_iterations=3000 if planner.anytime else 20000)
    check_solution(p, r)


@pytest.mark.parametrize("cls", ALL, ids=lambda c: c.name)
def test_geometric_world(cls):
    w = GeometricWorld(60, 40, [Circle(30, 20, 8), Rectangle(10, 0, 14, 28), Rectangle(44, 12, 48, 40)])
    p = Problem(w, (3, 5), (57, 35), goal_tolerance=1.0)
    r = make(cls, p, seed=1).solve(max_iterations=20000)
    check_solution(p, r)


# Each (planner, metric) compiles the planner's kernels for that metric (10-30 s of the suite each). The
# default tier runs every planner on one of the two metrics and each metric with a tree planner (the k-d
# index answers both in test_nn); the rest of the product runs with -m slow.
@pytest.mark.parametrize("cls, metric", [
    (RRT, "chebyshev"), (RRTStar, "manhattan"), (PRM, "chebyshev"),
    pytest.param(RRT, "manhattan", marks=pytest.mark.slow),
    pytest.param(RRTStar, "chebyshev", marks=pytest.mark.slow),
    pytest.param(PRM, "manhattan", marks=pytest.mark.slow),
], ids=lambda v: getattr(v, "name", v))
def test_other_metrics(cls, metric, open_problem):
    p = open_problem.with_query(open_problem.start, open_problem.goal, metric=metric)
    r = make(cls, p).solve(max_iterations=20000)
    check_solution(p, r)


@pytest.mark.parametrize("cls", [PRM, LazyPRM], ids=lambda c: c.name)
@pytest.mark.parametrize("connection", ["knn", "radius"])
def test_roadmap_edges_are_valid(cls, connection):
    p = random_problem(7)
    planner = cls(p, connection=connection, seed=3)
    planner.solve(max_iterations=5000)
    planner.grow(300)
    data = planner.planner_data()
    assert len(data.edges) > 100
    V, E = data.vertices, data.edges
    if cls is PRM:
        assert p.world.check_motions(V[E[:, 0]], V[E[:, 1]]).all()
        assert all(fine_check_path(p.world, V[e]) for e in E[::7])
    else:
        # Lazy-PRM keeps unchecked edges; every edge on the returned path was checked
        check_solution(p, planner.result())


def test_prm_multi_query_reuses_the_roadmap():
    p = random_problem(11)
    prm = PRM(p, seed=0)
    prm.grow(2000)
    before = prm.num_vertices
    g = p.world
    free = np.argwhere(~g.obstacles)
    rng = np.random.default_rng(0)
    solved_without_sampling = 0
    for _ in range(10):
        a, b = (g.cell_center(*free[i]) for i in rng.choice(len(free), 2, replace=False))
        if not _bfs_connected(g.obstacles, tuple(np.floor(a[::-1]).astype(int)), tuple(np.floor(b[::-1]).astype(int))):
            continue
        r = prm.query(a, b, max_iterations=5000)
        check_solution(prm.problem, r)
        solved_without_sampling += r.iterations == 0
    assert solved_without_sampling >= 5
    assert prm.num_vertices >= before


def test_rrtstar_invariants_hold_after_every_iteration():
    p = random_problem(5, tol=1.0)
    planner = RRTStar(p, step_size=3.0, sampler=GoalBiasedSampler(0.05), seed=2)
    best = np.inf
    for i in range(3000):
        planner.step()
        if i % 50 == 0 or planner.solved:
            par, cost, el = planner.parents(), planner.costs(), planner.edge_lengths()
            V = planner.planner_data().vertices
            assert par[0] == -1 and cost[0] == 0.0
            assert np.allclose(cost[1:], cost[par[1:]] + el[1:], rtol=0, atol=1e-9)
            assert np.allclose(el[1:], np.linalg.norm(V[1:] - V[par[1:]], axis=1), atol=1e-9)
        c = planner.result().cost
        assert c <= best + 1e-12
        best = c
    assert planner.solved
    check_solution(p, planner.result())
    assert planner.result().cost < planner.result().cost * 0 + planner.problem.path_length(
        RRT(p, step_size=3.0, seed=2).solve(max_iterations=20000).path) + 1e-9


@pytest.mark.parametrize("cls", ALL, ids=lambda c: c.name)
def test_step_equals_solve_and_clear_repeats(cls):
    p = random_problem(21)
    a = make(cls, p, seed=4)
    r1 = a.solve(max_iterations=400 if a.anytime else 20000)
    b = make(cls, p, seed=4)
    for _ in range(r1.iterations):
        b.step()
    assert b.iterations == r1.iterations
    assert np.array_equal(b.result().path, r1.path)
    # solve again: non-anytime planners return at once; anytime ones keep improving
    r2 = a.solve(max_iterations=200)
    if a.anytime:
        assert r2.iterations == r1.iterations + 200 and r2.cost <= r1.cost
    else:
        assert r2.iterations == r1.iterations and np.array_equal(r2.path, r1.path)
    a.clear()
    assert a.iterations == 0 and not a.solved
    r3 = a.solve(max_iterations=400 if a.anytime else 20000)
    assert r3.iterations == r1.iterations and np.array_equal(r3.path, r1.path)
    assert r3.collision_checks == r1.collision_checks


@pytest.mark.parametrize("cls", ALL, ids=lambda c: c.name)
def test_resuming_in_pieces_equals_one_call(cls):
    p = random_problem(33)
    whole = make(cls, p, seed=9).solve(max_iterations=1500)
    pieces = make(cls, p, seed=9)
    for _ in range(3):
        r = pieces.solve(max_iterations=500)
    assert r.iterations == whole.iterations and r.solved == whole.solved
    assert np.array_equal(r.path, whole.path)


@pytest.mark.parametrize("cls", ALL, ids=lambda c: c.name)
def test_seeds_reproduce_and_differ(cls):
    p = random_problem(44)
    r1 = make(cls, p, seed=5).solve(max_iterations=3000)
    r2 = make(cls, p, seed=5).solve(max_iterations=3000)
    r3 = make(cls, p, seed=6).solve(max_iterations=3000)
    assert np.array_equal(r1.path, r2.path) and r1.iterations == r2.iterations
    assert not (np.array_equal(r1.path, r3.path) and r1.iterations == r3.iterations)
    assert r1.seed == 5


@pytest.mark.parametrize("cls", ALL, ids=lambda c: c.name)
def test_unreachable_goal_returns_unsolved(cls):
    obs = np.zeros((20, 20), bool)
    obs[:, 9:11] = True  # a full wall
    g = OccupancyGrid(obs)
    p = Problem(g, (2.5, 10.5), (17.5, 10.5), goal_tolerance=1.0)
    r = make(cls, p).solve(max_iterations=3000)
    assert not r.solved and r.iterations == 3000 and r.stop_reason == "max_iterations"
    assert r.path.shape == (0, 2) and r.cost == np.inf


def test_time_limit_stops(open_problem):
    obs = np.zeros((200, 200), bool)
    obs[:, 99:101] = True
    p = Problem(OccupancyGrid(obs), (5.5, 5.5), (190.5, 5.5))
    r = RRT(p, step_size=2.0, seed=0).solve(time_limit=0.05)
    assert r.stop_reason == "time_limit" and not r.solved and r.iterations > 0
    assert r.time < 1.0


def test_start_within_tolerance_is_solved_at_once(open_problem):
    p = open_problem.with_query((5.5, 5.5), (6.0, 5.5))
    for cls in ALL:
        r = make(cls, p).solve(max_iterations=10)
        assert r.solved and r.first_solution_iteration == 0, cls.name
        check_solution(p, r)


class FixedSampler(SamplerBase):
    """Replays a fixed list of samples (for exact step-level tests)."""

    def __init__(self, pts, anchored=None):
        self.pts = np.asarray(pts, float)
        self.anchored = anchored
        self.i = 0

    def draw(self, rng, n, view):
        j = self.i % len(self.pts)
        self.i += 1
        a = None if self.anchored is None else np.array([self.anchored[j]])
        return SampleBatch(self.pts[j : j + 1], a, np.array([3]))


def test_rrt_step_semantics(open_problem):
    planner = RRT(open_problem, step_size=4.0, sampler=FixedSampler([(12.5, 15.5), (2.5, 15.5), (4.5, 2.0)]), seed=0)
    s = planner.step()  # steer 4 towards (12.5, 15.5)
    assert s.iterated and s.iteration == 1 and s.added == 1
    assert np.allclose(planner.planner_data().vertices[1], (6.5, 15.5))
    assert planner.collision_checks == 1
    s = planner.step()  # sample coincides with the start vertex: no progress, no check
    assert s.added == -1 and planner.collision_checks == 1 and planner.iterations == 2
    s = planner.step()
    assert s.added == 2 and np.allclose(s.sample, (4.5, 2.0))
    assert planner.result().candidates == 9  # each FixedSampler sample reports 3 candidates


def test_anchored_samples_follow_the_progress_vertex(open_problem):
    # offsets of +4 in x from the vertex nearest the goal: the tree marches straight ahead
    planner = RRT(open_problem, step_size=4.0, sampler=FixedSampler([(4.0, 0.0)], anchored=[True]), seed=0)
    for k in range(1, 3):
        planner.step()
        assert np.allclose(planner.planner_data().vertices[k], (2.5 + 4 * k, 15.5))
    assert planner.view().best_vertex == 2
    assert planner.step().added == -1  # the next offset ends inside the wall at column 14


@numba.njit
def _uniform_rrt_loop(budget, rng, tree, istate, fstate, last, world, space, goal, step, tol, low, high, st, sb):
    q, qe, new = np.empty(2), np.empty(2), np.empty(2)
    sample = np.empty(2)
    for s in range(budget):
        if istate[I_SOLVED] or istate[I_N] >= tree.X.shape[0]:
            return s
        for d in range(2):
            sample[d] = low[d] + (high[d] - low[d]) * rng.random()
        rrt_kernels.rrt_iterate(sample, 0, tree, istate, fstate, last, world, space, goal, step, tol, low, high, st,
                                sb, q, qe,
                      new)
    return budget


class FusedUniform(UniformSampler):
    """Uniform samples drawn inside RRT's compiled loop (the ``Sampler.fuse`` hook)."""

    calls = 0

    def fuse(self, planner):
        FusedUniform.calls += 1
        if planner.fusable_loop != "rrt":
            return None
        return lambda planner, n: _uniform_rrt_loop(n, planner.rng, *planner.loop_args())


class DrawnOnlyUniform(UniformSampler):
    """``UniformSampler`` through ``draw`` only (the library's own draws inside the compiled loops)."""

    fuse = None


def test_fused_sampler_hook(open_problem):
    # a fused loop that draws what UniformSampler draws gives the same run, stepped or solved
    ref = RRT(open_problem, step_size=2.0, sampler=DrawnOnlyUniform(), seed=3).solve(max_iterations=5000)
    fused = RRT(open_problem, step_size=2.0, sampler=FusedUniform(), seed=3)
    assert fused._fused is not None
    r = fused.solve(max_iterations=5000)
    assert (r.iterations, r.num_vertices, r.collision_checks, r.candidates) == (ref.iterations, ref.num_vertices,
                                                                               ref.collision_checks, ref.candidates)
    assert np.array_equal(r.path, ref.path)
    stepped = RRT(open_problem, step_size=2.0, sampler=FusedUniform(), seed=3)
    while not stepped.solved:
        stepped.step()
    assert stepped.iterations == r.iterations and np.array_equal(stepped.result().path, r.path)
    # planners without a fusable loop never ask (PRM draws as usual); RRT-Connect and RRT* ask for their own
    # loops, and a sampler that fuses RRT's only draws as usual there
    FusedUniform.calls = 0
    for cls in (RRTConnect, RRTStar, PRM):
        planner = cls(open_problem, sampler=FusedUniform(), seed=0)
        assert planner._fused is None and planner.solve(max_iterations=5000).solved
    assert FusedUniform.calls == 2 and (RRTConnect.fusable_loop, RRTStar.fusable_loop) == ("connect", "rrtstar")


class BadSampler(SamplerBase):
    def __init__(self, out):
        self.out = out

    def draw(self, rng, n, view):
        return self.out


@pytest.mark.parametrize(
    "out, match",
    [(np.full((1, 2), np.nan), "NaN"), (np.zeros((1, 3)), "dimension 2"), (np.zeros((0, 2)), "1..")],
)
def test_bad_sampler_output_is_reported(open_problem, out, match):
    with pytest.raises(ValueError, match=match):
        RRT(open_problem, step_size=2.0, sampler=BadSampler(out)).step()


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(step_size=0), "step_size"),
        (dict(step_size=-1.0), "step_size"),
        (dict(step_size=np.nan), "step_size"),
        (dict(step_size="a"), "step_size"),
        (dict(seed=-1), "seed"),
        (dict(seed=1.5), "seed"),
    ],
)
def test_bad_planner_arguments(open_problem, kwargs, match):
    with pytest.raises(ValueError, match=match):
        RRT(open_problem, **kwargs)


def test_bad_budgets_and_samplers(open_problem):
    planner = RRT(open_problem, step_size=2.0)
    with pytest.raises(ValueError, match="max_iterations or time_limit"):
        planner.solve()
    with pytest.raises(ValueError, match="max_iterations"):
        planner.solve(max_iterations=-5)
    with pytest.raises(ValueError, match="time_limit"):
        planner.solve(time_limit=0)
    with pytest.raises(TypeError, match="sampler"):
        RRT(open_problem, sampler=object())
    with pytest.raises(TypeError, match="Problem"):
        RRT("map.png")
    with pytest.raises(ValueError, match="goal bias"):
        GoalBiasedSampler(1.5)
    with pytest.raises(ValueError, match="connection"):
        PRM(open_problem, connection="grid")
    with pytest.raises(ValueError, match="k must"):
        PRM(open_problem, k=0)


def test_goal_bias_one_walks_straight_to_the_goal(open_problem):
    obs = np.zeros((30, 30), bool)
    p = Problem(OccupancyGrid(obs), (2.5, 2.5), (26.5, 2.5), goal_tolerance=0.5)
    r = RRT(p, step_size=4.0, sampler=GoalBiasedSampler(1.0), seed=0).solve(max_iterations=100)
    assert r.solved and r.iterations == 6 and len(r.path) == 7


def test_uniform_sampler_stays_in_bounds(open_problem):
    s = UniformSampler().bind(open_problem)
    pts = s.draw(np.random.default_rng(0), 10000, None)
    lo, hi = open_problem.world.bounds
    assert pts.shape == (10000, 2) and (pts >= lo).all() and (pts < hi).all()


def test_lazy_prm_resolution_in_bounded_pieces(monkeypatch):
    """One search per call (the time limit is looked at in between) changes nothing but the pacing."""
    import planners.algorithms.prm as prm_mod
    from planners.maps.generators import generate

    problem = generate("maze", 3, 64)
    ref = LazyPRM(problem, seed=2).solve(max_iterations=20000)
    monkeypatch.setattr(prm_mod, "LAZY_ROUNDS", 1)
    pieces = LazyPRM(problem, seed=2).solve(max_iterations=20000)
    assert ref.solved and pieces.solved
    assert fine_check_path(problem.world, pieces.path)
    stepped = LazyPRM(problem, seed=2)
    while not stepped.solved and stepped.iterations < 20000:
        stepped.step()
    assert stepped.iterations == pieces.iterations
    assert np.array_equal(stepped.result().path, pieces.path)


@pytest.mark.parametrize("bitgen", [np.random.PCG64, np.random.MT19937, np.random.Philox, np.random.SFC64])
def test_compiled_draws_through_the_bitgen_address_continue_the_generators_stream(bitgen):
    import numba as nb

    from planners.kernels.bitgen import bitgen_address, next_double

    @nb.njit
    def draw(address, n):
        out = np.empty(n)
        for i in range(n):
            out[i] = next_double(address)
        return out

    a, b = np.random.Generator(bitgen(7)), np.random.Generator(bitgen(7))
    got = np.concatenate([a.random(3), draw(bitgen_address(a), 500), a.random(4)])
    assert np.array_equal(got, b.random(507))
    with pytest.raises(TypeError, match="numpy Generator"):
        bitgen_address(np.random.RandomState(0))
