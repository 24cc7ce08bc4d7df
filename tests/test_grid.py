"""OccupancyGrid: construction, loaders, and exact collision checking against rational arithmetic."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import exact_segment_free
from hypothesis import given
from hypothesis import strategies as st
from PIL import Image

from planners import OccupancyGrid

# --- construction ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "arr, match",
    [
        (np.zeros((0, 5), bool), "empty"),
        (np.zeros(5, bool), "2-D"),
        (np.zeros((2, 2, 2), bool), "2-D"),
        (np.array([[0, 2], [1, 0]]), "only 0/1.*2.*row 0, col 1"),
        (np.array([[0.0, np.nan]]), "only 0/1"),
        (np.array([["a"]]), "dtype"),
    ],
)
def test_bad_arrays_are_rejected_with_the_value(arr, match):
    with pytest.raises(ValueError, match=match):
        OccupancyGrid(arr)


@pytest.mark.parametrize("res", [0, -1, np.nan, np.inf])
def test_bad_resolution(res):
    with pytest.raises(ValueError, match="resolution"):
        OccupancyGrid(np.zeros((3, 3), bool), resolution=res)


def test_grid_is_frozen_and_copied():
    a = np.zeros((4, 5), bool)
    g = OccupancyGrid(a)
    a[0, 0] = True
    assert not g.obstacles[0, 0]
    with pytest.raises(ValueError):
        g.obstacles[0, 0] = True
    assert g.shape == (4, 5) and g.width == 5 and g.height == 4
    lo, hi = g.bounds
    assert np.array_equal(lo, [0, 0]) and np.array_equal(hi, [5, 4])


def test_coordinates_and_resolution():
    a = np.zeros((10, 20), bool)
    a[3, 7] = True  # row 3, col 7 covers x in [7, 8), y in [3, 4)
    g = OccupancyGrid(a)
    assert not g.is_valid((7.5, 3.5))
    assert g.is_valid((3.5, 7.5))
    g2 = OccupancyGrid(a, resolution=0.5)
    assert not g2.is_valid((3.75, 1.75))
    assert g2.bounds[1].tolist() == [10.0, 5.0]
    assert g2.cell_of((3.75, 1.75)) == (3, 7)


# --- image loading ---------------------------------------------------------------------------


def test_from_image_threshold_invert_and_alpha(tmp_path):
    gray = np.full((6, 8), 255, np.uint8)
    gray[1, 2] = 0  # black -> obstacle
    gray[4, 5] = 100  # 0.39 gray -> obstacle at threshold 0.5, free at 0.3
    Image.fromarray(gray).save(tmp_path / "m.png")
    g = OccupancyGrid.from_image(tmp_path / "m.png")
    assert g.shape == (6, 8)
    assert set(map(tuple, np.argwhere(g.obstacles))) == {(1, 2), (4, 5)}
    light = OccupancyGrid.from_image(tmp_path / "m.png", threshold=0.3)
    assert set(map(tuple, np.argwhere(light.obstacles))) == {(1, 2)}
    assert OccupancyGrid.from_image(tmp_path / "m.png", invert=True).obstacles.sum() == 48 - 2
    rgba = np.zeros((3, 3, 4), np.uint8)  # fully transparent black counts as white
    rgba[1, 1] = (0, 0, 0, 255)
    Image.fromarray(rgba, "RGBA").save(tmp_path / "a.png")
    assert np.argwhere(OccupancyGrid.from_image(tmp_path / "a.png").obstacles).tolist() == [[1, 1]]
    Image.fromarray(np.stack([gray] * 3, -1)).save(tmp_path / "m.jpg", quality=100)
    assert OccupancyGrid.from_image(tmp_path / "m.jpg").obstacles[1, 2]


def test_from_image_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.png"):
        OccupancyGrid.from_image(tmp_path / "nope.png")
    (tmp_path / "bad.png").write_bytes(b"not an image")
    with pytest.raises(ValueError, match="bad.png"):
        OccupancyGrid.from_image(tmp_path / "bad.png")
    Image.fromarray(np.zeros((2, 2), np.uint8)).save(tmp_path / "ok.png")
    with pytest.raises(ValueError, match="threshold"):
        OccupancyGrid.from_image(tmp_path / "ok.png", threshold=1.5)


# --- MovingAI ------------------------------------------------------------------------------------

# (file, width, height, obstacle fraction) from ../shared/maps/README.md
MOVINGAI_TABLE = [
    ("arena.map", 49, 49, 0.145),
    ("den312d.map", 65, 81, 0.536),
    ("lak303d.map", 194, 194, 0.607),
    ("Berlin_0_256.map", 256, 256, 0.265),
    ("maze512-32-0.map", 512, 512, 0.032),
    ("random512-10-0.map", 512, 512, 0.100),
    ("32room_000.map", 512, 512, 0.082),
    ("maze-32-32-2.map", 32, 32, 0.350),
    ("room-32-32-4.map", 32, 32, 0.334),
    ("room-64-64-8.map", 64, 64, 0.211),
    ("random-32-32-10.map", 32, 32, 0.100),
    ("random-64-64-20.map", 64, 64, 0.202),
]


@pytest.mark.parametrize("name, w, h, frac", MOVINGAI_TABLE)
def test_movingai_maps_load(movingai, name, w, h, frac):
    g = OccupancyGrid.from_movingai(movingai / name)
    assert (g.width, g.height) == (w, h)
    assert g.obstacles.mean() == pytest.approx(frac, abs=6e-4)


def test_movingai_trees_are_obstacles(movingai):
    # '@' and 'T' both block; arena has trees
    text = (movingai / "arena.map").read_text().splitlines()[4:]
    g = OccupancyGrid.from_movingai(movingai / "arena.map")
    expect = np.array([[ch in "@OTW" for ch in row] for row in text])
    assert np.array_equal(g.obstacles, expect)
    assert any("T" in row for row in text)


def _write(tmp_path, text, name="m.map", newline="\n"):
    p = tmp_path / name
    p.write_bytes(text.replace("\n", newline).encode())
    return p


GOOD = "type octile\nheight 2\nwidth 3\nmap\n.@.\nT..\n"


@pytest.mark.parametrize("newline", ["\n", "\r\n"])
def test_movingai_line_endings_and_final_newline(tmp_path, newline):
    g = OccupancyGrid.from_movingai(_write(tmp_path, GOOD.rstrip("\n"), newline=newline))
    assert g.obstacles.tolist() == [[False, True, False], [True, False, False]]


@pytest.mark.parametrize(
    "text, match",
    [
        ("type octile\nheight 2\nwidth 3\nmap\n.@.\n", "height 2 but only 1"),
        ("type octile\nheight 2\nwidth 3\nmap\n.@..\nT..\n", "line 5.*4 characters.*width 3"),
        ("type octile\nheight 2\nwidth 3\nmap\n.@.\nTx.\n", "line 6, column 2.*'x'"),
        ("type octile\nheight two\nwidth 3\nmap\n", "'height' must be an integer.*'two'"),
        ("type octile\nwidth 3\nmap\n...\n", "no 'height'"),
        ("type octile\nheight 1\nwidth 3\n", "no 'map' line"),
        ("type octile\nbanana 3\n", "line 2.*banana"),
        ("type octile\nheight 1\nwidth 3\nmap\n...\n...\n", "line 6: unexpected content"),
    ],
)
def test_malformed_movingai_names_the_line(tmp_path, text, match):
    p = _write(tmp_path, text)
    with pytest.raises(ValueError, match=match) as info:
        OccupancyGrid.from_movingai(p)
    assert str(p) in str(info.value)


def test_movingai_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="absent.map"):
        OccupancyGrid.from_movingai(tmp_path / "absent.map")


# --- exact collision checking -------------------------------------------------------------------


def _grid(seed, h=6, w=7, p=0.3):
    return OccupancyGrid(np.random.default_rng(seed).random((h, w)) < p)


EIGHTHS = st.integers(-8, 8 * 8).map(lambda v: v / 8)  # lattice points, grid lines and corners included


@given(seed=st.integers(0, 10_000), ax=EIGHTHS, ay=EIGHTHS, bx=EIGHTHS, by=EIGHTHS)
def test_motion_check_equals_exact_oracle_on_lattice_inputs(seed, ax, ay, bx, by):
    g = _grid(seed)
    assert g.check_motion((ax, ay), (bx, by)) == exact_segment_free(g, (ax, ay), (bx, by))


@given(seed=st.integers(0, 10_000), pts=st.lists(st.floats(-1, 9, allow_nan=False), min_size=4, max_size=4))
def test_motion_check_never_accepts_a_colliding_float_segment(seed, pts):
    g = _grid(seed)
    a, b = pts[:2], pts[2:]
    if g.check_motion(a, b):
        assert exact_segment_free(g, a, b)


def test_corner_cases():
    a = np.zeros((3, 3), bool)
    a[0, 1] = a[1, 0] = True  # two obstacles touching diagonally at the lattice point (1, 1)
    g = OccupancyGrid(a)
    assert not g.check_motion((0.5, 0.5), (1.5, 1.5))  # through the shared corner: blocked
    assert not g.check_motion((1.5, 1.5), (0.5, 0.5))  # either direction
    b = np.zeros((3, 3), bool)
    b[0, 0] = True
    g2 = OccupancyGrid(b)
    assert g2.check_motion((1.0, 1.5), (1.0, 2.5))  # on a grid line between free cells only
    assert not g2.check_motion((0.5, 1.0), (2.5, 1.0))  # along the grid line bordering the obstacle
    assert g2.check_motion((0.5, 1.5), (2.5, 1.5))
    assert not g2.check_motion((2.0, 2.0), (1.0, 1.0))  # ends exactly on the obstacle's corner
    assert not g2.check_motion((1.5, 1.5), (1.5, 3.0))  # ends on the map edge
    assert not g2.check_motion((1.5, 1.5), (1.5, 4.0))  # leaves the map
    assert not g2.is_valid((0.0, 1.5)) and not g2.is_valid((1.5, 3.0))
    assert g2.is_valid((1.5, 1.5))
    long = OccupancyGrid(np.pad(np.zeros((1, 98), bool), 1, constant_values=False))
    assert long.check_motion((0.5, 1.5), (99.5, 1.5))


def test_batched_checks_match_single():
    g = _grid(3, 20, 20)
    rng = np.random.default_rng(0)
    A, B = rng.random((200, 2)) * 20, rng.random((200, 2)) * 20
    single = np.array([g.check_motion(a, b) for a, b in zip(A, B, strict=True)])
    assert np.array_equal(g.check_motions(A, B), single)
    assert 0 < single.sum() < len(single)
    assert not g.check_motion((1.0, np.nan), (2.0, 2.0))
