"""Samplers by name, as planners are: ``make_sampler(name, **params)``, ``sampler_names()``, ``SamplerSpec``.

Every sampler of the comparison is built here from its name and its parameters (plain numbers and
strings), never from a string parsed back. A user's sampler is a spec on the command line
(``user_sampler``): ``MODEL.zip@ENV_ID[@OPTION...]`` for a Stable-Baselines3 model, or
``module:callable`` for a factory returning a ``Sampler``.

The references (``REFERENCES``) are privileged, not competitors: in 2-D they read the map's exact geodesic
distance (a grid search) and say what perfect route knowledge reaches; in 6-DoF, where no exact search exists,
``rigid_expert`` samples along a solution that long runs found before the run.
"""

from __future__ import annotations

import functools
import importlib
import inspect
import json
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from planners import GoalBiasedSampler, InformedSampler, Sampler, UniformSampler
from planners.base.fileio import InputError
from planners.base.samplers import check_sampler_params
from planners.tools.benchmark import STEP  # the step samplers are built for unless told otherwise


def _uniform() -> Sampler:
    return UniformSampler()


def _informed() -> Sampler:
    return InformedSampler()


def _goal_bias(bias: float = 0.05) -> Sampler:
    return GoalBiasedSampler(bias)


def _follower(step_size: float = STEP) -> Sampler:
    from learning.samplers.route import FOLLOWER_SETTINGS, RouteSampler

    return RouteSampler(None, step_size=step_size, **FOLLOWER_SETTINGS)


def _route(step_size: float = STEP, path: str | None = None, device: str = "auto", coarse_side: int | None = None, *,
           models: ModelCache | None = None) -> Sampler:
    from learning.samplers.route import SHIPPED, shipped_sampler

    path = str(SHIPPED) if path is None else path
    coarse = {} if coarse_side is None else {"coarse_side": coarse_side}  # None: RouteSampler's own default
    return shipped_sampler(path if models is None else models.route_net(path), step_size, device=device, **coarse)


def _route_lazy(after: float | None = None, cap: float | None = None, stall: float | None = None,
                connect_after: float | None = None,
                roadmap_after: float | None = None, floor: float | None = None, connect_floor: float | None = None,
                roadmap_floor: float | None = None, connect_cap: float | None = None,
                roadmap_cap: float | None = None, goal_in_sight: bool | None = None, step_size: float = STEP,
                path: str | None = None, device: str = "auto", coarse_side: int | None = None, *,
                models: ModelCache | None = None) -> Sampler:
    from learning.models.route_net import load_route_net
    from learning.samplers.lazy_route import LazyRouteSampler
    from learning.samplers.route import SHIPPED

    path = str(SHIPPED) if path is None else path
    net = load_route_net(path) if models is None else models.route_net(path)
    switches = {"after": after, "cap": cap, "stall": stall, "connect_after": connect_after,
                "roadmap_after": roadmap_after, "floor": floor, "connect_floor": connect_floor,
                "roadmap_floor": roadmap_floor, "connect_cap": connect_cap,
                "roadmap_cap": roadmap_cap, "goal_in_sight": goal_in_sight,
                "coarse_side": coarse_side}  # None: LazyRouteSampler's own default
    return LazyRouteSampler(net, step_size=step_size, device=device,
                            **{k: v for k, v in switches.items() if v is not None})


def _route_ablation(step_size: float = STEP) -> Sampler:
    from learning.samplers.route import shipped_ablation

    return shipped_ablation(step_size)


def _policy(batch: int | None = None, path: str | None = None, step_size: float | None = None, *,
            models: ModelCache | None = None) -> Sampler:
    # the shipped policy at its validated batch unless a path or batch is given
    return (ModelCache() if models is None else models).policy(path, batch, step_size)


def _policy_ablation(frontier: float = 0.7, step_size: float = STEP, batch: int = 8) -> Sampler:
    from learning.samplers.ablation import ConstantGuidedSampler

    return ConstantGuidedSampler(frontier, step_size=step_size, batch=batch)


def _expert(step_size: float = STEP) -> Sampler:
    from learning.references.expert import ExpertSampler

    return ExpertSampler(step_size)


def _exact_route(step_size: float = STEP) -> Sampler:
    from learning.references.expert import GeodesicRouteSampler
    from learning.samplers.route import SHIPPED_SETTINGS

    return GeodesicRouteSampler(step_size=step_size, **SHIPPED_SETTINGS)


