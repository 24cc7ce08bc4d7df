"""The workspace route of the body's centre in mesh worlds: the inner radius, free voxels, the route, samplers."""

from __future__ import annotations

import numpy as np
import pytest

trimesh = pytest.importorskip("trimesh", reason="mesh worlds need the mesh extra (pip install samplergym[mesh])")
pytest.importorskip("fcl", reason="mesh worlds need the mesh extra (pip install samplergym[mesh])")

from test_mesh_world import box, wall_with_hole  # noqa: E402  (the same wall with a hole)

from planners import Problem, make_planner  # noqa: E402
from planners.guidance.workspace_route import centre_route, voxel_route  # noqa: E402
from planners.kernels.mesh import squared_distance_voxels  # noqa: E402
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
    # the Euclidean term: where the bound is positive, the distance exceeds it by at most 2 sqrt(3) voxels
    assert np.all(exact[bound > 0] <= bound[bound > 0] + 2 * np.sqrt(3) * world.route_cell + 1e-9)
    assert np.all(exact <= np.sqrt(3) * (bound + 2 * world.route_cell))  # never worse than the Chebyshev bound alone
    assert world.workspace_clearance([[100.0, 0.0, 0.0]])[0] == 0.0  # outside the grid: no bound


def test_the_squared_distances_are_the_brute_force_ones_with_the_layer_around_the_grid():
    rng = np.random.default_rng(4)
    for _ in range(40):
        nx, ny, nz = (int(n) for n in rng.integers(1, 9, size=3))
        grid = (rng.random((nx, ny * nz)) > rng.uniform(0.0, 0.3)).astype(np.uint8)  # 0: a voxel meets a triangle
        touched = np.ones((nx + 2, ny + 2, nz + 2), dtype=bool)  # the layer around the grid counts as met
        touched[1:-1, 1:-1, 1:-1] = grid.reshape(nx, ny, nz) == 0
        sites = np.argwhere(touched) - 1
        cells = np.indices((nx, ny, nz)).reshape(3, -1).T
        brute = ((cells[:, None, :] - sites[None]) ** 2).sum(axis=2).min(axis=1)
        assert np.array_equal(squared_distance_voxels(grid, nx, ny, nz).reshape(-1), brute.astype(np.float32))


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


def test_the_route_samplers_plan_a_mesh_world_seeded(world):
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
    # the learned one too: its classes carried to the body's own axes, seeded
    runs = [make_planner("RRTConnect", problem, seed=3, sampler=make_sampler("rigid_route")).solve(max_iterations=3000)
            for _ in range(2)]
    assert runs[0].solved and np.array_equal(runs[0].path, runs[1].path)


def test_on_a_mesh_world_every_planner_takes_the_roadmaps_rule_and_a_users_setting_holds(world):
    from learning.samplers.registry import make_sampler
    from learning.samplers.rigid_route import SHIPPED_RIGID_ROADMAP, SHIPPED_RIGID_SETTINGS, TREES_KEEP
    from planners.worlds.rigid_scenes import rigid_scene

    problem = Problem(world, np.array([2.0, 2.0, 8.0, 0, 0, 0]), np.array([8.0, 8.0, 2.0, 0, 0, 0]),
                      goal_tolerance=0.5)
    for name in ("RRT", "RRTConnect", "PRM"):
        bound = make_planner(name, problem, seed=0, sampler=make_sampler("rigid_route")).sampler
        ours = {**SHIPPED_RIGID_ROADMAP, **({} if name == "PRM" else
                                            {k: SHIPPED_RIGID_SETTINGS[k] for k in TREES_KEEP})}
        assert all(getattr(bound, k) == v for k, v in ours.items() if k != "uniform_ramp"), name
        # a tree keeps its uniform floor; a roadmap draws every sample on the route
        assert (bound.route_fraction < 1) == (name != "PRM"), name
        assert bound.refs.shape == (len(bound.route), 3, 3)
        # the trees turn to uniform angles as a query goes on; a roadmap keeps every sample and never does
        assert bound.uniform_ramp == (0.0 if name == "PRM" else SHIPPED_RIGID_ROADMAP["uniform_ramp"]), name
    # a box world: the trees keep their own rule
    tree = make_planner("RRT", rigid_scene("slot", 12345), seed=0, sampler=make_sampler("rigid_route")).sampler
    assert all(getattr(tree, k) == SHIPPED_RIGID_SETTINGS[k] for k in SHIPPED_RIGID_ROADMAP)
    # what a user sets holds on a mesh world too; what they leave is the roadmaps'
    mine = make_sampler("rigid_route", symmetry="ends", angle_noise=0.2)
    bound = make_planner("RRTConnect", problem, seed=0, sampler=mine).sampler
    assert (bound.symmetry, bound.angle_noise) == ("ends", 0.2)
    assert (bound.route_fraction, bound.uniform_share) == (SHIPPED_RIGID_SETTINGS["route_fraction"],
                                                          SHIPPED_RIGID_ROADMAP["uniform_share"])
    assert make_planner("PRM", problem, seed=0, sampler=mine).sampler.route_fraction == 1.0
    # the sampler handed over is unchanged: as given, the rest the trees'
    assert (mine.symmetry, mine.route_fraction) == ("ends", SHIPPED_RIGID_SETTINGS["route_fraction"])


