"""The comparison's samplers as data: tasks carrying a ``SamplerSpec``, and one display label per spec.

A task names its sampler by a :class:`~learning.samplers.registry.SamplerSpec` (a registered name and
its parameters, or a user's ``NAME=SPEC``); runs are labelled from the spec by :func:`sampler_label`
and record the spec itself as JSON (``runs.csv``'s ``sampler_spec``). An experiment may hand in a
sampler the registry does not know: any picklable object with ``build(models) -> Sampler`` and
``to_json() -> str``, labelled by the task (:class:`Task`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from learning.evaluation.protocol import Protocol, Query
from learning.samplers import registry
from learning.samplers.registry import USER, SamplerSpec

#: The strongest sampler without learning we know: ``learning.samplers.route.RouteSampler`` on the straight-line
#: distance (one step ahead of the vertex nearest the goal; the frontier after 4 iterations without progress).
FOLLOWER = "straight-line follower"


#: The shipped route encoder (``learning.samplers.route.shipped_sampler``) and its ablation, the same sampler
#: with the straight-line distance in place of the encoder's field (``learning.samplers.route.shipped_ablation``).
ROUTE, ROUTE_ABLATION = "route encoder", "route ablation"


#: The route encoder's field computed only when a query needs it (``make_sampler("route_lazy")``): with RRT and
#: RRT* the straight line first, with RRT-Connect and the roadmaps their uniform sampling first, then the field's rule.
LAZY_ROUTE = "lazy route"


#: The privileged references: the expert on the exact geodesic distance, and the route sampler on the exact
#: cost-to-go at the route encoder's own settings (what perfect route knowledge gives that sampler).
EXPERT, EXACT_ROUTE = "expert (reference)", "exact_route"


#: The test-split name of the ablation's runs, each at the frontier probability tuned for its map set.
CONSTANT = "constant (tuned)"


#: The roadmaps' classical option: OB-PRM's obstacle-based sampling (``planners.ObstacleBasedSampler``) at its
#: defaults (the registry's ``obstacle_based``), handed to PRM, Lazy-PRM or OB-PRM.
OBSTACLE_BASED = "obstacle-based"


#: Labels of the registered samplers whose label is not made from a parameter.
_LABELS = {"uniform": "uniform", "follower": FOLLOWER, "route": ROUTE, "route_lazy": LAZY_ROUTE,
           "route_ablation": ROUTE_ABLATION, "expert": EXPERT, "exact_route": EXACT_ROUTE,
           "obstacle_based": OBSTACLE_BASED}


#: Sampler labels the comparison defines itself; a user sampler takes another name.
BUILTIN_SAMPLERS = ("uniform", "policy", FOLLOWER, ROUTE, LAZY_ROUTE, ROUTE_ABLATION, EXPERT, EXACT_ROUTE)


def sampler_label(spec: SamplerSpec) -> str:
    """The label of ``spec``'s runs in ``runs.csv``, tables and logs.

    ``uniform``, ``goal_bias=<bias>``, ``constant=<frontier>`` (the ablation), ``policy`` (the checkpoint's
    own batch) or ``policy batch=<batch>``, the follower, route encoder and ablation and references by
    their names, a user's sampler by its ``NAME``.
    """
    if spec.name == "goal_bias":
        return bias_sampler(spec.param("bias"))
    if spec.name == "policy_ablation":
        return constant_sampler(spec.param("frontier"))
    if spec.name == "policy":
        batch = spec.param("batch")
        return "policy" if batch is None else policy_sampler(batch)
    if spec.name == USER:
        return spec.param("name")
    return _LABELS.get(spec.name, spec.name)  # the 6-DoF references go by their registry names


@dataclass(frozen=True)
class Task:
    """One run to make: a query, a planner, a sampler (a spec, or an experiment's builder) and a seed.

    ``label`` names the runs where it differs from the spec's own (:func:`sampler_label`): the policy
    at its tuned batch is ``policy``, the ablation at its tuned frontier ``constant (tuned)``; an
    experiment's own sampler must be given one.
    """

    query: Query
    planner: str
    sampler: Any  # SamplerSpec, or an object with build(models) and to_json()
    seed: int
    label: str = ""

    @property
    def sampler_label(self) -> str:
        """The label its run is recorded under."""
        return self.label or sampler_label(self.sampler)


def bias_spec(bias: float) -> SamplerSpec:
    """Goal bias ``bias`` as a spec: uniform sampling for 0."""
    return SamplerSpec.of("uniform") if bias == 0 else SamplerSpec.of("goal_bias", bias=bias)


def bias_sampler(bias: float) -> str:
    """The label of goal bias ``bias``: ``"uniform"`` for 0, else ``"goal_bias=<bias>"``."""
    return "uniform" if bias == 0 else f"goal_bias={bias:g}"


def sampler_bias(name: str) -> float | None:
    """The goal bias of the runs labelled ``name`` (0 for uniform), or None for other samplers."""
    if name == "uniform":
        return 0.0
    if name.startswith("goal_bias="):
        return float(name.split("=")[1])
    return None


def spec_bias(spec: SamplerSpec) -> float | None:
    """The goal bias of ``spec`` (0 for uniform), or None for other samplers."""
    if spec.name == "uniform":
        return 0.0
    return float(spec.param("bias")) if spec.name == "goal_bias" else None


def constant_spec(frontier: float, protocol: Protocol, batch: int) -> SamplerSpec:
    """The constant-distribution ablation at ``frontier``, deciding every ``batch`` samples as the policy does."""
    return SamplerSpec.of("policy_ablation", frontier=frontier, step_size=protocol.step, batch=batch)


def constant_sampler(frontier: float) -> str:
    """The label of the constant-distribution ablation at frontier probability ``frontier``."""
    return f"constant={frontier:g}"


def policy_spec(path: str, batch: int | None) -> SamplerSpec:
    """The policy checkpoint ``path`` deciding every ``batch`` samples (None: the checkpoint's own batch)."""
    return SamplerSpec.of("policy", path=path, batch=batch)


def policy_sampler(batch: int) -> str:
    """The label of the policy deciding every ``batch`` samples (a tuning run)."""
    return f"policy batch={batch}"


def fixed_specs(protocol: Protocol, route: str, users: dict[str, str], references: bool = True,
                device: str = "auto") -> list[SamplerSpec]:
    """The test samplers that need no tuned setting, at ``protocol``'s step.

    Uniform, the goal-bias sweep, the follower, the route encoder (checkpoint ``route``, its passes on
    ``device``), the same encoder computed lazily (``route_lazy``) and its ablation, users' samplers (name -> spec)
    and, with ``references``, the expert and the exact route reference (``exact_route``: the route sampler's own
    settings on the exact cost-to-go).
    """
    from learning.evaluation.tuning import GOAL_BIASES

    step = protocol.step
    out = [SamplerSpec.of("uniform"), *(bias_spec(b) for b in GOAL_BIASES), SamplerSpec.of("follower", step_size=step),
           SamplerSpec.of("route", path=route, step_size=step, device=device),
           SamplerSpec.of("route_lazy", path=route, step_size=step, device=device),
           SamplerSpec.of("route_ablation", step_size=step), *(SamplerSpec.user(n, s) for n, s in users.items())]
    if references:
        out += [SamplerSpec.of("expert", step_size=step), SamplerSpec.of("exact_route", step_size=step)]
    return out


def evaluation_tasks(queries: Sequence[Query], planner: str, specs: Sequence[SamplerSpec], seeds: int,
                     label: str = "") -> list[Task]:
    """Every spec on every test query with planner seeds ``0 .. seeds-1``."""
    return [Task(q, planner, s, seed, label) for q in queries if q.split == "test" for s in specs
            for seed in range(seeds)]


def parse_user_sampler(arg: str) -> tuple[str, str]:
    """``NAME=SPEC`` from the command line, checked: the name and the spec (``user_sampler``).

    The name may be neither a registered sampler nor one of the comparison's labels.
    """
    return registry.parse_user_sampler(arg, taken=BUILTIN_SAMPLERS)
