"""The comparison's figures (ECDF, medians) and OMPL benchmark logs for Planner Arena."""

from __future__ import annotations

import math
import textwrap
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from learning.evaluation.protocol import Protocol
from learning.evaluation.roster import bias_sampler, sampler_bias
from planners.base.fileio import safe_file_stem
from planners.tools.benchmark import (
    OMPL_PROGRESS_PROPERTIES,
    OMPL_RUN_PROPERTIES,
    Run,
    ompl_run_values,
    progress_points,
)
from planners.tools.benchmark_log import PlannerRuns, experiment_name, write_log


def wrap_text(text: str, width_in: float, fontsize: float) -> str:
    """``text`` wrapped to lines that fit ``width_in`` inches at ``fontsize`` points."""
    # a character of the default sans-serif font averages well under 0.6 em wide
    return textwrap.fill(text, max(12, int(width_in * 72 / (0.6 * fontsize))))


#: One colour per sampler role in every figure (tab10 and tab20 colours far apart; references in dark greys,
#: dashed). User samplers take the colours of :data:`EXTRA_COLORS` in the order given.
PALETTE = {
    "uniform": "#1f77b4", "goal bias 0.05": "#ff7f0e", "best goal bias": "#2ca02c", "policy": "#d62728",
    "constant (tuned)": "#ff9896", "straight-line follower": "#8c564b", "route encoder": "#9467bd",
    "route ablation": "#c5b0d5", "exact_route": "#17becf", "expert (reference)": "#000000",
}
EXTRA_COLORS = ("#e377c2", "#bcbd22", "#7f7f7f", "#aec7e8", "#98df8a", "#c49c94")
#: Legend names where a sampler's name in the runs is not the tables' word for it.
LEGEND = {"constant (tuned)": "policy ablation", "exact_route": "exact route reference", "expert (reference)": "expert"}
#: Samplers drawn dashed: the privileged references.
REFERENCES = ("exact_route", "expert (reference)")


def sampler_colors(extra: Sequence[str] = ()) -> dict[str, str]:
    """:data:`PALETTE` with a colour for every name in ``extra`` that has none (user samplers)."""
    colors = dict(PALETTE)
    free = iter(c for c in EXTRA_COLORS if c not in colors.values())
    for name in extra:
        if name not in colors:
            colors[name] = next(free, "#7f7f7f")
    return colors


def _roles(biases: dict, fam: str, planner: str, extra: Sequence[str]) -> list[tuple[str, str]]:
    """(role, sampler name) per curve of one map set: the role names the colour and the legend entry."""
    best = bias_sampler(biases.get((fam, planner), 0.05))
    roles = [("uniform", "uniform"), ("goal bias 0.05", "goal_bias=0.05")]
    if best not in ("uniform", "goal_bias=0.05"):
        roles.append(("best goal bias", best))
    roles += [("policy", "policy"), *((n, n) for n in extra if n not in REFERENCES)]
    return roles + [(n, n) for n in REFERENCES]


def save_plots(runs: Sequence[Run], rows: Sequence[dict], biases: dict, out_dir: Path,
               planner: str = "RRT", extra: Sequence[str] = ()) -> list[Path]:
    """Write the figures of the comparison; returns their paths.

    ``ecdf.png`` and ``ecdf-time.png`` (:func:`ecdf_figure` of iterations and of time), ``medians.png``
    (:func:`medians_figure`).
    """
    from planners.viz.plotting import save_figure

    if not any(r.split == "test" and r.planner == planner for r in runs):
        return []
    return [save_figure(ecdf_figure(runs, biases, planner, extra), out_dir / "ecdf.png", dpi=110),
            save_figure(ecdf_figure(runs, biases, planner, extra, metric="time"), out_dir / "ecdf-time.png", dpi=110),
            save_figure(medians_figure(runs, rows, biases, planner, extra), out_dir / "medians.png", dpi=110)]


