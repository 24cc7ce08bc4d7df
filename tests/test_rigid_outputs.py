"""``scripts/evaluate_rigid.py``'s outputs: the targets table marked held or not, the 6-DoF ECDFs and the passage.

Small runs (one scene a family, one seed, a low cap) on the box scenes and on the test-only mesh scenes.
"""

from __future__ import annotations

import math

import pytest
from conftest import load_script

from learning.evaluation.rigid import (
    RIGID_FIGURES,
    RigidRow,
    passage_candidates,
    rigid_targets,
    scene_set_of,
    targets_markdown,
)

PNG = b"\x89PNG\r\n\x1a\n"


def _row(scene: str, family: str, sampler: str, *, planner: str = "RRTConnect", seed: int = 0, solved: bool = True,
         iterations: int = 100, time: float = 0.1) -> RigidRow:
    return RigidRow(scene=scene, family=family, part="test", planner=planner, sampler=sampler, seed=seed,
                    solved=solved, iterations=iterations if solved else 500, cap=500, collision_checks=iterations,
                    sampler_checks=0, candidates=iterations, time=time)


def _marks(printed: str) -> list[str]:
    """The ``held`` cells of the targets table in ``printed``."""
    lines = printed[printed.index("| scene set |"):].splitlines()
    head = [c.strip() for c in lines[0].strip("|").split("|")]
    rows = [[c.strip() for c in line.strip("|").split("|")] for line in lines[2:] if line.startswith("|")]
    return [r[head.index("held")] for r in rows]


def _figures_written(out) -> None:
    for name in RIGID_FIGURES:
        data = (out / name).read_bytes()
        assert data.startswith(PNG) and len(data) > 10_000, name


def test_box_scenes_print_the_targets_held_or_not_and_write_the_ecdfs_and_a_passage(tmp_path, capsys):
    script = load_script("evaluate_rigid")
    out = tmp_path / "box"
    assert script.main(["--part", "test", "--families", "slot", "--test-only", "hatch", "--scenes", "1",
                        "--seeds", "1", "--planners", "RRTConnect", "--samplers", "uniform", "rigid_route",
                        "--max-iterations", "2000", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    marks = _marks(printed)
    assert len(marks) == 2 and set(marks) <= {"yes", "no"}  # slot and hatch, RRT-Connect, rigid_route
    assert "| hatch | RRTConnect | rigid_route | uniform |" in printed and "Held on " in printed
    summary = (out / "summary.md").read_text()
    assert "## Targets" in summary and _marks(summary) == marks
    _figures_written(out)
    assert "passage.png" in printed.splitlines()[-1]
    # a run where nothing solves: the ECDFs still, and no passage (an earlier run's is not left to pass for this one's)
    assert script.main(["--part", "test", "--families", "slot", "--test-only", "--scenes", "1", "--planners", "RRT",
                        "--samplers", "uniform", "--max-iterations", "5", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "Targets: none to judge" in printed and "no passage.png" in printed
    assert (out / "ecdf-rigid.png").is_file() and (out / "ecdf-rigid-time.png").is_file()
    assert not (out / "passage.png").exists()


def test_mesh_scenes_print_the_targets_and_write_the_figures(tmp_path, capsys):
    pytest.importorskip("trimesh")
    pytest.importorskip("fcl")
    script = load_script("evaluate_rigid")
    out = tmp_path / "mesh"
    assert script.main(["--mesh", "--part", "test", "--test-only", "hatch", "--scenes", "1", "--planners",
                        "RRTConnect", "--samplers", "uniform", "rigid_route", "--max-iterations", "2000",
                        "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "| hatch (mesh) | RRTConnect | rigid_route |" in printed
    assert len(_marks(printed)) == 1 and set(_marks(printed)) <= {"yes", "no"}
    _figures_written(out)


def test_targets_are_judged_per_scene_set_each_omplapp_problem_its_own():
    rows = [_row("hatch-3000000-mesh", "hatch", "uniform", iterations=400),
            _row("hatch-3000000-mesh", "hatch", "rigid_route", iterations=40, time=0.01),
            _row("Easy", "omplapp", "uniform", iterations=10),
            _row("Easy", "omplapp", "rigid_route", iterations=30),
            _row("Home", "omplapp", "uniform", solved=False),
            _row("Home", "omplapp", "rigid_route", iterations=50, time=0.01)]
    assert [scene_set_of(r) for r in rows[::2]] == ["hatch (mesh)", "OMPL.app Easy", "OMPL.app Home"]
    assert scene_set_of(_row("slot-1000000", "slot", "uniform")) == "slot"
    held = {t["scene set"]: t["held"] for t in rigid_targets(rows)}
    assert held == {"hatch (mesh)": True, "OMPL.app Easy": False, "OMPL.app Home": True}
    text = targets_markdown(rigid_targets(rows))
    assert "| OMPL.app Easy | RRTConnect | rigid_route |" in text and "Held on 2 of 3" in text
    assert _marks(text) == ["yes", "no", "yes"]
    assert targets_markdown(rigid_targets(rows[::2])).startswith("Targets: none to judge")


def test_the_passage_is_rigid_route_on_a_test_only_scene_with_rrt_connect_and_the_lowest_seed():
    rows = [_row("slot-1", "slot", "rigid_route"),
            _row("hatch-3", "hatch", "uniform"),
            _row("hatch-3", "hatch", "rigid_route", planner="RRT"),
            _row("hatch-3", "hatch", "rigid_route", seed=1),
            _row("hatch-3", "hatch", "rigid_route", seed=0, solved=False),
            _row("elbow-3-mesh", "elbow (mesh)", "rigid_route", seed=0)]
    first, *rest = passage_candidates(rows)
    assert (first.scene, first.planner, first.seed) == ("elbow-3-mesh", "RRTConnect", 0)
    assert [(r.scene, r.planner, r.seed) for r in rest] == [("hatch-3", "RRTConnect", 1), ("hatch-3", "RRT", 0),
                                                             ("slot-1", "RRTConnect", 0), ("hatch-3", "RRTConnect", 0)]
    assert rest[-1].sampler == "uniform" and not passage_candidates([_row("a", "hatch", "rigid_route", solved=False)])


def test_the_ecdf_line_counts_unsolved_runs_as_never_reached():
    from learning.evaluation.outputs import ecdf_line
    from planners.viz.plotting import new_figure

    ax = new_figure((3, 3)).add_subplot()
    line = ecdf_line(ax, [30, None, 10, math.inf], start=1.0, end=100.0)
    x, y = line.get_data()
    assert list(x) == [1.0, 10, 30, 100.0] and list(y) == [0.0, 0.25, 0.5, 0.5]
    x, y = ecdf_line(ax, [None], start=1.0, end=100.0).get_data()  # none solved: flat at 0 across the axis
    assert list(x) == [1.0, 100.0] and list(y) == [0.0, 0.0]
    assert ecdf_line(ax, []) is None
    x, y = ecdf_line(ax, [2, None]).get_data()  # as the 2-D figure draws it: from the first value
    assert list(y) == [0.5, 1.0] and x[0] == 2
