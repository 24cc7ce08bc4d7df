"""SamplerGym under a name a user's project will not shadow; importing it registers the environments.

    import gymnasium as gym
    env = gym.make("samplergym:SamplerGym/RRT-Forest-v2")   # Gymnasium imports samplergym first

The library's code lives in the top-level packages ``planners``, ``envs`` and ``learning``. A project
with an ``envs/`` folder of its own (common in RL code) shadows ``envs``; ``import samplergym`` then
loads this library's environment package from its own folder as ``samplergym.envs`` and registers the
ids from there, leaving the project's ``envs`` alone. Otherwise ``samplergym.envs`` is ``envs``.

The main public names are re-exported here, each imported on first use (``learning`` needs torch):
``make_planner``, ``planner_names``, ``Problem``, ``OccupancyGrid`` (``planners``), ``SamplerEnv``,
``EnvSampler``, ``ENV_IDS`` (the environments) and ``SB3Sampler`` (``learning``).

``samplergym.envs`` is the one way this library's own code outside ``envs/`` reaches the environment
package (``from samplergym import envs``), so ``learning`` works beside a project's ``envs/`` too.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from pathlib import Path
from types import ModuleType

_ROOT = Path(__file__).resolve().parent.parent  # the folder that holds planners/, envs/, learning/
_OWN_ENVS = _ROOT / "envs"


def _is_own(origin: str | None) -> bool:
    return origin is not None and Path(origin).resolve().parent == _OWN_ENVS.resolve()


def _load_envs() -> ModuleType:
    """This library's environment package: ``envs`` when that name is ours, else a copy named ``samplergym.envs``."""
    loaded = sys.modules.get("envs")
    if loaded is not None:
        if _is_own(getattr(loaded, "__file__", None)):
            return loaded
    else:
        try:
            found = importlib.util.find_spec("envs")
        except (ImportError, ValueError):
            found = None
        if found is None or _is_own(found.origin):
            return importlib.import_module("envs")
    # "envs" is someone else's package: load ours from its folder under our own name
    name = f"{__name__}.envs"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, _OWN_ENVS / "__init__.py",
                                                  submodule_search_locations=[str(_OWN_ENVS)])
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    return module


envs = _load_envs()

_LAZY = {
    "make_planner": "planners",
    "planner_names": "planners",
    "Problem": "planners",
    "OccupancyGrid": "planners",
    "SB3Sampler": "learning",
}
_FROM_ENVS = ("SamplerEnv", "EnvSampler", "ENV_IDS")

__all__ = ["envs", *_FROM_ENVS, *_LAZY]


def __getattr__(name: str):
    if name in _FROM_ENVS:
        return getattr(envs, name)
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