def ecdf_figure(runs: Sequence[Run], biases: dict, planner: str = "RRT", extra: Sequence[str] = (),
                metric: str = "iterations"):
    """ECDF of iterations-to-solution per sampler (``metric="time"``: of wall time), one panel per family (test split).

    A run's time is its wall time from the planner's start to its first solution, the sampler's own per-query
    work included (``Run.wall_time``).

    Colours follow :data:`PALETTE` (the same in every figure); one legend for all panels sits below
    them, so no legend hides a curve. Titles are wrapped to the figure's width and the layout is
    constrained, so no text is cut off.
    """
    from planners.viz.plotting import new_figure

    test = [r for r in runs if r.split == "test" and r.planner == planner]
    fams = sorted({r.map for r in test})
    cols = min(4, len(fams))
    nrows = math.ceil(len(fams) / cols)
    size = (4.2 * cols, 3.4 * nrows + 1.4)
    fig = new_figure(size)
    within = "n iterations" if metric == "iterations" else "t ms, the sampler's own work included"
    fig.suptitle(wrap_text(f"{planner} on the test split: fraction of queries solved within {within} (unsolved "
                       "runs never reach 1); best goal bias tuned on a separate split", size[0], 11), fontsize=11)
    colors = sampler_colors(extra)
    handles: dict = {}
    for i, fam in enumerate(fams):
        ax = fig.add_subplot(nrows, cols, i + 1)
        for role, s in _roles(biases, fam, planner, extra):
            style = {"linestyle": "--"} if s in REFERENCES else {}
            line = ecdf_line(ax, [(r.iterations if metric == "iterations" else r.wall_time * 1e3) if r.solved else None
                                  for r in test if r.map == fam and r.sampler == s],
                             label=LEGEND.get(role, role), color=colors.get(role, "#7f7f7f"), **style)
            if line is not None:
                handles.setdefault(LEGEND.get(role, role), line)
        ax.set_xscale("log")
        ax.set_title(wrap_text(fam, 4.0, 12))
        ax.set_xlabel("iterations to solution" if metric == "iterations" else "time to solution (ms)")
        ax.set_ylabel("fraction solved")
        ax.grid(alpha=0.3)
    fig.legend(list(handles.values()), list(handles), loc="outside lower center", ncols=min(6, len(handles)),
               fontsize=8)
    return fig


def ecdf_line(ax, values: Sequence[float | None], *, start: float | None = None, end: float | None = None,
              **style):
    """Draw the ECDF of ``values`` on ``ax`` as a step line: the fraction of runs solved within each value.

    ``None`` (or ``inf``) is a run that never solved: it counts in the runs but is never reached, so the line ends
    below 1. ``start`` and ``end``: the line runs from 0 at ``start`` and on at its last fraction to ``end`` (the
    axis' ends: so a single run, or none solved, still shows), else from the first value to the last one solved.
    Returns the line, or None where there are no runs. ``style``: ``Axes.step``'s keywords (label, colour, style).
    """
    vals = np.sort([math.inf if v is None else float(v) for v in values])
    if len(vals) == 0:
        return None
    frac = np.arange(1, len(vals) + 1) / len(vals)
    if start is not None:
        vals, frac = np.concatenate([[start], vals]), np.concatenate([[0.0], frac])
    if end is not None:
        solved = np.isfinite(vals)
        last = frac[solved][-1] if solved.any() else 0.0
        vals, frac = np.concatenate([vals[solved], [end]]), np.concatenate([frac[solved], [last]])
    (line,) = ax.step(vals, frac, where="post", **style)
    return line


def medians_figure(runs: Sequence[Run], rows: Sequence[dict], biases: dict, planner: str = "RRT",  # noqa: ARG001
                   extra: Sequence[str] = ()):
    """Median iterations and median time per query with the quartiles, per sampler and group of map sets: a grid.

    One column per group (generated, shifted, unseen, MovingAI pooled, or a user's map set; every test
    run of the group pooled), iterations above and time below; one horizontal bar per sampler, named
    on the axis and coloured as in :func:`ecdf_figure`; the references hatched. Sized for a screen to
    show whole. ``rows`` is kept for callers that pass the summary; the bars come from ``runs``.
    """
    from learning.evaluation.tables import group_of
    from planners.viz.plotting import new_figure

    test = [r for r in runs if r.split == "test" and r.planner == planner]
    groups: dict = {}
    for r in test:
        groups.setdefault(group_of(r.map), []).append(r)
    order = {"generated": 0, "shifted": 1, "unseen": 2, "MovingAI": 4}
    names = sorted(groups, key=lambda g: (order.get(g, 3), g))
    colors = sampler_colors(extra)
    present = {r.sampler for r in test}
    sel = [("uniform", "uniform"), ("best goal bias", None), ("policy", "policy"),
           *((n, n) for n in extra if n not in REFERENCES), *((n, n) for n in REFERENCES if n in present)]
    cols = max(1, len(names))
    size = (2.2 + 2.6 * cols, 6.4)
    fig = new_figure(size)
    fig.suptitle(wrap_text(f"{planner} on the test split, every run of a group pooled: median iterations (top) and "
                       "median time per query, the sampler's own work included (bottom); bars from the first to the "
                       "third quartile, unsolved runs counting as what they ran", size[0], 10), fontsize=10)
    for j, group in enumerate(names):
        for i, metric in enumerate(("iterations", "time")):
            ax = fig.add_subplot(2, cols, i * cols + j + 1)
            labels, meds, errs, colours, hatches = [], [], [], [], []
            for label, s in sel:
                rs = [r for r in groups[group]
                      if r.sampler == (s or bias_sampler(biases.get((r.map, planner), 0.05)))]
                if not rs:
                    continue
                v = np.array([r.iterations if metric == "iterations" else r.wall_time * 1e3 for r in rs], float)
                q1, med, q3 = np.percentile(v, [25, 50, 75])
                labels.append(LEGEND.get(label, label))
                meds.append(med)
                errs.append((max(med - q1, 0.0), max(q3 - med, 0.0)))
                colours.append(colors.get(label, "#7f7f7f"))
                hatches.append("//" if s in REFERENCES else "")
            y = np.arange(len(labels))[::-1]
            # bars start at a power of ten below the lowest first quartile, never at 0 (off a log axis)
            low = min((m - e[0] for m, e in zip(meds, errs, strict=True) if m - e[0] > 0), default=1.0)
            base = 10.0 ** math.floor(math.log10(low))
            for k, label in enumerate(labels):  # one container per sampler, labelled with its name
                (bar,) = ax.barh([y[k]], [max(meds[k] - base, 0.0)], left=base, xerr=np.array([errs[k]]).T,
                                 color=colours[k], capsize=2, error_kw={"elinewidth": 0.8}, label=label)
                if hatches[k]:
                    bar.set_hatch(hatches[k])
                    bar.set_edgecolor("white")
            ax.set_xlim(left=base)
            ax.set_xscale("log")
            ax.set_yticks(y, labels if j == 0 else [""] * len(labels), fontsize=8)
            ax.tick_params(axis="x", labelsize=7)
            ax.set_title(f"{group}: {'iterations' if metric == 'iterations' else 'time (ms)'}", fontsize=9)
            ax.grid(axis="x", alpha=0.3)
    return fig


