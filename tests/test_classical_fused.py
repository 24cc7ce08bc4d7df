"""The classical samplers draw inside the planners' compiled loops: the drawn runs, on every world."""

from __future__ import annotations

import pytest

from planners import make_planner
from planners.base.samplers import GoalBiasedSampler, UniformSampler
from planners.compile import NEEDS, WORLDS


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
    for fused, drawn in ((UniformSampler(), DrawnUniform()), (GoalBiasedSampler(0.1), DrawnGoalBias(0.1))):
        for seed in (0, 1):
            key, planner = _run(planner_name, problem, fused, seed)
            assert planner.sampler.fuse(planner) is not None  # it does draw in the loop
            assert key == _run(planner_name, problem, drawn, seed)[0]
            assert key == _run(planner_name, problem, fused, seed, pieces=(1, 5, 70))[0]


def test_a_subclass_with_its_own_draw_and_a_planner_without_a_loop_are_not_fused():
    problem = WORLDS["grid"][0]("euclidean")
    rrt = make_planner("RRT", problem, sampler=OwnDraw(), seed=0)
    assert rrt.sampler.fuse(rrt) is None
    prm = make_planner("PRM", problem, sampler=UniformSampler(), seed=0)
    assert prm.sampler.fuse(prm) is None
    own, plain = _run("RRT", problem, OwnDraw(), 0)[0], _run("RRT", problem, DrawnUniform(), 0)[0]
    assert own != plain  # its own samples, drawn through draw
