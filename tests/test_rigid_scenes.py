"""Generated 6-DoF scene families, their split, the narrow-passage samplers, the workspace route and the comparison."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planners.base.fileio import InputError
from planners.base.samplers import BridgeTestSampler, GaussianSampler
from planners.guidance.workspace_route import WorkspaceRouteSampler, cost_to_go, inner_radius, voxel_route
from planners.kernels.space import SPACE_RIGID, rotation_angle_between
from planners.maps.generators import TEST_SEED0, TUNING_SEED0, VALIDATION_SEED0
from planners.maps.unseen import UNSEEN_SEED0
from planners.worlds.rigid3d import WINDOW_SCENE, euler_from_matrix, load_scene, rotation_matrix
from planners.worlds.rigid_scenes import (
    FAMILIES,
    TEST_ONLY_FAMILIES,
    TRAINING_FAMILIES,
    RigidSceneSet,
    draw_scene,
    rigid_scene,
    scene_seeds,
    scene_with_witness,
    subtract_box,
)

box = st.tuples(*[st.floats(0, 10) for _ in range(6)]).map(
    lambda v: np.array([min(v[0], v[3]), min(v[1], v[4]), min(v[2], v[5]), max(v[0], v[3]), max(v[1], v[4]),
                        max(v[2], v[5])]))


def volume(b) -> float:
    return float(np.prod(np.maximum(b[3:] - b[:3], 0.0)))


@given(box, box)
def test_subtract_box_leaves_what_lies_outside_the_hole(b, hole):
    pieces = subtract_box(b, hole)
    overlap = np.concatenate([np.maximum(b[:3], hole[:3]), np.minimum(b[3:], hole[3:])])
    assert sum(volume(p) for p in pieces) == pytest.approx(volume(b) - volume(overlap), abs=1e-9)
    for p in pieces:
        assert np.all(p[:3] >= b[:3] - 1e-12) and np.all(p[3:] <= b[3:] + 1e-12)
        inside = np.concatenate([np.maximum(p[:3], hole[:3]), np.minimum(p[3:], hole[3:])])
        assert volume(inside) == pytest.approx(0.0, abs=1e-9)  # no piece reaches into the hole


def test_parts_take_the_generated_maps_seed_ranges_and_never_share_a_scene():
    assert scene_seeds("slot", "validation", 2) == [VALIDATION_SEED0, VALIDATION_SEED0 + 1]
    assert scene_seeds("slot", "tuning", 1) == [TUNING_SEED0]
    assert scene_seeds("slot", "test", 1) == [TEST_SEED0]
    assert scene_seeds("hatch", "test", 1) == [UNSEEN_SEED0]
    with pytest.raises(InputError, match="test-only"):
        scene_seeds("elbow", "tuning", 1)
    with pytest.raises(InputError, match="TRAIN_SEEDS"):
        scene_seeds("slot", "train", 1)
    with pytest.raises(InputError, match="unknown scene family"):
        scene_seeds("corridor", "test", 1)
    ss = RigidSceneSet(counts={"validation": 3, "tuning": 3, "test": 3}, verify=False)
    names = {part: {q.name for q in ss.queries(part)} for part in ("validation", "tuning", "test")}
    assert not (names["validation"] & names["tuning"]) and not (names["tuning"] & names["test"])
    assert not (names["validation"] & names["test"])
    test_families = {q.family for q in ss.queries("test")}
    assert test_families == set(FAMILIES)
    assert {q.family for q in ss.queries("tuning")} == set(TRAINING_FAMILIES)
    assert not set(TEST_ONLY_FAMILIES) & set(TRAINING_FAMILIES)
    assert ss.record()["parts"]["test"][-1] == f"elbow-{UNSEEN_SEED0 + 2}"
    # a part from a later scene on: the scenes after those of a smaller set, and nothing else moves
    later = RigidSceneSet(counts={"validation": 2, "test": 1}, first={"validation": 3, "test": 2}, verify=False)
    assert [q.seed for q in later.queries("validation") if q.family == "slot"] == [VALIDATION_SEED0 + 3,
                                                                                    VALIDATION_SEED0 + 4]
    assert not {q.name for q in later.queries("validation")} & names["validation"]
    assert later.record()["parts"]["test"][-1] == f"elbow-{UNSEEN_SEED0 + 2}"
    assert later.queries("tuning") == RigidSceneSet(verify=False).queries("tuning")
    assert f"seeds from {VALIDATION_SEED0 + 3}" in later.describe()
    assert scene_seeds("slot", "tuning", 2, first=5) == [TUNING_SEED0 + 5, TUNING_SEED0 + 6]
    with pytest.raises(InputError, match="first"):
        RigidSceneSet(first={"train": 1})


@pytest.mark.parametrize("family", FAMILIES)
def test_every_family_draws_the_same_scene_from_a_seed_with_valid_witness_poses(family):
    a, passages = draw_scene(family, np.random.default_rng(5), "a")
    b, _ = draw_scene(family, np.random.default_rng(5), "b")
    assert np.array_equal(a.world.boxes, b.world.boxes) and np.array_equal(a.start, b.start)
    assert np.array_equal(a.goal, b.goal)
    assert not a.world.check_motion(a.start, a.goal)  # never a straight shot
    assert passages and all(a.world.is_valid(q) for pair in passages for q in pair)
    assert a.world.delta == 0.5 and np.allclose(a.world.high3, (100, 60, 40))


def test_a_verified_scene_has_a_witness_path_the_exact_check_passes():
    problem, witness = scene_with_witness("elbow", 7)
    assert problem.name == "elbow-7"
    assert problem.world.path_valid(witness.path)
    assert np.allclose(witness.path[0], problem.start) and np.allclose(witness.path[-1], problem.goal)
    again = rigid_scene("elbow", 7)
    assert np.array_equal(again.world.boxes, problem.world.boxes) and np.array_equal(again.start, problem.start)


def test_the_passages_are_too_narrow_for_the_body_unturned():
    # the slot family: an opening narrower than the body's long side one way and its middle side the other
    problem, passages = draw_scene("slot", np.random.default_rng(3), "s")
    before, after = passages[0]
    world = problem.world
    assert world.check_motion(before, after)
    for turn in ((0, 0, math.pi / 2), (0, math.pi / 2, 0), (math.pi / 2, 0, 0)):
        q0, q1 = before.copy(), after.copy()
        q0[3:] = q1[3:] = euler_from_matrix(rotation_matrix(*before[3:]) @ rotation_matrix(*turn))
        assert not world.check_motion(q0, q1)


@given(st.floats(-3.1, 3.1), st.floats(-1.5, 1.5), st.floats(-3.1, 3.1))
def test_euler_angles_invert_rotation_matrix(tx, ty, tz):
    R = rotation_matrix(tx, ty, tz)
    assert np.allclose(rotation_matrix(*euler_from_matrix(R)), R, atol=1e-9)


@pytest.mark.parametrize("cls", [GaussianSampler, BridgeTestSampler])
def test_narrow_passage_samplers_find_valid_states_near_obstacles_and_count_their_work(cls):
    problem = load_scene(WINDOW_SCENE)
    s = cls().bind(problem)
    batch = s.draw(np.random.default_rng(0), 40, None)
    assert batch.points.shape == (40, 6) and batch.candidates.sum() >= 40
    valid = [problem.world.is_valid(q) for q in batch.points]
    assert np.mean(valid) > 0.9  # a sample no attempt found is the last uniform state, rarely valid here
    near = [problem.world.clearance(q) < 6.0 for q, ok in zip(batch.points, valid, strict=True) if ok]
    assert np.mean(near) > 0.5  # mostly close to a wall, where uniform samples seldom fall
    assert s.checks >= batch.candidates.sum()
    again = cls().bind(problem).draw(np.random.default_rng(0), 40, None)
    assert np.array_equal(again.points, batch.points)
    with pytest.raises(InputError):
        cls(stddev=-1.0)
    with pytest.raises(InputError):
        cls(attempts=0)


def test_the_gaussian_rotation_stays_near_the_mean_when_its_deviation_is_small():
    from planners.kernels.narrow import gaussian_state

    low, high = np.array([0, 0, 0, -math.pi, -math.pi, -math.pi]), np.array([10, 10, 10, math.pi, math.pi, math.pi])
    mean = np.array([5, 5, 5, 0.4, -0.3, 2.0])
    out = np.empty(6)
    rng = np.random.default_rng(1)
    for _ in range(50):
        u = rng.random(15)
        gaussian_state(SPACE_RIGID, low, high, mean, u, 0, 0.5, 0.05, out)
        assert rotation_angle_between(mean, out) < 0.05 * 6
        assert np.all(np.abs(out[:3] - 5) < 0.5 * 6)


def test_the_workspace_route_passes_the_window_and_the_sampler_follows_it():
    problem = load_scene(WINDOW_SCENE)
    assert inner_radius(problem.world.body) == pytest.approx(1.25)
    route = voxel_route(problem.world, problem.start, problem.goal)
    assert np.allclose(route[0], problem.start[:3]) and np.allclose(route[-1], problem.goal[:3])
    at_wall = route[np.abs(route[:, 0] - 50) < 1.0]
    assert len(at_wall) and np.all((at_wall[:, 1] > 20) & (at_wall[:, 1] < 40) & (at_wall[:, 2] > 10)
                                    & (at_wall[:, 2] < 30))
    pts = WorkspaceRouteSampler(route_fraction=1.0, spread=0.5).bind(problem).draw(np.random.default_rng(0), 200, None)
    gaps = np.min(np.linalg.norm(pts[:, None, :3] - route[None], axis=2), axis=1)
    assert np.median(gaps) < 2.0 and np.all(pts[:, 3:] >= -math.pi) and np.all(pts[:, 3:] < math.pi)


def test_the_registry_builds_the_references_and_the_comparison_counts_sampler_checks():
    from learning.evaluation.rigid import evaluate_rigid, format_table, run_one, summarize
    from learning.samplers.registry import make_sampler

    for name in ("gaussian", "bridge_test", "obstacle_based", "rigid_workspace_route"):
        assert make_sampler(name) is not None
    problem = load_scene(WINDOW_SCENE)
    row = run_one(problem, "RRT", "gaussian", 0, max_iterations=30)
    assert row.iterations <= 30 and row.sampler_checks > 0 and row.collision_checks > row.sampler_checks
    ss = RigidSceneSet(("slot",), (), {"validation": 1})
    rows = evaluate_rigid(ss, "validation", planners=("RRTConnect", "PRM"), samplers=("uniform",), seeds=(0, 1),
                          max_iterations=40)
    assert len(rows) == 4 and {r.scene for r in rows} == {f"slot-{VALIDATION_SEED0}"}
    summary = summarize(rows)
    for s in summary:
        cap = 40
        its = [r.iterations if r.solved else cap for r in rows if r.planner == s["planner"]]
        assert s["median_iterations"] == float(np.median(its))
    assert "| RRTConnect | uniform | 2 |" in format_table(summary)
    with pytest.raises(InputError, match="unknown sampler"):
        evaluate_rigid(ss, "validation", samplers=("nope",))


def test_a_restarting_run_in_the_comparison_is_solve_with_restarts_own_and_counts_every_attempts_sampler_checks():
    from learning.evaluation.rigid import planner_setup, run_one
    from learning.samplers.registry import make_sampler
    from planners import solve_with_restarts

    problem = load_scene(WINDOW_SCENE)
    row = run_one(problem, "RRT", "gaussian", 0, max_iterations=60, restarts=7)
    p, kwargs = planner_setup("RRT", problem)
    checks = []
    r = solve_with_restarts("RRT", p, seed=0, unit=7, max_iterations=60, sampler=make_sampler("gaussian"),
                            on_attempt=lambda pl: checks.append(pl.sampler.checks), **kwargs)
    assert len(checks) == r.restarts + 1 >= 3  # 7, 7, 14, ... iterations: at least three attempts in 60
    assert row.iterations == r.iterations <= 60 and row.sampler_checks == sum(checks) > 0
    assert row.collision_checks == r.collision_checks + sum(checks)
    with pytest.raises(InputError, match="tree planners"):
        run_one(problem, "PRM", "uniform", 0, max_iterations=10, restarts=5)


def test_a_box_scene_whose_goal_meets_its_meshes_is_refused_as_a_witness_that_meets_them():
    pytest.importorskip("trimesh", reason="mesh scenes need the mesh extra (pip install samplergym[mesh])")
    pytest.importorskip("fcl", reason="mesh scenes need the mesh extra (pip install samplergym[mesh])")
    from planners.worlds.rigid_scenes import mesh_scene

    # this validation clutter scene's goal puts the body's surface into a box its points missed
    with pytest.raises(RuntimeError, match="witness path .* meets the mesh environment at its ends"):
        mesh_scene("clutter", VALIDATION_SEED0 + 1)


def test_a_box_scene_written_as_meshes_keeps_its_witness_and_omplapp_problems_join_the_test_only_set(tmp_path):
    pytest.importorskip("trimesh", reason="mesh scenes need the mesh extra (pip install samplergym[mesh])")
    pytest.importorskip("fcl", reason="mesh scenes need the mesh extra (pip install samplergym[mesh])")
    from planners.worlds.omplapp import OMPLAPP_ENV
    from planners.worlds.rigid_scenes import MeshSceneSet, mesh_scene

    problem, witness = scene_with_witness("hatch", UNSEEN_SEED0)
    mesh = mesh_scene("hatch", UNSEEN_SEED0)
    assert mesh.name == f"hatch-{UNSEEN_SEED0}-mesh" and np.array_equal(mesh.start, problem.start)
    assert mesh.world.path_valid(witness.path)
    assert not mesh.world.check_motion(problem.start, problem.goal)
    assert mesh.world.delta == problem.world.delta  # the box scene's resolution, unless one is given
    finer = mesh_scene("hatch", UNSEEN_SEED0, delta=0.05)
    assert finer.world.delta == 0.05 and finer.world.path_valid(witness.path)
    ms = MeshSceneSet(("hatch",), 1, omplapp=None)
    with pytest.raises(InputError, match="test-only"):
        ms.queries("tuning")
    import os

    folder = os.environ.get(OMPLAPP_ENV)
    if not folder:
        pytest.skip(f"OMPL.app's problems: set {OMPLAPP_ENV} to a copy of its resources/3D folder")
    ms = MeshSceneSet(("hatch",), 1, omplapp=folder, problems=["Easy"])
    names = [q.name for q in ms.queries("test")]
    assert names == [f"hatch-{UNSEEN_SEED0}-mesh", "Easy"]
    assert ms.problem(ms.queries("test")[1]).world.name == "Easy"


def test_the_spatial_index_answers_as_the_full_scan_does():
    from planners.kernels.rigid import N_INDEXED, N_PLAIN, states_clear
    from planners.tools.box_index_bench import pose_check_cost, random_box_world

    world = random_box_world(300, seed=4, sides=(0.05, 3.0))
    k = world.kernel
    assert k.params.shape == (N_INDEXED,) and k.grid.dtype == np.int64
    rng = np.random.default_rng(5)
    qs = np.column_stack([rng.uniform(5, 95, (3000, 3)), rng.uniform(-3, 3, (3000, 3))])
    for margin in (0.0, 0.5 * world.delta):
        a, b = np.empty(len(qs), dtype=np.bool_), np.empty(len(qs), dtype=np.bool_)
        states_clear(k.geom, k.grid, k.body, k.params, qs, margin, a)
        states_clear(k.geom, k.grid, k.body, k.params[:N_PLAIN], qs, margin, b)
        assert np.array_equal(a, b) and 0 < a.mean() < 1
    # a body corner exactly on a box's corner touches it: in collision either way
    inner = world.boxes[np.all((world.boxes[:, :3] > 10) & (world.boxes[:, 3:] < 90), axis=1)][0]
    q = np.array([[inner[3] + 5.0, inner[4] + 2.5, inner[5] + 1.25, 0, 0, 0]])
    for params in (k.params, k.params[:N_PLAIN]):
        out = np.empty(1, dtype=np.bool_)
        states_clear(k.geom, k.grid, k.body, params, q, 0.0, out)
        assert not out[0]
    assert pose_check_cost(40, poses=200).disagreements == 0


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([0.0, 0.25, 1.0]))
def test_a_body_point_near_a_box_is_seen_as_the_squared_distance_says(seed, margin):
    from planners.kernels.rigid import N_PLAIN, states_clear

    # one body point at the origin, so a state's position is the point: the compiled test against numpy's distance
    rng = np.random.default_rng(seed)
    lo = rng.uniform(20, 60, 3)
    boxes = np.hstack([lo, lo + rng.uniform(0.0, 10.0, 3)])[None]
    pts = np.vstack([rng.uniform(10, 80, (200, 3)),
                     np.clip(rng.uniform(10, 80, (50, 3)), boxes[0, :3], boxes[0, 3:]),  # on and in the box
                     boxes[0, 3:] + margin / math.sqrt(3) * np.array([1, 1, 1]),  # at the margin's corner
                     boxes[0, :3] - [margin, 0, 0]])  # on the margin, across a face
    gap = np.maximum(np.maximum(boxes[0, :3] - pts, 0.0), pts - boxes[0, 3:])
    near = (gap[:, 0] ** 2 + gap[:, 1] ** 2 + gap[:, 2] ** 2) <= margin * margin
    params = np.array([0, 0, 0, 100, 100, 100, 1.0, 0.0])
    assert params.shape == (N_PLAIN,)
    qs = np.hstack([pts, np.zeros((len(pts), 3))])
    out = np.empty(len(qs), dtype=np.bool_)
    states_clear(boxes, np.zeros((1, 1), dtype=np.int64), np.zeros((1, 3)), params, qs, margin, out)
    assert np.array_equal(out, ~near)


def test_the_scene_sets_run_inside_the_one_comparison_as_a_part_with_the_same_runs(tmp_path):
    import learning.evaluation as E
    from learning.evaluation.rigid import RigidPart, evaluate_rigid

    ss = RigidSceneSet(("clutter",), (), {"validation": 1})
    part = RigidPart(ss, "validation", planners=("RRTConnect", "RRT"), samplers=("uniform", "goal_bias"), seeds=2,
                     max_iterations=300)
    assert isinstance(part, E.Part) and len(part.tasks()) == 8
    out = tmp_path / "out"
    res = E.compare(E.Comparison([], parts=[part]), out, log=lambda line: None)
    runs, report = res.parts[part.name]
    # the same seeded runs as the rigid comparison's own loop: iterations, success and checks, run by run
    alone = evaluate_rigid(ss, "validation", planners=("RRTConnect", "RRT"), samplers=("uniform", "goal_bias"),
                           seeds=(0, 1), max_iterations=300)
    got = sorted((r.planner, r.sampler, r.seed, r.solved, r.iterations, r.collision_checks) for r in runs)
    assert got == sorted((r.planner, r.sampler, r.seed, r.solved, r.iterations, r.collision_checks) for r in alone)
    assert {r.map for r in runs} == {"clutter"} and {r.split for r in runs} == {"validation"}
    summary, details = (out / "summary.md").read_text(), (out / "details.md").read_text()
    assert "no 2D map set ran" in summary and "RRTConnect: best classical option" in summary
    assert "| clutter | RRTConnect | goal_bias | 2 |" in details and "## Results at a glance" not in details
    assert len((out / "runs.csv").read_text().splitlines()) == 1 + 8
    with pytest.raises(InputError, match="unknown rigid-body planner"):
        RigidPart(ss, "validation", planners=("RRTstar",))
    with pytest.raises(InputError, match="part must be one of"):
        RigidPart(ss, "train")


def test_a_learned_samplers_targets_are_marked_per_scene_set_and_planner():
    from learning.evaluation.rigid import target_rows

    def cell(sampler, its, solved, time):
        return {"family": "slot", "planner": "RRTConnect", "sampler": sampler, "runs": 4, "solved": solved,
                "success": solved / 4, "median_iterations": its, "median_checks": its, "median_time": time}

    by_set = [cell("uniform", 10_000, 2, 1.0), cell("gaussian", 8_000, 2, 2.0),
              cell("rigid_workspace_route", 4_000, 3, 0.5), cell("learned", 2_000, 3, 0.4)]
    (row,) = target_rows(by_set)
    assert row["best classical"] == "gaussian" and row["iterations vs classical"] == 0.25
    assert row["iterations vs ablation"] == 0.5 and row["time vs classical"] == 0.2 and row["held"]
    by_set[-1] = cell("learned", 2_000, 2, 0.4)  # success below the ablation's: not held
    assert not target_rows(by_set)[0]["held"]
    by_set[-1] = cell("learned", 3_000, 3, 0.4)  # 0.75x the ablation: learning must matter, not only the route
    assert not target_rows(by_set)[0]["held"]


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31), fill=st.floats(0.0, 0.4))
def test_a_search_stopped_at_the_start_keeps_every_shortest_route_exact_and_descends_as_the_full_search(seed, fill):
    from planners.guidance.workspace_route import STEP_LENGTHS, STEPS

    rng = np.random.default_rng(seed)
    free = rng.random((9, 8, 7)) >= fill
    goal, start = (int(i) for i in rng.integers(0, free.size, 2))
    free.flat[goal] = free.flat[start] = True
    full, stopped = cost_to_go(free, goal), cost_to_go(free, goal, start)
    assert stopped.flat[start] == full.flat[start]
    assert np.all(stopped >= full)
    if not np.isfinite(full.flat[start]):
        return
    # every voxel of every shortest route from the start holds its exact cost: those whose cost from the start
    # (a full search from there) plus their cost to the goal is the start's
    from_start = cost_to_go(free, start)
    on_route = np.isclose(from_start + full, full.flat[start], rtol=0, atol=1e-9)
    assert np.array_equal(stopped[on_route], full[on_route])

    def descent(cost):
        v, path = np.array(np.unravel_index(start, free.shape)), []
        while cost[tuple(v)] > 0:
            nb = v + STEPS
            ok = np.all((nb >= 0) & (nb < free.shape), axis=1)
            v = nb[ok][int(np.argmin(cost[tuple(nb[ok].T)] + STEP_LENGTHS[ok]))]
            path.append(tuple(v))
        return path

    assert descent(stopped) == descent(full)


def test_a_users_sampler_joins_the_rigid_comparison_by_its_label(tmp_path, capsys):
    """``user_samplers`` (``scripts/evaluate_rigid.py --sampler NAME=SPEC``): a factory's sampler runs beside the
    registry's, labelled by its name, and gives the runs that sampler gives; SB3 models take the same path
    (``MODEL.zip@SamplerGym/RRT-RigidScenes-v1``). A bad spec or a taken name is refused before any run."""
    from conftest import load_script

    from learning.evaluation.rigid import evaluate_rigid

    ss = RigidSceneSet(("slot",), (), {"validation": 1})
    rows = evaluate_rigid(ss, "validation", planners=("RRTConnect",), samplers=("uniform",), seeds=(0, 1),
                          max_iterations=60, user_samplers={"mine": "planners:UniformSampler"})
    mine = [(r.seed, r.iterations, r.solved) for r in rows if r.sampler == "mine"]
    assert len(mine) == 2 and mine == [(r.seed, r.iterations, r.solved) for r in rows if r.sampler == "uniform"]
    with pytest.raises(InputError, match="registered sampler"):
        evaluate_rigid(ss, "validation", samplers=("uniform",), user_samplers={"uniform": "planners:UniformSampler"})
    script = load_script("evaluate_rigid")
    assert script.main(["--families", "slot", "--test-only", "--scenes", "1", "--planners", "RRTConnect",
                        "--samplers", "uniform", "--max-iterations", "30", "--sampler", "mine=planners:UniformSampler",
                        "--out", str(tmp_path / "out")]) == 0
    assert "| RRTConnect | mine | 1 |" in (tmp_path / "out" / "summary.md").read_text()
    for bad, why in (("mine=no_such_module:f", "no_such_module"), ("uniform=planners:UniformSampler", "taken"),
                     ("mine", "expected NAME=SPEC")):
        assert script.main(["--scenes", "1", "--sampler", bad, "--out", str(tmp_path / "bad")]) == 2
        assert why in capsys.readouterr().err
    assert not (tmp_path / "bad").exists()