def write_ompl_logs(runs: Sequence[Run], biases: dict, out_dir: Path, protocol: Protocol,
                    stems: set[str] | None = None) -> list[Path]:
    """One OMPL benchmark log per family (map set) of the test split, under ``out_dir``, made under ``protocol``.

    ``stems``: the file stems taken already (by earlier calls into the same folder); this call's are added.

    Each planner and sampler pair is one OMPL planner configuration (e.g. ``RRT goal bias 0.05``), its
    settings holding the sampler's spec (name and parameters, as ``runs.csv`` records it);
    ``time`` is the run's wall time, including binding the sampler. Unsolved runs have no solution
    length. The logs open with ``ompl_benchmark_statistics.py out_dir/*.log -d db`` and Planner Arena.
    Tuning-split runs are left out: they choose the best bias, they are not the comparison.
    """
    test = [r for r in runs if r.split == "test"]
    names = [n for n, _ in OMPL_PROGRESS_PROPERTIES]
    fams: dict = {}
    for r in test:
        fams.setdefault(r.map, {}).setdefault((r.planner, r.sampler), []).append(r)
    paths, stems = [], set() if stems is None else stems
    for fam, configs in sorted(fams.items()):
        planners = {}
        for (planner, sampler), rs in sorted(configs.items()):
            b = sampler_bias(sampler)
            name = f"{planner} " + (sampler if b is None else "uniform" if b == 0 else f"goal bias {b:g}")
            settings = {"planner": planner, "sampler": sampler, "step_size": protocol.step,
                        "goal_tolerance": protocol.tolerance, "max_iterations": protocol.max_iterations}
            if b is not None:
                settings["best_goal_bias_on_tuning_split"] = "yes" if biases.get((fam, planner)) == b else "no"
            specs = sorted({r.sampler_spec for r in rs if r.sampler_spec})
            if specs:
                settings["sampler_spec"] = " ".join(specs)
            progress = [[dict(zip(names, point, strict=True)) for point in progress_points(r)] for r in rs]
            planners[name] = PlannerRuns(settings, [ompl_run_values(r) for r in rs],
                                         progress if any(progress) else [])
        queries = len({r.query for r in configs[next(iter(configs))]})
        cost = any(p.progress for p in planners.values())
        setup = (f"SamplerGym comparison on {fam}, test split ({queries} queries, all runs of every sampler on the "
                 "same queries and seeds). "
                 + ("Anytime planners run to their budget of iterations; 'iterations' is the first solution's, the "
                    "progress properties give the best cost each time it fell (time from the solve's start). "
                    if cost else f"Iterations to first solution, capped at {protocol.max_iterations}; ")
                 + "The best goal bias was chosen on a separate tuning split (for shifted maps, their family's). "
                 "'time' is wall time in seconds, including binding the sampler to the map. The expert is a "
                 "privileged reference.")
        stem = safe_file_stem(fam, taken=stems)  # bounded, and one file per map set: a name may be anything
        paths.append(write_log(
            out_dir / f"{stem}.log", experiment_name(fam), planners, [(p, t) for p, t, _ in OMPL_RUN_PROPERTIES],
            setup=setup, progress_properties=OMPL_PROGRESS_PROPERTIES if cost else (),
            total_time=sum(r.wall_time for rs in configs.values() for r in rs),
            experiment_properties={"step_size": ("REAL", protocol.step),
                                   "goal_tolerance": ("REAL", protocol.tolerance),
                                   "max_iterations": ("INTEGER", protocol.max_iterations)}))
    return paths