def _gaussian(stddev: float | None = None, attempts: int = 100) -> Sampler:
    from planners.base.samplers import GaussianSampler

    return GaussianSampler(stddev, attempts)


def _bridge_test(stddev: float | None = None, attempts: int = 100) -> Sampler:
    from planners.base.samplers import BridgeTestSampler

    return BridgeTestSampler(stddev, attempts)


def _obstacle_based(max_distance: float | None = None, uniform_fraction: float = 0.1) -> Sampler:
    from planners.algorithms.obprm import ObstacleBasedSampler

    return ObstacleBasedSampler(max_distance, uniform_fraction=uniform_fraction)


def _rigid_workspace_route(route_fraction: float = 0.75, spread: float | None = None,
                           cell: float | None = None) -> Sampler:
    from planners.guidance.workspace_route import WorkspaceRouteSampler

    return WorkspaceRouteSampler(route_fraction, spread, cell)


def _rigid_route(uniform_share: float | None = None, angle_noise: float | None = None, goal_share: float = 0.05,
                 temperature: float = 1.0, route_fraction: float | None = None, centre: int | None = None,
                 path: str | None = None, symmetry: str | None = None, min_confidence: float | None = None,
                 min_route_confidence: float | None = None, passage_weight: float | None = None,
                 uniform_ramp: float | None = None, uniform_first: float | None = None,
                 stall_window: float | None = None, follow: float | None = None,
                 follow_share: float | None = None, *,
                 models: ModelCache | None = None) -> Sampler:
    from learning.models.shipped import SHIPPED_RIGID_ORIENTATION
    from learning.samplers.rigid_route import SHIPPED_RIGID_ROADMAP, SHIPPED_RIGID_SETTINGS, RigidRouteSampler

    path = str(SHIPPED_RIGID_ORIENTATION) if path is None else path
    net = (ModelCache() if models is None else models).orientation_net(path)
    given = {"symmetry": symmetry, "route_fraction": route_fraction, "uniform_share": uniform_share,
             "angle_noise": angle_noise, "passage_weight": passage_weight, "uniform_ramp": uniform_ramp,
             "uniform_first": uniform_first, "stall_window": stall_window, "follow": follow,
             "follow_share": follow_share}
    tree = {"centre": centre, "min_confidence": min_confidence, "min_route_confidence": min_route_confidence, **given}
    return RigidRouteSampler(net, goal_share=goal_share, temperature=temperature,
                             **{k: SHIPPED_RIGID_SETTINGS[k] if v is None else v for k, v in tree.items()},
                             # a roadmap's own validated settings, where the user set none of them
                             roadmap={k: v for k, v in SHIPPED_RIGID_ROADMAP.items() if given[k] is None})


def _rigid_route_ablation(goal_share: float = 0.05, route_fraction: float = 0.75, centre: int | None = None,
                          passage_weight: float | None = None, follow: float | None = None) -> Sampler:
    from learning.samplers.rigid_route import SHIPPED_RIGID_ROADMAP, SHIPPED_RIGID_SETTINGS, RigidRouteSampler

    # the learned sampler's route positions without its model: the trees take the trees' passage weight and windows
    # that follow them, and a roadmap (and every planner on a mesh world) the roadmaps', as ``rigid_route`` does,
    # unless the user gives them
    given = {"passage_weight": passage_weight, "follow": follow}
    return RigidRouteSampler(None, route_fraction=route_fraction, uniform_share=1.0, goal_share=goal_share,
                             centre=SHIPPED_RIGID_SETTINGS.get("centre", 0) if centre is None else centre,
                             **{k: SHIPPED_RIGID_SETTINGS[k] if v is None else v for k, v in given.items()},
                             roadmap={k: SHIPPED_RIGID_ROADMAP[k] for k, v in given.items() if v is None} or None)


def _rigid_expert(attempts: int = 4, budget: int = 100_000, uniform_share: float = 0.1, goal_share: float = 0.05,
                  angle_noise: float = 0.1, follow: float | None = None) -> Sampler:
    from learning.references.rigid_expert import RigidExpertSampler

    return RigidExpertSampler(attempts, budget, uniform_share, goal_share, angle_noise, follow=follow)


