"""Training the 6-DoF orientation model (``learning.models.rigid_orientation``) on the training scenes' routes.

Examples come from training scenes only: ``scenes_per_family`` seeds of each family drawn from
``TRAIN_SEEDS`` with ``np.random.default_rng(seed)`` (``planners.worlds.rigid_scenes``; never a
validation, tuning or test seed, nor a test-only family). In each scene the positions are the
workspace route's points (``voxel_route``, what the sampler sees at planning time) and the points of
the scene's witness path (``scene_with_witness``: poses through every passage), one per unit of its
length. The observation at each is ``route_observation``'s (the same function the sampler calls). The
label (``class_validity``: a configuration-space query made at training time only) is, with
``label="window"``, the classes that fit at every point of the same path within
``window`` of arc length, a class fitting at a point when any of ``poses`` poses of it, jittered about
the point by ``jitter`` (the sampler's position noise), keeps the motion check's clearance: the
orientation the body must already have to pass what comes next, as the witness path holds its turned
pose from before a passage to after it (where no class fits throughout, the window's mean fit). With
``label="point"``, the share of the jittered poses of each class that keep it at the point alone.
With ``label="solution"`` (the default), the class of the orientation a solution takes nearest each point (one-hot,
``solution_classes``), on the route's points and the solution's own, the solution found by the privileged
expert's long runs (``learning.references.rigid_expert.solve_reference``) in place of the witness path; a scene
they do not solve is left out. Points where no class fits are left out, and of those where every class fits
(open space, most of a route) only ``open_keep`` are kept, drawn at random. Which classes fit is the label's own
answer for the ``point`` and ``window`` labels; for the one-hot ``solution`` label it is ``open_test``'s:
``"label"`` (the one-hot label: one class, so every point is kept) or ``"clearance"`` (``class_validity``'s
``"any"`` with the same ``poses`` and ``jitter``: the points the body could pass in any class).

The examples are collected through the orientation environment (``envs.RigidOrientationEnv``,
``SamplerGym/RigidOrientation-v1``): each scene an episode whose teacher is ``recipe_teacher(config)``, each step
the observation of one point and the teacher's label in ``info``, the expert's class the action.

The model learns the label normalised to a distribution (cross-entropy with soft targets). Each
example is seen under one of the 48 symmetries of the voxel grid per epoch (a permutation of the
world's axes and reflections; the classes and the direction move with it), so a passage along x
teaches passages along y and z too. Every random choice comes from ``seed``; with one torch thread
the same seed gives the same weights.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass

import numpy as np
import torch

from envs.orientation import Lesson, NoLessons, RigidOrientationEnv, Teacher
from learning.models.rigid_orientation import HALF_RANGE, OrientationNet
from learning.references.rigid_expert import LABEL_ABLATION, solve_reference
from planners.base.fileio import InputError, check_int, check_number
from planners.base.problem import Problem
from planners.guidance.rigid_orientation import (
    AXIS_PERMUTATIONS,
    CLASS_PERMUTATIONS,
    PATCH_HALF,
    class_validity,
    path_points,
    solution_classes,
)
from planners.maps.generators import TRAIN_SEEDS
from planners.worlds.rigid_scenes import TRAINING_FAMILIES

#: The labels a model may learn (``RigidTrainConfig.label``; the module doc).
LABELS = ("point", "window", "solution")
#: How the ``solution`` label tells open space (``RigidTrainConfig.open_test``; the module doc).
OPEN_TESTS = ("label", "clearance")


def window_labels(points: np.ndarray, fit: np.ndarray, window: float) -> np.ndarray:
    """``(n, 6)``: per point of a path, the classes that fit (``fit > 0``) at every point within ``window`` of it.

    ``window`` is measured in arc length; where no class fits throughout, the mean of ``fit`` over the window.
    """
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points[:, :3], axis=0), axis=1))])
    lo = np.searchsorted(arc, arc - window, side="left")
    hi = np.searchsorted(arc, arc + window, side="right")
    out = np.zeros_like(fit, dtype=np.float64)
    for i in range(len(points)):
        w = fit[lo[i]:hi[i]]
        every = np.all(w > 0, axis=0)
        out[i] = every if every.any() else w.mean(axis=0)
    return out


@dataclass(frozen=True)
class RigidTrainConfig:
    """The recipe of an orientation model (every field is stored beside the weights)."""

    scenes_per_family: int = 40
    families: tuple[str, ...] = TRAINING_FAMILIES
    jitter: float = 1.25
    poses: int = 16
    epochs: int = 15
    batch: int = 64
    lr: float = 2e-3
    channels: int = 8
    hidden: int = 64
    augment: bool = True
    seed: int = 0
    held_out: float = 0.1
    open_keep: float = 0.25
    label: str = "solution"
    window: float = 6.0
    open_test: str = "label"
    half: int = PATCH_HALF

    def check(self) -> RigidTrainConfig:
        """The config, or an ``InputError`` naming the first field out of range."""
        check_int(self.scenes_per_family, "scenes_per_family", low=1)
        for f in self.families:
            if f not in TRAINING_FAMILIES:
                raise InputError(f"{f!r} is not a training scene family; choose from {', '.join(TRAINING_FAMILIES)}")
        check_number("RigidTrainConfig", "jitter", self.jitter, low=0)
        check_int(self.poses, "poses", low=1)
        check_int(self.epochs, "epochs", low=1)
        check_int(self.batch, "batch", low=1)
        check_number("RigidTrainConfig", "lr", self.lr, low=0, low_open=True)
        check_int(self.seed, "seed", low=0)
        check_number("RigidTrainConfig", "held_out", self.held_out, low=0, high=0.5)
        check_number("RigidTrainConfig", "open_keep", self.open_keep, low=0, high=1)
        if self.label not in LABELS:
            raise InputError(f"label = {self.label!r}; choose from {', '.join(LABELS)}")
        check_number("RigidTrainConfig", "window", self.window, low=0)
        if check_int(self.half, "half", low=HALF_RANGE[0]) > HALF_RANGE[1]:  # what a model file may hold
            raise InputError(f"half = {self.half}: at most {HALF_RANGE[1]}")
        if self.open_test not in OPEN_TESTS:
            raise InputError(f"open_test = {self.open_test!r}; choose from {', '.join(OPEN_TESTS)}")
        return self

    def as_dict(self) -> dict:
        d = asdict(self)
        d["families"] = list(self.families)
        return d


@dataclass
class RigidExamples:
    """Observations and labels: ``patches (n, s, s, s)``, ``directions (n, 3)``, ``labels (n, 6)``, ``scene (n,)``.

    ``fits (n,)``: how many classes fit at each point (the module doc's open-space test).
    """

    patches: np.ndarray
    directions: np.ndarray
    labels: np.ndarray
    scene: np.ndarray
    names: list[str]
    fits: np.ndarray


def recipe_teacher(config: RigidTrainConfig) -> Teacher:
    """The teacher of ``config``'s label (the module doc), for ``envs.RigidOrientationEnv``: the workspace route's
    points and the solution's (``label="solution"``: the expert's long runs, a scene they do not solve left out) or
    the witness path's, each labelled, and the points kept where some class fits and, where every class does, at
    ``open_keep``, drawn with the episode's teacher generator.
    """

    def teach(problem: Problem, route: np.ndarray | None, witness, rng: np.random.Generator) -> list[Lesson] | None:
        world = problem.world
        parts = [] if route is None else [route]
        solution = None
        if config.label == "solution":  # the expert's long runs (learning.references.rigid_expert)
            solution = solve_reference(problem, settings=LABEL_ABLATION)[0]
            if solution is None:
                return None
            parts.append(path_points(solution))
        else:
            parts.append(path_points(witness.path))
        lessons = []
        for pts in parts:
            fit = None
            if solution is not None:
                y = solution_classes(pts, solution)
                if config.open_test == "clearance":
                    fit = (class_validity(world, pts, rng, config.jitter, config.poses, "any") > 0).sum(1)
            elif config.label == "point":
                y = class_validity(world, pts, rng, config.jitter, config.poses)
            else:
                y = window_labels(pts, class_validity(world, pts, rng, config.jitter, config.poses, "any"),
                                  config.window)
            fit = (y > 0).sum(axis=1) if fit is None else fit
            keep = (fit > 0) & ((fit < y.shape[1]) | (rng.random(len(y)) < config.open_keep))
            lessons.append(Lesson(pts, y, fit, keep))
        return lessons

    return teach


def collect_rigid_examples(config: RigidTrainConfig, progress: Callable[[str], None] | None = None) -> RigidExamples:
    """The examples of ``config``'s training scenes (the module doc), collected through the orientation environment
    (``envs.RigidOrientationEnv``, ``SamplerGym/RigidOrientation-v1``) with ``recipe_teacher(config)`` as its
    teacher: each scene an episode, each step the observation and the teacher's label of one point, the expert's
    class the action.
    """
    rng = np.random.default_rng(config.seed)
    env = RigidOrientationEnv(families=config.families, teacher=recipe_teacher(config), half=config.half)
    patches, dirs, labels, scene, names, fits = [], [], [], [], [], []
    for family in config.families:
        seeds = rng.integers(*TRAIN_SEEDS, size=config.scenes_per_family)
        for s in seeds:
            try:
                obs, info = env.reset(options={"family": family, "scene_seed": int(s),
                                               "teacher_seed": [config.seed, int(s), len(names)]})
            except NoLessons as e:
                if e.labelled:  # labelled, every point left out: the scene counts, with no example
                    names.append(env.scene)
                elif progress is not None:
                    progress(f"{env.scene}: no solution by the long runs, left out")
                continue
            done = False
            while not done:
                patches.append(obs["patch"])
                dirs.append(obs["direction"])
                labels.append(info["label"].astype(np.float32))
                fits.append(info["fits"])
                obs, _, done, _, info = env.step(labels[-1].argmax())
            scene.append(np.full(info["points"], len(names)))
            names.append(env.scene)
            if progress is not None:
                progress(f"{env.scene}: {len(labels)} examples so far")
    if not patches:
        raise RuntimeError(f"no training examples: none of the {len(config.families) * config.scenes_per_family} "
                           f"scenes of {', '.join(config.families)} gave one (label {config.label!r}: "
                           "the long runs found no solution in any)")
    return RigidExamples(np.stack(patches), np.stack(dirs), np.stack(labels), np.concatenate(scene), names,
                         np.array(fits))


def augment(patches: np.ndarray, directions: np.ndarray, labels: np.ndarray, rng: np.random.Generator):
    """Each example under one of the grid's 48 symmetries drawn from ``rng`` (the module doc); new arrays."""
    n = len(patches)
    perm_of = rng.integers(len(AXIS_PERMUTATIONS), size=n)
    flips = rng.random((n, 3)) < 0.5
    P, D, Y = np.empty_like(patches), np.empty_like(directions), np.empty_like(labels)
    for k, perm in enumerate(AXIS_PERMUTATIONS):
        idx = np.flatnonzero(perm_of == k)
        P[idx] = np.transpose(patches[idx], (0, 1 + perm[0], 1 + perm[1], 1 + perm[2]))
        D[idx] = directions[idx][:, list(perm)]
        Y[idx[:, None], CLASS_PERMUTATIONS[k][None, :]] = labels[idx]
    for axis in range(3):
        idx = np.flatnonzero(flips[:, axis])
        P[idx] = np.flip(P[idx], axis=1 + axis)
        D[idx, axis] = -D[idx, axis]
    return P, D, Y


