"""OMPL benchmark logs: results that OMPL's tools and Planner Arena open.

The format is the one ``ompl::tools::Benchmark`` writes and OMPL's ``ompl_benchmark_statistics``
turns into the SQLite database that Planner Arena shows; its grammar is in OMPL's documentation
("The benchmark logfile format"). One log holds one experiment (one problem or map set); each
planner configuration is one "planner" entry with a row of properties per run. With
``pip install ompl plannerarena`` (in a venv of their own)::

    ompl_benchmark_statistics results/evaluation/ompl/*.log -d evaluation.db
    DATABASE=evaluation.db plannerarena

Standard library only, so ``planners/`` keeps its numpy-only footprint.
"""

from __future__ import annotations

import importlib.metadata
import math
import os
import platform
import re
import socket
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

from planners.base.fileio import InputError, atomic_write_text

#: Property types the reader turns into SQLite column types.
PROPERTY_TYPES = ("BOOLEAN", "INTEGER", "REAL")

# Property and experiment-property names become SQLite column names in the reader (spaces turned into
# underscores), so only identifier characters and single inner spaces are allowed.
_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*( [A-Za-z0-9_]+)*")


@dataclass
class PlannerRuns:
    """One planner configuration of an experiment and its runs.

    Attributes:
        settings: The configuration's parameters, shown as the planner's settings.
        runs: One mapping per run from property name to value; a missing or ``None`` value, or a
            non-finite float, is written as empty and read as NULL.
        progress: Per run, its progress points (a mapping from progress property to value each, times
            increasing), as an anytime planner reports them; empty: no progress data. Either empty or one
            list per run.
    """

    settings: Mapping[str, object] = field(default_factory=dict)
    runs: list[Mapping[str, object]] = field(default_factory=list)
    progress: list[Sequence[Mapping[str, object]]] = field(default_factory=list)


def _check_line(what: str, text: str) -> str:
    text = str(text)
    if not text or "\n" in text or "\r" in text:
        raise InputError(f"OMPL log {what} {text!r}: expected a non-empty single line")
    return text


def _check_name(what: str, name: str) -> str:
    if not _NAME.fullmatch(name):
        raise InputError(f"OMPL log {what} {name!r}: expected letters, digits, underscores and single inner "
                         f"spaces, starting with a letter (it becomes a database column)")
    return name


def _format_value(kind: str, value: object, where: str) -> str:
    if value is None:
        return ""
    if kind == "BOOLEAN":
        if isinstance(value, str) or value not in (0, 1):  # numpy booleans compare equal to 0 / 1 too
            raise InputError(f"OMPL log {where}: {value!r} is not a boolean")
        return str(int(value))
    if kind == "INTEGER":
        if isinstance(value, float) and not math.isfinite(value):
            return ""
        if isinstance(value, float) and not value.is_integer():
            raise InputError(f"OMPL log {where}: {value!r} is not an integer")
        try:
            return str(int(value))  # type: ignore[call-overload]
        except (TypeError, ValueError):
            raise InputError(f"OMPL log {where}: {value!r} is not an integer") from None
    try:
        x = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise InputError(f"OMPL log {where}: {value!r} is not a number") from None
    return repr(x) if math.isfinite(x) else ""


def _multiline(text: str) -> list[str]:
    lines = str(text).splitlines() or [""]
    for ln in lines:
        if ln.startswith("|>>>"):
            raise InputError(f"OMPL log text line {ln!r} would end its block early (starts with '|>>>')")
    return ["<<<|", *lines, "|>>>"]


def experiment_name(name: str) -> str:
    """``name`` as an OMPL experiment name: the reader keeps only its last word, so spaces become ``_``."""
    return re.sub(r"\s+", "_", str(name).strip())


