"""Learning: reproducible training, the compiled actor, PolicySampler behaviour, and a real gain."""

from __future__ import annotations

import dataclasses
import zipfile
from pathlib import Path

import numpy as np
import pytest
import torch

from learning import PolicySampler
from learning.models.fast_policy import FastActor
from learning.models.shipped import SHIPPED_POLICY
from learning.training.policy import TrainConfig, train
from planners import PRM, RRT, OccupancyGrid, Problem, RRTStar, UniformSampler, make_planner
from planners.base.fileio import InputError
from planners.maps.generators import TEST_SEED0, generate

TINY = TrainConfig(name="tiny", families=("forest",), sizes=(64,), dagger_rounds=2, maps_per_round=32, bc_epochs=10,
                   ppo_steps=1024, value_warmup=512, ppo_n_steps=256, ppo_batch=128, ppo_epochs=2,
                   validation_maps=2, checkpoint_every=10**9, max_iterations=1500)


#: For the checks that train several times (reproducibility, Ray): smaller than TINY, every phase still
#: run (two DAgger rounds, the second with the policy acting, the value warm-up, PPO, validation)
REPRO = dataclasses.replace(TINY, name="repro", maps_per_round=8, bc_epochs=2, ppo_steps=512, value_warmup=256,
                            ppo_n_steps=128, ppo_batch=64, ppo_epochs=1)


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    out = tmp_path_factory.mktemp("runs")
    return train(TINY, out, progress=False, log_stdout=False), out


@pytest.fixture(scope="module")
def repro_trained(tmp_path_factory):
    return train(REPRO, tmp_path_factory.mktemp("repro"), progress=False, log_stdout=False)


def _weights(path):
    from stable_baselines3.common.save_util import load_from_zip_file

    _, params, _ = load_from_zip_file(path, device="cpu", print_system_info=False)
    return params["policy"]


def test_seeded_training_is_reproducible(repro_trained, tmp_path):
    final = repro_trained
    again = train(REPRO, tmp_path, progress=False, log_stdout=False)
    a, b = _weights(final), _weights(again)
    assert a.keys() == b.keys()
    for k in a:
        assert torch.equal(a[k], b[k]), k
    other = train(dataclasses.replace(REPRO, seed=1), tmp_path / "other", progress=False, log_stdout=False)
    assert not torch.equal(_weights(other)["action_net.weight"], a["action_net.weight"])


@pytest.mark.slow  # a training run on Ray
def test_training_on_ray_reaches_the_same_weights(repro_trained, tmp_path, ray_backend):
    """DAgger's rollouts and the validation runs on Ray workers: the weights do not depend on the backend."""
    final = repro_trained
    on_ray = train(REPRO, tmp_path, progress=False, log_stdout=False, backend=ray_backend)
    a, b = _weights(final), _weights(on_ray)
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
    assert (final.parent / "summary.json").read_text() == (on_ray.parent / "summary.json").read_text()


def test_training_writes_config_checkpoints_and_logs(trained):
    final, out = trained
    run = out / "tiny"
    for name in ("config.json", "checkpoint.zip", "imitation.zip", "final.zip", "state.json", "summary.json"):
        assert (run / name).is_file(), name
    assert any((run / "tb").glob("events.out.tfevents.*"))
    assert TrainConfig.from_json(run / "config.json") == TINY


def test_training_leaves_no_open_files(tmp_path):
    # the logger's CSV file was once left open: its ResourceWarning then surfaced in whichever test
    # happened to run the garbage collector next
    import gc
    import warnings

    cfg = dataclasses.replace(TINY, dagger_rounds=1, ppo_steps=256, value_warmup=0, ppo_n_steps=128, ppo_batch=64)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        train(cfg, tmp_path, progress=False, log_stdout=False)
        gc.collect()
    assert not [str(w.message) for w in caught if issubclass(w.category, ResourceWarning)]


