"""Fuzz every reader the library has: any input loads to something valid or raises ``InputError``.

Readers: images, MovingAI ``.map`` and ``.scen``, ROS map_server YAML, rigid-body scene files, sampler
checkpoints and environment actions. Each gets random bytes and structured near-misses of its format
(hypothesis, derandomized, so CI is reproducible). The contract under test: a reader returns a valid
object, or raises :class:`planners.base.fileio.InputError` whose message names the file or argument; never
another exception type, never a hang (each example has a deadline).
"""

from __future__ import annotations

import io
import json
import string
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from learning.models.shipped import SHIPPED_POLICY
from planners import OccupancyGrid, Problem, load_movingai_scenarios, load_scene
from planners.base.fileio import InputError

# The deadline catches hangs, not slowness: 10 s per example holds on a loaded CI machine, and each reader
# runs once before its timed examples so that imports and compilation are not timed.
FUZZ = settings(max_examples=40, deadline=10_000, suppress_health_check=[HealthCheck.function_scoped_fixture])


def _scratch(tmp_path_factory, name: str) -> Path:
    return tmp_path_factory.mktemp("fuzz") / name


def _check_grid(grid) -> None:
    assert isinstance(grid, OccupancyGrid)
    assert grid.obstacles.ndim == 2 and grid.obstacles.dtype == bool and grid.obstacles.size > 0


def _loads_or_names(read, path: Path, check) -> None:
    """``read(path)`` either returns something ``check`` accepts or raises InputError naming the file."""
    try:
        obj = read(path)
    except InputError as exc:
        assert path.name in str(exc), f"error does not name the file: {exc}"
        return
    check(obj)


# --- images ---------------------------------------------------------------------------------------


def _image_bytes(arr: np.ndarray, fmt: str) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(arr).save(buf, format=fmt)
    return buf.getvalue()


image_arrays = st.one_of(
    st.builds(lambda h, w, s: np.random.default_rng(s).integers(0, 256, (h, w), dtype=np.uint8),
              st.integers(1, 12), st.integers(1, 12), st.integers(0, 2**32 - 1)),
    st.builds(lambda h, w, s: np.random.default_rng(s).integers(0, 65536, (h, w)).astype(np.uint16),
              st.integers(1, 12), st.integers(1, 12), st.integers(0, 2**32 - 1)),
    st.builds(lambda h, w, s: np.random.default_rng(s).integers(0, 256, (h, w, 3), dtype=np.uint8),
              st.integers(1, 12), st.integers(1, 12), st.integers(0, 2**32 - 1)),
)


@FUZZ
@given(arr=image_arrays, garble=st.integers(0, 3), seed=st.integers(0, 2**32 - 1))
def test_image_reader(tmp_path_factory, arr, garble, seed):
    data = bytearray(_image_bytes(arr, "PNG"))
    rng = np.random.default_rng(seed)
    for _ in range(garble):  # flip bytes past the signature: a damaged file, not another format
        i = int(rng.integers(8, len(data)))
        data[i] = int(rng.integers(0, 256))
    path = _scratch(tmp_path_factory, "map.png")
    path.write_bytes(bytes(data))
    _loads_or_names(OccupancyGrid.from_file, path, _check_grid)


@FUZZ
@given(data=st.binary(max_size=300), suffix=st.sampled_from([".png", ".pgm", ".tif", ".npy", ".map", ".yaml"]))
def test_any_map_reader_on_random_bytes(tmp_path_factory, data, suffix):
    path = _scratch(tmp_path_factory, "map" + suffix)
    path.write_bytes(data)
    _loads_or_names(OccupancyGrid.from_file, path, _check_grid)


# --- MovingAI .map and .scen ----------------------------------------------------------------------

terrain = st.text(alphabet=".@TGSOW x\t", min_size=0, max_size=8)
header_value = st.one_of(st.integers(-3, 6).map(str), st.sampled_from(["", "nan", "1e3", "0x4", "4_0", "٣", "octile"]))


@st.composite
def movingai_text(draw) -> str:
    keys = draw(st.lists(st.sampled_from(["type", "height", "width", "map", "HEIGHT", "bogus"]), max_size=6))
    lines = [f"{k} {draw(header_value)}" if k not in ("map",) else k for k in keys]
    lines += draw(st.lists(terrain, max_size=6))
    return draw(st.sampled_from(["\n", "\r\n"])).join(lines)


