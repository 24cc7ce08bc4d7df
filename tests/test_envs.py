"""Environments: API checkers, determinism, pickling, vector envs, actions, rewards, rendering."""

from __future__ import annotations

import importlib
import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
from conftest import movingai_dir
from PIL import Image

import envs
from envs import ENV_IDS, SamplerEnv, record_episode
from planners import RRT, UniformSampler
from planners.base.fileio import InputError
from planners.maps.generators import generate

gym.register_envs(envs)


@pytest.fixture(scope="module")
def png_map(tmp_path_factory):
    img = np.full((48, 64), 255, np.uint8)
    img[10:38, 30:34] = 0
    path = tmp_path_factory.mktemp("maps") / "floor.png"
    Image.fromarray(img).save(path)
    return path


def make_kwargs(env_id, png_map, **extra):
    kw = dict(extra)
    if env_id.endswith("Files-v2"):
        kw["source_kwargs"] = {"paths": [str(png_map)]}
    if env_id.endswith("MovingAI-v2"):
        if movingai_dir() is None:
            pytest.skip("MovingAI maps not found")
        kw["source_kwargs"] = {"directory": str(movingai_dir()), "maps": ["arena", "room-32-32-4"], "per_map": 5}
    return kw


CHECKER_WARNINGS = (
    "minimal resolution",  # SB3: the 32x32 local window is below NatureCNN's minimum; we ship our own extractor
    "not have the same shape",
    "no display is available",  # the checker renders in human mode too; CI has no screen
)

ALL_IDS = sorted(ENV_IDS)
VECTOR_IDS = ("SamplerGym/RRT-RigidBody-v1", "SamplerGym/RRT-RigidScenes-v1")  # Box (vector) observations, not Dict


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_gymnasium_and_sb3_checkers(env_id, png_map):
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    for mode in envs.ACTION_MODES:
        if mode == "guided" and env_id in VECTOR_IDS:
            continue  # guided actions are defined for 2-D grid problems only
        env = gym.make(env_id, action_mode=mode, render_mode="rgb_array", **make_kwargs(env_id, png_map))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            check_env(env.unwrapped, skip_render_check=False)
            sb3_check_env(env.unwrapped, warn=True)
        unexpected = [str(w.message) for w in caught
                      if not any(s in str(w.message) for s in CHECKER_WARNINGS) and "precision" not in str(w.message)]
        assert not unexpected, unexpected
        env.close()


def rollout(env, seed, steps=60):
    obs, info = env.reset(seed=seed)
    env.action_space.seed(seed)
    out = [(obs, None, info)]
    for _ in range(steps):
        obs, r, term, trunc, info = env.step(env.action_space.sample())
        out.append((obs, r, {k: v for k, v in info.items() if k != "sample"}))
        if term or trunc:
            obs, info = env.reset()
            out.append((obs, None, info))
    return out


def assert_same(a, b):
    assert len(a) == len(b)
    for (o1, r1, i1), (o2, r2, i2) in zip(a, b, strict=True):
        if not isinstance(o1, dict):
            o1, o2 = {"vector": o1}, {"vector": o2}
        for k in o1:
            assert np.array_equal(o1[k], o2[k]), k
        assert r1 == r2
        assert {k: v for k, v in i1.items() if k != "sample"} == {k: v for k, v in i2.items() if k != "sample"}


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_same_seed_same_rollout(env_id, png_map):
    kw = make_kwargs(env_id, png_map, max_iterations=40)
    a = rollout(gym.make(env_id, **kw), seed=3)
    b = rollout(gym.make(env_id, **kw), seed=3)
    assert_same(a, b)
    c = rollout(gym.make(env_id, **kw), seed=4)
    key = (lambda o: o) if env_id in VECTOR_IDS else (lambda o: o["image"] if "image" in o else o["local"])
    assert not all(np.array_equal(key(x[0]), key(y[0])) for x, y in zip(a, c, strict=False))