#: name -> (factory, one line for help texts).
REGISTRY: dict[str, tuple[Callable[..., Sampler], str]] = {
    "uniform": (_uniform, "uniform sampling"),
    "goal_bias": (_goal_bias, "uniform sampling with the goal drawn with probability bias"),
    "informed": (_informed, "Informed RRT*'s sampling: uniform, then uniform over the informed set once a path "
                 "exists (Euclidean real-vector worlds)"),
    "follower": (_follower, "the straight-line follower: the route sampler on the straight-line distance"),
    "route": (_route, "the shipped route encoder at its validated settings"),
    "route_lazy": (_route_lazy, "the route encoder's field computed only where needed: RRT draws the goal where "
                   "the start sees it (goal_in_sight=), else follows the straight line first and runs the encoder if "
                   "that has not solved within after= iterations per step-sized square of the map (at least floor=, "
                   "at most cap= iterations), or has stalled stall= iterations; RRT-Connect's trees grow uniformly "
                   "until connect_after= of them (at least connect_floor=, at most connect_cap=), a roadmap's samples "
                   "until roadmap_after= (at least roadmap_floor=, at most roadmap_cap=)"),
    "route_ablation": (_route_ablation, "the route sampler without its encoder, tuned for itself"),
    "policy": (_policy, "the learned sampler policy (shipped at its validated batch, or path=)"),
    "policy_ablation": (_policy_ablation, "the policy's action classes at a constant distribution (frontier=)"),
    "gaussian": (_gaussian, "OMPL's Gaussian sampling: the valid one of a uniform state and a Gaussian one near it"),
    "bridge_test": (_bridge_test, "OMPL's bridge test: the valid midpoint of two invalid states close together"),
    "obstacle_based": (_obstacle_based, "OB-PRM's sampling: a step out of an obstacle to the first free state"),
    "rigid_workspace_route": (_rigid_workspace_route, "6-DoF box and mesh worlds: along the workspace route of "
                              "the body's centre, uniform angles (the no-learning ablation)"),
    "rigid_route": (_rigid_route, "6-DoF box and mesh worlds: the workspace route, centred in its passages, with "
                    "orientations from the shipped orientation model (or path=), carried to a mesh body's axes"),
    "rigid_route_ablation": (_rigid_route_ablation, "6-DoF box and mesh worlds: rigid_route without its model (the "
                             "same centred route positions and goal share, uniform angles): its no-learning "
                             "ablation"),
    "expert": (_expert, "reference: the privileged expert on the exact geodesic distance"),
    "exact_route": (_exact_route, "reference: the route sampler on the exact cost-to-go"),
    "rigid_expert": (_rigid_expert, "reference, 6-DoF box and mesh worlds: samples along a solution that long runs "
                     "of RRT-Connect found before the run (the privileged expert)"),
}
#: Names that are privileged references, not competitors.
REFERENCES = ("expert", "exact_route", "rigid_expert")


def sampler_names() -> tuple[str, ...]:
    """Every registered sampler name."""
    return tuple(REGISTRY)


@functools.cache
def _factory_parameters(factory: Callable) -> tuple[tuple[str, ...], bool]:
    """A registered factory's parameters a user may pass, and whether it takes ``models``.

    Read once per factory: ``inspect.signature`` costs about as much as making a classical sampler.
    """
    signature = inspect.signature(factory).parameters
    return tuple(k for k, p in signature.items() if p.kind is not p.KEYWORD_ONLY), "models" in signature


def make_sampler(name: str, *, models: ModelCache | None = None, **params: Any) -> Sampler:
    """The sampler registered as ``name`` with ``params``; an unknown name or parameter is an ``InputError``.

    ``models``: where samplers that load a file (the route encoder, the policy) take it from, loaded
    once (:class:`ModelCache`); without it they load the file themselves.
    """
    if name not in REGISTRY:
        raise InputError(f"unknown sampler {name!r}; choose from {', '.join(REGISTRY)}")
    factory = REGISTRY[name][0]
    allowed, takes_models = _factory_parameters(factory)
    unknown = sorted(set(params) - set(allowed))
    if unknown:
        raise InputError(f"sampler {name!r} takes no parameter {', '.join(unknown)}; it takes "
                         f"{', '.join(allowed) or 'none'}")
    check_sampler_params(f"sampler {name!r}", step_size=params.get("step_size"), batch=params.get("batch"))
    if models is not None and takes_models:
        return factory(**params, models=models)
    return factory(**params)


#: The name of a user's ``NAME=SPEC`` sampler in a :class:`SamplerSpec` (``params``: ``name`` and ``spec``).
USER = "user"