def soft_cross_entropy(logits: torch.Tensor, labels: torch.Tensor) -> torch.Tensor:
    """Mean cross-entropy of ``logits`` against ``labels`` normalised to distributions."""
    target = labels / labels.sum(dim=1, keepdim=True)
    return -(target * torch.log_softmax(logits, dim=1)).sum(dim=1).mean()


def _evaluate(net: OrientationNet, P, D, Y, fit_counts) -> dict:
    """Held-out loss, and how often the most likely class is one the label names (label > 0): everywhere, and at
    the passages' points (``fit_counts``: at most two classes fit).
    """
    with torch.no_grad():
        logits = net(torch.as_tensor(P), torch.as_tensor(D))
        loss = float(soft_cross_entropy(logits, torch.as_tensor(Y)))
        top = logits.argmax(dim=1).numpy()
    narrow = fit_counts <= 2  # points where at most two classes fit: the passages
    fits = Y[np.arange(len(Y)), top] > 0
    return {"loss": loss, "top_fits": float(fits.mean()) if len(Y) else 0.0,
            "top_fits_narrow": float(fits[narrow].mean()) if narrow.any() else 0.0, "narrow": int(narrow.sum())}


def train_rigid_orientation(config: RigidTrainConfig, examples: RigidExamples | None = None,
                            progress: Callable[[str], None] | None = None) -> tuple[OrientationNet, dict]:
    """Train an orientation model on ``config``'s training scenes: ``(net, log)``.

    ``examples`` (from ``collect_rigid_examples(config)``) may be passed to skip collecting them. The
    log holds the example counts, each epoch's training loss and the held-out scenes' loss and accuracy
    (scenes of the training seeds kept out of the fit, ``held_out`` of them).
    """
    config.check()
    t0 = time.perf_counter()
    ex = collect_rigid_examples(config, progress) if examples is None else examples
    t_collect = time.perf_counter() - t0
    rng = np.random.default_rng([config.seed, 1])
    n_scenes = len(ex.names)
    held = rng.permutation(n_scenes)[:int(round(config.held_out * n_scenes))]
    test = np.isin(ex.scene, held)
    train_idx = np.flatnonzero(~test)
    with torch.random.fork_rng(devices=[]):  # the weights' initialisation from the seed, the caller's state kept
        torch.manual_seed(config.seed)
        net = OrientationNet(half=config.half, channels=config.channels, hidden=config.hidden)
    opt = torch.optim.Adam(net.parameters(), lr=config.lr)
    steps = config.epochs * int(np.ceil(len(train_idx) / config.batch))
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, max(1, steps))
    log = {"examples": int(len(train_idx)), "held_out_examples": int(test.sum()), "scenes": n_scenes,
           "held_out_scenes": len(held), "epochs": [], "collect_seconds": round(t_collect, 1)}
    for epoch in range(config.epochs):
        order = rng.permutation(train_idx)
        P, D, Y = ex.patches[order], ex.directions[order], ex.labels[order]
        if config.augment:
            P, D, Y = augment(P, D, Y, rng)
        net.train()
        total = 0.0
        for i in range(0, len(order), config.batch):
            loss = soft_cross_entropy(net(torch.as_tensor(P[i:i + config.batch]),
                                          torch.as_tensor(D[i:i + config.batch])),
                                      torch.as_tensor(Y[i:i + config.batch]))
            opt.zero_grad()
            loss.backward()
            opt.step()
            sched.step()
            total += float(loss.detach()) * len(P[i:i + config.batch])
        net.eval()
        entry = {"epoch": epoch, "loss": round(total / max(1, len(order)), 5)}
        if test.any():
            held_stats = _evaluate(net, ex.patches[test], ex.directions[test], ex.labels[test], ex.fits[test])
            entry.update({f"held_out_{k}": (round(v, 5) if isinstance(v, float) else v)
                          for k, v in held_stats.items()})
        log["epochs"].append(entry)
        if progress is not None:
            progress(f"epoch {epoch}: {entry}")
    log["seconds"] = round(time.perf_counter() - t0, 1)
    log["parameters"] = int(sum(p.numel() for p in net.parameters()))
    return net.eval(), log
