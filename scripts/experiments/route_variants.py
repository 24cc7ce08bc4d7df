"""Route samplers whose encoder (or the exact cost-to-go) ranks the frontier, for ``evaluate.py --sampler``.

    python scripts/train_route.py --epochs 80
    python scripts/evaluate.py --other-planners none --sampler "ranked=route_variants:ranked" \\
        --sampler "ranked-ablation=route_variants:ranked_ablation" --sampler "ranked-exact=route_variants:ranked_exact"

``uses="frontier"`` (a knob of the private ``_VariantRouteSampler`` below, not of ``RouteSampler``) keeps
the follower's progress on the straight line and lets the encoder's predicted cost-to-go choose among
the frontier's cells when the tree is stuck; these settings (stuck after 1 iteration, frontier temperature half a
step) were chosen on validation maps.
``ranked_symmetric`` averages the encoder's prediction over the square's 8 symmetries; ``both_symmetric``
uses the field everywhere, as the shipped encoder is used (``SHIPPED_SETTINGS``), ``both``
does so with one pass, ``both_sym<k>`` averages over the first k symmetries (1-8), and ``exact_both``
is the reference at those settings;
``grid_encoder_l<lookahead>_s<sigma>`` and ``grid_ablation_l<lookahead>_s<sigma>`` are the grid the
shipped lookahead and spread were chosen on; ``walk_<ripple>_<growth>`` is the shipped encoder and settings
with another walk to the target (``walk_0_0``: strictly downhill; ``walk_0.1_0``: a fixed tolerance;
``walk_0.1_0.01_nosight``: the shipped walk, not cut where it leaves the progress cell's sight);
``no_wall_cost`` is the shipped sampler with value iteration free to price a wall as the network does;
``ranked_ablation`` is the same sampler with the encoder removed (straight-line ranking), and
``ranked_exact`` the privileged reference with the exact cost-to-go (a grid search);
``ranked_exact_tau1`` the same at the follower's temperature of one step.
Settings are chosen with ``scripts/experiments/validate_samplers.py`` (validation maps).
"""

from __future__ import annotations

import re
from pathlib import Path

from learning.models.route_net import load_route_net
from learning.references.expert import GeodesicRouteSampler
from learning.samplers.route import ABLATION_SETTINGS, SHIPPED, SHIPPED_SETTINGS, RouteSampler, shipped_sampler

#: Where ``scripts/train_route.py`` writes the encoder by default.
TRAINED = Path(__file__).resolve().parents[2] / "runs" / "route" / "route.pt"

#: ``RouteSampler``'s defaults when these variants were measured (before the validated ones became the defaults).
MEASURED = {"lookahead": 1.0, "stuck": 4, "tau": 1.0, "ripple": 0.0, "ripple_growth": 0.0, "sight": False,
            "uses": "progress", "symmetries": 1}
SETTINGS = {**MEASURED, "stuck": 1, "tau": 0.5}


class _VariantRouteSampler(RouteSampler):
    """``RouteSampler`` with the knobs that did not pay: where the field goes (``uses``) and fewer symmetries.

    ``uses``: "progress", "frontier" or "both" (the shipped "both"); ``symmetries``: 1 to 8 (shipped 8).
    """

    def __init__(self, net, *, uses: str = "both", symmetries: int = 8, **kwargs) -> None:
        if uses not in ("progress", "frontier", "both"):
            raise ValueError(f"uses must be progress, frontier or both, got {uses!r}")
        if isinstance(symmetries, bool) or not isinstance(symmetries, int) or not 1 <= symmetries <= 8:
            raise ValueError(f"symmetries must be an integer from 1 to 8, got {symmetries!r}")
        super().__init__(net, **kwargs)
        self._uses, self._symmetries = uses, symmetries

    @property
    def uses(self) -> str:
        return self._uses

    @property
    def symmetries(self) -> int:
        return self._symmetries

    def __repr__(self) -> str:
        return f"{super().__repr__()[:-1]}, uses={self._uses!r}, symmetries={self._symmetries})"


def _variant(**settings) -> _VariantRouteSampler:
    """The trained encoder (``TRAINED``) at ``settings``."""
    return _VariantRouteSampler(load_route_net(_trained()), **settings)