class ModelCache:
    """What samplers load from files, loaded once and kept: route encoders by path, policies, users' samplers.

    A worker receives one with its tasks, so a run never loads weights again. A policy or a user's
    sampler is kept as the sampler itself (it is bound afresh to every problem); a route encoder as its
    network, each run building its sampler around it. ``load_seconds`` holds the wall time of each load, by
    what was loaded ("route encoder PATH", "policy PATH", "sampler SPEC"): a cost paid once, not per query.
    """

    def __init__(self) -> None:
        self.routes: dict[str, Any] = {}
        self.orientations: dict[str, Any] = {}
        self.policies: dict[tuple, Sampler] = {}
        self.users: dict[str, Sampler] = {}
        self.load_seconds: dict[str, float] = {}

    def _timed(self, label: str, load: Callable[[], Any]) -> Any:
        t0 = time.perf_counter()
        out = load()
        self.load_seconds[label] = self.load_seconds.get(label, 0.0) + time.perf_counter() - t0
        return out

    def __getstate__(self) -> dict:
        # users' samplers are built in each worker: a user's object need not survive pickling
        return {**self.__dict__, "users": {}}

    def orientation_net(self, path: str):
        """The 6-DoF orientation model in ``path`` (``load_orientation_net``), loaded on first use."""
        if path not in self.orientations:
            from learning.models.rigid_orientation import load_orientation_net

            self.orientations[path] = self._timed(f"orientation model {path}", lambda: load_orientation_net(path))
        return self.orientations[path]

    def route_net(self, path: str):
        """The route encoder in ``path``, loaded on first use."""
        if path not in self.routes:
            from learning.models.route_net import load_route_net

            self.routes[path] = self._timed(f"route encoder {path}", lambda: load_route_net(path))
        return self.routes[path]

    def policy(self, path: str | None, batch: int | None, step_size: float | None = None) -> Sampler:
        """The policy in ``path`` (None: the shipped one) deciding every ``batch`` samples, loaded on first use."""
        key = (path, batch, step_size)
        if key not in self.policies:
            from learning.samplers.policy import PolicySampler

            kwargs = {} if step_size is None else {"step_size": step_size}
            if path is None:  # the shipped policy at its validated batch unless one is given
                kwargs.update({} if batch is None else {"batch": batch})
                self.policies[key] = self._timed("policy (shipped)", lambda: PolicySampler.load(**kwargs))
            else:
                self.policies[key] = self._timed(f"policy {path}", lambda: PolicySampler.load(path, batch=batch,
                                                                                              **kwargs))
        return self.policies[key]

    def forget_maps(self) -> None:
        """Have every route encoder forget the maps' parts it keeps (``RouteVIN.clear_map_cache``; an encoder that
        keeps none has nothing to forget): each map's next query pays its whole pass, as a first query does.
        """
        for net in self.routes.values():
            forget = getattr(net, "clear_map_cache", None)
            if forget is not None:
                forget()

    def user(self, spec: str) -> Sampler:
        """The user's sampler of ``spec`` (:func:`user_sampler`), built on first use."""
        if spec not in self.users:
            self.users[spec] = self._timed(f"sampler {spec}", lambda: user_sampler(spec))
        return self.users[spec]


@dataclass(frozen=True)
class SamplerSpec:
    """A sampler as data: a registered name and its parameters (``make_sampler(name, **params)``)."""

    name: str
    params: tuple[tuple[str, Any], ...] = ()

    @classmethod
    def of(cls, name: str, **params: Any) -> SamplerSpec:
        """The spec of ``make_sampler(name, **params)``, its parameters in a fixed order."""
        return cls(name, tuple(sorted(params.items())))

    @classmethod
    def user(cls, name: str, spec: str) -> SamplerSpec:
        """A user's ``NAME=SPEC`` sampler (:func:`user_sampler`) as a spec."""
        return cls(USER, (("name", name), ("spec", spec)))

    @classmethod
    def from_json(cls, text: str) -> SamplerSpec:
        """The spec that :meth:`to_json` wrote."""
        data = json.loads(text)
        return cls(data["name"], tuple(sorted(data["params"].items())))

    def param(self, key: str, default: Any = None) -> Any:
        """The parameter ``key``: as the spec sets it, else the registered factory's default, else ``default``."""
        params = dict(self.params)
        if key in params:
            return params[key]
        factory = REGISTRY.get(self.name, (None,))[0]
        p = inspect.signature(factory).parameters.get(key) if factory is not None else None
        return default if p is None or p.default is p.empty else p.default

    def build(self, models: ModelCache | None = None) -> Sampler:
        """A sampler of this spec, taking loaded files from ``models`` where given (see :func:`make_sampler`)."""
        if self.name == USER:
            spec = self.param("spec")
            return user_sampler(spec) if models is None else models.user(spec)
        return make_sampler(self.name, models=models, **dict(self.params))

    def to_json(self) -> str:
        """``{"name": ..., "params": {...}}`` as one line of JSON."""
        return json.dumps({"name": self.name, "params": dict(self.params)}, sort_keys=True)