def test_a_tree_on_a_mesh_world_comes_to_its_uniform_floor_over_the_ramp(world):
    from learning.samplers.registry import make_sampler

    problem = Problem(world, np.array([2.0, 2.0, 8.0, 0, 0, 0]), np.array([8.0, 8.0, 2.0, 0, 0, 0]),
                      goal_tolerance=0.5)
    floor = make_sampler("rigid_route", goal_share=0.0, uniform_ramp=1000).bind(problem)
    # every sample on the route (a user's route_fraction holds), the same stream otherwise
    plain = make_sampler("rigid_route", goal_share=0.0, uniform_ramp=1000, route_fraction=1.0).bind(problem)
    assert (floor.route_fraction, plain.route_fraction) == (0.75, 1.0)
    rng = np.random.default_rng(5)
    q = np.concatenate([floor.draw(rng, 600, None), floor.draw(rng, 1400, None)])  # batches: the count runs on
    p = plain.draw(np.random.default_rng(5), 2000, None)
    uniform = np.any(q[:, :3] != p[:, :3], axis=1)  # the floor's uniform states: where the positions part
    assert uniform[:200].mean() < 0.06 and 0.18 < uniform[1000:].mean() < 0.32  # from none to a quarter
    assert np.array_equal(q[~uniform], p[~uniform])  # the route samples are the plain stream's, angles and all
    # seeded; a new query starts the ramp again; a roadmap draws every sample on the route
    again = make_sampler("rigid_route", goal_share=0.0, uniform_ramp=1000).bind(problem)
    assert np.array_equal(again.draw(np.random.default_rng(5), 2000, None), q)
    assert make_sampler("rigid_route").for_planner("roadmap").bind(problem).route_fraction == 1.0


def test_the_learned_orientations_put_a_mesh_body_s_long_side_along_a_world_axis():
    from learning.samplers.registry import make_sampler
    from planners.guidance.rigid_orientation import body_axes
    from planners.kernels.rigid import rotation_matrix

    # a 4 x 2 x 1 box body turned off its own axes: its long side must still land on a world axis
    turn = trimesh.transformations.rotation_matrix(0.7, [1, 2, 3])
    body = trimesh.creation.box(extents=(4.0, 2.0, 1.0), transform=turn)
    axes, extents = body_axes(body.vertices)
    assert np.allclose(extents, [4, 2, 1]) and np.allclose(np.linalg.det(axes), 1.0)
    assert np.allclose(np.abs(axes[:, 0] @ turn[:3, 0]), 1.0) and np.allclose(np.abs(axes[:, 1] @ turn[:3, 1]), 1.0)
    world = MeshWorld(wall_with_hole(thickness=0.5, hole=4.5), body, low=(0, 0, 0), high=(10, 10, 10))
    problem = Problem(world, np.array([2.0, 5.0, 5.0, 0, 0, 0]), np.array([8.0, 5.0, 5.0, 0, 0, 0]),
                      goal_tolerance=0.5)
    sampler = make_sampler("rigid_route", uniform_share=0.0, angle_noise=0.0, goal_share=0.0,
                           route_fraction=1.0, uniform_ramp=0).bind(problem)
    assert sampler.probs.shape == (len(sampler.route), 6) and np.allclose(sampler.probs.sum(axis=1), 1.0)
    q = sampler.draw(np.random.default_rng(0), 100, None)
    long_side = np.array([np.asarray(rotation_matrix(*a)) @ axes[:, 0] for a in q[:, 3:]])
    assert np.allclose(np.sort(np.abs(long_side), axis=1), [0, 0, 1], atol=1e-9)


def test_a_mesh_world_s_solid_share_is_the_boxes_volume_where_it_was_built_from_boxes():
    from planners.guidance.rigid_orientation import occupancy_grid, route_observation, route_patches
    from planners.worlds.rigid_scenes import as_mesh_scene, rigid_scene

    box = rigid_scene("duct", 200_000)  # its wall is 5 to 8 thick: the inside of the boxes counts, not only faces
    mesh = as_mesh_scene(box)
    seeds = np.stack([box.start[:3], box.goal[:3]])
    exact, seen = occupancy_grid(box.world, 1.0), occupancy_grid(mesh.world, 1.0, seeds)
    assert exact.shape == seen.shape and seen.dtype == np.float32
    assert np.abs(exact - seen).mean() < 0.02 and np.mean(np.abs(exact - seen) > 0.5) < 0.02
    assert seen[exact == 1.0].mean() > 0.97  # whole voxels inside boxes, the thick wall's middle among them
    with pytest.raises(ValueError, match="seeds"):
        occupancy_grid(mesh.world, 1.0)
    # the sampler's observation reads only the voxels its patches cover: the same values as the whole grid's
    route = voxel_route(mesh.world, box.start, box.goal, 1.0)
    patches, dirs = route_observation(mesh.world, route, 1.0, seeds=seeds)
    assert np.array_equal(patches, route_patches(seen, route, mesh.world.low3, 1.0)) and len(dirs) == len(route)


