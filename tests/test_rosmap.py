"""ROS map_server maps: the map.yaml subset, ROS's pixel semantics, metres and y up, on a real turtlebot3 map."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from test_grid import min_clearance

from planners import RRT, OccupancyGrid, Problem, smooth
from planners.base.fileio import InputError
from planners.maps.rosmap import load_ros_map, parse_map_yaml

TB3 = Path(__file__).parent / "data" / "ros" / "turtlebot3_world" / "map.yaml"
TB3_RADIUS = 0.105  # turtlebot3 burger's footprint radius, metres


def _read_pgm(path: Path) -> np.ndarray:
    """A binary 8-bit PGM's pixels, parsed by hand (no Pillow), image rows top first."""
    data = path.read_bytes()
    tokens, pos = [], 0
    while len(tokens) < 4:
        m = re.compile(rb"\s*(#[^\n]*\n\s*)*(\S+)").match(data, pos)
        tokens.append(m.group(2))
        pos = m.end()
    assert tokens[0] == b"P5" and tokens[3] == b"255"
    w, h = int(tokens[1]), int(tokens[2])
    return np.frombuffer(data[pos + 1: pos + 1 + w * h], dtype=np.uint8).reshape(h, w)


def _ros_classes(x, occ=0.65, free=0.196) -> np.ndarray:
    """map_server's trinary rule, pixel by pixel: 100 occupied, 0 free, -1 unknown."""
    out = np.full(x.shape, -1)
    for idx, v in np.ndenumerate(x):
        p = (255 - float(v)) / 255.0
        out[idx] = 100 if p > occ else 0 if p < free else -1
    return out


# --- the shipped turtlebot3 map ------------------------------------------------------------------


def test_turtlebot3_map_loads_in_metres_with_y_up():
    g = OccupancyGrid.from_file(TB3)
    assert g.shape == (384, 384) and g.resolution == 0.05 and g.y_up
    assert g.origin.tolist() == [-10.0, -10.0]
    assert np.allclose(g.bounds[1], [-10.0 + 384 * 0.05] * 2)
    classes = _ros_classes(_read_pgm(TB3.with_name("map.pgm")))
    # the image's bottom row is grid row 0 (ROS's origin is the lower-left pixel); unknown is blocked
    assert np.array_equal(g.obstacles, classes[::-1] != 0)
    assert (classes == -1).sum() > 100_000 and (classes == 0).sum() > 5_000  # grey 205 everywhere outside
    assert g.is_valid((-2.0, -0.5))  # turtlebot3's spawn pose in turtlebot3_world
    assert not g.is_valid((0.0, 0.0))  # the centre pillar (its rim occupied, its unscanned inside unknown)
    assert not g.is_valid((-9.0, -9.0))  # unmapped: unknown, so blocked
    free_unknown = load_ros_map(TB3, unknown="free")
    assert free_unknown.is_valid((-9.0, -9.0))
    assert np.array_equal(free_unknown.obstacles, classes[::-1] == 100)