def test_pickle_resumes_identically():
    env = gym.make("SamplerGym/RRT-Maze-v2", action_mode="relative")
    env.reset(seed=1)
    env.action_space.seed(1)
    for _ in range(20):
        env.step(env.action_space.sample())
    clone = pickle.loads(pickle.dumps(env))
    acts = [env.action_space.sample() for _ in range(30)]
    for a in acts:
        o1, r1, t1, u1, i1 = env.step(a)
        o2, r2, t2, u2, i2 = clone.step(a)
        assert np.array_equal(o1["local"], o2["local"]) and r1 == r2 and i1["iterations"] == i2["iterations"]
        if t1 or u1:
            break


@pytest.mark.parametrize("vectorization_mode", ["sync", "async"])
def test_vector_envs(vectorization_mode):
    vec = gym.make_vec("SamplerGym/RRT-Rooms-v2", num_envs=2, vectorization_mode=vectorization_mode,
                       action_mode="bias", observation="image", shaping=False, max_iterations=30)
    obs, _ = vec.reset(seed=0)
    assert obs["image"].shape == (2, 4, 64, 64)
    for _ in range(40):
        obs, r, term, trunc, info = vec.step(vec.action_space.sample())
    assert r.shape == (2,) and np.all(r <= -1.0)
    vec.close()


def test_sb3_make_vec_env():
    from stable_baselines3.common.env_util import make_vec_env

    vec = make_vec_env("SamplerGym/RRT-Bugtrap-v2", n_envs=2, seed=0, env_kwargs={"action_mode": "mixture",
                                                                                      "observation": "image",
                                                                                      "shaping": False})
    obs = vec.reset()
    assert obs["vector"].shape == (2, 11)
    obs, rew, done, info = vec.step(np.stack([vec.action_space.sample()] * 2))
    assert rew.tolist() == [-1.0, -1.0]
    vec.close()


def test_reregistering_is_harmless():
    importlib.reload(envs)
    assert "SamplerGym/RRT-Maze-v2" in gym.registry


@pytest.mark.parametrize("mode, n", [("point", 2), ("bias", 1), ("mixture", 4), ("relative", 3)])
def test_bad_actions_are_rejected_or_clipped(mode, n):
    env = SamplerEnv("forest", action_mode=mode)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="NaN"):
        env.step(np.full(n, np.nan))
    with pytest.raises(ValueError, match=rf"shape \({n},\)"):
        env.step(np.zeros(n + 1))
    # out-of-range values are clipped (documented): 5.0 acts like 1.0, and no sample leaves the map
    a, b = SamplerEnv("forest", action_mode=mode), SamplerEnv("forest", action_mode=mode)
    a.reset(seed=2)
    b.reset(seed=2)
    for _ in range(10):
        _, _, _, _, ia = a.step(np.full(n, 5.0))
        _, _, _, _, ib = b.step(np.ones(n))
        assert np.array_equal(ia["sample"], ib["sample"])
        lo, hi = a.problem.world.bounds
        assert np.all(ia["sample"] >= lo) and np.all(ia["sample"] < hi)


def test_bad_construction_arguments():
    with pytest.raises(ValueError, match="action_mode"):
        SamplerEnv("forest", action_mode="teleport")
    with pytest.raises(ValueError, match="planner"):
        SamplerEnv("forest", planner="astar")
    with pytest.raises(ValueError, match="map_source"):
        SamplerEnv("volcano")
    with pytest.raises(ValueError, match="paths"):
        SamplerEnv("files", source_kwargs={"paths": []})
    with pytest.raises(ValueError, match="max_iterations"):
        SamplerEnv("forest", max_iterations=0)


