"""The workspace route of the body's centre in mesh worlds: the inner radius, free voxels, the route, samplers."""

from __future__ import annotations

import numpy as np
import pytest

trimesh = pytest.importorskip("trimesh", reason="mesh worlds need the mesh extra (pip install samplergym[mesh])")
pytest.importorskip("fcl", reason="mesh worlds need the mesh extra (pip install samplergym[mesh])")

from test_mesh_world import box, wall_with_hole  # noqa: E402  (the same wall with a hole)

from planners import Problem, make_planner  # noqa: E402
from planners.base.fileio import InputError  # noqa: E402
from planners.guidance.workspace_route import centre_route, voxel_route  # noqa: E402
from planners.worlds.mesh import MeshWorld, solid_inner_radius  # noqa: E402


@pytest.fixture(scope="module")
def world():
    body = box((1.0, 1.0, 1.0), (0.0, 0.0, 0.0))
    return MeshWorld(wall_with_hole(), body, low=(0, 0, 0), high=(10, 10, 10), grid_cells=64)


def triangle_distances(mesh, points):
    """Each point's distance to the mesh's triangles, by dense sampling of every triangle (an upper bound)."""
    rng = np.random.default_rng(0)
    uv = rng.random((4000, 2))
    uv[uv.sum(axis=1) > 1] = 1 - uv[uv.sum(axis=1) > 1]
    uv = np.concatenate([uv, [[0, 0], [1, 0], [0, 1]]])
    tri = np.asarray(mesh.triangles)
    pts = (tri[:, None, 0] + uv[None, :, :1] * (tri[:, None, 1] - tri[:, None, 0])
           + uv[None, :, 1:] * (tri[:, None, 2] - tri[:, None, 0])).reshape(-1, 3)
    return np.array([np.linalg.norm(pts - p, axis=1).min() for p in points])


def test_the_inner_radius_is_the_ball_about_the_origin_inside_the_solid():
    b = box((2.0, 4.0, 6.0), (0.0, 0.0, 0.0))
    assert solid_inner_radius(np.asarray(b.vertices), np.asarray(b.faces)) == pytest.approx(1.0)
    moved = box((2.0, 4.0, 6.0), (5.0, 0.0, 0.0))  # the origin outside the solid
    assert solid_inner_radius(np.asarray(moved.vertices), np.asarray(moved.faces)) == 0.0
    ball = trimesh.creation.icosphere(subdivisions=3, radius=2.0)
    r = solid_inner_radius(np.asarray(ball.vertices), np.asarray(ball.faces))
    assert 1.95 < r <= 2.0
    for seed in range(3):  # the distance to the triangles, against dense sampling, about other points too
        rng = np.random.default_rng(seed)
        blob = trimesh.creation.icosphere(subdivisions=1, radius=1.0)
        blob.vertices = np.asarray(blob.vertices) * rng.uniform(0.7, 1.3, (len(blob.vertices), 1))
        r = solid_inner_radius(np.asarray(blob.vertices), np.asarray(blob.faces))
        assert r > 0
        assert r == pytest.approx(triangle_distances(blob, [np.zeros(3)])[0], abs=2e-2)
        assert r <= triangle_distances(blob, [np.zeros(3)])[0] + 1e-9


def test_the_clearance_bound_never_exceeds_the_distance_to_the_environment(world):
    rng = np.random.default_rng(1)
    # near the wall, farther from the grid's edge (which the bound counts as an obstacle) than from the wall
    pts = np.column_stack([rng.uniform(3.5, 6.5, 60), rng.uniform(3.0, 7.0, (60, 2))])
    bound = world.workspace_clearance(pts)
    exact = triangle_distances(wall_with_hole(), pts)
    assert np.all(bound <= exact + 1e-9)
    # a Chebyshev bound in voxels: the distance is at most sqrt(3) times it, plus two voxels
    assert np.all(exact <= np.sqrt(3) * (bound + 2 * world.route_cell))
    assert world.workspace_clearance([[100.0, 0.0, 0.0]])[0] == 0.0  # outside the grid: no bound


def test_free_voxels_leave_out_the_wall_and_keep_the_hole(world):
    cell = world.route_cell
    free = world.centre_free_voxels(cell)
    assert free.shape == tuple(np.floor(10 / cell).astype(int) for _ in range(3))

    def at(p):
        return free[tuple(np.floor(np.asarray(p) / cell).astype(int))]

    assert not at((5.0, 2.0, 2.0)) and not at((5.0, 8.0, 5.0))  # in the wall
    assert at((5.0, 5.0, 5.0)) and at((2.0, 2.0, 2.0)) and at((8.0, 8.0, 8.0))


def test_the_route_crosses_the_wall_through_its_hole(world):
    start, goal = np.array([2.0, 2.0, 8.0, 0, 0, 0]), np.array([8.0, 8.0, 2.0, 0, 0, 0])
    route = voxel_route(world, start, goal)
    assert np.array_equal(route[0], start[:3]) and np.array_equal(route[-1], goal[:3])
    k = int(np.flatnonzero((route[:-1, 0] < 5.0) & (route[1:, 0] >= 5.0))[0])
    t = (5.0 - route[k, 0]) / (route[k + 1, 0] - route[k, 0])
    crossing = route[k] + t * (route[k + 1] - route[k])
    assert np.all(np.abs(crossing[1:] - 5.0) < 1.0)  # inside the hole
    moved = centre_route(world, route, 2)
    assert moved.shape == route.shape and np.array_equal(moved[[0, -1]], route[[0, -1]])
    assert np.all(world.workspace_clearance(moved[1:-1]) >= world.workspace_clearance(route[1:-1]))


def test_the_route_samplers_plan_a_mesh_world_seeded_and_the_learned_one_says_it_needs_boxes(world):
    from learning.samplers.registry import make_sampler

    problem = Problem(world, np.array([2.0, 2.0, 8.0, 0, 0, 0]), np.array([8.0, 8.0, 2.0, 0, 0, 0]),
                      goal_tolerance=0.5)
    for name in ("rigid_workspace_route", "rigid_route_ablation"):
        runs = [make_planner("RRTConnect", problem, seed=3, sampler=make_sampler(name)).solve(max_iterations=3000)
                for _ in range(2)]
        assert runs[0].solved and np.array_equal(runs[0].path, runs[1].path), name
        assert all(problem.world.check_motion(a, b) for a, b in zip(runs[0].path[:-1], runs[0].path[1:], strict=True))
    on_route = make_sampler("rigid_workspace_route", route_fraction=1.0, spread=0.0).bind(problem)
    pts = on_route.draw(np.random.default_rng(0), 200, None)[:, :3]
    a, b = on_route.route[:-1], on_route.route[1:]  # every position on the route's polyline
    t = np.clip(np.einsum("nkj,kj->nk", pts[:, None] - a, b - a) / np.maximum(((b - a) ** 2).sum(1), 1e-300), 0, 1)
    assert np.linalg.norm(a + t[..., None] * (b - a) - pts[:, None], axis=2).min(axis=1).max() < 1e-9
    with pytest.raises(InputError, match="rigid_route_ablation"):
        make_planner("RRTConnect", problem, seed=0, sampler=make_sampler("rigid_route")).solve(max_iterations=10)
