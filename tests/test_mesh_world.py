"""Mesh worlds: reading meshes, exact checks against FCL, the broad phase, motions that cannot tunnel, planners."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

trimesh = pytest.importorskip("trimesh", reason="mesh worlds need the mesh extra (pip install samplergym[mesh])")
fcl = pytest.importorskip("fcl", reason="mesh worlds need the mesh extra (pip install samplergym[mesh])")

from planners import GoalBiasedSampler, Problem, make_planner  # noqa: E402
from planners.base.fileio import InputError  # noqa: E402
from planners.kernels import mesh as mesh_kernels  # noqa: E402
from planners.worlds.mesh import DEFAULT_BAND_FRACTION, MeshWorld, read_mesh  # noqa: E402
from planners.worlds.rigid3d import euler_from_matrix, rotation_matrix  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
PI = math.pi


def box(extents, centre):
    return trimesh.creation.box(extents=extents, transform=trimesh.transformations.translation_matrix(centre))


def wall_with_hole(thickness=0.2, hole=2.0):
    """A wall across x = 5 of a 10-cube, with a square hole of side ``hole`` around (5, 5, 5)."""
    lo, hi = 5 - hole / 2, 5 + hole / 2
    parts = [box((thickness, 10, lo), (5, 5, lo / 2)), box((thickness, 10, 10 - hi), (5, 5, (10 + hi) / 2)),
             box((thickness, lo, hole), (5, lo / 2, 5)), box((thickness, 10 - hi, hole), (5, (10 + hi) / 2, 5))]
    return trimesh.util.concatenate(parts)


@pytest.fixture(scope="module")
def hole_world():
    return MeshWorld(wall_with_hole(), trimesh.creation.box(extents=(1.0, 1.0, 1.0)), low=(0, 0, 0), high=(10, 10, 10))


@pytest.fixture(scope="module")
def wide_hole_world():
    return MeshWorld(wall_with_hole(hole=3.0), trimesh.creation.box(extents=(1.0, 1.0, 1.0)), low=(0, 0, 0),
                     high=(10, 10, 10))


def states_along(world, a, b, spacing=None):
    """Poses along a -> b at body-point travel <= spacing (default delta; own interpolation: linear,
    shorter-arc angles)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    dang = (b[3:] - a[3:] + PI) % (2 * PI) - PI
    travel = np.linalg.norm(b[:3] - a[:3]) + world.radius * np.abs(dang).sum()
    n = max(1, int(np.ceil(travel / (world.delta if spacing is None else spacing))))
    t = np.linspace(0.0, 1.0, n + 1)[:, None]
    return np.hstack([a[:3] + t * (b[:3] - a[:3]), a[3:] + t * dang])


def test_importing_planners_loads_no_mesh_library():
    code = ("import json, sys; import planners, planners.worlds.rigid3d; "
            "print(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] in ('trimesh', 'fcl', 'collada'))))")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, check=True,
                         env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"})
    assert json.loads(out.stdout) == []


@pytest.mark.parametrize("suffix", [".obj", ".stl"])
def test_read_mesh_reads_what_trimesh_wrote(tmp_path, suffix):
    mesh = box((1, 2, 3), (4, 5, 6))
    path = tmp_path / f"box{suffix}"
    mesh.export(path)
    V, F = read_mesh(path)
    assert F.shape == (12, 3) and F.dtype == np.int32
    assert np.allclose(V.min(0), [3.5, 4, 4.5]) and np.allclose(V.max(0), [4.5, 6, 7.5])


def test_read_mesh_turns_a_z_up_collada_file_to_y_up_as_assimp_does(tmp_path):
    pytest.importorskip("collada", reason="COLLADA needs pycollada (the mesh extra)")
    path = tmp_path / "box.dae"
    box((1, 2, 3), (4, 5, 6)).export(path)
    text = path.read_text()
    assert "<up_axis>Y_UP</up_axis>" in text
    V, _ = read_mesh(path)
    assert np.allclose(V.min(0), [3.5, 4, 4.5]) and np.allclose(V.max(0), [4.5, 6, 7.5])
    # the same file declared Z_UP: (x, y, z) becomes (x, z, -y)
    path.write_text(text.replace("<up_axis>Y_UP</up_axis>", "<up_axis>Z_UP</up_axis>"))
    V, _ = read_mesh(path)
    assert np.allclose(V.min(0), [3.5, 4.5, -6]) and np.allclose(V.max(0), [4.5, 7.5, -4])


