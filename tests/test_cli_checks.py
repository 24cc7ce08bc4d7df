"""The benchmark commands check every argument before their first run: exit 2 with one line naming the flag."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from conftest import load_script  # noqa: E402


@pytest.mark.parametrize("script, flags, named", [
    ("benchmark_planners", ["--seeds", "0"], "--seeds"),
    ("benchmark_planners", ["--size", "100000"], "--size = 100000"),
    ("benchmark_planners", ["--step", "nan"], "--step"),
    ("benchmark_planners", ["--tolerance", "-1"], "--tolerance"),
    ("benchmark_planners", ["--max-iterations", "0"], "--max-iterations"),
    ("benchmark_planners", ["--movingai", "/nonexistent/maps"], "--movingai"),
    ("benchmark_planners", ["--out", "FILE"], "--out"),
    ("benchmark_backends", ["--processes", "0"], "--processes"),
    ("benchmark_backends", ["--empty-tasks", "-3"], "--empty-tasks"),
    ("benchmark_envs", ["--steps", "0"], "--steps"),
    ("benchmark_envs", ["--modes", "bias,nope"], "--modes"),
    ("benchmark_envs", ["--files", "/nonexistent.png"], "--files"),
    ("sb3_defaults", ["--steps", "0"], "--steps"),
    ("sb3_defaults", ["--family", "lake"], "--family"),
    ("sb3_defaults", ["--batch", "-1"], "--batch"),
    ("sb3_defaults", ["--rigid", "--scenes", "0"], "--scenes"),
    ("benchmark_policy", ["--maps", "0"], "--maps"),
    ("benchmark_policy", ["--bias", "2"], "--bias"),
    ("benchmark_route", ["--sides", "4"], "--sides"),
    ("benchmark_route", ["--threads", "0"], "--threads"),
    ("benchmark_route", ["--symmetries", "9"], "--symmetries"),
    ("benchmark_route", ["--route", "/nonexistent/route.pt"], "--route"),
    ("benchmark_route", ["--kept", "-1"], "--kept"),
    ("benchmark_route", ["--device", "cuda"] if not __import__("torch").cuda.is_available() else ["--batch", "0"],
     "--device" if not __import__("torch").cuda.is_available() else "--batch"),
])
def test_bad_flags_exit_2_with_one_line(tmp_path, capsys, script, flags, named):
    (tmp_path / "FILE").write_text("x")
    flags = [str(tmp_path / "FILE") if f == "FILE" else f for f in flags]
    with pytest.raises(SystemExit) as exc:
        load_script(script).main(flags)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert named in err and err.count("\n") == 1, err


def test_benchmark_route_table_and_refusal(capsys, monkeypatch):
    """A small side is timed, a side above the block limit is a 'refused' row naming the limit."""
    monkeypatch.setenv("SAMPLERGYM_MAX_ROUTE_BLOCKS", "256")  # 32 x 32 cells at the shipped encoder's 2 cells per block
    assert load_script("benchmark_route").main(["--sides", "32", "64", "--repeat", "1", "--batch", "2",
                                                "--symmetries", "2", "--families", "maze"]) == 0
    out = capsys.readouterr().out.split("| family |")[1]  # the table after the rows printed as they come
    rows = [line for line in out.splitlines() if line.startswith("| maze | 32 ") or line.startswith("| maze | 64 ")]
    assert len(rows) == 2 and "refused" in rows[1] and "refused" not in rows[0], out
    assert "above the limit of 256 blocks" in out


def test_benchmark_route_times_the_torch_inference_on_request(capsys):
    from learning.models.route_vin import RouteVIN

    assert load_script("benchmark_route").main(["--sides", "32", "--repeat", "1", "--families", "forest",
                                                "--torch-inference"]) == 0
    out = capsys.readouterr().out
    assert "torch inference" in out.splitlines()[0] and "| forest | 32 " in out
    assert RouteVIN.compiled_inference  # the script's own encoder only


def test_benchmark_route_times_first_queries_with_other_maps_kept(capsys):
    assert load_script("benchmark_route").main(["--sides", "32", "--repeat", "2", "--families", "forest",
                                                "--kept", "3"]) == 0
    lines = capsys.readouterr().out.splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("| family |"))  # the table after the rows
    header = [c.strip() for c in lines[at].split("|")]
    row = next(line for line in lines[at:] if line.startswith("| forest | 32 "))
    assert float(row.split("|")[header.index("kept_ms")]) > 0


def test_benchmark_route_times_a_new_maps_two_fields(capsys):
    assert load_script("benchmark_route").main(["--sides", "32", "--repeat", "2", "--families", "maze",
                                                "--two-fields"]) == 0
    lines = capsys.readouterr().out.splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("| family |"))
    header = [c.strip() for c in lines[at].split("|")]
    row = next(line for line in lines[at:] if line.startswith("| maze | 32 "))
    assert float(row.split("|")[header.index("two_fields_ms")]) > 0


def test_benchmark_envs_runs_every_registered_id_and_leaves_guided_actions_to_the_2d_ones(capsys):
    script = load_script("benchmark_envs")
    assert script.main(["--steps", "1", "--modes", "guided"]) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| SamplerGym/")]
    ids = {line.split("|")[1].strip() for line in rows}
    assert "SamplerGym/RRT-Maze-v2" in ids and not any("Rigid" in i for i in ids)


def test_the_first_call_benchmark_runs_the_mesh_rows_only_with_omplapps_files(capsys, monkeypatch):
    monkeypatch.delenv("SAMPLERGYM_OMPLAPP_DIR", raising=False)
    script = load_script("benchmark_first_call")
    assert script.main(["--rows", "mesh-easy"]) == 2
    assert "--omplapp" in capsys.readouterr().err
    assert script.main(["--rows", "mesh-cubicles", "--omplapp", "/nonexistent/omplapp"]) == 2
    assert "/nonexistent/omplapp" in capsys.readouterr().err


def test_the_first_call_benchmark_checks_the_checkout_it_compares_against(capsys, tmp_path):
    script = load_script("benchmark_first_call")
    assert script.main(["--rows", "rrt-goal", "--against", str(tmp_path)]) == 2
    assert "--against" in capsys.readouterr().err
    assert script.main(["--rows", "rrt-goal", "--against", str(Path(__file__).resolve().parents[1]), "--save"]) == 2
    assert "not with --against" in capsys.readouterr().err
    assert script.main(["--rows", "rrt-goal", "--against", str(Path(__file__).resolve().parents[1])]) == 2
    assert "another" in capsys.readouterr().err