def _exact(**kwargs) -> GeodesicRouteSampler:
    """The geodesic reference at ``kwargs`` over ``MEASURED`` (ranking the frontier, unless ``uses`` is given)."""
    return GeodesicRouteSampler(**{**{k: v for k, v in MEASURED.items() if k not in ("uses", "symmetries")},
                                   "uses": "frontier", **kwargs})


def _trained():
    if not TRAINED.is_file():
        raise FileNotFoundError(f"no route encoder at {TRAINED}: train one first with python scripts/train_route.py")
    return TRAINED


def ranked() -> RouteSampler:
    """The trained encoder (``runs/route/route.pt``) ranking the follower's frontier."""
    return _variant(**{**SETTINGS, "uses": "frontier"})


def ranked_symmetric() -> RouteSampler:
    """``ranked`` with the encoder's prediction averaged over the square's 8 symmetries (8 passes per query)."""
    return _variant(**{**SETTINGS, "uses": "frontier", "symmetries": 8})


def both_symmetric() -> RouteSampler:
    """The trained encoder at the shipped settings (``SHIPPED_SETTINGS``): its field everywhere."""
    return shipped_sampler(_trained())


def both() -> RouteSampler:
    """``both_symmetric`` with one pass of the encoder per query instead of 8."""
    return _variant(**SHIPPED_SETTINGS, symmetries=1)


def exact_both() -> GeodesicRouteSampler:
    """The reference at the shipped settings: the exact cost-to-go everywhere the encoder's field goes."""
    return GeodesicRouteSampler(uses="both", **SHIPPED_SETTINGS)


def no_wall_cost() -> RouteSampler:
    """The shipped encoder and settings without the inference threshold on wall prices (``RouteVIN.wall_cost``)."""
    net = load_route_net(SHIPPED)
    net.wall_cost = None
    return RouteSampler(net, **SHIPPED_SETTINGS)


def no_step_walls() -> RouteSampler:
    """The shipped encoder and settings without the rule that a block move no cell can step is a wall."""
    net = load_route_net(SHIPPED)
    net.step_walls = False
    return RouteSampler(net, **SHIPPED_SETTINGS)


def ranked_ablation() -> RouteSampler:
    """The same sampler without the encoder: the frontier ranked by the straight-line distance."""
    return _VariantRouteSampler(None, **SETTINGS)


def ranked_exact() -> GeodesicRouteSampler:
    """The reference: the frontier ranked by the exact cost-to-go (runs a grid search)."""
    return _exact(stuck=SETTINGS["stuck"], tau=SETTINGS["tau"])


def ranked_exact_tau1() -> GeodesicRouteSampler:
    """The reference at the follower's frontier temperature (one step): what first showed the room."""
    return _exact(stuck=SETTINGS["stuck"])


_GRID = re.compile(r"grid_(encoder|ablation)_l([0-9.]+)_s([0-9.]+)")
_WALK = re.compile(r"walk_([0-9.]+)_([0-9.]+)(_nosight)?")
_SYM = re.compile(r"both_sym(\d)")


def __getattr__(name: str):
    """``grid_encoder_l3_s0.5`` / ``grid_ablation_l2.5_s0.5``: the lookahead and spread grid the shipped
    settings were chosen on (``--sampler e=route_variants:grid_encoder_l3_s0.5``); the rest as shipped.
    ``both_sym4``, ``walk_0.1_0``, ``walk_0.1_0.01_nosight``: the module docstring."""
    walk = _WALK.fullmatch(name)
    if walk is not None:
        ripple, growth = float(walk.group(1)), float(walk.group(2))
        sight = walk.group(3) is None
        return lambda: RouteSampler(load_route_net(SHIPPED), **{**SHIPPED_SETTINGS, "ripple": ripple,
                                                                "ripple_growth": growth, "sight": sight})
    sym = _SYM.fullmatch(name)
    if sym is not None:
        return lambda: _variant(**SHIPPED_SETTINGS, symmetries=int(sym.group(1)))
    match = _GRID.fullmatch(name)
    if match is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    kind, lookahead, sigma = match.group(1), float(match.group(2)), float(match.group(3))
    if kind == "encoder":
        return lambda: _variant(**{**SHIPPED_SETTINGS, "lookahead": lookahead, "sigma": sigma})
    return lambda: _VariantRouteSampler(None, **{**MEASURED, **ABLATION_SETTINGS, "lookahead": lookahead,
                                                 "sigma": sigma})