def test_resume_continues_from_the_checkpoint(tmp_path):
    cfg = dataclasses.replace(TINY, dagger_rounds=1, ppo_steps=512, value_warmup=0)
    train(cfg, tmp_path, progress=False, log_stdout=False)
    longer = dataclasses.replace(cfg, ppo_steps=1024)
    with pytest.raises(ValueError, match="differs"):
        train(longer, tmp_path, resume=True, progress=False, log_stdout=False)
    (tmp_path / "tiny" / "config.json").write_text((tmp_path / "tiny" / "config.json").read_text())
    with pytest.raises(FileNotFoundError, match="nothing to resume"):
        train(cfg, tmp_path / "elsewhere", resume=True, progress=False, log_stdout=False)


def test_fast_actor_matches_torch(trained):
    from stable_baselines3 import PPO

    from envs import SamplerEnv

    final, _ = trained
    model = PPO.load(final, device="cpu")
    actor = FastActor(model.policy.state_dict())
    env = SamplerEnv("maze", source_kwargs={"size": 64}, action_mode="guided", observation="egocentric")
    obs, _ = env.reset(seed=0)
    for t in range(40):
        with torch.no_grad():
            ref = model.policy.get_distribution(model.policy.obs_to_tensor(obs)[0]).distribution.probs[0].numpy()
        lg = actor.logits(obs["local"], obs["vector"]).astype(np.float64)
        p = np.exp(lg - lg.max())
        assert np.allclose(p / p.sum(), ref, atol=1e-5)
        obs, _, term, trunc, _ = env.step(int(np.argmax(ref)) if t % 2 else env.action_space.sample())
        if term or trunc:
            obs, _ = env.reset()


@pytest.mark.parametrize("problem_fn", [
    lambda: generate("rooms", TEST_SEED0, 64),
    lambda: generate("bugtrap", TEST_SEED0, 200),
    lambda: Problem(OccupancyGrid(np.pad(np.zeros((90, 150), bool), 1, constant_values=True)), (3.5, 3.5),
                    (146.5, 86.5), goal_tolerance=2.0),
], ids=["64", "200", "non-square"])
def test_policy_sampler_on_other_maps_and_planners(trained, problem_fn):
    final, _ = trained
    sampler = PolicySampler.load(final)
    p = problem_fn()
    lo, hi = p.world.bounds
    planner = RRT(p, step_size=4.0, sampler=sampler, seed=0)
    for _ in range(300):
        s = planner.step()
        assert np.all(np.isfinite(s.sample)) and np.all(s.sample >= lo) and np.all(s.sample < hi)
        if s.solved:
            break
    r = planner.solve(max_iterations=20000)
    assert r.solved and p.world.path_valid(r.path)
    assert planner.sampler.forward_passes >= 1
    for name in ("RRTstar", "PRM"):
        assert make_planner(name, p, extension_step=4.0, sampler=sampler, seed=1).solve(max_iterations=20000).solved


SHIPPED = SHIPPED_POLICY


@pytest.mark.parametrize("family", ["bugtrap", "maze", "narrow_passage"])
def test_fused_loop_draws_exactly_what_draw_calls_do(family):
    # the shipped policy, whose timings the README reports: fused and unfused runs must be the same runs
    fused, plain = PolicySampler.load(SHIPPED), PolicySampler.load(SHIPPED, fuse=False)
    for key, size in ((TEST_SEED0, 96), (TEST_SEED0 + 1, 128)):
        p = generate(family, key, size)
        for seed in range(2):
            a = RRT(p, step_size=4.0, sampler=fused, seed=seed)
            b = RRT(p, step_size=4.0, sampler=plain, seed=seed)
            assert a._fused is not None and b._fused is None
            ra, rb = a.solve(max_iterations=3000), b.solve(max_iterations=3000)
            assert (ra.iterations, ra.num_vertices, ra.collision_checks) == (rb.iterations, rb.num_vertices,
                                                                          rb.collision_checks)
            assert np.array_equal(ra.path, rb.path)
            assert a.sampler.forward_passes == b.sampler.forward_passes >= 1
            # stepping the fused planner one iteration at a time is the same run again
            c = RRT(p, step_size=4.0, sampler=fused, seed=seed)
            while not c.solved and c.iterations < ra.iterations:
                c.step()
            assert c.iterations == ra.iterations and np.array_equal(c.result().path, ra.path)


