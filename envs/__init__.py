"""SamplerGym environments; importing this package registers them under ``SamplerGym/``.

    import gymnasium as gym
    env = gym.make("samplergym:SamplerGym/RRT-Maze-v2", action_mode="relative")

(``samplergym:`` makes Gymnasium import ``samplergym``, which registers the ids even when a project's
own ``envs/`` folder shadows this package; ``import envs`` registers them too.)

Registered ids:

* ``SamplerGym/RRT-{Forest,NarrowPassage,Bugtrap,Maze,Rooms}-v2``: RRT on a fresh generated map of
  that family each episode (``source_kwargs={"size": ...}``, default 64).
* ``SamplerGym/RRT-MovingAI-v2``: RRT on the MovingAI benchmark scenarios, found by
  ``planners.movingai_dir`` (``source_kwargs={"directory": ...}``, else ``SAMPLERGYM_MOVINGAI_DIR``,
  else ``../shared/maps/movingai`` from the working directory).
* ``SamplerGym/RRT-Files-v2``: RRT on your own maps (``source_kwargs={"paths": [...]}``), by default on
  the small sample maps shipped in ``envs/data/maps``.
* ``SamplerGym/RRT-RigidBody-v1``: RRT for a 6-DoF rigid body among 3-D boxes, a fresh
  ``planners.worlds.rigid3d.random_scene`` each episode (``source_kwargs={"n_boxes": ...}``); vector
  observations, step 0.5, 5,000 iterations.
* ``SamplerGym/RRT-RigidScenes-v1``: RRT for the 6-DoF body on the generated scene sets, whose passages it must
  turn to pass (``planners.worlds.rigid_scenes``): a training scene each episode by default
  (``source_kwargs={"part": "validation"}`` and so on, ``SceneSetSource``), at the seed project's RRT set-up
  (step 1.0, goal distance 1.0, 20,000 iterations). ``map_source="problem.cfg"`` (an OMPL.app problem, with the
  ``mesh`` extra) or ``"scene.scene"`` plans one 6-DoF problem every episode.
* ``SamplerGym/RigidOrientation-v1``: the orientation class the 6-DoF route sampler gives its samples, one route
  point of a generated scene a step (``RigidOrientationEnv``): Dict observations (the occupancy patch about the point
  and the route's direction), ``Discrete(6)`` actions, a teacher's label in ``info`` for imitation; the shipped
  orientation model's examples are collected through it (``learning.training.rigid``).
* ``SamplerGym/Planning-v1``: everything by kwargs (``planner``, ``map_source``, ``step_size``,
  ``max_iterations``, ``action_mode``, ...); ``map=array_or_path, start=(x, y), goal=(x, y)`` plans on
  your own map; ``map_set=DIR, split="train"`` draws episodes from a part of a map set
  (``planners.maps.mapset``, ``docs/map-sets.md``).

The generated-family, ``MovingAI`` and ``Files`` ids are at version 2: ``guided`` actions (a class of
egocentric cells ahead of the tree's progress, or its frontier, so that PPO's initial, nearly uniform
policy already samples near the tree's progress), ``egocentric_flat`` observations (small windows
SB3's default MLP reads, cheap to evaluate) and progress shaping at PPO's discount 0.99
(``V2_DEFAULTS``). ``gym.make`` of a ``-v0`` or ``-v1`` id is Gymnasium's ``DeprecatedEnv`` error naming
the ``-v2`` id. A model trained on version 1 plans under version 2 with ``action_mode="mixture",
observation="image", shaping=False``; one trained on version 0 with ``action_mode="point"`` too.
``RRT-RigidBody-v1`` and ``Planning-v1`` keep ``SamplerEnv``'s own defaults (``mixture`` actions, a 5%
uniform floor; image or vector observations).

Every id trains with Stable-Baselines3's defaults: ``PPO("MultiInputPolicy", env)`` (Dict
observations) or ``PPO("MlpPolicy", env)`` (``RRT-RigidBody-v1``'s Box observations); on
``RRT-Forest-v2`` 10,000 steps of it already plan in fewer iterations than tuned goal bias on
held-out maps (``docs/first-steps.md``).
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

# relative imports: the package works under another name too (``samplergym`` loads it so when a
# user's own ``envs/`` folder shadows this one)
from .actions import ACTION_MODES
from .env_sampler import EnvSampler, NoExplorationWarning
from .orientation import Lesson, NoLessons, RigidOrientationEnv, witness_teacher
from .render import record_episode
from .sampler_env import SamplerEnv, make_sampler_env
from .sources import (
    FamilySource,
    FileSource,
    MapSetSource,
    MovingAISource,
    ProblemListSource,
    RigidSceneSource,
    SceneSetSource,
    sample_map_paths,
)

__all__ = ["ACTION_MODES", "ENV_IDS", "ORIENTATION_ENV_ID", "EnvSampler", "FamilySource", "FileSource", "Lesson",
           "MapSetSource", "MovingAISource", "NoExplorationWarning", "NoLessons", "ProblemListSource",
           "RigidOrientationEnv", "RigidSceneSource", "SamplerEnv", "SceneSetSource", "make_sampler_env",
           "record_episode", "sample_map_paths", "witness_teacher"]

_FAMILY_IDS = {
    "Forest": "forest",
    "NarrowPassage": "narrow_passage",
    "Bugtrap": "bugtrap",
    "Maze": "maze",
    "Rooms": "rooms",
}

#: What version 2 of the 2-D ids changed from version 1 (``SamplerEnv``'s own defaults, which ``Planning-v1``
#: keeps): guided actions, egocentric observations an MLP reads, and progress shaping at PPO's discount.
V2_DEFAULTS = {"action_mode": "guided", "observation": "egocentric_flat", "shaping": True, "shaping_gamma": 0.99}

ENV_IDS: dict[str, dict] = {f"SamplerGym/RRT-{name}-v2": {"map_source": fam, **V2_DEFAULTS}
                            for name, fam in _FAMILY_IDS.items()}
ENV_IDS["SamplerGym/RRT-MovingAI-v2"] = {"map_source": "movingai", **V2_DEFAULTS}
ENV_IDS["SamplerGym/RRT-Files-v2"] = {"map_source": "files", **V2_DEFAULTS}
ENV_IDS["SamplerGym/RRT-RigidBody-v1"] = {"map_source": "rigid", "step_size": 0.5, "max_iterations": 5000}
ENV_IDS["SamplerGym/RRT-RigidScenes-v1"] = {"map_source": "rigid_scenes", "step_size": 1.0, "max_iterations": 20000}
ENV_IDS["SamplerGym/Planning-v1"] = {}
#: The orientation environment's id (not a planning environment: ``RigidOrientationEnv``, not ``SamplerEnv``).
ORIENTATION_ENV_ID = "SamplerGym/RigidOrientation-v1"


def _register_all() -> None:
    for env_id, kwargs in ENV_IDS.items():
        if env_id in registry:  # re-import (e.g. importlib.reload, or a second package path)
            continue
        # a factory, not the class: it adds TimeLimit at the env's own max_iterations (see make_sampler_env)
        register(id=env_id, entry_point=f"{__name__}.sampler_env:make_sampler_env", kwargs=kwargs)
    if ORIENTATION_ENV_ID not in registry:
        register(id=ORIENTATION_ENV_ID, entry_point=f"{__name__}.orientation:RigidOrientationEnv")


_register_all()
