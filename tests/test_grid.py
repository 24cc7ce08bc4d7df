"""OccupancyGrid: construction, loaders, and exact collision checking against rational arithmetic."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import exact_segment_free
from hypothesis import given
from hypothesis import strategies as st
from PIL import Image

from planners import OccupancyGrid
from planners.base.fileio import InputError

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


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("where", [0, 1])
def test_a_state_with_a_non_finite_entry_is_neither_valid_nor_moved_from_or_to(bad, where):
    g = OccupancyGrid(np.zeros((8, 8), bool))
    q = np.array([2.0, 3.0])
    q[where] = bad
    assert g.is_valid((2.0, 3.0)) and g.check_motion((2.0, 3.0), (5.0, 5.0))
    assert not g.is_valid(q)
    assert not g.check_motion(q, (5.0, 5.0)) and not g.check_motion((5.0, 5.0), q)


# --- origin (maps placed in a world frame) ------------------------------------------------------


def test_origin_places_the_cells_in_the_world():
    a = np.zeros((4, 6), bool)
    a[1, 2] = True  # row 1, col 2 covers x in [-3 + 1.0, -3 + 1.5), y in [2 + 0.5, 2 + 1.0)
    g = OccupancyGrid(a, 0.5, origin=(-3.0, 2.0))
    assert g.origin.tolist() == [-3.0, 2.0] and not g.origin.flags.writeable
    lo, hi = g.bounds
    assert lo.tolist() == [-3.0, 2.0] and hi.tolist() == [0.0, 4.0]
    assert not g.is_valid((-1.75, 2.75)) and g.is_valid((-2.75, 2.75))
    assert g.cell_of((-1.75, 2.75)) == (1, 2)
    assert g.cell_center(1, 2).tolist() == [-1.75, 2.75]
    assert "blocked cell (row 1, col 2)" in g.explain_invalid((-1.75, 2.75))
    assert "outside" in g.explain_invalid((0.25, 3.0))  # inside the origin-0 extent, outside this one
    assert not g.is_valid((-3.0, 3.0)) and g.is_valid((-2.99, 3.0))  # the left edge is a wall
    assert not g.y_up and "origin=(-3, 2)" in repr(g)
    assert g.free_volume() == OccupancyGrid(a, 0.5).free_volume()


@given(seed=st.integers(0, 10_000), ax=EIGHTHS, ay=EIGHTHS, bx=EIGHTHS, by=EIGHTHS,
       ox=st.sampled_from([-10.0, -3.25, 0.5, 7.0]), oy=st.sampled_from([-10.0, -0.125, 4.0]))
def test_motion_check_with_origin_equals_the_shifted_oracle(seed, ax, ay, bx, by, ox, oy):
    g = _grid(seed)
    shifted = OccupancyGrid(g.obstacles, origin=(ox, oy))
    assert shifted.check_motion((ax + ox, ay + oy), (bx + ox, by + oy)) == exact_segment_free(g, (ax, ay), (bx, by))


def test_bad_origin_is_refused():
    for bad in [(0.0,), (0.0, np.nan), "ab", (1, 2, 3)]:
        with pytest.raises(InputError, match="origin"):
            OccupancyGrid(np.zeros((2, 2), bool), origin=bad)


def test_shortest_path_is_in_the_grid_frame():
    from planners.maps.gridsearch import shortest_path, shortest_path_length

    a = np.zeros((5, 5), bool)
    a[1:4, 2] = True
    base = OccupancyGrid(a, 0.5)
    moved = OccupancyGrid(a, 0.5, origin=(-10.0, 3.0))
    s, g = (0.25, 1.25), (2.25, 1.25)
    path = shortest_path(moved, np.add(s, moved.origin), np.add(g, moved.origin))
    assert np.allclose(path, shortest_path(base, s, g) + moved.origin, atol=1e-12)
    assert moved.path_valid(path) and all(moved.is_valid(p) for p in path)
    assert shortest_path_length(moved, path[0], path[-1]) == shortest_path_length(base, s, g)


# --- robot radius: inflation ---------------------------------------------------------------------


def _inflate_brute_force(obstacles: np.ndarray, rc: float) -> np.ndarray:
    """The definition, cell pair by cell pair: blocked if the closed squares are within rc cells (edge = wall)."""
    padded = np.pad(obstacles, 1, constant_values=True)
    blocked = np.argwhere(padded)
    out = np.zeros_like(padded)
    for r, c in np.ndindex(padded.shape):
        gap_r = np.maximum(np.abs(blocked[:, 0] - r) - 1, 0)
        gap_c = np.maximum(np.abs(blocked[:, 1] - c) - 1, 0)
        out[r, c] = bool(np.any(gap_r**2 + gap_c**2 <= rc * rc))
    return out[1:-1, 1:-1]


@given(seed=st.integers(0, 10_000), radius=st.sampled_from([0.01, 0.5, 1.0, 1.49, 1.5, 2.0, 2.2, 3.0, 5.0, 40.0]),
       res=st.sampled_from([1.0, 0.5, 0.05]))
def test_inflate_equals_the_cell_distance_definition(seed, radius, res):
    rng = np.random.default_rng(seed)
    obs = rng.random((int(rng.integers(1, 12)), int(rng.integers(1, 12)))) < rng.random() * 0.2
    g = OccupancyGrid(obs, res, origin=(1.0, -2.0), y_up=True, source="s")
    inf = g.inflate(radius * res)
    assert np.array_equal(inf.obstacles, _inflate_brute_force(obs, radius))
    assert (inf.resolution, inf.y_up, inf.source) == (res, True, "s") and inf.origin.tolist() == [1.0, -2.0]


def test_inflate_zero_and_bad_radii():
    g = _grid(1, 8, 9)
    assert np.array_equal(g.inflate(0).obstacles, g.obstacles)
    for bad in [-0.1, np.nan, np.inf, "1", None, True]:
        with pytest.raises(InputError, match="radius"):
            g.inflate(bad)


def min_clearance(grid: OccupancyGrid, path, spacing: float) -> float:
    """Smallest distance from dense points along ``path`` to a blocked cell's closed square or the map edge.

    Independent of the library's checks: plain distances to every blocked square near each point.
    """
    path = np.asarray(path, float)
    res, (ox, oy) = grid.resolution, grid.origin
    (x0, y0), (x1, y1) = grid.bounds
    H, W = grid.shape
    blocked = np.argwhere(grid.obstacles)
    lo = np.stack([ox + blocked[:, 1] * res, oy + blocked[:, 0] * res], axis=1)  # squares' lower corners
    best = np.inf
    for a, b in zip(path[:-1], path[1:], strict=True):
        n = max(2, int(np.ceil(np.linalg.norm(b - a) / spacing)) + 1)
        pts = a + np.linspace(0.0, 1.0, n)[:, None] * (b - a)
        edge = np.minimum.reduce([pts[:, 0] - x0, x1 - pts[:, 0], pts[:, 1] - y0, y1 - pts[:, 1]])
        best = min(best, float(edge.min()))
        for chunk in np.array_split(pts, max(1, len(pts) // 64)):
            dx = np.maximum(np.maximum(lo[None, :, 0] - chunk[:, None, 0], chunk[:, None, 0] - lo[None, :, 0] - res), 0)
            dy = np.maximum(np.maximum(lo[None, :, 1] - chunk[:, None, 1], chunk[:, None, 1] - lo[None, :, 1] - res), 0)
            best = min(best, float(np.sqrt(dx**2 + dy**2).min()))
    return best


def test_inflated_plans_keep_the_robot_radius_clear():
    from planners import RRT, Problem, smooth

    rng = np.random.default_rng(5)
    obs = rng.random((40, 40)) < 0.01
    obs[8:32, 19:21] = True  # a wall to go around
    obs[:, :3] = obs[:3, :] = False
    grid = OccupancyGrid(obs, 0.1, origin=(-2.0, -2.0))
    radius = 0.17
    inflated = grid.inflate(radius)
    start, goal = (-1.25, -0.45), (1.05, 0.45)
    for world in (grid, inflated):
        assert world.is_valid(start) and world.is_valid(goal)
    # without inflation a smoothed path hugs the obstacles; that is what a robot radius is for
    plain = Problem(grid, start, goal, goal_tolerance=0.05)
    assert min_clearance(grid, smooth(RRT(plain, step_size=0.5, seed=0).solve(20000).path, plain), 0.002) < radius
    p = Problem(inflated, start, goal, goal_tolerance=0.05)
    for seed in range(3):
        res = RRT(p, step_size=0.5, seed=seed).solve(max_iterations=20000)
        assert res.solved
        path = smooth(res.path, p, seed=seed)
        assert min_clearance(grid, path, 0.002) > radius


def test_from_file_robot_radius(tmp_path):
    obs = np.zeros((12, 12), bool)
    obs[6, 6] = True
    np.save(tmp_path / "m.npy", obs)
    g = OccupancyGrid.from_file(tmp_path / "m.npy", resolution=0.5, robot_radius=0.6)
    assert np.array_equal(g.obstacles, OccupancyGrid(obs, 0.5).inflate(0.6).obstacles)
    assert g.obstacles[6, 4] and not g.obstacles[6, 3] and g.obstacles[0, 5] and not g.obstacles[2, 5]


# --- images read by their own value range --------------------------------------------------------


def test_16_bit_png_is_scaled_by_its_range(tmp_path):
    a = np.full((5, 6), 60000, np.uint16)
    a[1, 2] = a[3, 4] = 10000
    Image.fromarray(a).save(tmp_path / "m16.png")
    g = OccupancyGrid.from_image(tmp_path / "m16.png")
    assert np.array_equal(g.obstacles, a == 10000)
    assert not OccupancyGrid.from_file(tmp_path / "m16.png", threshold=0.1).obstacles.any()  # 10000/65535 = 0.15


def test_float_tiff_of_zeros_and_ones(tmp_path):
    f = np.ones((4, 5), np.float32)
    f[2, 1] = f[0, 4] = 0.0
    Image.fromarray(f).save(tmp_path / "m.tif")
    assert np.array_equal(OccupancyGrid.from_file(tmp_path / "m.tif").obstacles, f == 0)
    Image.fromarray(f * 200).save(tmp_path / "big.tif")
    with pytest.raises(InputError, match=r"big.tif.*0\.\.200.*\[0, 1\]"):
        OccupancyGrid.from_file(tmp_path / "big.tif")
    f[1, 1] = np.nan
    Image.fromarray(f).save(tmp_path / "nan.tif")
    with pytest.raises(InputError, match="nan.tif.*NaN"):
        OccupancyGrid.from_file(tmp_path / "nan.tif")


def _png_header_only(path, width, height):
    """A PNG whose header claims ``width`` x ``height`` gray pixels, with no image data worth decoding."""
    import struct
    import zlib

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", width, height, 1, 0, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\0" * 64))
                     + chunk(b"IEND", b""))
    return path


def test_huge_image_is_refused_from_its_header(tmp_path, monkeypatch):
    monkeypatch.delenv("SAMPLERGYM_MAX_PIXELS", raising=False)
    huge = _png_header_only(tmp_path / "huge.png", 20000, 20000)
    with pytest.raises(InputError, match=r"huge.png.*20000 x 20000.*max_pixels=400000000.*SAMPLERGYM_MAX_PIXELS"):
        OccupancyGrid.from_file(huge)
    Image.fromarray(np.full((300, 200), 255, np.uint8)).save(tmp_path / "m.png")
    with pytest.raises(InputError, match="m.png.*200 x 300"):
        OccupancyGrid.from_file(tmp_path / "m.png", max_pixels=59_999)
    assert OccupancyGrid.from_file(tmp_path / "m.png", max_pixels=60_000).shape == (300, 200)
    monkeypatch.setenv("SAMPLERGYM_MAX_PIXELS", "50000")
    with pytest.raises(InputError, match="m.png"):
        OccupancyGrid.from_image(tmp_path / "m.png")
    assert OccupancyGrid.from_image(tmp_path / "m.png", max_pixels=10**5).shape == (300, 200)
    monkeypatch.setenv("SAMPLERGYM_MAX_PIXELS", "lots")
    with pytest.raises(InputError, match="SAMPLERGYM_MAX_PIXELS='lots'"):
        OccupancyGrid.from_image(tmp_path / "m.png")
    # allowed past Pillow's own bomb limit, the header-only file is then read and found truncated
    with pytest.raises(InputError, match="cannot read .*huge.png"):
        OccupancyGrid.from_file(huge, max_pixels=400_000_000)


def test_huge_movingai_header_is_refused(tmp_path):
    p = _write(tmp_path, "type octile\nheight 2\nwidth 3\nmap\n.@.\nT..\n")
    with pytest.raises(InputError, match="m.map.*3 x 2"):
        OccupancyGrid.from_movingai(p, max_pixels=5)


# --- MovingAI: duplicate keys and non-ASCII files -------------------------------------------------


def test_movingai_duplicate_header_key_is_refused(tmp_path):
    p = _write(tmp_path, "type octile\nheight 2\nwidth 3\nheight 1\nmap\n.@.\n")
    with pytest.raises(InputError, match=r"m.map, line 4: 'height' is given twice \(first '2', again '1'\)"):
        OccupancyGrid.from_movingai(p)


@pytest.mark.parametrize("data", ["type octile\nheight 1\nwidth 2\nmap\n.é\n".encode(), b"type \xff\xfe\n"])
def test_non_ascii_movingai_map_names_the_file(tmp_path, data):
    p = tmp_path / "bad.map"
    p.write_bytes(data)
    with pytest.raises(InputError, match="bad.map.*not an ASCII"):
        OccupancyGrid.from_file(p)


def test_a_new_map_format_plugs_in_by_registering_a_reader(tmp_path, monkeypatch):
    from planners.maps import readers

    monkeypatch.setattr(readers, "MAP_READERS", dict(readers.MAP_READERS))

    @readers.register_reader(".txtmap", description="a text map")
    def read_text(path, *, resolution=1.0, **_):
        rows = path.read_text().split()
        return OccupancyGrid(np.array([[c == "#" for c in r] for r in rows]), resolution, source=str(path))

    f = tmp_path / "m.txtmap"
    f.write_text("..#\n...\n")
    grid = OccupancyGrid.from_file(f)
    assert grid.obstacles.tolist() == [[False, False, True], [False, False, False]]
    with pytest.raises(ValueError, match="already read by read_text"):
        readers.register_reader(".txtmap", description="again")(read_text)
    other = tmp_path / "m.xyz"
    other.write_text("?")
    with pytest.raises(InputError, match=r"unknown kind '\.xyz'.*a text map"):
        OccupancyGrid.from_file(other)


def test_an_unknown_world_kind_is_an_error_not_another_kinds_check():
    from planners.kernels import geometry
    from planners.kernels.state import WorldKernel

    grid = OccupancyGrid(np.zeros((8, 8), dtype=bool))
    k = grid.kernel
    assert geometry.state_free(k, np.array([2.5, 2.5]))
    alien = WorldKernel(7, k.grid, k.geom, k.body, k.params)
    with pytest.raises(ValueError, match="unknown world kind"):
        geometry.state_free(alien, np.array([2.5, 2.5]))


@given(st.integers(1, 90), st.integers(1, 90), st.floats(0.3, 12.0, allow_nan=False))
def test_the_resampled_shape_is_the_resampled_maps_shape(h, w, factor):
    from planners.worlds.grid import resample_obstacles, resampled_shape

    assert resampled_shape((h, w), factor) == resample_obstacles(np.zeros((h, w), bool), factor).shape
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="factor"):
            resampled_shape((h, w), bad)
