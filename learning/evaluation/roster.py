"""The comparison's samplers by name: built-in names, tuned variants, and users' ``NAME=SPEC`` samplers."""

from __future__ import annotations

from learning.samplers import registry


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
    """``NAME=SPEC`` from the command line, checked: the name and the spec (``user_sampler``).

    The name may be neither a registered sampler nor one of the comparison's labels.
    """
    return registry.parse_user_sampler(arg, taken=BUILTIN_SAMPLERS)