@FUZZ
@given(text=movingai_text())
def test_movingai_map_reader(tmp_path_factory, text):
    path = _scratch(tmp_path_factory, "fuzz.map")
    path.write_text(text, encoding="latin-1", errors="replace")
    _loads_or_names(OccupancyGrid.from_file, path, _check_grid)


_MAP_4x4 = "type octile\nheight 4\nwidth 4\nmap\n....\n.@@.\n....\n....\n"
scen_field = st.one_of(st.integers(-2, 6).map(str), st.sampled_from(["nan", "inf", "-0", "1.5", "", "x", "é", "4_1"]))


@st.composite
def scen_text(draw) -> str:
    lines = [draw(st.sampled_from(["version 1", "version 1.0", "", "garbage"]))]
    for _ in range(draw(st.integers(0, 4))):
        fields = ["0", "m.map", "4", "4"] + [draw(scen_field) for _ in range(4)] + [draw(scen_field)]
        if draw(st.booleans()):
            fields = fields[: draw(st.integers(0, 9))]
        lines.append("\t".join(fields))
    return "\n".join(lines)


@FUZZ
@given(text=scen_text(), encoding=st.sampled_from(["ascii", "utf-8", "utf-16"]))
def test_movingai_scenario_reader(tmp_path_factory, text, encoding):
    folder = tmp_path_factory.mktemp("scen")
    (folder / "m.map").write_text(_MAP_4x4)
    path = folder / "fuzz.scen"
    path.write_bytes(text.encode(encoding, errors="replace"))

    def check(problems):
        for p in problems:
            assert isinstance(p, Problem)
            assert np.isfinite(p.reference_length) and p.reference_length >= 0

    _loads_or_names(lambda p: list(load_movingai_scenarios(p)), path, check)


# --- ROS map_server YAML --------------------------------------------------------------------------

yaml_value = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-5, 5).map(str),
    st.sampled_from(["[0.0, 0.0, 0.0]", "[1, 2]", "[a, b, c]", "trinary", "scale", "raw", "bogus", "", "map.pgm",
                     "../../etc/passwd", "!!python/object/apply:os.mkdir ['x']", "{a: 1}", "'quoted'", "0_5"]),
)
yaml_key = st.sampled_from(["image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode",
                            "unknown_key"])


@st.composite
def ros_yaml(draw) -> str:
    base = {"image": "map.pgm", "resolution": "0.05", "origin": "[-1.0, -2.0, 0.0]", "negate": "0",
            "occupied_thresh": "0.65", "free_thresh": "0.196"}
    for key in draw(st.lists(yaml_key, max_size=3)):
        if draw(st.booleans()) and key in base:
            del base[key]
        else:
            base[key] = draw(yaml_value)
    lines = [f"{k}: {v}" for k, v in base.items()]
    if draw(st.booleans()):
        lines.insert(draw(st.integers(0, len(lines))), draw(st.text(string.printable, max_size=20)))
    return "\n".join(lines)


@FUZZ
@given(text=ros_yaml())
def test_ros_yaml_reader(tmp_path_factory, text):
    folder = tmp_path_factory.mktemp("ros")
    (folder / "map.pgm").write_bytes(_pgm(np.full((6, 8), 254, np.uint8)))
    path = folder / "map.yaml"
    path.write_text(text)
    _loads_or_names(OccupancyGrid.from_file, path, _check_grid)
    assert not (folder / "x").exists()  # nothing in the YAML ran


def _pgm(arr: np.ndarray) -> bytes:
    h, w = arr.shape
    return f"P5\n{w} {h}\n255\n".encode() + arr.tobytes()


# --- rigid-body scenes ------------------------------------------------------------------------------

scene_number = st.one_of(st.floats(-3, 12, allow_nan=False).map(lambda v: f"{v:.3g}"),
                         st.sampled_from(["nan", "inf", "-inf", "0_3", "1e-12", "1e9", "x", "", "٣", "0"]))


@st.composite
def scene_text(draw) -> str:
    lines = ["bounds 0 0 0 10 10 10", "body box 1 1 1", "start 1 1 1 0 0 0", "goal 8 8 8 0 0 0"]
    for _ in range(draw(st.integers(0, 4))):
        key = draw(st.sampled_from(["bounds", "box", "point", "start", "goal", "tolerance", "delta", "rot_weight",
                                    "metric", "body", "bogus"]))
        lines.insert(draw(st.integers(0, len(lines))), " ".join([key] + draw(st.lists(scene_number, max_size=7))))
    if draw(st.booleans()):
        del lines[draw(st.integers(0, len(lines) - 1))]
    return "\n".join(lines)


