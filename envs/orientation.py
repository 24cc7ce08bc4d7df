"""The 6-DoF route sampler's orientation choice as a Gymnasium environment: ``SamplerGym/RigidOrientation-v1``.

``make_sampler("rigid_route")`` draws its positions along the workspace route of the body's centre and turns the
body, at each route point, to one of six axis-aligned orientation classes (``planners.guidance.rigid_orientation``)
that a learned model names from what it sees there: the occupancy about the point and the route's direction. This
environment is that decision, one point at a time. An episode is one scene of the generated scene sets
(``planners.worlds.rigid_scenes``); its points are those a teacher labels (by default the workspace route's points
and the scene's witness path's, the path that proved the scene solvable); each step the observation is the model's
at the next point (``{"patch": (s, s, s) occupancy, "direction": (3,)}``, ``route_observation``, the same function
the sampler calls at planning time), the action a class, and the reward the teacher's weight of that class (its
label normalised to a distribution: 1 for the class a solution takes there, 0 for the others, with the default
teacher). ``info["label"]`` and ``info["expert_action"]`` give the teacher's label and class for the observation
just returned, so the same environment serves imitation (``learning.training.rigid`` collects the shipped
model's examples through it, with the expert's long runs as the teacher) and reinforcement learning with
Stable-Baselines3's defaults (``PPO("MultiInputPolicy", env)``). A scene's episode ends after its last point.

A teacher is a callable ``teacher(problem, route, witness, rng) -> list[Lesson] | None``: ``route`` the workspace
route's points (or None where the workspace has none), ``witness`` the scene's ``Verification``, ``rng`` the
episode's teacher generator; ``None`` leaves the scene out (a reset draws another). The default,
``witness_teacher``, needs nothing but the scene: the class the witness path takes nearest each point.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from planners.base.fileio import InputError, check_int
from planners.base.problem import Problem
from planners.guidance.rigid_orientation import (
    N_CLASSES,
    PATCH_HALF,
    path_points,
    route_observation,
    solution_classes,
)
from planners.guidance.workspace_route import voxel_route
from planners.maps.generators import TRAIN_SEEDS
from planners.worlds.rigid3d import densify, seed_step
from planners.worlds.rigid_scenes import (
    PARTS,
    TEST_ONLY_FAMILIES,
    TRAINING_FAMILIES,
    Verification,
    scene_seeds,
    scene_with_witness,
)

#: Scenes a reset without a named scene draws before giving up on a teacher that labels none of them.
SCENE_DRAWS = 8
#: Scenes per family among which a reset of a fixed part (validation, tuning, test) draws.
PART_SCENES = 8


@dataclass(frozen=True)
class Lesson:
    """Points of a scene with a teacher's labels: ``points (n, 3+)``, ``labels (n, 6)`` (non-negative weights of the
    classes), ``fits (n,)`` (how many classes fit at each point) and ``keep (n,)`` (the points an episode presents).
    The observations are computed over all ``points`` (a route point's direction reads its neighbours), then kept.
    """

    points: np.ndarray
    labels: np.ndarray
    fits: np.ndarray
    keep: np.ndarray


Teacher = Callable[[Problem, "np.ndarray | None", Verification, np.random.Generator], "Sequence[Lesson] | None"]


class NoLessons(RuntimeError):
    """A scene named to ``reset`` that the teacher does not label (``labelled`` False) or whose lessons keep no
    point (``labelled`` True).
    """

    def __init__(self, message: str, labelled: bool) -> None:
        super().__init__(message)
        self.labelled = labelled


def witness_teacher(problem: Problem, route: np.ndarray | None, witness: Verification,
                    rng: np.random.Generator) -> list[Lesson]:
    """The class the scene's witness path (densified at half the seed set-up's step) takes nearest each point of the
    workspace route and of the witness path itself (one-hot; every point kept). ``rng`` is not used.
    """
    states = densify(witness.path, problem, 0.5 * seed_step(problem.world))
    lessons = []
    for pts in ([] if route is None else [route]) + [path_points(witness.path)]:
        labels = solution_classes(pts, states)
        lessons.append(Lesson(pts, labels, np.ones(len(pts), dtype=np.int64), np.ones(len(pts), dtype=bool)))
    return lessons


class RigidOrientationEnv(gym.Env):
    """The orientation class of the route sampler's samples, one route point a step (the module doc).

    Args:
        part: The scene sets' part the episodes draw from: ``train`` (default; a family at random, then a seed from
            ``TRAIN_SEEDS``), ``validation``, ``tuning`` or ``test`` (among the part's first ``PART_SCENES`` scenes
            of each family; ``test`` includes the test-only families).
        families: Training families to draw (default all); a test-only family is allowed in ``test`` only.
        teacher: Labels the points (the module doc); default ``witness_teacher``.
        half: Half the observation patch's side, in voxels (the model's ``half``).

    ``reset(options={"family": F, "scene_seed": S, "teacher_seed": T})`` plays that scene (``T``, an int or a
    sequence of ints, seeds the teacher's generator; default ``S``) and raises ``NoLessons`` where the teacher
    labels no point of it; without a scene named, a reset draws scenes with its ``np_random`` until the teacher
    labels one (at most ``SCENE_DRAWS``).
    """

    metadata = {"render_modes": []}

    def __init__(self, part: str = "train", families: Sequence[str] | None = None, teacher: Teacher | None = None,
                 half: int = PATCH_HALF) -> None:
        if part not in PARTS:
            raise InputError(f"part must be one of {', '.join(PARTS)}, got {part!r}")
        families = tuple(TRAINING_FAMILIES if families is None else families)
        allowed = TRAINING_FAMILIES + (TEST_ONLY_FAMILIES if part == "test" else ())
        bad = [f for f in families if f not in allowed]
        if bad or not families:
            raise InputError(f"families {list(families)} for the {part!r} part: choose one or more of "
                             f"{', '.join(allowed)}")
        self.part, self.families = part, families
        self.teacher = witness_teacher if teacher is None else teacher
        self.half = check_int(half, "half", low=1)
        side = 2 * self.half + 1
        self.observation_space = spaces.Dict({
            "patch": spaces.Box(0.0, 1.0, (side, side, side), dtype=np.float32),
            "direction": spaces.Box(-1.0, 1.0, (3,), dtype=np.float32),
        })
        self.action_space = spaces.Discrete(N_CLASSES)
        self.scene = ""
        self._patches = np.zeros((0, side, side, side), dtype=np.float32)
        self._directions = np.zeros((0, 3), dtype=np.float32)
        self._labels = np.zeros((0, N_CLASSES))
        self._fits = np.zeros(0, dtype=np.int64)
        self._at = 0

    # the scenes

    def _draw_scene(self) -> tuple[str, int]:
        family = self.families[int(self.np_random.integers(len(self.families)))]
        if self.part == "train":
            return family, int(self.np_random.integers(*TRAIN_SEEDS))
        seeds = scene_seeds(family, self.part, PART_SCENES)
        return family, seeds[int(self.np_random.integers(len(seeds)))]

    def _lessons(self, family: str, seed: int, teacher_seed) -> str | None:
        """Load the scene's points; None where it has some, else why not (and whether the teacher labelled it)."""
        problem, witness = scene_with_witness(family, seed)
        self.scene = problem.name
        route = voxel_route(problem.world, problem.start, problem.goal)
        lessons = self.teacher(problem, route, witness, np.random.default_rng(teacher_seed))
        if lessons is None:
            return "unlabelled"
        patches, directions, labels, fits = [], [], [], []
        for lesson in lessons:
            keep = np.asarray(lesson.keep, dtype=bool)
            p, d = route_observation(problem.world, lesson.points, half=self.half)
            patches.append(p[keep])
            directions.append(d[keep])
            labels.append(np.asarray(lesson.labels, dtype=np.float64)[keep])
            fits.append(np.asarray(lesson.fits)[keep])
        if not patches or not sum(len(y) for y in labels):
            return "empty"
        self._patches, self._directions = np.concatenate(patches), np.concatenate(directions)
        self._labels, self._fits = np.concatenate(labels), np.concatenate(fits)
        if (self._labels < 0).any() or not (self._labels.sum(axis=1) > 0).all():
            raise InputError(f"{self.scene}: the teacher's labels must be non-negative with a positive sum per point")
        return None

    # the Gymnasium interface

    def _observation(self, i: int) -> dict:
        return {"patch": self._patches[i], "direction": self._directions[i]}

    def _info(self, i: int) -> dict:
        info = {"scene": self.scene, "point": i, "points": len(self._labels)}
        if i < len(self._labels):
            info.update(label=self._labels[i].copy(), expert_action=int(np.argmax(self._labels[i])),
                        fits=int(self._fits[i]))
        return info

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        options = dict(options or {})
        if "family" in options or "scene_seed" in options:
            family, scene_seed = options.get("family"), options.get("scene_seed")
            if family not in self.families or isinstance(scene_seed, bool) or not isinstance(scene_seed,
                                                                                             (int, np.integer)):
                raise InputError(f"reset options name a scene by 'family' (one of {', '.join(self.families)}) and "
                                 f"'scene_seed' (an integer), got {family!r} and {scene_seed!r}")
            why = self._lessons(family, int(scene_seed), options.get("teacher_seed", int(scene_seed)))
            if why is not None:
                raise NoLessons(f"{self.scene}: the teacher labels no point of it ({why})", why == "empty")
        else:
            for _ in range(SCENE_DRAWS):
                family, scene_seed = self._draw_scene()
                if self._lessons(family, scene_seed, int(self.np_random.integers(2**63))) is None:
                    break
            else:
                raise RuntimeError(f"the teacher labelled none of {SCENE_DRAWS} scenes drawn from the "
                                   f"{self.part!r} part")
        self._at = 0
        return self._observation(0), self._info(0)

    def step(self, action):
        if not self.action_space.contains(action):
            raise InputError(f"action must be an orientation class 0..{N_CLASSES - 1}, got {action!r}")
        if self._at >= len(self._labels):
            raise RuntimeError("the episode has ended: call reset()")
        label = self._labels[self._at]
        reward = float(label[int(action)] / label.sum())
        self._at += 1
        done = self._at >= len(self._labels)
        return self._observation(min(self._at, len(self._labels) - 1)), reward, done, False, self._info(self._at)
