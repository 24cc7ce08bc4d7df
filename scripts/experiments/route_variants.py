"""Route samplers whose encoder (or the exact cost-to-go) ranks the frontier, for ``evaluate.py --sampler``.

    python scripts/train_route.py --epochs 80
    python scripts/evaluate.py --other-planners --sampler "ranked=route_variants:ranked" \\
        --sampler "ranked-ablation=route_variants:ranked_ablation" --sampler "ranked-exact=route_variants:ranked_exact"

``RouteSampler(..., uses="frontier")`` keeps the follower's progress on the straight line and lets the
encoder's predicted cost-to-go choose among the frontier's cells when the tree is stuck; these
settings (stuck after 1 iteration, frontier temperature half a step) were chosen on validation maps.
``ranked_symmetric`` averages the encoder's prediction over the square's 8 symmetries; ``both_symmetric``
uses the field everywhere, as the shipped encoder is used (``SHIPPED_SETTINGS``), ``both``
does so with one pass, ``both_lazy25`` / ``50`` / ``100`` run the encoder only after that many
iterations on the straight line, ``both_stall<k>`` once the tree has come no closer to the goal for k
iterations, ``both_sym<k>`` averages over the first k symmetries (1-8), and ``exact_both`` is the
reference at those settings;
``grid_encoder_l<lookahead>_s<sigma>`` and ``grid_ablation_l<lookahead>_s<sigma>`` are the grid the
shipped lookahead and spread were chosen on;
``ranked_ablation`` is the same sampler with the encoder removed (straight-line ranking), and
``ranked_exact`` the privileged reference with the exact cost-to-go (a grid search);
``ranked_exact_tau1`` the same at the follower's temperature of one step.
Settings are chosen with ``scripts/experiments/validate_samplers.py`` (validation maps).
"""

from __future__ import annotations

import re

from learning.references.expert import GeodesicRouteSampler
from learning.samplers.route import ABLATION_SETTINGS, SHIPPED_SETTINGS, TRAINED, RouteSampler, shipped_sampler

#: ``RouteSampler``'s defaults when these variants were measured (before the validated ones became the defaults).
MEASURED = {"lookahead": 1.0, "stuck": 4, "tau": 1.0, "uses": "progress", "symmetries": 1}
SETTINGS = {**MEASURED, "stuck": 1, "tau": 0.5}


def _exact(**kwargs) -> GeodesicRouteSampler:
    """The geodesic reference at ``kwargs`` over ``MEASURED`` (its own ``uses``: the frontier, unless given)."""
    return GeodesicRouteSampler(**{**{k: v for k, v in MEASURED.items() if k != "uses"}, **kwargs})


def _trained():
    if not TRAINED.is_file():
        raise FileNotFoundError(f"no route encoder at {TRAINED}: train one first with python scripts/train_route.py")
    return TRAINED


def ranked() -> RouteSampler:
    """The trained encoder (``runs/route/route.pt``) ranking the follower's frontier."""
    return RouteSampler.load(_trained(), **{**SETTINGS, "uses": "frontier"})


def ranked_symmetric() -> RouteSampler:
    """``ranked`` with the encoder's prediction averaged over the square's 8 symmetries (8 passes per query)."""
    return RouteSampler.load(_trained(), **{**SETTINGS, "uses": "frontier", "symmetries": 8})


def both_symmetric() -> RouteSampler:
    """The trained encoder at the shipped settings (``SHIPPED_SETTINGS``): its field everywhere."""
    return shipped_sampler(_trained())


def both() -> RouteSampler:
    """``both_symmetric`` with one pass of the encoder per query instead of 8."""
    return RouteSampler.load(_trained(), **{**SHIPPED_SETTINGS, "symmetries": 1})


def _lazy(k: int) -> RouteSampler:
    return RouteSampler.load(_trained(), **SHIPPED_SETTINGS, lazy=k)


def both_lazy25() -> RouteSampler:
    """``both_symmetric`` that follows the straight line for 25 iterations before it runs the encoder."""
    return _lazy(25)


def both_lazy50() -> RouteSampler:
    """``both_symmetric`` that follows the straight line for 50 iterations before it runs the encoder."""
    return _lazy(50)


def both_lazy100() -> RouteSampler:
    """``both_symmetric`` that follows the straight line for 100 iterations before it runs the encoder."""
    return _lazy(100)


def exact_both() -> GeodesicRouteSampler:
    """The reference at the shipped settings: the exact cost-to-go everywhere the encoder's field goes."""
    return GeodesicRouteSampler(**{k: v for k, v in SHIPPED_SETTINGS.items() if k != "symmetries"})


def ranked_ablation() -> RouteSampler:
    """The same sampler without the encoder: the frontier ranked by the straight-line distance."""
    return RouteSampler(None, **SETTINGS)


def ranked_exact() -> GeodesicRouteSampler:
    """The reference: the frontier ranked by the exact cost-to-go (runs a grid search)."""
    return _exact(stuck=SETTINGS["stuck"], tau=SETTINGS["tau"])


def ranked_exact_tau1() -> GeodesicRouteSampler:
    """The reference at the follower's frontier temperature (one step): what first showed the room."""
    return _exact(stuck=SETTINGS["stuck"])


_GRID = re.compile(r"grid_(encoder|ablation)_l([0-9.]+)_s([0-9.]+)")
_STALL = re.compile(r"both_stall(\d+)")
_SYM = re.compile(r"both_sym(\d)")


def __getattr__(name: str):
    """``grid_encoder_l3_s0.5`` / ``grid_ablation_l2.5_s0.5``: the lookahead and spread grid the shipped
    settings were chosen on (``--sampler e=route_variants:grid_encoder_l3_s0.5``); the rest as shipped.
    ``both_stall6``, ``both_sym4``: the module docstring."""
    stall = _STALL.fullmatch(name)
    if stall is not None:
        return lambda: RouteSampler.load(_trained(), **SHIPPED_SETTINGS, stall=int(stall.group(1)))
    sym = _SYM.fullmatch(name)
    if sym is not None:
        return lambda: RouteSampler.load(_trained(), **{**SHIPPED_SETTINGS, "symmetries": int(sym.group(1))})
    match = _GRID.fullmatch(name)
    if match is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    kind, lookahead, sigma = match.group(1), float(match.group(2)), float(match.group(3))
    if kind == "encoder":
        return lambda: RouteSampler.load(_trained(), **{**SHIPPED_SETTINGS, "lookahead": lookahead, "sigma": sigma})
    return lambda: RouteSampler(None, **{**MEASURED, **ABLATION_SETTINGS, "lookahead": lookahead, "sigma": sigma})