@FUZZ
@given(text=scene_text(), encoding=st.sampled_from(["utf-8", "utf-16", "latin-1"]))
def test_scene_reader(tmp_path_factory, text, encoding):
    path = _scratch(tmp_path_factory, "fuzz.scene")
    path.write_bytes(text.encode(encoding, errors="replace"))

    def check(problem):
        assert isinstance(problem, Problem)
        assert np.isfinite(problem.goal_tolerance) and problem.goal_tolerance > 0

    _loads_or_names(load_scene, path, check)


# --- sampler checkpoints ------------------------------------------------------------------------------

SHIPPED = SHIPPED_POLICY


@st.composite
def damaged_checkpoint(draw) -> bytes:
    with zipfile.ZipFile(SHIPPED) as zf:
        entries = {name: zf.read(name) for name in zf.namelist()}
    victim = draw(st.sampled_from(sorted(entries)))
    how = draw(st.sampled_from(["drop", "garble", "truncate", "json"]))
    if how == "drop":
        del entries[victim]
    elif how == "garble":
        data = bytearray(entries[victim])
        rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
        for _ in range(draw(st.integers(1, 8))):
            if data:
                data[int(rng.integers(0, len(data)))] = int(rng.integers(0, 256))
        entries[victim] = bytes(data)
    elif how == "truncate":
        entries[victim] = entries[victim][: draw(st.integers(0, max(0, len(entries[victim]) - 1)))]
    else:
        value = draw(st.sampled_from([None, -5, float("nan"), "3", [1, 2], {"a": 1}, 1e308]))
        try:
            data = json.loads(entries["data"])
        except (KeyError, ValueError):
            data = {}
        key = draw(st.sampled_from(sorted(data) or ["samplergym_config"]))
        data[key] = value
        entries["data"] = json.dumps(data).encode()
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        for name, blob in entries.items():
            zf.writestr(name, blob)
    return buf.getvalue()


@pytest.fixture(scope="module")
def policy_loader():
    """``PolicySampler.load``, run once on the shipped checkpoint so that its imports are not timed."""
    from learning import PolicySampler

    PolicySampler.load(SHIPPED)
    return PolicySampler.load


@FUZZ
@given(blob=st.one_of(damaged_checkpoint(), st.binary(max_size=200)))
def test_checkpoint_reader(tmp_path_factory, policy_loader, blob):
    from learning import PolicySampler

    path = _scratch(tmp_path_factory, "policy.zip")
    path.write_bytes(blob)
    _loads_or_names(policy_loader, path, lambda s: isinstance(s, PolicySampler))


def _zip(entries: dict[str, bytes]) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
        for name, blob in entries.items():
            zf.writestr(name, blob)
    return buf.getvalue()


def _shipped_entries() -> dict[str, bytes]:
    with zipfile.ZipFile(SHIPPED) as zf:
        return {name: zf.read(name) for name in zf.namelist()}