def format_log(experiment: str, planners: Mapping[str, PlannerRuns], properties: Sequence[tuple[str, str]], *,
               setup: str, total_time: float, seed: int = 0, time_limit: float = 0.0, memory_limit: float = 0.0,
               progress_properties: Sequence[tuple[str, str]] = (),
               experiment_properties: Mapping[str, tuple[str, object]] | None = None,
               library: str = "SamplerGym", version: str | None = None, hostname: str | None = None,
               date: datetime | None = None) -> str:
    """The text of one OMPL benchmark log.

    Args:
        experiment: Experiment (problem) name; must not contain whitespace (see :func:`experiment_name`).
        planners: Planner configurations by name, in the order they are written.
        properties: ``(name, type)`` of each per-run property, ``type`` one of :data:`PROPERTY_TYPES`,
            e.g. ``("time", "REAL")``, ``("solved", "BOOLEAN")``, ``("graph states", "INTEGER")``.
        setup: Free text describing the set-up (stored as the experiment's setup).
        progress_properties: ``(name, type)`` of each progress property, ``("time", "REAL")`` first as OMPL's
            ``Benchmark`` writes it; a planner whose ``progress`` is not empty gets a progress block.
        total_time: Seconds spent collecting the data.
        seed: The experiment's seed.
        time_limit: Seconds per run (0 when runs are capped by iterations instead).
        memory_limit: MB per run (0: none).
        experiment_properties: ``name -> (type, value)``, extra columns of the experiment.
        library: Library name written in the version line.
        version: Library version (default: the installed samplergym's).
        hostname: Machine name (default: this machine's).
        date: Start time (default: now, UTC).

    Raises:
        InputError: A name, type or value the reader would misread.
    """
    experiment = _check_line("experiment name", experiment)
    if re.search(r"\s", experiment):
        raise InputError(f"OMPL log experiment name {experiment!r}: expected no whitespace (the reader keeps "
                         f"only the last word); use experiment_name()")
    props = [(_check_name("property name", n), t) for n, t in properties]
    progress_props = [(_check_name("progress property name", n), t) for n, t in progress_properties]
    if progress_props and progress_props[0] != ("time", "REAL"):
        raise InputError(f"OMPL log progress properties {progress_props}: expected ('time', 'REAL') first (the "
                         "reader keys progress by run and time)")
    for n, t in props + progress_props:
        if t not in PROPERTY_TYPES:
            raise InputError(f"OMPL log property {n!r} has type {t!r}: expected one of {PROPERTY_TYPES}")
    if len({n.replace(" ", "_") for n, _ in props}) != len(props):
        raise InputError(f"OMPL log properties {[n for n, _ in props]}: expected distinct names")
    if not planners:
        raise InputError(f"OMPL log {experiment!r}: expected at least one planner")
    if version is None:
        try:
            version = importlib.metadata.version("samplergym")
        except importlib.metadata.PackageNotFoundError:
            version = "unknown"
    host = re.sub(r"\s+", "_", hostname or socket.gethostname() or "unknown")
    when = (date or datetime.now(timezone.utc)).strftime("%Y-%m-%d %H:%M:%S %Z").strip()
    lines = [f"{_check_line('library name', library).replace(' ', '_')} version {_check_line('version', version)}",
             f"Experiment {experiment}"]
    eprops = dict(experiment_properties or {})
    if eprops:
        lines.append(f"{len(eprops)} experiment properties")
        for n, (t, v) in eprops.items():
            if t not in PROPERTY_TYPES or not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", n):
                raise InputError(f"OMPL log experiment property {n!r} {t!r}: expected an identifier and a type "
                                 f"in {PROPERTY_TYPES}")
            value = _format_value(t, v, f"experiment property {n!r}")
            if not value:
                raise InputError(f"OMPL log experiment property {n!r}: {v!r} is not a finite value")
            lines.append(f"{n} {t} = {value}")
    counts = {len(p.runs) for p in planners.values()}
    lines += [f"Running on {host}", f"Starting at {when}", *_multiline(setup),
              *_multiline(f"{platform.processor() or platform.machine()}, Python {platform.python_version()}"),
              f"{int(seed)} is the random seed", f"{float(time_limit)!r} seconds per run",
              f"{float(memory_limit)!r} MB per run"]
    if len(counts) == 1:
        lines.append(f"{counts.pop()} runs per planner")
    lines += [f"{float(total_time)!r} seconds spent to collect the data", f"{len(planners)} planners"]
    for name, p in planners.items():
        _check_line("planner name", name)
        lines.append(name)
        settings = {str(k): _check_line(f"setting {k!r}", str(v)) for k, v in p.settings.items()}
        lines.append(f"{len(settings)} common properties")
        lines += [f"{k} = {v}" for k, v in settings.items()]
        lines.append(f"{len(props)} properties for each run")
        lines += [f"{n} {t}" for n, t in props]
        lines.append(f"{len(p.runs)} runs")
        known = {n for n, _ in props}
        for i, run in enumerate(p.runs):
            extra = set(run) - known
            if extra:
                raise InputError(f"OMPL log planner {name!r} run {i}: properties {sorted(extra)} were not declared")
            lines.append("".join(f"{_format_value(t, run.get(n), f'{name!r} run {i} {n!r}')}; " for n, t in props))
        if p.progress:
            lines += _progress_lines(name, p, progress_props)
        lines.append(".")
    return "\n".join(lines) + "\n"


def _progress_lines(name: str, p: PlannerRuns, props: Sequence[tuple[str, str]]) -> list[str]:
    """A planner's progress block: its properties, then one line per run of ``v,v,v,;`` per point."""
    if not props:
        raise InputError(f"OMPL log planner {name!r} has progress data but no progress properties were declared")
    if len(p.progress) != len(p.runs):
        raise InputError(f"OMPL log planner {name!r}: progress for {len(p.progress)} runs, expected one per run "
                         f"({len(p.runs)})")
    lines = [f"{len(props)} progress properties for each run", *(f"{n} {t}" for n, t in props), f"{len(p.runs)} runs"]
    known = {n for n, _ in props}
    for i, points in enumerate(p.progress):
        last, cells = -math.inf, []
        for j, point in enumerate(points):
            extra = set(point) - known
            if extra:
                raise InputError(f"OMPL log planner {name!r} run {i} progress point {j}: properties {sorted(extra)} "
                                 "were not declared")
            t = point.get("time")
            if not isinstance(t, int | float) or not math.isfinite(t) or t <= last:
                raise InputError(f"OMPL log planner {name!r} run {i} progress point {j}: time {t!r}, expected a "
                                 "finite number above the point before's (the reader keys progress by time)")
            last = t
            cells.append("".join(f"{_format_value(k, point.get(n), f'{name!r} run {i} progress {n!r}')},"
                                 for n, k in props) + ";")
        lines.append("".join(cells))
    return lines


def write_log(path: str | os.PathLike, experiment: str, planners: Mapping[str, PlannerRuns],
              properties: Sequence[tuple[str, str]], **kwargs) -> Path:
    """Write :func:`format_log`'s text to ``path`` atomically; returns the path."""
    text = format_log(experiment, planners, properties, **kwargs)
    atomic_write_text(path, text)
    return Path(path)
