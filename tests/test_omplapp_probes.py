"""The OMPL.app probes: omplapp_frames.py (readings of instanced parts, origins, the replay) and mesh_vs_ompl.py."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import load_script

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
