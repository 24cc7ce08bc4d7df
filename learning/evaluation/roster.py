"""The comparison's samplers by name: built-in names, tuned variants, and users' ``NAME=SPEC`` samplers."""

from __future__ import annotations

from planners import Sampler
from planners.base.fileio import InputError


def bias_sampler(bias: float) -> str:
    """The sampler name of goal bias ``bias``: ``"uniform"`` for 0, else ``"goal_bias=<bias>"``."""
    return "uniform" if bias == 0 else f"goal_bias={bias:g}"


def sampler_bias(name: str) -> float | None:
    """The goal bias of sampler ``name`` (0 for uniform), or None for other samplers."""
    if name == "uniform":
        return 0.0
    if name.startswith("goal_bias="):
        return float(name.split("=")[1])
    return None


#: The test-split name of the ablation's runs, each at the frontier probability tuned for its map set.
CONSTANT = "constant (tuned)"


def constant_sampler(frontier: float) -> str:
    """The sampler name of the constant-distribution ablation at frontier probability ``frontier``."""
    return f"constant={frontier:g}"


#: Name prefix of the privileged ablation whose frontier knows the geodesic distance (``learning.references.expert``).
GEODESIC_FRONTIER = "geodesic frontier="


#: Name prefixes of the privileged corridor references (``learning.references.expert.CorridorSampler``): the share of
#: samples drawn from the exact near-shortest-path corridor follows, the rest come from uniform sampling or
#: the straight-line follower.
CORRIDOR_UNIFORM, CORRIDOR_FOLLOWER = "corridor+uniform=", "corridor+follower="


def sampler_constant(name: str) -> float | None:
    return float(name.split("=")[1]) if name.startswith("constant=") else None


def policy_sampler(batch: int) -> str:
    """The sampler name of the policy deciding every ``batch`` samples (a tuning run)."""
    return f"policy batch={batch}"


def sampler_policy_batch(name: str) -> int | None:
    return int(name.split("=")[1]) if name.startswith("policy batch=") else None


#: Sampler names the comparison defines itself; a user sampler takes another name.
#: The strongest sampler without learning we know: ``learning.samplers.route.RouteSampler`` on the straight-line
#: distance (one step ahead of the vertex nearest the goal; the frontier after 4 iterations without progress).
FOLLOWER = "straight-line follower"


#: The shipped route encoder (``learning.samplers.route.shipped_sampler``) and its ablation, the same sampler
#: with the straight-line distance in place of the encoder's field (``learning.samplers.route.shipped_ablation``).
ROUTE, ROUTE_ABLATION = "route encoder", "route ablation"


BUILTIN_SAMPLERS = ("uniform", "policy", FOLLOWER, ROUTE, ROUTE_ABLATION, "expert (reference)")


def parse_user_sampler(arg: str) -> tuple[str, str]:
    """``NAME=SPEC`` from the command line, checked: the name and the spec (see :func:`user_sampler`)."""
    name, sep, spec = arg.partition("=")
    name, spec = name.strip(), spec.strip()
    if not sep or not name or not spec:
        raise InputError(f"--sampler {arg!r}: expected NAME=SPEC, e.g. mine=user_ppo.zip@SamplerGym/RRT-Forest-v0 "
                         "or mine=my_module:make_sampler")
    if name in BUILTIN_SAMPLERS or name.startswith("goal_bias=") or "," in name:
        raise InputError(f"--sampler {arg!r}: the name {name!r} is taken or has a comma; choose another")
    return name, spec


def user_sampler(spec: str):
    """The sampler a spec names.

    ``MODEL.zip@ENV_ID[@OPTION...]``: an SB3 model trained on that SamplerGym id (``SB3Sampler``);
    options are ``stochastic`` (draw actions from the policy's distribution; default deterministic),
    ``algo=NAME``, or env kwargs ``key=value`` (the ones the model was trained with; values read as
    JSON where they parse, else as strings). ``module:callable``: ``callable()`` returns a ``Sampler``.
    """
    import importlib
    import json

    if "@" in spec:
        from learning.samplers.sb3 import SB3Sampler

        path, env_id, *options = spec.split("@")
        kwargs: dict = {"deterministic": True}
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