def parse_user_sampler(arg: str, taken: tuple[str, ...] = ()) -> tuple[str, str]:
    """``NAME=SPEC`` from the command line, checked: the name and the spec (see :func:`user_sampler`).

    The name may not be one of ``taken`` (the caller's own labels) or a registered name.
    """
    name, sep, spec = arg.partition("=")
    name, spec = name.strip(), spec.strip()
    if not sep or not name or not spec:
        raise InputError(f"--sampler {arg!r}: expected NAME=SPEC, e.g. mine=user_ppo.zip@SamplerGym/RRT-Forest-v2 "
                         "or mine=my_module:make_sampler")
    if name in taken or name in REGISTRY or name.startswith("goal_bias=") or "," in name:
        raise InputError(f"--sampler {arg!r}: the name {name!r} is taken or has a comma; choose another")
    return name, spec


def checked_user_samplers(args: Sequence[str], flag: str = "--sampler", taken: tuple[str, ...] = ()) -> dict[str, str]:
    """A command line's ``NAME=SPEC`` arguments of ``flag`` as name -> spec, each parsed and built once.

    Each is parsed (:func:`parse_user_sampler`, ``taken`` the caller's own labels) and built (:func:`user_sampler`),
    so that a bad file, spec or name is refused before any run: an ``InputError`` naming the flag and the argument (a
    name given twice too).
    """
    out: dict[str, str] = {}
    for arg in args:
        try:
            name, spec = parse_user_sampler(arg, taken)
            user_sampler(spec)
        except (ValueError, OSError) as exc:
            raise InputError(f"{flag} {arg!r}: {exc}" if arg not in str(exc) else str(exc)) from exc
        except Exception as exc:  # noqa: BLE001 - e.g. an env kwarg the env does not take (TypeError)
            raise InputError(f"{flag} {arg!r}: {type(exc).__name__}: {exc}") from exc
        if name in out:
            raise InputError(f"{flag} name {name!r} is given twice")
        out[name] = spec
    return out


def user_sampler(spec: str) -> Sampler:
    """The sampler a spec names.

    ``MODEL.zip@ENV_ID[@OPTION...]``: an SB3 model trained on that SamplerGym id (``SB3Sampler``);
    options are ``stochastic`` (draw actions from the policy's distribution) or ``deterministic`` (its mode;
    without either, ``SB3Sampler``'s default: the mode, draws in the ``guided`` action mode), ``batch=K``,
    ``algo=NAME``, or env kwargs ``key=value`` (the ones the model was trained with; values read as
    JSON where they parse, else as strings). ``module:callable``: ``callable()`` returns a ``Sampler``.
    """
    if "@" in spec:
        from learning.samplers.sb3 import SB3Sampler

        path, env_id, *options = spec.split("@")
        kwargs: dict = {}
        for opt in options:
            key, sep, value = opt.partition("=")
            if opt in ("stochastic", "deterministic"):
                kwargs["deterministic"] = opt == "deterministic"
            elif sep and key:
                try:
                    kwargs[key] = json.loads(value)
                except ValueError:
                    kwargs[key] = value
            else:
                raise InputError(f"sampler spec {spec!r}: option {opt!r} is not stochastic, deterministic or key=value")
        return SB3Sampler(path, env_id, **kwargs)
    module, sep, attr = spec.partition(":")
    if not sep or not module or not attr:
        raise InputError(f"sampler spec {spec!r}: expected MODEL.zip@ENV_ID or module:callable")
    try:
        factory = getattr(importlib.import_module(module), attr)
    except (ImportError, AttributeError) as exc:
        raise InputError(f"sampler spec {spec!r}: {type(exc).__name__}: {exc}") from None
    try:
        sampler = factory()
    except Exception as exc:  # noqa: BLE001 - the user's code: whatever it raises, name the spec
        raise InputError(f"sampler spec {spec!r}: {attr}() raised {type(exc).__name__}: {exc}") from None
    if not isinstance(sampler, Sampler):
        raise InputError(f"sampler spec {spec!r}: {attr}() returned a {type(sampler).__name__}, not a Sampler "
                         "(an object with bind(problem) and draw(rng, n, view))")
    return sampler