def test_turtlebot3_plan_between_rviz_points_stays_in_known_free_space():
    classes = _ros_classes(_read_pgm(TB3.with_name("map.pgm")))[::-1]  # row 0 = bottom row, as the map frame
    grid = OccupancyGrid.from_file(TB3, robot_radius=TB3_RADIUS)
    plain = OccupancyGrid.from_file(TB3)
    start, goal = (-2.0, -0.5), (2.0, 0.5)  # metres in the map frame, as read off RViz
    p = Problem(grid, start=start, goal=goal, goal_tolerance=0.1)
    for seed in range(3):
        res = RRT(p, step_size=0.3, seed=seed).solve(max_iterations=50_000)
        assert res.solved and np.allclose(res.path[0], start)
        path = smooth(res.path, p, seed=seed)
        assert np.linalg.norm(path[-1] - np.array(goal)) <= 0.1
        # every point of the path lies in a known-free pixel, found from the raw image by hand
        for a, b in zip(path[:-1], path[1:], strict=True):
            for t in np.linspace(0.0, 1.0, 200):
                x, y = a + t * (b - a)
                assert classes[int((y + 10.0) // 0.05), int((x + 10.0) // 0.05)] == 0
        assert min_clearance(plain, path, 0.005) > TB3_RADIUS


# --- map_server's pixel semantics -----------------------------------------------------------------


def _yaml(tmp_path, image="m.png", **fields):
    base = dict(resolution=0.5, origin="[1.0, -2.0, 0.0]", negate=0, occupied_thresh=0.65, free_thresh=0.196)
    base.update(fields)
    text = f"image: {image}\n" + "".join(f"{k}: {v}\n" for k, v in base.items() if v is not None)
    (tmp_path / "m.yaml").write_text(text)
    return tmp_path / "m.yaml"


LEVELS = np.array([[0, 89, 90, 204, 205, 255]], np.uint8)  # p = 1, 0.651, 0.647, 0.2, 0.196, 0


def test_trinary_and_negate(tmp_path):
    Image.fromarray(np.vstack([LEVELS, LEVELS[:, ::-1]])).save(tmp_path / "m.png")
    g = load_ros_map(_yaml(tmp_path), unknown="free")
    expect = _ros_classes(np.vstack([LEVELS, LEVELS[:, ::-1]]))[::-1]
    assert np.array_equal(g.obstacles, expect == 100)
    assert np.array_equal(load_ros_map(_yaml(tmp_path)).obstacles, expect != 0)
    # negate: p = x / 255
    neg = load_ros_map(_yaml(tmp_path, negate=1), unknown="free")
    assert np.array_equal(neg.obstacles, _ros_classes(255 - np.vstack([LEVELS, LEVELS[:, ::-1]]))[::-1] == 100)
    assert g.origin.tolist() == [1.0, -2.0] and g.resolution == 0.5
    # colour pixels average their channels (alpha excluded) before the rule
    rgb = np.zeros((1, 3, 3), np.uint8)
    rgb[0, 0] = (255, 255, 255)
    rgb[0, 1] = (255, 255, 0)  # average 170: p = 0.33, unknown
    rgb[0, 2] = (0, 0, 255)  # average 85: p = 0.67, occupied
    Image.fromarray(rgb).save(tmp_path / "m.png")
    assert load_ros_map(_yaml(tmp_path), unknown="free").obstacles.tolist() == [[False, False, True]]
    assert load_ros_map(_yaml(tmp_path)).obstacles.tolist() == [[False, True, True]]


def test_scale_mode_alpha_is_unknown(tmp_path):
    la = np.zeros((1, 4, 2), np.uint8)
    la[0, :, 0] = (255, 255, 0, 150)  # free, free, occupied, in between (graded, unknown here)
    la[0, :, 1] = (255, 0, 255, 255)  # the second pixel is transparent: unknown
    Image.fromarray(la, mode="LA").save(tmp_path / "m.png")
    assert load_ros_map(_yaml(tmp_path, mode="scale")).obstacles.tolist() == [[False, True, True, True]]
    assert load_ros_map(_yaml(tmp_path, mode="scale"), unknown="free").obstacles.tolist() == [[False, False, True,
                                                                                              False]]
    # trinary ignores alpha
    assert load_ros_map(_yaml(tmp_path), unknown="free").obstacles.tolist() == [[False, False, True, False]]


def test_raw_mode_values_are_occupancy_percent(tmp_path):
    Image.fromarray(np.array([[0, 19, 20, 65, 66, 100, 101, 255]], np.uint8)).save(tmp_path / "m.png")
    g = load_ros_map(_yaml(tmp_path, mode="raw"), unknown="free")
    assert g.obstacles.tolist() == [[False, False, False, False, True, True, False, False]]
    assert load_ros_map(_yaml(tmp_path, mode="raw")).obstacles.tolist() == [[False, False, True, True, True, True,
                                                                             True, True]]


# --- the YAML subset -----------------------------------------------------------------------------


def test_yaml_subset_comments_quotes_and_absolute_image(tmp_path):
    Image.fromarray(np.full((2, 3), 255, np.uint8)).save(tmp_path / "my map.pgm")
    sub = tmp_path / "sub"
    sub.mkdir()
    (sub / "m.yaml").write_text(
        "---\n# saved by hand\nimage: \"" + str(tmp_path / "my map.pgm") + "\"  # absolute\n"
        "resolution: 5e-2\norigin: [ -1.5 , 2, 0.0 ]\nnegate: false\n"
        "occupied_thresh: 0.65\nfree_thresh: .196\nmode: 'trinary'\nextra_key: ignored\n")
    meta = parse_map_yaml(sub / "m.yaml")
    assert meta["origin"] == [-1.5, 2.0, 0.0] and meta["free_thresh"] == 0.196 and meta["negate"] is False
    g = OccupancyGrid.from_file(sub / "m.yaml")
    assert g.shape == (2, 3) and g.resolution == 0.05 and g.origin.tolist() == [-1.5, 2.0] and not g.obstacles.any()


@pytest.mark.parametrize(
    "change, match",
    [
        (dict(resolution=0.5, negate=None), "missing negate"),
        (dict(origin="[1.0, -2.0, 0.5]"), "yaw is 0.5.*only yaw 0"),
        (dict(origin="[1.0, -2.0]"), r"'origin' must be \[x, y, yaw\]"),
        (dict(origin="[1.0, -2.0, 0.0"), "does not end with"),
        (dict(resolution=-0.5), "'resolution' must be positive"),
        (dict(resolution=".nan"), "'resolution' must be a finite number"),
        (dict(resolution="fine"), "'resolution' must be a finite number.*'fine'"),
        (dict(occupied_thresh=1.5), r"'occupied_thresh' must lie in \[0, 1\]"),
        (dict(free_thresh=0.7), "'free_thresh' .0.7. must not exceed"),
        (dict(negate=2), "'negate' must be 0 or 1"),
        (dict(mode="fancy"), "'mode' must be one of trinary, scale, raw.*'fancy'"),
        (dict(mode="!!python/object/apply:os.system ['touch pwned']"), "unsupported YAML value"),
        (dict(image="absent.png"), "'image' names .*absent.png.*does not exist"),
    ],
)
def test_bad_yaml_is_refused_naming_file_and_value(tmp_path, change, match):
    Image.fromarray(LEVELS).save(tmp_path / "m.png")
    image = change.pop("image", "m.png")
    with pytest.raises(InputError, match=match) as info:
        OccupancyGrid.from_file(_yaml(tmp_path, image=image, **change))
    assert "m.yaml" in str(info.value)
    assert not (tmp_path / "pwned").exists() and not Path("pwned").exists()


@pytest.mark.parametrize(
    "text, match",
    [
        ("image: m.png\nresolution: 0.5\nresolution: 0.1\n", "line 3: 'resolution' is given twice"),
        ("image: m.png\n  resolution: 0.5\n", "line 2: expected a top-level 'key: value'"),
        ("image m.png\n", "line 1: expected a top-level"),
        ("image: 'm.png\n", "unterminated quoted string"),
    ],
)
def test_malformed_yaml_lines(tmp_path, text, match):
    (tmp_path / "m.yaml").write_text(text)
    with pytest.raises(InputError, match=f"m.yaml.*{match}"):
        OccupancyGrid.from_file(tmp_path / "m.yaml")


def test_non_utf8_yaml_and_misused_arguments(tmp_path):
    (tmp_path / "m.yaml").write_bytes(b"image: m\xff.png\n")
    with pytest.raises(InputError, match="m.yaml: not a UTF-8"):
        OccupancyGrid.from_file(tmp_path / "m.yaml")
    Image.fromarray(LEVELS).save(tmp_path / "m.png")
    y = _yaml(tmp_path)
    with pytest.raises(InputError, match="resolution=0.1 cannot be applied"):
        OccupancyGrid.from_file(y, resolution=0.1)
    with pytest.raises(InputError, match="unknown must be one of"):
        OccupancyGrid.from_file(y, unknown="maybe")
    with pytest.raises(FileNotFoundError, match="absent.yaml"):
        OccupancyGrid.from_file(tmp_path / "absent.yaml")