def test_a_frontier_decision_holds_until_the_progress_vertex_moves():
    # trees stuck in narrow passages: the policy answers "frontier" and would repeat that answer on
    # every re-run; holding it must save those passes and change nothing else
    passes = {0.9: 0, 2.0: 0}
    for key in (2, 5, 9, 10):
        p = generate("narrow_passage", TEST_SEED0 + key, 96)
        runs = {}
        for hold in passes:
            planner = RRT(p, step_size=4.0, sampler=PolicySampler.load(SHIPPED, hold=hold), seed=0)
            runs[hold] = planner.solve(max_iterations=20000)
            passes[hold] += planner.sampler.forward_passes
        assert runs[0.9].iterations == runs[2.0].iterations and np.array_equal(runs[0.9].path, runs[2.0].path)
    assert passes[0.9] < 0.5 * passes[2.0], passes
    with pytest.raises(ValueError, match="hold"):
        PolicySampler.load(SHIPPED, hold=0.0)


@pytest.mark.parametrize("family, size", [("maze", 96), ("bugtrap", 130)])
def test_policy_sampler_observes_what_the_training_environment_observes(family, size):
    # the sampler builds the guided geometry without GuidedSampling's objects; the policy must still
    # see at inference exactly what it was trained on
    from planners.guidance.guided import GuidedSampling

    p = generate(family, TEST_SEED0, size)
    grower = RRT(p, step_size=4.0, seed=0)
    grower.solve(max_iterations=150)
    view = grower.view()
    sampler = PolicySampler.load(SHIPPED).bind(p)
    sampler.draw(np.random.default_rng(0), 8, view)  # the first draw runs a forward pass
    guide = GuidedSampling(p, 4.0, uniform_floor=sampler.config["uniform_floor"],
                           max_iterations=sampler.config["max_iterations"])
    guide.update(view)
    obs = guide.observe(view)
    seen = sampler.last_observation()
    local, vector = seen["local"], seen["vector"]
    assert view.num_vertices > 30 and obs["local"][1].any()  # the tree shows in the window
    assert np.array_equal(obs["local"], local)
    assert np.array_equal(obs["vector"], vector)


def test_a_fused_planner_is_freed_without_the_cycle_collector():
    # a planner holding a loop that holds the planner would live until the next gc pass, keeping its
    # arrays (and the time to free them) in whichever solve runs then
    import gc
    import weakref

    p = generate("bugtrap", TEST_SEED0, 64)
    planner = RRT(p, step_size=4.0, sampler=PolicySampler.load(SHIPPED), seed=0)
    planner.solve(max_iterations=2000)
    ref = weakref.ref(planner)
    gc.disable()
    try:
        del planner
        assert ref() is None
    finally:
        gc.enable()


def test_only_rrt_runs_the_fused_loop():
    from planners import RRTConnect

    sampler = PolicySampler.load(SHIPPED)
    p = generate("rooms", TEST_SEED0, 64)
    assert RRT(p, step_size=4.0, sampler=sampler, seed=0)._fused is not None
    for planner in (RRTConnect(p, step_size=4.0, sampler=sampler, seed=0),
                    RRTStar(p, step_size=4.0, sampler=sampler, seed=0), PRM(p, sampler=sampler, seed=0)):
        assert planner._fused is None
        assert planner.solve(max_iterations=20000).solved


def test_sampler_rejects_other_worlds(trained):
    from planners import Circle, GeometricWorld

    final, _ = trained
    p = Problem(GeometricWorld(20, 20, [Circle(10, 10, 2)]), (2, 2), (18, 18))
    with pytest.raises(ValueError, match="OccupancyGrid"):
        RRT(p, step_size=2.0, sampler=PolicySampler.load(final))