def test_read_mesh_refuses_bad_files(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        read_mesh(tmp_path / "nothing.obj")
    (tmp_path / "a.xyz").write_text("1 2 3\n")
    with pytest.raises(InputError, match="unknown mesh type"):
        read_mesh(tmp_path / "a.xyz")
    (tmp_path / "empty.obj").write_text("# no faces\nv 0 0 0\n")
    with pytest.raises(InputError, match="empty.obj"):
        read_mesh(tmp_path / "empty.obj")
    (tmp_path / "zero.dae").write_bytes(b"")  # a file a partial copy left empty
    with pytest.raises(InputError, match=r"zero.dae is empty \(0 bytes\)"):
        read_mesh(tmp_path / "zero.dae")
    with pytest.raises(InputError, match="face indices"):
        MeshWorld((np.zeros((3, 3)), [[0, 1, 5]]), box((1, 1, 1), (0, 0, 0)), low=(0, 0, 0), high=(1, 1, 1))
    with pytest.raises(InputError, match="low < high"):
        MeshWorld(box((1, 1, 1), (0, 0, 0)), box((1, 1, 1), (0, 0, 0)), low=(0, 0, 0), high=(1, 0, 1))


def test_euler_angles_round_trip():
    rng = np.random.default_rng(0)
    for _ in range(200):
        R = trimesh.transformations.random_rotation_matrix(rng.random(3))[:3, :3]
        assert np.allclose(rotation_matrix(*euler_from_matrix(R)), R, atol=1e-9)
    for tx in (PI / 2, -PI / 2):  # gimbal lock
        R = rotation_matrix(tx, 0.4, -1.1)
        assert np.allclose(rotation_matrix(*euler_from_matrix(R)), R, atol=1e-9)


def test_euler_angles_from_python_are_the_compiled_kernels():
    from planners.kernels.rigid import euler_angles

    rng = np.random.default_rng(1)
    compiled = np.empty(3)
    for R in [trimesh.transformations.random_rotation_matrix(rng.random(3))[:3, :3] for _ in range(50)] + \
             [rotation_matrix(PI / 2, 0.4, -1.1), rotation_matrix(-PI / 2, 2.0, 0.3)]:
        R = np.ascontiguousarray(R)
        euler_angles(R, compiled)
        assert np.array_equal(euler_from_matrix(R), compiled)


def test_states_known_free_and_known_in_collision(hole_world):
    w = hole_world
    assert w.is_valid([2, 5, 5, 0, 0, 0])  # in front of the wall
    assert w.is_valid([5, 5, 5, 0, 0, 0])  # in the hole, 0.5 from its sides
    assert not w.is_valid([5, 2, 5, 0, 0, 0])  # in the wall
    assert w.is_valid([5, 4.6, 5, 0, 0, 0])  # 0.1 from the hole's side
    assert not w.is_valid([5, 4.6, 5, 0, 0, PI / 4])  # turned there: a corner reaches 0.71 from the centre
    assert not w.is_valid([11, 5, 5, 0, 0, 0])  # origin outside the bounds
    assert "environment" in w.explain_invalid([5, 2, 5, 0, 0, 0])
    assert "outside the bounds" in w.explain_invalid([11, 5, 5, 0, 0, 0])
    with pytest.raises(InputError, match="not a valid state"):
        Problem(w, [5, 2, 5, 0, 0, 0], [8, 5, 5, 0, 0, 0])
    # through the hole and turned 90 degrees on the way is free; beside it is not
    assert w.check_motion([2, 5, 5, 0, 0, 0], [8, 5, 5, 0, 0, PI / 2])
    assert not w.check_motion([2, 2, 5, 0, 0, 0], [8, 2, 5, 0, 0, 0])


def test_broad_phase_never_contradicts_fcl():
    rng = np.random.default_rng(3)
    env = trimesh.util.concatenate([wall_with_hole(), box((1, 1, 6), (2, 2, 3)), box((3, 0.5, 0.5), (7, 7, 7))])
    w = MeshWorld(env, trimesh.creation.capsule(height=1.0, radius=0.3), low=(0, 0, 0), high=(10, 10, 10),
                  grid_cells=64)
    proved = undecided = 0
    for _ in range(600):
        q = np.concatenate([rng.uniform(0, 10, 3), rng.uniform(-PI, PI, 3)])
        margin = float(rng.choice([0.0, w.delta / 2, 0.3]))
        exact = w.pose_free_exact(q, margin)
        if w.pose_free_broad(q, margin):
            proved += 1
            assert exact, q  # the broad phase only proves what FCL confirms
            assert w.clearance(q) > margin
        else:
            undecided += 1
    assert proved > 100 and undecided > 50  # both paths are exercised


def test_motion_check_agrees_with_fcl_along_the_motion(hole_world):
    # accepted: FCL finds every pose free at a quarter of the resolution; refused: some pose comes
    # closer than the band (plus the travel between the poses sampled here)
    w = hole_world
    rng = np.random.default_rng(4)
    seen = {True: 0, False: 0}
    for _ in range(40):
        a = np.concatenate([rng.uniform([1, 3.5, 3.5], [9, 6.5, 6.5]), rng.uniform(-0.4, 0.4, 3)])
        b = np.concatenate([rng.uniform([1, 3.5, 3.5], [9, 6.5, 6.5]), rng.uniform(-0.4, 0.4, 3)])
        got = w.check_motion(a, b)
        fine = states_along(w, a, b, w.delta / 4)
        if got:
            assert all(w.pose_free_exact(q) for q in fine), (a, b)
        else:
            assert not all(w.pose_free_exact(q, w.band + w.delta / 8) for q in fine), (a, b)
        seen[got] += 1
    assert seen[True] and seen[False]


def test_a_motion_through_a_thin_wall_is_rejected():
    hair = box((1e-4, 10, 10), (5, 5, 5))  # no hole: a wall far thinner than any check step
    w = MeshWorld(hair, trimesh.creation.box(extents=(0.2, 1.0, 0.25)), low=(0, 0, 0), high=(10, 10, 10))
    a, b = [2.125, 2.5, 2.5, 0, 0, 0], [8.125, 2.5, 2.5, 0, 0, 0]
    assert w.is_valid(a) and w.is_valid(b)
    coarse = [np.r_[x, 2.5, 2.5, 0, 0, 0] for x in np.arange(2.125, 8.13, 0.25)]
    assert all(w.pose_free_exact(q) for q in coarse)  # a check every 0.25 passes straight through
    assert not w.check_motion(a, b)
    # turning the body through the wall with its origin still: at a quarter turn it reaches x = 5.2
    c, d = [4.7, 2.5, 2.5, 0, 0, 0], [4.7, 2.5, 2.5, 0, 0, 3.0]
    assert w.is_valid(c) and w.is_valid(d) and not w.is_valid([4.7, 2.5, 2.5, 0, 0, PI / 2])
    assert not w.check_motion(c, d)


def test_a_narrow_band_lets_the_body_through_a_gap_the_default_band_closes_and_still_cannot_tunnel():
    """A slot leaves the body less than ``delta / 2`` on each side: a band of ``delta / 2`` refuses the motion through
    it, the default band of ``delta / 8`` accepts it, with every pose along it free by FCL's test, and still refuses
    the thin wall."""
    delta = 0.4
    side = 1.0 + 2 * 0.1  # the slot leaves 0.1 on each side of a unit cube: above delta / 8, below delta / 2
    walls = trimesh.util.concatenate([box((0.5, 10, (10 - side) / 2), (5, 5, (10 - side) / 4)),
                                      box((0.5, 10, (10 - side) / 2), (5, 5, 10 - (10 - side) / 4))])
    body = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    a, b = [2.0, 5, 5, 0, 0, 0], [8.0, 5, 5, 0, 0, 0]
    wide = MeshWorld(walls, body, low=(0, 0, 0), high=(10, 10, 10), delta=delta, band=delta / 2)
    narrow = MeshWorld(walls, body, low=(0, 0, 0), high=(10, 10, 10), delta=delta)
    assert wide.band == delta / 2 and "band=0.2" in repr(wide)
    assert narrow.band == delta / 8 == DEFAULT_BAND_FRACTION * delta and "band" not in repr(narrow)
    assert wide.is_valid(a) and wide.is_valid(b)
    assert not wide.check_motion(a, b)
    assert narrow.check_motion(a, b)
    assert all(narrow.pose_free_exact(q) for q in states_along(narrow, a, b, delta / 16))
    # a motion a hair's breadth nearer the wall than the band is refused
    assert not narrow.check_motion([2.0, 5, 5 - 0.07, 0, 0, 0], [8.0, 5, 5 - 0.07, 0, 0, 0])
    hair = box((1e-4, 10, 10), (5, 5, 5))
    thin = MeshWorld(hair, trimesh.creation.box(extents=(0.2, 1.0, 0.25)), low=(0, 0, 0), high=(10, 10, 10),
                     band=1e-3)
    assert not thin.check_motion([2.125, 2.5, 2.5, 0, 0, 0], [8.125, 2.5, 2.5, 0, 0, 0])
    assert not thin.check_motion([4.7, 2.5, 2.5, 0, 0, 0], [4.7, 2.5, 2.5, 0, 0, 3.0])
    # a pickled copy keeps the band
    import pickle

    assert pickle.loads(pickle.dumps(wide)).band == wide.band


@pytest.mark.parametrize("band", [0.0, -0.1, 0.3, float("nan"), "wide"])
def test_a_band_outside_zero_to_half_delta_is_refused(band):
    with pytest.raises(InputError, match=r"band must .*delta / 2 = 0\.2"):
        MeshWorld(wall_with_hole(), trimesh.creation.box(extents=(1.0, 1.0, 1.0)), low=(0, 0, 0), high=(10, 10, 10),
                  delta=0.4, band=band)
    with pytest.raises(InputError, match=r"band 1e-06 is too fine .* use band >= 0\.000127"):
        MeshWorld(wall_with_hole(), trimesh.creation.box(extents=(1.0, 1.0, 1.0)), low=(0, 0, 0), high=(10, 10, 10),
                  delta=0.4, band=1e-6)


def test_clustered_cover_bound_is_the_bound_over_every_point(hole_world):
    """The clusters skip points, never change the bound: the smallest over every cover point where it clears
    ``need``, and at or below ``need`` exactly where that smallest is."""
    from planners.kernels.mesh import P_COVER, P_GRID, clearance_bound

    w = MeshWorld(wall_with_hole(), trimesh.creation.cylinder(radius=0.4, height=2.0, sections=24), low=(0, 0, 0),
                  high=(10, 10, 10))
    assert len(w.clusters) > 4
    params, h = w.kernel.params, w.kernel.params[P_GRID + 3]
    origin, shape = params[P_GRID:P_GRID + 3], params[P_GRID + 4:P_GRID + 7].astype(int)
    rng = np.random.default_rng(7)
    seen = {True: 0, False: 0}
    for _ in range(1000):
        q = np.concatenate([rng.uniform([3.0, 0.5, 0.5], [7.0, 9.5, 9.5]), rng.uniform(-PI, PI, 3)])
        need = float(rng.choice([0.0, w.delta / 2, 0.3]))
        got = clearance_bound(w.grid, w.cover, w.clusters, params, q, need)
        i, j, k = np.floor((q[:3] - origin) / h).astype(int)
        sphere = (w.grid[i, j * shape[2] + k] - 1.0) * h - w.radius
        if sphere > need:
            assert got == sphere
            continue
        pts = w.cover @ np.asarray(rotation_matrix(q[3], q[4], q[5])).T + q[:3]
        ii, jj, kk = np.floor((pts - origin) / h).astype(int).T
        lowest = float(((w.grid[ii, jj * shape[2] + kk] - 1.0) * h - params[P_COVER]).min())
        assert (got > need) == (max(sphere, lowest) > need)
        if got > need:
            assert got == max(sphere, lowest)
        seen[got > need] += 1
    assert seen[True] > 20 and seen[False] > 20


def test_a_motion_blocked_inside_is_refused(hole_world):
    """Both ends far from the wall, the middle inside it: the probe at the midpoint finds it."""
    w = hole_world
    a, b = [2.0, 1.5, 1.5, 0, 0, 0], [8.0, 1.5, 1.5, 0, 0, 0]
    assert w.pose_free_broad(a, w.delta) and w.pose_free_broad(b, w.delta)  # the grid alone clears both ends
    assert not w.check_motion(a, b)
    # the probe at the midpoint is in contact; the poses a walk from either end would certify first are not
    assert not w.pose_free_exact(np.add(a, b) / 2) and w.pose_free_exact(a, w.delta) and w.pose_free_exact(b, w.delta)
    # a motion through the hole has probes in the hole, none in contact: the walk decides as before
    c, d = [2.0, 5.0, 5.0, 0, 0, 0], [8.0, 5.0, 5.0, 0, 0, 0]
    assert w.check_motion(c, d) == all(w.pose_free_exact(q, w.band) for q in states_along(w, c, d)) is True


BIASED = {"step_size": 1.0, "sampler": GoalBiasedSampler(0.05)}
PLANNERS = [("RRT", BIASED), ("RRTConnect", {"step_size": 1.0}), ("RRTstar", BIASED), ("InformedRRTstar", BIASED),
            ("PRM", {}), ("LazyPRM", {}), ("OBPRM", {})]


@pytest.mark.parametrize("name, kwargs", PLANNERS, ids=[n for n, _ in PLANNERS])
def test_planners_go_through_the_hole_and_repeat_with_the_seed(wide_hole_world, name, kwargs):
    world = wide_hole_world
    problem = Problem(world, [2, 3, 3, 0, 0, 0], [8, 7, 7, 0, 0, 0], goal_tolerance=0.5)
    results = [make_planner(name, problem, seed=2, **kwargs).solve(max_iterations=4000) for _ in range(2)]
    r = results[0]
    assert r.solved, name
    assert world.path_valid(r.path)
    assert np.array_equal(r.path, results[1].path) and r.iterations == results[1].iterations
    assert r.collision_checks == results[1].collision_checks
    dense = np.concatenate([states_along(world, a, b) for a, b in zip(r.path[:-1], r.path[1:], strict=True)])
    cross = np.flatnonzero(np.diff(np.sign(dense[:, 0] - 5.0)) != 0)
    assert len(cross) and all(np.all(np.abs(dense[i, 1:3] - 5.0) < 1.5) for i in cross)  # through the hole


def test_the_tree_planners_default_step_is_the_mesh_worlds_share_of_the_box_diagonal(hole_world):
    from planners.base.world import DEFAULT_RANGE_FRACTION
    from planners.maps.generators import generate
    from planners.worlds.mesh import MESH_RANGE_FRACTION

    problem = Problem(hole_world, [2, 3, 3, 0, 0, 0], [8, 7, 7, 0, 0, 0], goal_tolerance=0.5)
    low, high = hole_world.bounds
    diagonal = float(np.linalg.norm(high - low))
    for name in ("RRT", "RRTConnect", "RRTstar"):
        assert make_planner(name, problem, seed=0).step_size == pytest.approx(MESH_RANGE_FRACTION * diagonal), name
        assert make_planner(name, problem, seed=0, step_size=1.5).step_size == 1.5, name  # one given is kept
    grid = generate("forest", 0, 64)  # other worlds keep OMPL's default range
    low, high = grid.world.bounds
    assert make_planner("RRT", grid, seed=0).step_size == pytest.approx(
        DEFAULT_RANGE_FRACTION * float(np.linalg.norm(np.asarray(high) - np.asarray(low))))


def test_a_time_limit_holds_on_a_mesh_world(hole_world):
    # an unsolvable query (the goal is walled in), so only the time limit stops the planner
    env = trimesh.util.concatenate([wall_with_hole(), box((3, 3, 0.2), (8, 8, 6.5)), box((3, 3, 0.2), (8, 8, 9.5)),
                                    box((0.2, 3, 3), (6.5, 8, 8)), box((0.2, 3, 3), (9.5, 8, 8)),
                                    box((3, 0.2, 3), (8, 6.5, 8)), box((3, 0.2, 3), (8, 9.5, 8))])
    w = MeshWorld(env, trimesh.creation.box(extents=(1.0, 1.0, 1.0)), low=(0, 0, 0), high=(10, 10, 10))
    problem = Problem(w, [2, 3, 3, 0, 0, 0], [8, 8, 8, 0, 0, 0], goal_tolerance=0.5)
    for name in ("RRTConnect", "PRM"):
        make_planner(name, problem, seed=0).solve(max_iterations=20)  # compile outside the clock
        planner = make_planner(name, problem, seed=0)
        t = time.perf_counter()
        r = planner.solve(time_limit=1.0)
        spent = time.perf_counter() - t - planner.compile_time
        assert not r.solved and r.stop_reason == "time_limit"
        assert spent < 1.1, (name, spent)


def test_past_a_deadline_exact_checks_answer_blocked_and_only_then(hole_world):
    w = hole_world
    a, b = [2, 4.55, 5, 0, 0, 0], [8, 4.55, 5, 0, 0, 0]  # through the hole 0.05 from its side: the exact test decides
    assert len(w.motion_poses(a, b)) > 4 * mesh_kernels.DEADLINE_EVERY
    assert w.check_motion(a, b)
    w.set_deadline(0.0, lambda: 1.0)
    try:
        assert not w.check_motion(a, b)
        assert w.check_motion([1, 1, 1, 0, 0, 0], [1.2, 1, 1, 0, 0, 0])  # proved free without FCL: unaffected
    finally:
        w.set_deadline(None)
    assert w.check_motion(a, b)


def test_past_a_deadline_a_run_of_short_motions_answers_blocked_within_the_looks_interval(hole_world):
    w = hole_world
    a, b = [2, 4.55, 5, 0, 0, 0], [2.05, 4.55, 5, 0, 0, 0]  # a few poses near the hole's side: never a look of its own
    assert len(w.motion_poses(a, b)) < mesh_kernels.DEADLINE_EVERY and w.check_motion(a, b)
    w.set_deadline(0.0, lambda: 1.0)
    try:
        answers = [w.check_motion(a, b) for _ in range(mesh_kernels.DEADLINE_EVERY + 1)]
    finally:
        w.set_deadline(None)
    assert not all(answers)  # the poses count across motions towards the next look
    assert w.check_motion(a, b)


def test_motion_poses_are_the_poses_checked(hole_world):
    a, b = [2, 5, 5, 0.1, 0, 3.0], [8, 5, 5, 0, 0, -3.0]  # across +-pi, the short way
    P = hole_world.motion_poses(a, b)
    S = states_along(hole_world, a, b)
    assert P.shape == S.shape and np.allclose(P[:, :3], S[:, :3])
    assert np.allclose((P[:, 3:] - S[:, 3:] + PI) % (2 * PI) - PI, 0, atol=1e-12)
    assert hole_world.motion_poses(a, a).shape == (1, 6)


def test_vectorised_rotations_are_the_compiled_ones():
    from planners.worlds.mesh import rotation_matrices

    angles = np.random.default_rng(5).uniform(-PI, PI, (100, 3))
    R = rotation_matrices(angles)
    assert all(np.allclose(R[i], rotation_matrix(*angles[i]), atol=1e-15) for i in range(100))


def test_a_mesh_world_pickles_by_its_triangles(hole_world):
    import pickle

    copy = pickle.loads(pickle.dumps(hole_world))
    assert copy is not hole_world and repr(copy) == repr(hole_world)
    assert np.array_equal(copy.grid, hole_world.grid) and copy.delta == hole_world.delta
    for q in ([5, 4.6, 5, 0, 0, 0], [5, 4.6, 5, 0, 0, PI / 4]):
        assert copy.is_valid(q) == hole_world.is_valid(q)


@pytest.mark.parametrize("low_first", [False, True])
def test_the_exact_clearance_is_a_lower_bound_above_the_margin_or_zero(hole_world, low_first):
    """Where it certifies a clearance the pose has more than that (FCL's distance); where it answers 0 it has at most
    the margin (times 1 + 2**-30)."""
    w, k = hole_world, hole_world.kernel
    rng = np.random.default_rng(4)
    low, high = w.bounds
    answers = {True: 0, False: 0}
    for _ in range(300):
        q = low + rng.random(6) * (high - low)
        need = w.delta / 2 * rng.choice([0.25, 1.0, 4.0, 20.0])
        none = np.full(2, -1, dtype=np.int64)  # no hint
        got = mesh_kernels.exact_clearance(k.body, k.params, q, need, np.bool_(low_first), none)
        d = w.clearance(q)
        lowest = need * mesh_kernels.BAND_RAISE
        rungs = [m for m in w.delta / 2 * mesh_kernels.CLEARANCE_LADDER if m > lowest] + [lowest]
        if got > need:
            assert got < d and got in rungs, (q, got, d)
        else:
            assert got == 0.0 and d <= lowest + 1e-12, (q, d)
        answers[got > need] += 1
    assert answers[True] > 30 and answers[False] > 30
