"""The planner registry: every planner by its own ``name``, one way to build any of them.

``make_planner("RRTConnect", problem, seed=0)`` builds a planner by name; names are matched ignoring
case, ``-`` and ``_``, so ``"rrt-connect"`` and ``"RRTConnect"`` are the same planner. Each planner has
one canonical spelling, its ``name`` (``RRTstar``, ``InformedRRTstar``, ...), which results and tables
print; the class name (``RRTStar``) and the ``*`` forms (``"RRT*"``, ``"Informed-RRT*"``) are accepted as
aliases. The step is ``step_size`` everywhere: ``make_planner(..., step_size=)`` sets each planner's own
step argument (RRT's extension, PRM's longest edge), and ``step`` and ``max_edge_length`` are accepted
as aliases for it. The planner
classes register themselves with ``@register_planner`` where they are defined (``planners.algorithms``);
to add a planner, subclass ``Planner`` there, give it a ``name`` and a ``step_parameter``, decorate it,
and import it in ``planners/__init__.py``: the environments, ``scripts/plan.py``, the evaluation and
the benchmarks then accept its name.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from planners.base.planner import Planner
    from planners.base.problem import Problem

_PLANNERS: dict[str, type[Planner]] = {}


def _key(name: str) -> str:
    return name.lower().replace("-", "").replace("_", "").replace(" ", "").replace("*", "star")


def register_planner(cls: type[Planner]) -> type[Planner]:
    """Class decorator: make ``cls`` buildable by its ``name``; a name is registered once."""
    key = _key(cls.name)
    if key in _PLANNERS and _PLANNERS[key] is not cls:
        raise ValueError(f"planner name {cls.name!r} is already taken by {_PLANNERS[key].__name__}")
    if cls.step_parameter is None:
        raise ValueError(f"{cls.__name__} must say which argument sets its step length (step_parameter)")
    _PLANNERS[key] = cls
    return cls


def planner_names() -> tuple[str, ...]:
    """Every registered planner's name, sorted."""
    return tuple(sorted(cls.name for cls in _PLANNERS.values()))


def planner_class(name: str) -> type[Planner]:
    """The planner class registered under ``name`` (case, ``-`` and ``_`` ignored)."""
    cls = _PLANNERS.get(_key(name)) if isinstance(name, str) else None
    if cls is None and isinstance(name, str):  # the class's own name, where it differs from the registered one
        cls = next((c for c in _PLANNERS.values() if _key(c.__name__) == _key(name)), None)
    if cls is None:
        raise ValueError(f"unknown planner {name!r}; choose from {', '.join(planner_names())}")
    return cls


def planner_name_arg(text: str) -> str:
    """For argparse's ``type=``: the registered spelling of ``text``, or an error naming the valid names."""
    import argparse

    try:
        return planner_class(text).name
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


#: Other names of ``make_planner``'s ``step_size``.
STEP_ALIASES = ("step", "max_edge_length")


def one_step_size(who: str, **given: float | None) -> float | None:
    """The one step length among ``given`` (``step_size=`` and its aliases), None if none is set.

    Raises:
        ValueError: Two or more are set (naming them and ``who``), even to the same value.
    """
    named = {k: v for k, v in given.items() if v is not None}
    if len(named) > 1:
        given = [f"{k}={v!r}" for k, v in named.items()]
        names = f"both {given[0]} and {given[1]}" if len(given) == 2 else f"all of {', '.join(given)}"
        raise ValueError(f"{who}: give one step length, not {names} ({', '.join(STEP_ALIASES)} and step_size "
                         "are one argument; extension_step sets the RRT family's step only)")
    return next(iter(named.values()), None)


def make_planner(name: str, problem: Problem, *, step_size: float | None = None, extension_step: float | None = None,
                 **kwargs) -> Planner:
    """Build the planner registered under ``name`` for ``problem``.

    Args:
        name: A registered name (``planner_names()``) or an alias of one.
        problem: The planning problem.
        step_size: The planner's step length, whatever it means for it: RRT's extension per iteration,
            PRM's longest roadmap edge (passed as the class's ``step_parameter``); None: its default.
            ``step=`` and ``max_edge_length=`` are the same argument; giving two of them is an error.
        extension_step: An extension length for planners that extend toward samples (the RRT
            family); roadmap planners keep their default edge length. What a comparison of
            samplers across planners passes. Not together with ``step_size``.
        **kwargs: The class's own constructor arguments (``sampler``, ``seed``, ...).

    Raises:
        ValueError: An unknown name, or more than one of ``step_size``, ``step``, ``max_edge_length``
            and ``extension_step``.
    """
    cls = planner_class(name)
    aliases = {a: kwargs.pop(a) for a in STEP_ALIASES if a in kwargs}
    step = one_step_size(f"make_planner({cls.name!r})", step_size=step_size, extension_step=extension_step, **aliases)
    if step is not None and extension_step is None:
        kwargs[cls.step_parameter] = step
    elif extension_step is not None and cls.step_parameter == "step_size":
        kwargs["step_size"] = extension_step
    return cls(problem, **kwargs)