def test_bad_checkpoints_get_clear_errors(tmp_path, trained):
    with pytest.raises(FileNotFoundError, match="missing.zip"):
        PolicySampler.load(tmp_path / "missing.zip")
    (tmp_path / "junk.zip").write_bytes(b"not a zip at all")
    with pytest.raises(ValueError, match="junk.zip.*not a readable"):
        PolicySampler.load(tmp_path / "junk.zip")
    # a valid SB3 model that is not a SamplerGym policy
    import gymnasium as gym
    from stable_baselines3 import PPO

    PPO("MlpPolicy", gym.make("CartPole-v1"), n_steps=64, batch_size=32).save(tmp_path / "cartpole.zip")
    with pytest.raises(ValueError, match="without a SamplerGym config"):
        PolicySampler.load(tmp_path / "cartpole.zip")
    # a SamplerGym checkpoint whose weights were truncated
    final, _ = trained
    broken = tmp_path / "broken.zip"
    with zipfile.ZipFile(final) as src, zipfile.ZipFile(broken, "w") as dst:
        for item in src.infolist():
            data = src.read(item.filename)
            dst.writestr(item, data[: len(data) // 2] if item.filename == "policy.pth" else data)
    with pytest.raises(ValueError, match="broken.zip"):
        PolicySampler.load(broken)


def test_a_checkpoint_config_with_a_vanishing_step_is_refused_by_the_reader():
    from learning.samplers.policy import MIN_STEP, OBS_VERSION, check_config

    good = {"step_size": 4.0, "uniform_floor": 0.05, "batch": 8, "obs_version": OBS_VERSION}
    assert check_config(good, "ckpt.zip")["step_size"] == 4.0
    for bad in (1e-9, 0.0, -4.0, float("nan"), float("inf")):
        with pytest.raises(InputError, match=f"ckpt.zip: step_size = .*{MIN_STEP:g}|ckpt.zip: step_size = .*finite"):
            check_config({**good, "step_size": bad}, "ckpt.zip")


def test_short_training_beats_uniform_sampling(trained):
    final, _ = trained
    sampler = PolicySampler.load(final)
    policy, uniform = [], []
    for i in range(20):
        p = generate("forest", TEST_SEED0 + i, 64)
        policy.append(RRT(p, step_size=4.0, sampler=sampler, seed=i).solve(max_iterations=20000).iterations)
        uniform.append(RRT(p, step_size=4.0, sampler=UniformSampler(), seed=i).solve(max_iterations=20000).iterations)
    # seconds of imitation on 64x64 forests: at least 2x fewer iterations than uniform (about 3x measured)
    assert np.median(policy) < 0.5 * np.median(uniform), (np.median(policy), np.median(uniform))


def test_train_script_builds_a_flag_for_every_config_field():
    import importlib.util

    path = Path(__file__).resolve().parents[1] / "scripts" / "train.py"
    spec = importlib.util.spec_from_file_location("train_script", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    with pytest.raises(SystemExit) as e:
        mod.main(["--help"])
    assert e.value.code == 0


def _script(name):
    import importlib.util

    script = Path(__file__).resolve().parents[1] / "scripts" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"{name.replace('/', '_')}_script", script)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_evaluate_script_writes_tables_csv_and_plots(trained, tmp_path, movingai):
    import csv

    final, _ = trained
    out = tmp_path / "eval"
    rc = _script("evaluate").main([
        "--policy", str(final), "--families", "forest", "--size", "64", "--maps", "3", "--tuning-maps", "2",
        "--seeds", "1", "--shifted-maps", "1", "--no-unseen", "--movingai", str(movingai), "--movingai-maps",
        "arena", "random-32-32-10",  # two maps, so the pooled row; open ones, which every sampler solves quickly
        "--scenarios", "2", "--other-planners", "PRM", "--processes", "1", "--out", str(out)])
    assert rc == 0
    text = (out / "details.md").read_text()  # the wide tables; summary.md opens with the short one
    assert "MovingAI †" in (out / "summary.md").read_text() and "With PRM" in (out / "summary.md").read_text()
    for needle in ("forest", "forest (shifted)", "MovingAI (all)", "policy", "goal bias 0.05 (default",
                   "expert (reference)", "PRM"):
        assert needle in text, needle
    rows = list(csv.DictReader((out / "runs.csv").open()))
    samplers = {r["sampler"] for r in rows}
    assert {"uniform", "policy", "goal_bias=0.01", "goal_bias=0.5", "expert (reference)"} <= samplers
    assert all(int(r["candidates"]) >= int(r["iterations"]) for r in rows if r["solved"] == "True")
    for png in ("ecdf.png", "medians.png"):
        assert (out / png).stat().st_size > 10_000


def test_benchmark_policy_script_times_passes_and_queries(capsys):
    rc = _script("benchmark_policy").main(["--family", "forest", "--maps", "2", "--seeds", "1"])
    assert rc == 0
    out = capsys.readouterr().out
    for needle in ("us_per_pass", "policy, no hold", "goal bias 0.05", "guided.zip"):
        assert needle in out, needle


@pytest.mark.experiments
def test_imitation_ceiling_script_reports_labels_beside_the_policy(capsys):
    _script("experiments/imitation_ceiling").main(["--families", "forest", "--maps", "2", "--processes", "1",
                                       "--max-iterations", "3000"])
    out = capsys.readouterr().out
    for needle in ("constant (p=", "| forest | policy |", "| forest | labels |", "labels, no frontier fallback",
                   "expert (reference)", "frontier by geodesic distance (reference, p=",
                   "top cell within 1 direction of the label"):
        assert needle in out, needle


@pytest.mark.experiments
@pytest.mark.parametrize("model, inputs", [("dilated", "fraction"), ("recurrent", "fraction"), ("unet", "cells")])
def test_route_probe_script_trains_and_reports(model, inputs, capsys):
    rows = _script("experiments/route_probe").main(["--model", model, "--input", inputs, "--maps", "1",
                                                    "--val-maps", "1", "--epochs", "1", "--size", "64"])
    assert [r["family"] for r in rows] == ["forest", "narrow_passage", "bugtrap", "maze", "rooms"]
    assert all(r["blocks"] > 0 and 0.0 <= float(r["network"]) <= 1.0 for r in rows)
    assert "parameters; forward on a 128x128 map" in capsys.readouterr().out


@pytest.mark.experiments
@pytest.mark.parametrize("script, argv, flag", [("imitation_ceiling", ["--maps", "0"], "--maps"),
                                               ("imitation_ceiling", ["--size", "8"], "--size"),
                                               ("route_probe", ["--epochs", "0"], "--epochs"),
                                               ("route_probe", ["--block", "40", "--size", "64"], "--block"),
                                               ("tune_stuck_floor", ["--floors", "2"], "--floors"),
                                               ("tune_stuck_floor", ["--seeds", "0"], "--seeds")])
def test_probe_scripts_refuse_bad_flags_by_name(script, argv, flag, capsys):
    with pytest.raises(SystemExit) as exc:
        _script(f"experiments/{script}").main(argv)
    assert exc.value.code == 2 and flag in capsys.readouterr().err


@pytest.mark.experiments
def test_stuck_floor_rule_prefers_the_worst_map_then_the_mean_then_the_median():
    choose = _script("experiments/tune_stuck_floor").choose
    success = {0.1: {"a": 0.5, "b": 1.0, "never": 0.0}, 0.3: {"a": 0.9, "b": 0.9, "never": 0.0},
               0.5: {"a": 0.9, "b": 1.0, "never": 0.0}}
    assert choose(success, {0.1: 10.0, 0.3: 5.0, 0.5: 50.0}) == 0.5  # a map none solves does not decide
    success[0.3]["b"] = 1.0
    assert choose(success, {0.1: 10.0, 0.3: 5.0, 0.5: 50.0}) == 0.3
    # evaluate.py --sampler loads it
    assert _script("experiments/tune_stuck_floor").policy_with_cap_0_3().max_floor == 0.3


@pytest.mark.experiments
def test_stuck_floor_script_runs_on_the_movingai_tuning_scenarios(movingai, capsys):
    best = _script("experiments/tune_stuck_floor").main(["--movingai", str(movingai), "--floors", "0.1", "0.5",
                                                         "--scenarios", "1", "--seeds", "1", "--maps", "1",
                                                         "--max-iterations", "300", "--processes", "1"])
    out = capsys.readouterr().out
    assert best in (0.1, 0.5) and "| maze512-32-0 |" in out and "| forest (validation) |" in out


def test_actor_with_other_convolution_kernels_is_refused():
    from stable_baselines3.common.save_util import load_from_zip_file

    _, params, _ = load_from_zip_file(SHIPPED, device="cpu", print_system_info=False)
    weights = dict(params["policy"])
    w = weights["pi_features_extractor.cnn.0.weight"]
    weights["pi_features_extractor.cnn.0.weight"] = w.repeat(1, 1, 2, 2)[:, :, :8, :8]
    with pytest.raises(ValueError, match="kernels"):
        FastActor(weights)


def test_mirror_augmentation_is_the_goal_frames_reflection():
    """A map reflected across the start-goal line observes the reversed window rows and mirrored labels."""
    from learning.training.imitation import mirror_labels
    from planners.guidance.egocentric import EgocentricView
    from planners.guidance.guided import FRONTIER, ego_class

    rng = np.random.default_rng(0)
    grid = (rng.random((64, 64)) < 0.2).astype(np.uint8)
    grid[30:34, :] = 0
    mirrored = grid[::-1].copy()  # row r -> 63 - r: y -> 64 - y, and the line y = 32 stays put
    start, goal = np.array([8.5, 32.0]), np.array([56.5, 32.0])
    views = [EgocentricView(Problem(OccupancyGrid(g, 1.0), start=start, goal=goal, goal_tolerance=2.0), 4.0)
             for g in (grid, mirrored)]
    anchor = np.array([20.25, 32.0])
    a, b = (v.observe(anchor, 1, 2, 10) for v in views)
    np.testing.assert_array_equal(a["local"][:, ::-1, :], b["local"])
    np.testing.assert_array_equal(a["vector"], b["vector"])
    for dx, dy in rng.uniform(-90.0, 90.0, (200, 2)):
        assert mirror_labels(torch.tensor([ego_class(dx, dy, 4.0)])).item() == ego_class(dx, -dy, 4.0)
    assert mirror_labels(torch.tensor([FRONTIER])).item() == FRONTIER


def test_mirrored_cloning_splits_a_label_between_its_reflections(trained):
    """On windows that look the same both ways, mirrored batches teach bin b and bin 15 - b equally."""
    from stable_baselines3 import PPO

    from learning.training.imitation import Dataset, behaviour_cloning
    from planners.guidance.guided import ANGLES

    n, label = 512, 3 * ANGLES + 2  # ring 3, bin 2; its reflection is bin 13
    data = Dataset(np.zeros((n, 6, 16, 16), np.uint8), np.zeros((n, 8), np.float32),
                   np.full(n, label, np.int64), np.zeros(n, np.float32))
    probs = {}
    for mirror in (False, True):
        policy = PPO.load(trained[0], device="cpu").policy
        behaviour_cloning(policy, data, epochs=30, batch_size=128, lr=1e-2, seed=0, mirror=mirror)
        obs = {"local": torch.as_tensor(data.local[:1]), "vector": torch.as_tensor(data.vector[:1])}
        with torch.no_grad():
            probs[mirror] = policy.get_distribution(obs).distribution.probs[0]
    plain, mirrored = probs[False], probs[True]
    assert plain[label] > 0.9 and plain[label + 11] < 0.05
    assert abs(mirrored[label] - mirrored[label + 11]) < 0.1 and mirrored[label] + mirrored[label + 11] > 0.9


@pytest.mark.experiments
def test_policy_variants_load_the_shipped_policy_at_each_batch():
    variants = _script("experiments/policy_variants")  # evaluate.py --sampler loads them
    assert (variants.batch_1().batch, variants.batch_2().batch, variants.batch_8().batch) == (1, 2, 8)


@pytest.mark.experiments
def test_tune_policy_batch_names_a_batch_from_the_tuning_maps(capsys):
    best = _script("experiments/tune_policy_batch").main(["--batches", "8", "1", "--maps", "1", "--seeds", "1",
                                              "--processes", "1"])
    out = capsys.readouterr().out
    assert best in (8, 1) and "sum of log medians" in out and f"chosen batch: {best}" in out


@pytest.mark.experiments
def test_tune_policy_batch_refuses_a_batch_below_one(capsys):
    with pytest.raises(SystemExit) as exc:
        _script("experiments/tune_policy_batch").main(["--batches", "0"])
    assert exc.value.code == 2 and "--batches" in capsys.readouterr().err