# 60 maps by default; with -m slow also 300, which detects a bias sqrt(60/300) = 0.45 times as large
@pytest.mark.parametrize("n", [60, pytest.param(300, marks=pytest.mark.slow)])
def test_uniform_point_actions_match_rrt_with_uniform_sampler(n):
    """The env adds no hidden advantage or handicap: same iterations-to-solution distribution."""
    size = 64
    env = SamplerEnv("forest", source_kwargs={"size": size, "seeds": list(range(n))}, action_mode="point",
                     max_iterations=20000)
    env_its, rrt_its = [], []
    for ep in range(n):
        env.reset(seed=10_000 + ep)
        env.action_space.seed(ep)
        done = False
        while not done:
            _, _, term, trunc, info = env.step(env.action_space.sample())
            done = term or trunc
        env_its.append(info["iterations"])
        rrt = RRT(env.problem, step_size=env.step_size, sampler=UniformSampler(), seed=ep).solve(max_iterations=20000)
        rrt_its.append(rrt.iterations)
    a, b = np.array(env_its, float), np.array(rrt_its, float)
    # paired by map: the difference of means is zero within sampling error (3 standard errors)
    d = a - b
    assert abs(d.mean()) <= 3 * d.std(ddof=1) / np.sqrt(n), (a.mean(), b.mean())


def test_rewards_and_potential_based_shaping():
    plain = SamplerEnv("bugtrap", source_kwargs={"size": 64}, action_mode="bias", max_iterations=5000)
    shaped = SamplerEnv("bugtrap", source_kwargs={"size": 64}, action_mode="bias", max_iterations=5000,
                        shaping=True, shaping_gamma=1.0)
    for seed in range(3):
        plain.reset(seed=seed)
        shaped.reset(seed=seed)
        phi0 = shaped._potential
        rp = rs = 0.0
        done = False
        while not done:
            a = np.array([0.2])
            _, r1, term, trunc, i1 = plain.step(a)
            _, r2, _, _, i2 = shaped.step(a)
            rp += r1
            rs += r2
            done = term or trunc
        assert term and rp == -i1["iterations"]  # the return is minus the iterations-to-solution
        assert rs - rp == pytest.approx(-phi0)  # gamma = 1: shaping telescopes to Phi(end) - Phi(start), Phi(end) = 0
    checks = SamplerEnv("forest", reward="checks", checks_weight=0.5, action_mode="point")
    checks.reset(seed=0)
    _, r, _, _, info = checks.step(np.zeros(2))
    assert r == -1.0 - 0.5 * info["collision_checks"]


def test_observation_contents():
    env = SamplerEnv("narrow_passage", source_kwargs={"size": 64}, action_mode="relative", local_size=16)
    obs, info = env.reset(seed=5)
    assert obs["image"].dtype == np.uint8 and obs["image"][1].sum() > 0  # the start vertex is marked
    for _ in range(50):
        obs, _, term, trunc, info = env.step(np.array([0.3, 0.0, -0.5]))
        if term or trunc:
            break
    tree_px = int((obs["image"][1] > 0).sum())
    assert 1 <= tree_px <= info["tree_size"]
    view = env.planner.view()
    anchor = view.vertices[view.best_vertex]
    assert obs["local"][1, 8, 8] == 255  # the anchor vertex sits at the window's centre
    v = obs["vector"]
    assert v.dtype == np.float32 and np.all(np.abs(v) <= 1)
    lo, hi = env.problem.world.bounds
    assert v[4:6] == pytest.approx(2 * (anchor - lo) / (hi - lo) - 1, abs=1e-6)
    assert obs in env.observation_space


@pytest.mark.parametrize("planner", ["rrtstar", "prm", "rrtconnect", "lazyprm"])
def test_generic_id_runs_other_planners(planner):
    env = gym.make("SamplerGym/Planning-v1", map_source="rooms", planner=planner, source_kwargs={"size": 64},
                   max_iterations=3000, action_mode="point")
    env.reset(seed=0)
    env.action_space.seed(0)
    done = False
    while not done:
        _, _, term, trunc, info = env.step(env.action_space.sample())
        done = term or trunc
    assert term and info["solved"] and info["is_success"]


