"""The OMPL.app probes: omplapp_frames.py (readings of instanced parts, origins, the replay) and mesh_vs_ompl.py."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import load_script

from planners.base.fileio import InputError

pytestmark = pytest.mark.experiments

DAE = """<node name="SketchUp">
    <instance_geometry url="#G1" />
    <node id="ID2" name="instance_0">
        <matrix>0 -1 0 5 1 0 0 6 0 0 1 7 0 0 0 1</matrix>
        <instance_node url="#ID3" />
    </node>
    <node id="ID4" name="instance_1">
        <matrix>1 0 0 1 0 1 0 2 0 0 1 3 0 0 0 1</matrix>
        <instance_node url="#ID3" />
    </node>
</node>"""


def omplapp_folder(needed: str):
    """The user's copy of OMPL.app's problems holding ``needed`` (with the mesh extra), or skip, saying why."""
    pytest.importorskip("fcl", reason="the mesh extra")
    from planners.worlds.omplapp import OMPLAPP_ENV, omplapp_dir

    try:
        folder = omplapp_dir()
    except InputError as e:
        pytest.skip(str(e))
    if folder is None or not (folder / needed).is_file():
        pytest.skip(f"OMPL.app's problems not found: set {OMPLAPP_ENV} to a copy (its licence forbids shipping them)")
    return folder


def test_each_instanced_part_is_kept_left_out_or_turned_back():
    frames = load_script("experiments/omplapp_frames")
    assert frames.with_readings(DAE, ("as given", "as given")) == DAE
    out = frames.with_readings(DAE, ("left out", "as given"))
    assert "instance_0" not in out and "instance_1" in out and '<instance_geometry url="#G1" />' in out
    turned = frames.with_readings(DAE, ("transposed", "left out"))
    matrix = np.array(turned.split("<matrix>")[1].split("</matrix>")[0].split(), dtype=float).reshape(4, 4)
    assert np.array_equal(matrix[:3, :3], [[0, 1, 0], [-1, 0, 0], [0, 0, 1]])
    assert np.array_equal(matrix[:3, 3], [5, 6, 7])
    assert "instance_1" not in turned
    with pytest.raises(ValueError):
        frames.with_readings(DAE, ("as given",))  # one reading per part
    with pytest.raises(ValueError, match="unknown reading"):
        frames.with_readings(DAE, ("as given", "moved"))


def test_the_origins_compared_and_the_contact_replay():
    pytest.importorskip("fcl", reason="the probe checks with FCL (the mesh extra)")
    trimesh = pytest.importorskip("trimesh", reason="the mesh extra")
    frames = load_script("experiments/omplapp_frames")
    box = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    V, F = np.asarray(box.vertices, float), np.asarray(box.faces, np.int32)
    c = frames.centres(V + 2.0, F)
    assert all(np.allclose(v, 2.0) for v in c.values())  # a cube's centres all agree
    states = np.array([[0.0, 0, 0, 0, 0, 0], [5.0, 0, 0, 0, 0, 0], [0.9, 0, 0, 0.3, 0, 0]])
    assert frames.in_contact((V, F), (V, F), states) == [0, 2]


def test_it_needs_a_copy_of_omplapp(monkeypatch, tmp_path):
    frames = load_script("experiments/omplapp_frames")
    monkeypatch.delenv("SAMPLERGYM_OMPLAPP_DIR", raising=False)
    with pytest.raises(SystemExit):
        frames.main([])
    with pytest.raises(SystemExit):
        frames.main(["--omplapp", str(tmp_path), "--problem", "nothing"])


def test_the_ompl_comparison_refuses_bad_counts():
    probe = load_script("experiments/mesh_vs_ompl")
    for bad in (["--scenes", "0"], ["--seeds", "0"], ["--time-limit", "0"], ["--families", "clutter"]):
        with pytest.raises(SystemExit):
            probe.main(bad)


def test_the_long_runs_table_counts_an_unsolved_run_beyond_every_solved_one():
    long_runs = load_script("experiments/omplapp_long_runs")
    median = long_runs._median
    assert median([10.0, 30.0, 20.0], [True, True, True]) == "20.00"
    assert median([1000, 5, 3000, 2000], [True, False, True, True]) == "2,500"  # sorted 1000, 2000, 3000, unsolved
    assert median([1000, 5, 3000, 2000], [True, False, False, True]) == "> 2,000"  # halfway from 2,000 to unsolved
    assert median([1000, 5, 3000], [True, False, False]) == "> 1,000"  # the middle run is unsolved: beyond 1,000
    rows = [{"variant": "a", "solved": s, "iterations": i, "states": i // 4, "checks": 2 * i, "seconds": i / 1e3}
            for s, i in ((True, 4000), (False, 9000), (True, 2000))]
    table = long_runs.summary(rows)
    assert "| a | 2/3 | 4,000 | 1,000 | 8,000 | 4.00 |" in table


def test_the_long_runs_solve_a_small_problem_file_and_refuse_bad_arguments(tmp_path):
    pytest.importorskip("fcl", reason="the probe plans with FCL (the mesh extra)")
    pytest.importorskip("trimesh", reason="the mesh extra")
    from test_mesh_omplapp import write_offset_problem, write_problem

    long_runs = load_script("experiments/omplapp_long_runs")
    write_problem(tmp_path, name="hole")
    out = tmp_path / "runs.jsonl"
    assert long_runs.main(["--omplapp", str(tmp_path), "--problem", "hole", "--seeds", "2", "--time-limit", "5",
                           "--fractions", "1e-3", "5e-4", "--out", str(out)]) == 0
    rows = [json.loads(line) for line in out.read_text().splitlines()]
    assert [r["seed"] for r in rows] == [0, 1, 0, 1] and all(r["solved"] for r in rows)
    assert rows[2]["delta"] == pytest.approx(0.5 * rows[0]["delta"])
    assert long_runs.main(["--omplapp", str(tmp_path), "--problem", "hole", "--seeds", "1", "--no-uniform",
                           "--samplers", "rigid_route_ablation", "--out", str(out)]) == 0
    rows = [json.loads(line) for line in out.read_text().splitlines()]
    assert [r["variant"] for r in rows] == ["ours, delta 0.001 of the diagonal, rigid_route_ablation"]
    write_offset_problem(tmp_path)  # the first connect through the hole solves "hole" at once: nothing to restart
    assert long_runs.main(["--omplapp", str(tmp_path), "--problem", "offset", "--seeds", "1", "--luby", "3",
                           "--out", str(out)]) == 0
    (row,) = [json.loads(line) for line in out.read_text().splitlines()]
    assert row["variant"].endswith("Luby restarts x 3") and row["solved"] and row["restarts"] >= 1
    for bad in (["--seeds", "0"], ["--fractions", "0.5"], ["--fractions"], ["--out", str(tmp_path)],
                ["--samplers", "nothing"], ["--no-uniform"]):
        with pytest.raises(SystemExit):
            long_runs.main(["--omplapp", str(tmp_path), "--problem", "hole", "--out", str(out), *bad])
    with pytest.raises(InputError, match="nothing.cfg"):
        long_runs.main(["--omplapp", str(tmp_path), "--problem", "nothing", "--out", str(out)])


def test_ompls_motions_replayed_turn_the_shortest_way_and_find_a_wall(tmp_path):
    pytest.importorskip("fcl", reason="the probe checks with FCL (the mesh extra)")
    pytest.importorskip("trimesh", reason="the mesh extra")
    from test_mesh_omplapp import write_problem

    from planners.worlds.omplapp import load_omplapp_cfg
    from planners.worlds.rigid3d import rotation_matrix

    long_runs = load_script("experiments/omplapp_long_runs")
    a, b = np.array([0.0, 0, 0, 0.3, -2.0, 3.0]), np.array([1.0, 2, 0, -2.5, 1.0, 0.5])
    poses = long_runs.slerp_poses(a, b, 0.05, 2.0)
    assert np.allclose(poses[0], a) and np.allclose(rotation_matrix(*poses[-1, 3:]), rotation_matrix(*b[3:]))
    turns = [np.arccos(np.clip(0.5 * (np.trace(rotation_matrix(*p[3:]).T @ rotation_matrix(*q[3:])) - 1), -1, 1))
             for p, q in zip(poses[:-1], poses[1:], strict=True)]
    travel = np.linalg.norm(np.diff(poses[:, :3], axis=0), axis=1) + 2.0 * np.array(turns)
    assert np.all(travel <= 0.05 + 1e-9) and np.ptp(travel) < 1e-6  # even steps of one shortest turn
    world = load_omplapp_cfg(write_problem(tmp_path)).world
    through_hole = np.array([[2.0, 5, 5, 0, 0, 0], [8.0, 5, 5, 0, 0, 0]])
    through_wall = np.array([[2.0, 5, 5, 0, 0, 0], [2.0, 1.5, 1.5, 0, 0, 0], [8.0, 1.5, 1.5, 0, 0, 0]])
    assert long_runs.motions_through(world, through_hole, 0.05) == 0
    assert long_runs.motions_through(world, through_wall, 0.05) == 1


def test_the_mesh_tuning_script_refuses_an_unknown_sampler_negative_restarts_and_bad_steps(tmp_path, capsys):
    tune = load_script("experiments/tune_mesh_delta")
    for bad, said in ((["--sampler", "nothing"], "no such sampler"), (["--restarts", "0", "-5"], "--restarts takes"),
                      (["--steps", "1", "0"], "--steps must lie in (0, 4]"), (["--steps", "5"], "--steps must lie")):
        with pytest.raises(SystemExit):
            tune.main(["--out", str(tmp_path / "runs.jsonl"), *bad])
        assert said in capsys.readouterr().err
    assert not (tmp_path / "runs.jsonl").exists()  # refused before any run


def test_the_exact_cost_script_times_a_function_and_refuses_bad_arguments(tmp_path, monkeypatch):
    split = load_script("experiments/mesh_exact_cost")
    answers, us = split.per_pose_us(lambda x: 2 * x, [3, 4])
    assert answers == [6, 8] and us >= 0
    for bad in (["--poses", "0"],):
        with pytest.raises(SystemExit):
            split.main(["--omplapp", str(tmp_path), *bad])
    with pytest.raises(InputError, match="no OMPL.app problems there"):
        split.main(["--omplapp", str(tmp_path), "--problem", "nothing"])
    (tmp_path / "Easy.cfg").write_text("[problem]\n")
    with pytest.raises(InputError, match="no nothing.cfg"):
        split.main(["--omplapp", str(tmp_path), "--problem", "nothing"])
    monkeypatch.setitem(__import__("sys").modules, "coal", None)  # coal absent: refused before any run, saying why
    with pytest.raises(SystemExit):
        split.main(["--omplapp", str(tmp_path), "--coal"])


def test_the_exact_cost_on_omplapps_cubicles_agrees_with_fcl(capsys):
    folder = omplapp_folder("cubicles.cfg")
    split = load_script("experiments/mesh_exact_cost")
    assert split.main(["--omplapp", str(folder), "--problem", "cubicles", "--poses", "40"]) == 0
    out = capsys.readouterr().out
    assert "| FCL's distance |" in out and "every compiled answer agrees with FCL's distance: True" in out


def test_the_grid_tuning_refuses_bad_arguments_and_unknown_problems(tmp_path):
    tune = load_script("experiments/tune_mesh_grid")
    for bad in (["--seeds", "0"], ["--iterations", "0"], ["--cells", "4"], ["--cells", "1024"]):
        with pytest.raises(SystemExit):
            tune.main(["--omplapp", str(tmp_path), *bad])
    (tmp_path / "Easy.cfg").write_text("[problem]\n")
    with pytest.raises(InputError, match="no nothing.cfg"):
        tune.main(["--omplapp", str(tmp_path), "--problems", "nothing"])


def test_the_tree_rule_script_refuses_bad_arguments_before_any_run(tmp_path):
    rules = load_script("experiments/tree_rule_meshes")
    out = tmp_path / "runs.jsonl"
    for bad in (["--time-limit", "0"], ["--seeds", "0"], ["--rules", "nothing"], ["--omplapp", str(tmp_path)],
                ["--rule", "pw16"], ["--rule", "pw16={nope"], ["--rule", 'trees={"passage_weight": 1}'],
                ["--rule", 'x={"colour": 1}']):
        with pytest.raises(SystemExit):
            rules.main(["--out", str(out), *bad])
    with pytest.raises(SystemExit):
        rules.main(["--out", str(tmp_path)])  # a folder, not a file
    assert not out.exists()


def test_the_tree_rule_script_runs_each_rule_on_a_mesh_scene():
    pytest.importorskip("fcl", reason="the mesh extra")
    from planners.worlds.rigid_scenes import scene_seeds

    rules = load_script("experiments/tree_rule_meshes")
    source = ("scene", "slot", scene_seeds("slot", "tuning", 1)[0])
    named = [(rule, rules.RULES[rule]) for rule in ("uniform", "trees", "roadmap")]
    rows = [rules._run((source, "RRTConnect", 0, item, 1.0, "default")) for item in named]
    assert [r["rule"] for r in rows] == ["uniform", "trees", "roadmap"]
    for r in rows:  # a scene the mesh scene set keeps; each run within its limit (compiling left out)
        assert "refused" not in r and r["iterations"] > 0 and 0 <= r["seconds"] <= 1.0 + 0.5
    assert rows[1]["solved"] and rows[2]["solved"]  # the learned rules pass the slot
    again = rules._run((source, "RRTConnect", 0, named[2], 1.0, "default"))
    assert again["iterations"] == rows[2]["iterations"]  # seeded: the same run twice
    # a rule of one's own: the roadmaps' rule with a setting changed, named on the command line
    assert rules._run((source, "RRTConnect", 0, ("pw0", {**rules.RULES["roadmap"], "passage_weight": 0.0}),
                       1.0, "default"))["rule"] == "pw0"
    # the seed project's set-up: its small step takes more iterations on the same scene, seed and rule
    seeded = rules._run((source, "RRTConnect", 0, named[2], 1.0, "seed"))
    assert "refused" not in seeded and seeded["iterations"] > 0 and seeded["iterations"] != rows[2]["iterations"]


def test_the_twisted_slot_passes_only_a_body_rolled_with_it():
    pytest.importorskip("fcl", reason="the mesh extra")
    import math

    rules = load_script("experiments/tree_rule_meshes")
    seed = rules.TWIST_SEED0["tuning"]
    problem = rules.twisted_slot(seed)
    world = problem.world
    assert world.is_valid(problem.start) and world.is_valid(problem.goal)
    assert np.array_equal(rules.twisted_slot(seed).start, problem.start)  # seeded: the same scene twice
    # the first draw's slot (its witness passed on the first draw): a body rolled with it passes straight through
    c, t, _, _, phi, centre = rules.twist_geometry(np.random.default_rng(seed))
    before, after = np.array([c - t / 2 - 4.5, *centre, phi, 0.0, 0.0]), np.array([c + t / 2 + 4.5, *centre, phi, 0, 0])
    assert world.check_motion(before, after)
    quarter = (-math.pi / 2, 0.0, math.pi / 2, math.pi)  # and no axis-aligned orientation fits in the slot
    assert not any(world.is_valid(np.array([c, *centre, a, b, d])) for a in quarter for b in quarter for d in quarter)
    # the workspace route goes through the slot: its free voxels' Euclidean bound sees the oblique walls' distance
    from planners.guidance.workspace_route import voxel_route

    route = voxel_route(world, problem.start, problem.goal, world.route_cell)
    assert route is not None and route[0, 0] < c < route[-1, 0]
    with pytest.raises(SystemExit):  # twist has tuning and validation parts only
        rules.main(["--families", "twist", "--part", "test", "--out", "x.jsonl"])


def test_the_route_beside_omplapps_solution(tmp_path, capsys):
    probe = load_script("experiments/route_vs_solution")
    with pytest.raises(SystemExit):  # no .cfg with a .path there: refused before any work, naming the problem
        probe.main(["--omplapp", str(tmp_path), "--problems", "Easy"])
    assert "Easy" in capsys.readouterr().err
    folder = omplapp_folder("Easy.path")
    assert probe.main(["--omplapp", str(folder), "--problems", "Easy"]) == 0
    row = capsys.readouterr().out.strip().splitlines()[-1]
    assert row.startswith("| Easy |") and row.endswith("| 40 of 40 |")


def test_the_walk_replay_is_the_compiled_check_and_counts_fewer_gaps_below_a_whole_clearance(capsys):
    folder = omplapp_folder("Easy.cfg")
    replay = load_script("experiments/walk_poses")
    argv = ["--omplapp", str(folder), "--problems", "Easy", "--iterations", "300", "--motions", "150",
            "--guesses", "1", "0.99"]
    assert replay.main(argv) == 0  # 1 where the copy's verdicts at the shipped guess differ from the compiled check's
    rows = [line.split("|") for line in capsys.readouterr().out.splitlines() if line.startswith("| Easy")]
    whole, shipped = ({"guess": float(r[2]), "walk": float(r[3]), "gaps": float(r[5]), "free": r[6]} for r in rows)
    assert (whole["guess"], shipped["guess"]) == (1.0, 0.99) and whole["free"] == shipped["free"]
    assert shipped["gaps"] < whole["gaps"] and shipped["walk"] < whole["walk"]
    with pytest.raises(SystemExit):
        replay.main([*argv[:4], "--guesses", "1.5"])
    assert "--guesses 1.5" in capsys.readouterr().err