@pytest.mark.parametrize("case", ["nested data", "data bomb", "weights bomb"])
def test_hostile_checkpoints_are_refused_before_the_work(tmp_path, case):
    """Deep JSON is an InputError, not RecursionError; a zip bomb is refused on its declared sizes."""
    import tracemalloc

    from learning import PolicySampler
    from learning.samplers.sb3 import load_sb3_policy

    entries = _shipped_entries()
    if case == "nested data":
        entries["data"] = b"[" * 200_000 + b"]" * 200_000
    elif case == "data bomb":
        entries["data"] = b'{"a": "' + b" " * (20 << 20) + b'"}'
    else:
        entries["policy.pth"] = b"\0" * (100 << 20)
    path = tmp_path / "hostile.zip"
    path.write_bytes(_zip(entries))
    assert path.stat().st_size < 1 << 20
    tracemalloc.start()
    try:
        with pytest.raises(InputError, match="hostile.zip.*(nested|unpacks|claims)"):
            PolicySampler.load(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 64 << 20, f"{peak / 2**20:.0f} MiB spent before refusing"
    with pytest.raises(InputError, match="hostile.zip"):
        load_sb3_policy(path, None)


def test_nested_training_configs_and_resume_states_are_named(tmp_path):
    from learning.training.policy import STATE_KEY, TrainConfig, read_state

    path = tmp_path / "deep.json"
    path.write_text('{"extra": ' + "[" * 10_000 + "]" * 10_000 + "}")
    with pytest.raises(InputError, match="deep.json.*nested"):
        TrainConfig.from_json(path)
    path.write_text('{"n' + "a" * 100_000 + '": 1}')
    with pytest.raises(InputError, match="unknown config keys") as err:
        TrainConfig.from_json(path)
    assert len(str(err.value)) < 400
    good = {"phase": "ppo", "round": 3, "ppo_steps": 0, "log_rows": 4, "dagger_rows": 10, "log_time": 1.0}
    for key, bad in (("phase", "x" * 10_000), ("round", "3"), ("ppo_steps", -1), ("log_rows", 1.5),
                     ("dagger_rows", None), ("log_time", float("nan"))):
        entries = _shipped_entries()
        data = json.loads(entries["data"])
        data[STATE_KEY] = {**good, key: bad}
        entries["data"] = json.dumps(data).encode()
        (tmp_path / "run").mkdir(exist_ok=True)
        (tmp_path / "run" / "checkpoint.zip").write_bytes(_zip(entries))
        with pytest.raises(InputError, match=f"checkpoint.zip.*{key}") as err:
            read_state(tmp_path / "run")
        assert len(str(err.value)) < 400


# --- environment actions --------------------------------------------------------------------------------

odd_actions = st.one_of(
    st.none(), st.text(max_size=3), st.integers(-10, 10), st.floats(allow_nan=True, allow_infinity=True),
    st.lists(st.floats(allow_nan=True, allow_infinity=True, width=32), max_size=4).map(
        lambda v: np.asarray(v, dtype=np.float32)),
    st.lists(st.integers(-3, 12), max_size=3).map(np.asarray),
)


@pytest.mark.parametrize("env_id, kwargs", [
    ("SamplerGym/RRT-Forest-v2", {}),
    ("SamplerGym/RRT-Forest-v2", {"action_mode": "guided", "observation": "egocentric"}),
    ("SamplerGym/RRT-Forest-v2", {"action_mode": "bias"}),
    ("SamplerGym/RRT-RigidBody-v1", {}),
])
def test_env_actions(env_id, kwargs):
    import gymnasium as gym

    import envs

    gym.register_envs(envs)
    env = gym.make(env_id, **kwargs).unwrapped
    env.reset(seed=0)
    env.step(env.action_space.sample())  # compile before the timed examples

    @settings(max_examples=40, deadline=2000)
    @given(action=odd_actions)
    def run(action):
        env.reset(seed=1)
        try:
            obs, reward, terminated, truncated, _ = env.step(action)
        except InputError as exc:
            assert "action" in str(exc)
            return
        assert env.observation_space.contains(obs)
        assert np.isfinite(reward)

    run()
    env.close()


# --- bounded work ----------------------------------------------------------------------------------


def test_generated_sizes_have_a_limit_that_names_how_to_raise_it(monkeypatch, tmp_path):
    from learning.training.policy import TrainConfig
    from planners.maps.generators import MAX_SIZE_ENV, generate

    monkeypatch.delenv(MAX_SIZE_ENV, raising=False)
    for size in (100_000, 10**6):
        with pytest.raises(InputError, match=rf"size = {size}: .*at most 4096 .*{MAX_SIZE_ENV}={size}"):
            generate("forest", 0, size)
    path = tmp_path / "big.json"
    path.write_text(json.dumps({"sizes": [64, 10**6]}))
    with pytest.raises(InputError, match=f"big.json.*sizes = 1000000.*{MAX_SIZE_ENV}"):
        TrainConfig.from_json(path)
    monkeypatch.setenv(MAX_SIZE_ENV, "40")
    with pytest.raises(InputError, match="at most 40"):
        generate("forest", 0, 64)
    assert generate("forest", 0, 40).world.obstacles.shape == (40, 40)
    monkeypatch.setenv(MAX_SIZE_ENV, "many")
    with pytest.raises(InputError, match=f"{MAX_SIZE_ENV}='many'"):
        generate("forest", 0, 64)


@pytest.mark.parametrize("step", [1e-5, 1e-9, 1e-300])
def test_tiny_steps_are_refused_relative_to_the_map(monkeypatch, step):
    from planners import RRT
    from planners.algorithms.rrt import MAX_STEPS_ENV, RRTConnect
    from planners.maps.generators import generate

    monkeypatch.delenv(MAX_STEPS_ENV, raising=False)
    problem = generate("forest", 0, 64)
    for planner in (RRT, RRTConnect):
        with pytest.raises(InputError, match=rf"step_size = {step:g} .*at least 0.000905.*{MAX_STEPS_ENV}="):
            planner(problem, step_size=step)
    assert RRTConnect(problem, step_size=0.001).step_size == 0.001


@pytest.mark.parametrize("lines, line, match", [
    (["bounds 0 0 0 1e308 1e308 1e308"], 1, "workspace bounds .* too large"),
    (["bounds -1e308 0 0 1e308 10 10"], 1, "workspace bounds .* too large"),
    (["bounds 0 0 0 10 10 10", "delta 1e9"], 2, "delta 1e\\+09 leaves no valid state"),
    (["bounds 0 0 0 10 10 10", "delta 10"], 2, "delta 10 leaves no valid state"),
], ids=["huge bounds", "huge span", "delta 1e9", "delta = side"])
def test_scene_values_are_blamed_on_their_own_line(tmp_path, lines, line, match):
    path = tmp_path / "odd.scene"
    body = lines + ["start 1 1 1 0 0 0", "goal 9 9 9 0 0 0"]
    path.write_text("\n".join(body) + "\n")
    with pytest.raises(InputError, match=rf"odd.scene, line {line}: {match}"):
        load_scene(path)


def test_scene_angles_out_of_range_are_refused(tmp_path):
    path = tmp_path / "angles.scene"
    path.write_text("bounds 0 0 0 10 10 10\nstart 1 1 1 0 0 0\ngoal 9 9 9 1e300 0 0\n")
    with pytest.raises(InputError, match=r"angles.scene, line 3: goal angles .*within \+-2 pi"):
        load_scene(path)


def test_the_box_count_has_a_limit_that_names_how_to_raise_it(monkeypatch):
    from planners.worlds.rigid3d import MAX_BOXES_ENV, RigidBodyWorld

    monkeypatch.setenv(MAX_BOXES_ENV, "3")
    boxes = [(i, 0, 0, i + 0.5, 1, 1) for i in range(4)]
    with pytest.raises(InputError, match=f"4 boxes, more than the limit of 3.*{MAX_BOXES_ENV}=4"):
        RigidBodyWorld(boxes)
    assert len(RigidBodyWorld(boxes[:3]).boxes) == 3


@pytest.mark.parametrize("image, says", [(".", "which is a folder"), ("/dev/null", "not a regular file"),
                                         ("missing.png", "does not exist")])
def test_ros_image_that_is_not_a_file_is_named_for_what_it_is(tmp_path, image, says):
    from planners.maps.rosmap import load_ros_map

    path = tmp_path / "map.yaml"
    path.write_text(f"image: {image}\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\n"
                    "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    with pytest.raises(InputError, match=f"map.yaml: 'image' names .*{says}"):
        load_ros_map(path)


def test_time_limits_hold_on_a_scene_at_the_box_limit():
    """5,000 boxes (the default limit): PRM, RRT and RRT-Connect stop within about their time limit."""
    import time

    from planners import PRM, RRT, Problem, RRTConnect
    from planners.worlds.rigid3d import DEFAULT_MAX_BOXES, RigidBodyWorld, random_scene

    rng = np.random.default_rng(0)
    corners = np.column_stack([rng.uniform(3, 7, DEFAULT_MAX_BOXES), rng.uniform(0, 10, (DEFAULT_MAX_BOXES, 2))])
    world = RigidBodyWorld(np.hstack([corners, corners + 0.05]))
    problem = Problem(world, [1, 5, 5, 0, 0, 0], [9, 5, 5, 0, 0, 0], goal_tolerance=0.5)
    for planner in (PRM, RRT, RRTConnect):
        planner(random_scene(1, 5), seed=0).solve(max_iterations=20)  # compile outside the timing
        t0 = time.perf_counter()
        result = planner(problem, seed=0).solve(time_limit=0.5)
        took = time.perf_counter() - t0
        assert result.solved or result.stop_reason == "time_limit"
        assert took < 0.5 + 1.5, f"{planner.__name__}: {took:.2f} s under a 0.5 s limit"