def test_render_and_record(tmp_path):
    env = gym.make("SamplerGym/RRT-Forest-v2", render_mode="rgb_array", source_kwargs={"size": 64})
    env.reset(seed=0)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    info = record_episode(env, None, tmp_path / "ep.gif", seed=1, every=5)
    assert "iterations" in info
    with Image.open(tmp_path / "ep.gif") as img:
        assert img.n_frames > 2
    human = SamplerEnv("forest", render_mode="human", action_mode="point")
    human.reset(seed=0)
    human.step(np.zeros(2))  # no display here: warns once, never crashes
    human.close()


def test_problem_option_and_lower_bound():
    p = generate("maze", 1, 64)
    env = SamplerEnv("maze", source_kwargs={"size": 64})
    _, info = env.reset(seed=0, options={"problem": p})
    assert env.problem is p
    assert info["lower_bound"] == int(np.ceil((p.reference_length - p.goal_tolerance) / env.step_size))


@pytest.mark.parametrize("shape", [(128, 128), (37, 53), (5, 3)])
def test_pyramid_levels_match_a_numpy_reference(shape):
    from planners.guidance.egocentric import build_pyramid

    def level(grid, f):
        layout, levels, _ = build_pyramid(grid, np.array([f], dtype=np.int64))
        return levels.reshape(layout[0, 1], layout[0, 2])

    obstacles = np.random.default_rng(1).random(shape) < 0.3
    for f in (1, 2, 3, 4, 16):
        h, w = -(-shape[0] // f), -(-shape[1] // f)
        padded = np.ones((h * f, w * f), bool)  # the outside of the map counts as blocked
        padded[: shape[0], : shape[1]] = obstacles
        ref = np.round(255.0 * padded.reshape(h, f, w, f).mean(axis=(1, 3))).astype(np.uint8)
        assert np.array_equal(level(obstacles.astype(np.uint8), f), ref), f


@pytest.mark.parametrize("seed", range(4))
def test_frontier_is_the_visible_uncovered_free_neighbour_cells(seed):
    # the incremental, lazily checked frontier (box-sum shortcut included) against its definition,
    # checked cell by cell with the planners' own motion check
    from planners import OccupancyGrid, Problem
    from planners.guidance.frontier import Frontier
    from planners.kernels.geometry import motion_free

    rng = np.random.default_rng(seed)
    res = (1.0, 0.5, 1.0, 0.25)[seed]
    obstacles = rng.random((40, 52)) < 0.2
    obstacles[0, 0] = obstacles[-1, -1] = False  # start and goal cells
    grid = OccupancyGrid(obstacles, resolution=res)
    lo, hi = grid.bounds
    problem = Problem(grid, np.asarray(lo) + 0.1, np.asarray(hi) - 0.1)
    cell = (2.0, 1.5, 4.0, 1.0)[seed]
    front = Frontier(problem, cell)
    V = rng.uniform(lo, hi, size=(120, 2))
    for b in (30, 31, 120):  # incremental updates
        front.update(V, b)
    H, W = front.H, front.W
    cov = {(int(v[1] // cell), int(v[0] // cell)) for v in V}
    want = set()
    for r in range(H):
        for c in range(W):
            centre = np.array([(c + 0.5) * cell, (r + 0.5) * cell])
            if (r, c) in cov or not motion_free(grid.kernel, centre, centre):
                continue
            near = [v for v in V if abs(int(v[1] // cell) - r) <= 1 and abs(int(v[0] // cell) - c) <= 1]
            if any(motion_free(grid.kernel, v, centre) for v in near):
                want.add(r * W + c)
    assert set(front.front[:len(front)].tolist()) == want and len(want) > 0


def test_a_frontier_given_costs_ranks_its_cells_by_them():
    from planners import OccupancyGrid, Problem
    from planners.guidance.frontier import Frontier

    grid = OccupancyGrid(np.zeros((32, 32), bool))
    problem = Problem(grid, [2.0, 2.0], [30.0, 30.0])
    straight = Frontier(problem, 4.0)
    cost = np.arange(64, dtype=float)  # cells nearer the origin, away from the goal, are cheaper
    ranked = Frontier(problem, 4.0, cost=cost)
    V = np.array([[14.0, 14.0]])
    for f in (straight, ranked):
        f.update(V, 1)
    cells = ranked.front[:len(ranked)]
    assert np.array_equal(ranked.dist[cells], cost[cells])
    assert straight.dist[cells].argmin() != ranked.dist[cells].argmin()
    pts = ranked.sample(np.random.default_rng(0), 200)
    best = cells[cost[cells].argmin()]
    assert np.mean((pts[:, 1] // 4) * 8 + pts[:, 0] // 4 == best) > 0.5  # tau 1: the cheapest cell dominates
    with pytest.raises(ValueError, match="one value per frontier cell"):
        Frontier(problem, 4.0, cost=np.zeros(10))


def test_observations_come_from_one_factory_and_the_guide_is_passed_explicitly():
    from envs.actions import make_action_sampler
    from envs.observation import OBSERVATIONS, EgocentricObservation, make_observation
    from planners.base.fileio import InputError
    from planners.maps.generators import generate

    expected = r"observation must be one of \('image', 'egocentric', 'egocentric_flat'\), got 'pixels'"
    with pytest.raises(InputError, match=expected):
        make_observation("pixels", 2)
    for env_id in envs.ENV_IDS:
        spec = gym.spec(env_id)
        assert spec.kwargs.get("observation", "image") in OBSERVATIONS, env_id
    p = generate("forest", 0, 64)
    with pytest.raises(ValueError, match="pass it as guide"):
        EgocentricObservation().reset(p, 100)
    guided = make_action_sampler("guided", 4.0).bind(p)
    guided.set_action(3)
    with pytest.raises(RuntimeError, match="set_guide"):
        guided.draw(np.random.default_rng(0), 1, None)
    with pytest.raises(ValueError, match="guide=None"):
        guided.set_guide(None)
    # an egocentric, guided episode: the env hands one GuidedSampling to both
    env = gym.make("SamplerGym/Planning-v1", observation="egocentric", action_mode="guided").unwrapped
    env.reset(seed=0)
    assert env.guide is not None and env.planner.sampler.guide is env.guide


def test_a_family_source_draws_training_maps_only_by_default(monkeypatch):
    """Without a seed pool an environment serves training maps, never a validation, tuning or test seed."""
    from envs import sources
    from planners.maps.generators import TRAIN_SEEDS

    seen = []
    monkeypatch.setattr(sources, "generate", lambda family, seed, size, **kw: seen.append(seed))
    source, rng = sources.FamilySource("forest"), np.random.default_rng(0)
    for _ in range(500):
        source(rng)
    assert all(TRAIN_SEEDS[0] <= s < TRAIN_SEEDS[1] for s in seen) and len(set(seen)) > 450
    pooled = sources.FamilySource("forest", seeds=[5_000_000])
    pooled(rng)
    assert seen[-1] == 5_000_000  # a pool the caller gives is used as it is


def test_the_scene_sets_are_an_environment_source_part_by_part_and_a_scene_file_is_one_problem():
    from envs import SceneSetSource
    from planners.worlds.rigid_scenes import RigidSceneSet

    train = SceneSetSource()
    a, b = train(np.random.default_rng(5)), train(np.random.default_rng(5))
    assert a.name == b.name and a.dim == 6 and train.dim == 6  # seeded by the env's generator
    validation = SceneSetSource("validation", families=["slot", "duct"], counts={"validation": 2})
    names = {validation(np.random.default_rng(s)).name for s in range(12)}
    want = {q.name for q in RigidSceneSet(("slot", "duct"), (), {"validation": 2}).queries("validation")}
    assert names <= want and len(names) > 1
    with pytest.raises(InputError, match="part must be"):
        SceneSetSource("bogus")
    from planners.worlds.rigid3d import WINDOW_SCENE, load_scene

    env = gym.make("samplergym:SamplerGym/Planning-v1", map_source=str(WINDOW_SCENE), step_size=0.5)
    obs, _ = env.reset(seed=0)
    assert env.unwrapped.dim == 6 and obs.shape == env.observation_space.shape
    with pytest.raises(InputError, match="source options"):
        gym.make("samplergym:SamplerGym/Planning-v1", map_source="window.scene", source_kwargs={"n_boxes": 3})
    # map=, the keyword for one map, takes a problem file too, with the start and goal it holds
    env = gym.make("samplergym:SamplerGym/RRT-RigidBody-v1", map=str(WINDOW_SCENE))
    again, _ = env.reset(seed=0)
    assert env.unwrapped.dim == 6 and np.array_equal(env.unwrapped.problem.start, load_scene(WINDOW_SCENE).start)
    with pytest.raises(InputError, match="holds its own start and goal"):
        gym.make("samplergym:SamplerGym/RRT-RigidBody-v1", map=str(WINDOW_SCENE), start=(1, 2, 3), goal=(4, 5, 6))


def test_rrt_connect_observation_shows_both_trees_and_whose_turn():
    """RRT-Connect's image observation: the goal tree in its own channel, its anchor and the turn in the vector."""
    from envs.observation import CHANNELS, TWO_TREE_FEATURES, VECTOR_FEATURES

    env = gym.make("SamplerGym/Planning-v1", map_source="maze", planner="rrtconnect", source_kwargs={"size": 64},
                   max_iterations=400, action_mode="point")
    space = env.observation_space
    assert space["image"].shape[0] == len(CHANNELS) + 1 and space["local"].shape[0] == len(CHANNELS) + 1
    assert space["vector"].shape == (len(VECTOR_FEATURES) + len(TWO_TREE_FEATURES),)
    obs, _ = env.reset(seed=3)
    env.action_space.seed(3)
    turns = set()
    for _ in range(60):
        obs, _, term, trunc, _ = env.step(env.action_space.sample())
        assert obs in space
        inner = env.unwrapped
        view = inner.planner.view()
        turns.add(view.tree)
        v = obs["vector"]
        assert v[-1] == (1.0 if view.tree == 1 else -1.0)
        # the goal tree's anchor is its vertex nearest the start, and the goal channel marks every goal-tree vertex
        d = np.linalg.norm(view.goal_tree - inner.problem.start, axis=1)
        near = view.goal_tree[np.argmin(d)]
        lo, hi = inner.problem.world.bounds
        assert v[11:13] == pytest.approx(np.clip(2 * (near - lo) / (hi - lo) - 1, -1, 1), abs=1e-6)
        grid = inner.problem.world
        side = space["image"].shape[1]
        px = ((view.goal_tree - lo) / (grid.resolution * max(grid.shape) / side)).astype(int).clip(0, side - 1)
        assert np.all(obs["image"][4, px[:, 1], px[:, 0]] == 255)
        if term or trunc:
            break
    assert turns == {0, 1}
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    check_env(env.unwrapped, skip_render_check=True)
    sb3_check_env(env, warn=False)
    # RRT keeps its four channels and eleven features; egocentric views follow one tree and refuse two
    rrt = gym.make("SamplerGym/Planning-v1", map_source="maze", source_kwargs={"size": 64})
    assert rrt.observation_space["image"].shape[0] == len(CHANNELS)
    with pytest.raises(InputError, match="RRT-Connect"):
        SamplerEnv("maze", planner="rrtconnect", observation="egocentric", action_mode="guided")


def test_rrt_connect_vector_observation_in_6dof():
    env = gym.make("SamplerGym/RRT-RigidBody-v1", planner="rrtconnect", max_iterations=50)
    base = gym.make("SamplerGym/RRT-RigidBody-v1", max_iterations=50)
    f = 3 + 2 * 3
    assert env.observation_space.shape == (base.observation_space.shape[0] + f + 2,)
    obs, _ = env.reset(seed=0)
    env.action_space.seed(0)
    for _ in range(10):
        obs, _, term, trunc, _ = env.step(env.action_space.sample())
        assert obs in env.observation_space
        assert obs[-1] == (1.0 if env.unwrapped.planner.view().tree == 1 else -1.0)
        if term or trunc:
            break