def test_a_mesh_world_s_shares_by_axis_and_kept_fills_are_the_pointwise_ones():
    import itertools

    from planners.guidance.rigid_orientation import occupancy_grid
    from planners.kernels import mesh as mesh_kernels
    from planners.worlds.rigid_scenes import as_mesh_scene, rigid_scene

    box = rigid_scene("shelves", 200_001)
    world = as_mesh_scene(box).world
    seeds = np.stack([box.start[:3], box.goal[:3]])
    for cell, low in ((1.0, world.low3), (2.7, world.low3 - 0.3)):  # a lattice off the grid's, partly outside it
        shape = np.floor((world.high3 - low) / cell).astype(np.int64) + 1
        corners = low + cell * np.stack(np.meshgrid(*(np.arange(n) for n in shape), indexing="ij"), axis=-1)
        pointwise = world.solid_share(corners.reshape(-1, 3), cell, seeds).reshape(tuple(shape))
        assert np.array_equal(world.solid_share_grid(low, cell, np.zeros(3, dtype=int), shape, seeds), pointwise)
        lo, hi = np.array([1, 2, 0]), shape - np.array([0, 1, 2])
        part = world.solid_share_grid(low, cell, lo, hi, seeds)
        assert np.array_equal(part, pointwise[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]])
    assert np.array_equal(occupancy_grid(world, 1.0, seeds), world.solid_share_grid(
        world.low3, 1.0, np.zeros(3, dtype=int), np.maximum(1, np.floor(world.high3 - world.low3)).astype(int), seeds))
    # the kept parts of the open voxels: what one fill from every seed (and the voxels about it) reaches
    # the sampler's observation over runs of compact boxes: each patch as point by point over its own voxels
    from planners.guidance.rigid_orientation import route_boxes, route_observation, voxel_index

    rng = np.random.default_rng(5)  # a long diagonal route (many boxes), jittered
    walk = np.linspace(world.low3, world.high3 - 1e-6, 80) + rng.uniform(-0.5, 0.5, (80, 3))
    walk = np.clip(walk, world.low3, world.high3 - 1e-6)
    for cell in (1.0, 0.7):
        patches, _ = route_observation(world, walk, cell, 3, seeds=seeds)
        low, lattice = world.low3, np.maximum(1, np.floor((world.high3 - world.low3) / cell)).astype(int)
        idx = voxel_index(walk, low, cell, lattice)
        window = np.stack(np.meshgrid(*[np.arange(-3, 4)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
        vox = idx[:, None, :] + window[None]
        inside = np.all((vox >= 0) & (vox < lattice), axis=2)
        expected = np.ones(inside.shape, dtype=np.float32)
        expected[inside] = world.solid_share(low + cell * vox[inside], cell, seeds)
        assert np.array_equal(patches, expected.reshape(-1, 7, 7, 7))
        runs = route_boxes(idx, 3)
        assert len(runs) > 1 and runs[0][0] == 0 and runs[-1][1] == len(walk)
        assert all(b0 == a1 for (_, b0), (a1, _) in zip(runs, runs[1:], strict=False))  # in order, each point once
    shape = np.array(world.grid_shape)
    nx, ny, nz = world.grid_shape
    rng = np.random.default_rng(3)
    for points in [seeds, rng.uniform(world.low3, world.high3, (6, 3)), rng.uniform(world.low3, world.high3, (1, 3)),
                   seeds]:
        near = (points[:, None] - world.grid_origin + world.route_cell
                * np.array(list(itertools.product((-1, 0, 1), repeat=3)))).reshape(-1, 3)
        at = np.floor(near / world.route_cell).astype(np.int64)
        at = at[np.all((at >= 0) & (at < shape), axis=1)]
        once = mesh_kernels.reach_open(world.grid, nx, ny, nz, (at[:, 0] * ny + at[:, 1]) * nz + at[:, 2])
        assert np.array_equal(world.reached_from(points), once)


def test_the_route_benchmark_times_a_mesh_worlds_bind_as_the_sampler_sees_it():
    from learning.evaluation.rigid_speed import PIECES, setup_times
    from learning.samplers.rigid_route import class_frame
    from planners.worlds.rigid_scenes import mesh_scene

    problem = mesh_scene("hatch", 3_000_000)
    (row,) = setup_times([problem], repeats=1)
    assert all(row[p] > 0 for p in PIECES)
    rotations, seen = class_frame(problem.world)
    assert rotations.shape == (6, 4, 3, 3) and seen > 0
    assert np.allclose(np.einsum("csij,csik->csjk", rotations, rotations), np.eye(3))  # still rotations
