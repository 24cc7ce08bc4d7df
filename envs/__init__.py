"""SamplerGym environments; importing this package registers them under ``SamplerGym/``.

    import gymnasium as gym
    env = gym.make("samplergym:SamplerGym/RRT-Maze-v1", action_mode="relative")

(``samplergym:`` makes Gymnasium import ``samplergym``, which registers the ids even when a project's
own ``envs/`` folder shadows this package; ``import envs`` registers them too.)

Registered ids:

* ``SamplerGym/RRT-{Forest,NarrowPassage,Bugtrap,Maze,Rooms}-v1``: RRT on a fresh generated map of
  that family each episode (``source_kwargs={"size": ...}``, default 64).
* ``SamplerGym/RRT-MovingAI-v1``: RRT on the MovingAI benchmark scenarios, found by
  ``planners.movingai_dir`` (``source_kwargs={"directory": ...}``, else ``SAMPLERGYM_MOVINGAI_DIR``,
  else ``../shared/maps/movingai`` from the working directory).
* ``SamplerGym/RRT-Files-v1``: RRT on your own maps (``source_kwargs={"paths": [...]}``), by default on
  the small sample maps shipped in ``envs/data/maps``.
* ``SamplerGym/RRT-RigidBody-v1``: RRT for a 6-DoF rigid body among 3-D boxes, a fresh
  ``planners.worlds.rigid3d.random_scene`` each episode (``source_kwargs={"n_boxes": ...}``); vector
  observations, step 0.5, 5,000 iterations.
* ``SamplerGym/Planning-v1``: everything by kwargs (``planner``, ``map_source``, ``step_size``,
  ``max_iterations``, ``action_mode``, ...); ``map=array_or_path, start=(x, y), goal=(x, y)`` plans on
  your own map; ``map_set=DIR, split="train"`` draws episodes from a part of a map set
  (``planners.maps.mapset``, ``docs/map-sets.md``).

The ids are at version 1. Version 0 defaulted to the ``point`` action mode, which has no uniform floor,
so a policy trained with SB3's defaults could not plan; version 1 defaults to ``mixture`` (a 5% uniform
floor). ``gym.make`` of a ``-v0`` id is Gymnasium's ``DeprecatedEnv`` error naming the ``-v1`` id; a model
trained on version 0 plans under version 1 with ``action_mode="point"``.

Every id trains with Stable-Baselines3's defaults: ``PPO("MultiInputPolicy", env)`` (Dict
observations) or ``PPO("MlpPolicy", env)`` (``RRT-RigidBody-v1``'s Box observations).
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

# relative imports: the package works under another name too (``samplergym`` loads it so when a
# user's own ``envs/`` folder shadows this one)
from .actions import ACTION_MODES
from .env_sampler import EnvSampler, NoExplorationWarning
from .render import record_episode
from .sampler_env import SamplerEnv, make_sampler_env
from .sources import (
    FamilySource,
    FileSource,
    MapSetSource,
    MovingAISource,
    ProblemListSource,
    RigidSceneSource,
    sample_map_paths,
)

__all__ = ["ACTION_MODES", "ENV_IDS", "EnvSampler", "FamilySource", "FileSource", "MapSetSource", "MovingAISource",
           "NoExplorationWarning", "ProblemListSource", "RigidSceneSource", "SamplerEnv", "make_sampler_env",
           "record_episode", "sample_map_paths"]

_FAMILY_IDS = {
    "Forest": "forest",
    "NarrowPassage": "narrow_passage",
    "Bugtrap": "bugtrap",
    "Maze": "maze",
    "Rooms": "rooms",
}

ENV_IDS: dict[str, dict] = {f"SamplerGym/RRT-{name}-v1": {"map_source": fam} for name, fam in _FAMILY_IDS.items()}
ENV_IDS["SamplerGym/RRT-MovingAI-v1"] = {"map_source": "movingai"}
ENV_IDS["SamplerGym/RRT-Files-v1"] = {"map_source": "files"}
ENV_IDS["SamplerGym/RRT-RigidBody-v1"] = {"map_source": "rigid", "step_size": 0.5, "max_iterations": 5000}
ENV_IDS["SamplerGym/Planning-v1"] = {}


def _register_all() -> None:
    for env_id, kwargs in ENV_IDS.items():
        if env_id in registry:  # re-import (e.g. importlib.reload, or a second package path)
            continue
        # a factory, not the class: it adds TimeLimit at the env's own max_iterations (see make_sampler_env)
        register(id=env_id, entry_point=f"{__name__}.sampler_env:make_sampler_env", kwargs=kwargs)


_register_all()
