"""The classical samplers draw inside the planners' compiled loops: the drawn runs, on every world."""

from __future__ import annotations

import pytest

from planners import make_planner
from planners.base.samplers import GoalBiasedSampler, UniformSampler, draw_classical_in_loops
from planners.compile import NEEDS, WORLDS
from planners.kernels import cache


class DrawnUniform(UniformSampler):
    """``UniformSampler`` through ``draw`` only."""

    fuse = None


class DrawnGoalBias(GoalBiasedSampler):
    """``GoalBiasedSampler`` through ``draw`` only."""

    fuse = None


class OwnDraw(UniformSampler):
    """A subclass that draws otherwise: its ``draw`` is what it means, so it is never fused."""

    def draw(self, rng, n, view):
        return self._uniform(rng.random((n, self.problem.dim)) * 0.5)


def _run(planner_name, problem, sampler, seed, pieces=()):
    planner = make_planner(planner_name, problem, sampler=sampler, seed=seed)
    for size in pieces:
        planner.solve(max_iterations=size)
    r = planner.solve(max_iterations=600 - sum(pieces))
    return (r.solved, r.iterations, r.collision_checks, r.num_vertices, r.cost,
            None if r.path is None else r.path.tobytes()), planner


@pytest.mark.parametrize("world", list(WORLDS))
@pytest.mark.parametrize("planner_name", ["RRT", "RRTConnect", "RRTstar"])
def test_fused_classical_runs_are_the_drawn_runs(world, planner_name):
    if world in NEEDS and not NEEDS[world][0]():
        pytest.skip(f"{world} worlds need the {NEEDS[world][1]} extra")
    problem = WORLDS[world][0](WORLDS[world][1][0])
    draw_classical_in_loops(problem)
    for fused, drawn in ((UniformSampler(), DrawnUniform()), (GoalBiasedSampler(0.1), DrawnGoalBias(0.1))):
        for seed in (0, 1):
            key, planner = _run(planner_name, problem, fused, seed)
            assert planner.sampler.fuse(planner) is not None  # it does draw in the loop
            assert key == _run(planner_name, problem, drawn, seed)[0]
            assert key == _run(planner_name, problem, fused, seed, pieces=(1, 5, 70))[0]


def test_a_subclass_with_its_own_draw_and_a_planner_without_a_loop_are_not_fused():
    problem = WORLDS["grid"][0]("euclidean")
    draw_classical_in_loops(problem)
    rrt = make_planner("RRT", problem, sampler=OwnDraw(), seed=0)
    assert rrt.sampler.fuse(rrt) is None
    prm = make_planner("PRM", problem, sampler=UniformSampler(), seed=0)
    assert prm.sampler.fuse(prm) is None
    own, plain = _run("RRT", problem, OwnDraw(), 0)[0], _run("RRT", problem, DrawnUniform(), 0)[0]
    assert own != plain  # its own samples, drawn through draw


def test_they_draw_in_the_loops_only_once_the_install_chooses_to(tmp_path, monkeypatch):
    # a fresh cache folder: a first solve compiles the planner's kernels and no classical loop
    monkeypatch.setitem(cache._state, "dir", tmp_path)
    grid, rigid = WORLDS["grid"][0]("euclidean"), WORLDS["rigid"][0]("cossin")
    for name in ("RRT", "RRTConnect", "RRTstar"):
        planner = make_planner(name, grid, sampler=GoalBiasedSampler(0.05), seed=0)
        assert planner.sampler.fuse(planner) is None
    draw_classical_in_loops(grid, ("connect",))
    connect = make_planner("RRTConnect", grid, seed=0)
    assert connect.sampler.fuse(connect) is not None
    rrt = make_planner("RRT", grid, seed=0)
    assert rrt.sampler.fuse(rrt) is None  # another loop: not chosen
    other = make_planner("RRTConnect", rigid, seed=0)
    assert other.sampler.fuse(other) is None  # another world kind: not chosen
    chosen = sorted(p.name for p in (tmp_path / "compiled").iterdir() if p.name.startswith("classical"))
    assert chosen == ["classical-draws-connect-GridKernel-" + type(grid.space).__name__]
    with pytest.raises(ValueError, match="unknown loop 'prm'"):
        draw_classical_in_loops(grid, ("prm",))
    # the choice is the cache's: a second process (a fresh record of what it has seen) finds it
    monkeypatch.setattr(cache, "_known", set())
    assert cache.is_compiled("classical-draws-connect", grid.world.kernel, grid.space)
    assert _run("RRTConnect", grid, UniformSampler(), 0)[0] == _run("RRTConnect", grid, DrawnUniform(), 0)[0]


def test_planners_compile_chooses_the_loops_on_the_2d_world_kinds_only(tmp_path, monkeypatch):
    from planners.compile import CLASSICAL_WORLDS, compile_one

    monkeypatch.setitem(cache._state, "dir", tmp_path)  # stamps only: the compiled kernels stay where they are
    assert CLASSICAL_WORLDS == ("grid", "shapes")
    for world in ("grid", "rigid"):
        assert compile_one("RRT", world, WORLDS[world][1][0]) is not None
    chosen = sorted(p.name for p in (tmp_path / "compiled").iterdir() if p.name.startswith("classical"))
    grid = WORLDS["grid"][0]("euclidean")
    assert chosen == ["classical-draws-rrt-GridKernel-" + type(grid.space).__name__]
    rrt = make_planner("RRT", grid, sampler=GoalBiasedSampler(0.05), seed=0)
    assert rrt.sampler.fuse(rrt) is not None
