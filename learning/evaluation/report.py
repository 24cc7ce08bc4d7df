"""The comparison's outputs: a short ``summary.md`` read at a glance, ``details.md`` with every table, the set on disk.

``summary.md`` opens with one short table (:func:`glance_short`: per sampler, the median iterations of each
group of map sets, the median time per query and the success rate, every test run of RRT pooled) and one
sentence per finding (:func:`findings`), each made from the measured numbers; ``details.md`` holds the wide
tables (per map set, ratios, the room, the targets, every cell, the other planners).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from learning.evaluation import tables as T
from learning.evaluation.mapsets import GENERATED_POOL
from learning.evaluation.outputs import save_plots, write_ompl_logs
from learning.evaluation.roster import (
    CONSTANT,
    EXACT_ROUTE,
    EXPERT,
    FOLLOWER,
    LAZY_ROUTE,
    OBSTACLE_BASED,
    ROUTE,
    ROUTE_ABLATION,
    bias_sampler,
)
from learning.evaluation.tables import group_of
from learning.evaluation.tuning import BATCH_TIE, POLICY_TUNING_SEEDS
from planners.base.fileio import atomic_write_text, output_set
from planners.maps.unseen import UNSEEN_SEED0
from planners.tools.benchmark import Run, markdown_table, write_runs_csv

#: The output set's files besides the figures and ``ompl/``.
SUMMARY, DETAILS = "summary.md", "details.md"
#: The privileged references: shown, never counted among the competitors in a finding.
PRIVILEGED = (EXPERT, EXACT_ROUTE)
#: What the glance table calls the best goal bias (each set's own, tuned on its tuning split).
BEST_BIAS = "best goal bias"


def _roster(results) -> list[tuple[str, str | None]]:
    """(label, sampler name in the runs) of the short table's rows; None: each set's tuned goal bias."""
    users = list(results.comparison.samplers)
    routes = [n for n in results.comparison.routes]
    return [("uniform", "uniform"), (BEST_BIAS, None), ("policy", "policy"), ("policy ablation", CONSTANT),
            (ROUTE, ROUTE), *((n, n) for n in routes), (LAZY_ROUTE, LAZY_ROUTE), (ROUTE_ABLATION, ROUTE_ABLATION),
            ("exact route reference", EXACT_ROUTE), ("expert", EXPERT), *((n, n) for n in users)]


def _test_runs(results, planner: str = "RRT") -> dict[tuple[str, str], list[Run]]:
    """Test runs of ``planner`` by (group, short-table label); the best goal bias per set as one label."""
    by_name = {name: label for label, name in _roster(results) if name is not None}
    out: dict = {}
    for r in results.runs:
        if r.split != "test" or r.planner != planner:
            continue
        group = group_of(r.map, results.movingai)
        b = results.best.get((r.map, planner))
        labels = [by_name[r.sampler]] if r.sampler in by_name else []
        if b is not None and r.sampler == bias_sampler(b):
            labels.append(BEST_BIAS)
        for label in labels:
            out.setdefault((group, label), []).append(r)
    return out


def _groups(keys) -> list[str]:
    order = {"generated": 0, "shifted": 1, "unseen": 2, "MovingAI": 4}
    return sorted({g for g, _ in keys}, key=lambda g: (order.get(g, 3), g))


def _ms(ms: float) -> str:
    return f"{ms:.2g} ms" if ms < 10 else f"{ms:.0f} ms"


def glance_short(results) -> list[dict]:
    """One row per sampler (RRT, test split): median iterations per group of sets, median time per query, success.

    The groups: generated (the five families), shifted, unseen, MovingAI (every map's runs pooled), or
    a user's map set by its name. The time and the success pool every test run of the sampler; an
    unsolved run counts with the iterations and time it ran. A dash where a sampler did not run.
    """
    runs = _test_runs(results)
    groups = _groups(runs)
    rows = []
    for label, _ in _roster(results):
        mine = [r for g in groups for r in runs.get((g, label), [])]
        if not mine:
            continue
        row = {"sampler": label}
        for g in groups:
            rs = runs.get((g, label), [])
            row[f"{g}{' †' if g == 'MovingAI' else ''}"] = (f"{np.median([r.iterations for r in rs]):.0f}"
                                                           if rs else "-")
        row["time per query"] = _ms(float(np.median([r.wall_time for r in mine])) * 1e3)
        row["success"] = f"{np.mean([r.solved for r in mine]):.0%}"
        rows.append(row)
    return rows


def _median(runs: Sequence[Run], what: str = "iterations") -> float:
    if not runs:
        return math.nan
    return float(np.median([r.iterations if what == "iterations" else r.wall_time * 1e3 for r in runs]))


def findings(results) -> list[str]:
    """One sentence per finding, each made from the measured numbers (never written in advance)."""
    runs = _test_runs(results)
    groups = _groups(runs)
    labels = [label for label, _ in _roster(results)]
    out = []
    competing = [s for s in labels if s not in ("exact route reference", "expert")]
    # fewest iterations per group, against the tuned goal bias
    fewest = []
    for g in groups:
        meds = {s: _median(runs.get((g, s), [])) for s in competing}
        meds = {s: v for s, v in meds.items() if not math.isnan(v)}
        if not meds:
            continue
        best = min(meds, key=meds.__getitem__)
        gb = meds.get(BEST_BIAS, math.nan)
        fewest.append(f"{g}: {best} ({meds[best]:.0f}"
                      + ("" if math.isnan(gb) or best == BEST_BIAS else f", {meds[best] / max(gb, 1e-9):.2f} of the "
                         f"tuned goal bias's {gb:.0f}") + ")")
    if fewest:
        out.append("Fewest median iterations among the samplers that compete (the references aside): "
                   + "; ".join(fewest) + ".")
    # learning against its own ablation
    for learned, ablation in ((ROUTE, ROUTE_ABLATION), ("policy", "policy ablation")):
        ratios = [(g, _median(runs.get((g, learned), [])) / max(_median(runs.get((g, ablation), [])), 1e-9))
                  for g in groups]
        ratios = [(g, v) for g, v in ratios if not math.isnan(v)]
        if ratios:
            worse = [g for g, v in ratios if v > 1]
            out.append(f"The {learned} needs " + ", ".join(f"{v:.2f} ({g})" for g, v in ratios)
                       + " of its ablation's median iterations: "
                       + ("learning pays on every group." if not worse else
                          f"learning does not pay on {', '.join(worse)}."))
    # the clock
    times = {s: _median([r for g in groups for r in runs.get((g, s), [])], "time") for s in competing}
    times = {s: v for s, v in times.items() if not math.isnan(v)}
    if times:
        fastest = min(times, key=times.__getitem__)
        route = times.get(ROUTE)
        out.append(f"On the clock the fastest is {fastest} ({_ms(times[fastest])} median per query, the sampler's "
                   "own work included)" + ("" if route is None or fastest == ROUTE else
                                           f"; the {ROUTE} takes {_ms(route)}, its pass over the map included")
                   + f" (all on {results.processes} process(es) of one machine).")
    # success
    success = {s: float(np.mean([r.solved for g in groups for r in runs.get((g, s), [])])) for s in competing
               if any(runs.get((g, s)) for g in groups)}
    short = sorted((v, s) for s, v in success.items() if v < 1)
    if success:
        out.append("Every competing sampler solves every query." if not short else
                   "Success below 100%: " + ", ".join(f"{s} {v:.1%}" for v, s in short) + ".")
    out += _user_routes(results, runs, groups)
    out += _other_planner_findings(results)
    for name, (_, report) in results.parts.items():
        out += [f"{name}: {line}" for line in report.findings]
    return out


def _user_routes(results, runs, groups) -> list[str]:
    """Per user's route encoder: whether it loses to the shipped one, said plainly, group by group."""
    out = []
    for name in results.comparison.routes:
        pairs = [(g, _median(runs.get((g, name), [])), _median(runs.get((g, ROUTE), []))) for g in groups]
        pairs = [(g, a, b) for g, a, b in pairs if not (math.isnan(a) or math.isnan(b))]
        if not pairs:
            continue
        loses = [f"{g} ({a:.0f} against {b:.0f})" for g, a, b in pairs if a > b]
        wins = [f"{g} ({a:.0f} against {b:.0f})" for g, a, b in pairs if a < b]
        mine = [r for g in groups for r in runs.get((g, name), [])]
        theirs = [r for g in groups for r in runs.get((g, ROUTE), [])]
        s_mine, s_theirs = np.mean([r.solved for r in mine]), np.mean([r.solved for r in theirs])
        verdict = ("loses to the shipped route encoder" if loses and not wins else
                   "beats the shipped route encoder" if wins and not loses else
                   "neither beats nor loses to the shipped route encoder everywhere")
        out.append(f"Your encoder {name} {verdict} in median iterations"
                   + (f": it loses on {', '.join(loses)}" if loses else "")
                   + (f"{';' if loses else ':'} it wins on {', '.join(wins)}" if wins else "")
                   + f"; success {s_mine:.1%} against {s_theirs:.1%}."
                   + (" Use the shipped one." if loses and not wins and s_mine <= s_theirs else ""))
    return out


def other_planner_rows(results, by_group: bool = True) -> list[dict]:
    """Every other planner (not RRT) with each sampler on the test split, by group of sets (or pooled).

    Iterations are samples for the roadmaps; checks count every validity check, the sampler's own included.
    """
    planners = list(dict.fromkeys(r.planner for r in results.runs if r.planner != "RRT" and r.split == "test"))
    rows = []
    for planner in planners:
        runs = _test_runs_any(results, planner)
        groups = _groups(runs) if by_group else ["all test sets"]
        for label in dict.fromkeys(s for _, s in runs):
            for g in groups:
                rs = (runs.get((g, label), []) if by_group
                      else [r for (_, s), v in runs.items() if s == label for r in v])
                if not rs:
                    continue
                rows.append({"planner": planner, "sampler": label, "sets": g, "runs": len(rs),
                             "median iterations (samples)": f"{_median(rs):.0f}",
                             "median checks": f"{np.median([r.collision_checks for r in rs]):.0f}",
                             "success": f"{np.mean([r.solved for r in rs]):.0%}",
                             "median time": _ms(_median(rs, "time"))})
    return rows


def which_planner(results) -> list[dict]:
    """Per group of sets, over every planner that ran: the fewest median iterations, and the fastest to a path.

    The fastest by median time per query, the sampler's own work included. Each planner's test runs by group
    and sampler (its set's tuned goal bias as "best goal bias", the privileged references left out).
    Iterations do not compare across planner kinds (a roadmap's are samples); each cell gives the other
    measure and the success rate beside. Empty unless a planner besides RRT ran.
    """
    planners = list(dict.fromkeys(r.planner for r in results.runs if r.split == "test"))
    if len(planners) < 2:
        return []
    cells: dict = {}
    for planner in planners:
        for (g, label), rs in _test_runs_any(results, planner).items():
            if label not in PRIVILEGED:
                cells.setdefault(g, {})[(planner, label)] = rs
    rows = []
    for g in _groups({(g, None) for g in cells}):
        mine = cells[g]
        its = {k: _median(rs) for k, rs in mine.items()}
        ms = {k: _median(rs, "time") for k, rs in mine.items()}
        fewest = min(mine, key=lambda k: (its[k], ms[k]))
        fastest = min(mine, key=lambda k: (ms[k], its[k]))

        def solved(k, mine=mine):
            share = float(np.mean([r.solved for r in mine[k]]))
            return "all solved" if share == 1.0 else f"{share:.0%} solved"

        rows.append({"group": g + (" †" if g == "MovingAI" else ""),
                     "fewest iterations (roadmaps: samples)": f"{fewest[0]} + {fewest[1]}: {its[fewest]:.0f} "
                                                              f"({_ms(ms[fewest])}), {solved(fewest)}",
                     "fastest to a path": f"{fastest[0]} + {fastest[1]}: {_ms(ms[fastest])} ({its[fastest]:.0f}), "
                                          f"{solved(fastest)}"})
    return rows


def _test_runs_any(results, planner: str) -> dict[tuple[str, str], list[Run]]:
    """Test runs of ``planner`` by (group, label): each set's tuned goal bias as "best goal bias", others by name."""
    out: dict = {}
    for r in results.runs:
        if r.split != "test" or r.planner != planner:
            continue
        b = results.best.get((r.map, planner))
        label = BEST_BIAS if b is not None and b != 0 and r.sampler == bias_sampler(b) else r.sampler
        if label.startswith("goal_bias="):
            continue  # a bias the set did not choose
        out.setdefault((group_of(r.map, results.movingai), label), []).append(r)
    return out


def _other_planner_findings(results) -> list[str]:
    """Per other planner: its classical option against the route encoder, pooled over the test sets."""
    out = []
    for planner in dict.fromkeys(r.planner for r in results.runs if r.planner != "RRT" and r.split == "test"):
        runs = _test_runs_any(results, planner)
        pooled_ = {}
        for (_, s), rs in runs.items():
            pooled_.setdefault(s, []).extend(rs)
        meds = {s: _median(rs) for s, rs in pooled_.items() if s not in PRIVILEGED}
        if not meds:
            continue
        best = min(meds, key=meds.__getitem__)
        classical = BEST_BIAS if BEST_BIAS in meds else OBSTACLE_BASED if OBSTACLE_BASED in meds else "uniform"
        line = f"With {planner}, the fewest median iterations over every test set: {best} ({meds[best]:.0f})"
        if ROUTE in meds and classical in meds and best != ROUTE:
            line += (f"; the {ROUTE} needs {meds[ROUTE]:.0f}, {meds[ROUTE] / max(meds[classical], 1e-9):.2f} times "
                     f"{classical}'s {meds[classical]:.0f}")
        out.append(line + ".")
    return out


def _where(results) -> str:
    c = results.comparison
    if c.map_set is not None:
        return (f"map set {c.map_set.name}: tuned on its tuning part, tested on its test part "
                f"({c.map_set.split.describe()})")
    size = c.protocol.size
    return (f"generated maps {size}x{size} on test seeds, and shifted variants (other generators, sides 64 to 256) "
            "tested with the settings tuned on their family's tuning split"
            + (", and unseen families (generators used only for testing) tested with the settings tuned on the "
               "generated families' tuning maps pooled" if results.unseen else "")
            + "; best goal bias chosen on a tuning split")


def _parts_only(results) -> bool:
    """Whether no 2D map set ran: the comparison is its parts alone (e.g. only 6-DoF scene sets)."""
    return not results.runs and bool(results.parts)


def summary_markdown(results) -> str:
    """``summary.md``: the short table, one sentence per finding, and where the rest is."""
    c = results.comparison
    if _parts_only(results):
        return (f"# Sampler comparison\n\n{len(results.all_runs)} runs in {results.minutes:.1f} min; no 2D map set "
                f"ran: the comparison is its parts ({', '.join(results.parts)}).\n\n## Findings\n\n"
                + "".join(f"- {line}\n" for line in findings(results))
                + f"\nEvery table: [{DETAILS}]({DETAILS}); every run: runs.csv.\n")
    glance = glance_short(results)
    users = "".join(f"`{n}`: `{spec}`; " for n, spec in c.samplers.items())
    routes = "".join(f"`{n}`: `{path}`; " for n, path in c.routes.items())
    groups = [k for k in (glance[0] if glance else {}) if k not in ("sampler", "time per query", "success")]
    return (f"# Sampler comparison\n\n{len(results.all_runs)} runs in {results.minutes:.1f} min; {_where(results)}. "
            f"Policy {c.policy}; route encoder {c.route}.\n\n"
            + (f"User samplers: {users.rstrip('; ')} (the policy's mode, draws for guided actions, unless the spec "
               "says @stochastic or @deterministic).\n\n"
               if users else "")
            + (f"Your route encoders, beside the shipped one: {routes.rstrip('; ')}.\n\n" if routes else "")
            + ("## At a glance\n\nNo 2D map set ran: the comparison is its parts (details.md has their "
               "sections).\n" if not glance else
               "## At a glance\n\nRRT on the test split, every run of a group pooled: median iterations to the first "
            f"solution in the {', '.join(groups)} columns (cap {c.protocol.max_iterations}, an unsolved run counting "
            "as the iterations it ran), then the median time per query (the sampler's own work included) and the "
            "success rate over every test run. Best goal bias: each set's own, tuned on its tuning split. The expert "
            "and the exact route reference are privileged references, not competitors.\n\n"
            + markdown_table(glance))
            + ("\n† Needs the MovingAI maps.\n" if any(g.startswith("MovingAI") for g in groups) else "")
            + _which_planner_section(results)
            + "\n## Findings\n\n" + "".join(f"- {line}\n" for line in findings(results))
            + f"\nEvery table (per map set, ratios, the room, the targets, every cell, the other planners): "
            f"[{DETAILS}]({DETAILS}). Figures: medians.png, ecdf.png, ecdf-time.png.\n")


def _which_planner_section(results) -> str:
    rows = which_planner(results)
    if not rows:
        return ""
    return ("\n## Which planner and sampler\n\nPer group, among every planner compared (the privileged references "
            "left out): the fewest median iterations over its test runs (a roadmap's are samples, so they do not "
            "compare with a tree's: the time beside does), and the lowest median time to a path, the sampler's own "
            "work included.\n\n" + markdown_table(rows))


def _left_out_note(results) -> str:
    """What the run times leave out: each model's load (once per process) and numba's compiling, measured."""
    loads = "; ".join(f"{what}: {seconds * 1e3:.0f} ms"
                      for what, seconds in sorted(results.comparison.models.load_seconds.items()))
    compiling = [r.compile_time for r in results.runs + results.pool if r.compile_time > 0]
    compiled, count = sum(compiling), len(compiling)
    return ("Loading a model is paid once per process, not per query, and is left out"
            + (f" ({loads})" if loads else "")
            + "; so is numba's compiling, a kernel's first call in a process (as time limits leave it out)"
            + (f": {compiled:.1f} s over {count} runs" if count else ": none in these runs"))


def _clock_note(results) -> str:
    return ("RRT on the test split: median wall time per query in ms, from the planner's start to its first "
            "solution, the sampler's own work for the query included (the route encoder's pass, the exact "
            "reference's and the expert's grid search, the policy's set-up); the fastest sampler of each set in "
            "bold, the privileged expert aside. An unsolved run counts with the time it ran. "
            + _left_out_note(results)
            + f". All runs share one machine, {results.processes} process(es) of one thread each.")


def wide_tables(results) -> dict:
    """The wide tables of ``details.md`` (and what the command line prints), computed once."""
    c, rows, best, mai = results.comparison, results.rows, results.best, results.movingai
    users = [*c.routes, *c.samplers]
    learned = [ROUTE, LAZY_ROUTE, ROUTE_ABLATION]
    runs = results.runs + results.pool
    head = T.headline(rows, best, [FOLLOWER, *learned, *users], results.constants)
    hcols = ["family", "best_bias", "uniform_median", "best_bias_median", "policy_median", "policy/best_bias",
             "policy_success", "best_bias_success", "policy_wall_ms", "best_bias_wall_ms", "expert_median",
             "policy/lower_bound", "expert/lower_bound", "expert/best_bias", "expert_success",
             "best_constant", "constant_median", "policy/constant", "expert/constant", "constant_success",
             "constant_wall_ms"]
    for n in (FOLLOWER, *learned, *users):
        hcols += [f"{n}_median", f"{n}/best_bias", f"policy/{n}", f"{n}/lower_bound", f"{n}_success", f"{n}_wall_ms"]
    return {
        "head": head, "hcols": hcols,
        "targets": T.target_check(head, mai), "route_targets": T.target_check(head, mai, ROUTE, ROUTE_ABLATION),
        "reach": T.target_check(head, mai, "expert"),
        "glance": T.glance_table(rows, best, users, mai),
        "clock": T.glance_table(rows, best, users, mai, metric="time"),
        "room": T.room_table(rows, mai),
        "goals": T.carry_targets(rows, mai, runs=runs) + T.carry_targets(rows, mai, "policy", CONSTANT, runs),
    }


def details_markdown(results, wide: dict | None = None) -> str:
    """``details.md``: every wide table of the comparison (what ``summary.md`` was before it got short)."""
    if _parts_only(results):
        return (f"# Sampler comparison: every table\n\nThe short version is [{SUMMARY}]({SUMMARY}).\n"
                + "".join(f"\n## {name}\n\n{report.markdown.rstrip()}\n"
                          for name, (_, report) in results.parts.items()))
    w = wide or wide_tables(results)
    c, rows = results.comparison, results.rows
    (targets, met, total), (route_targets, route_met, route_total) = w["targets"], w["route_targets"]
    reach, reach_met, reach_total = w["reach"]
    cols = ["family", "planner", "sampler", "runs", "success", "median_iterations", "iqr", "mean_iterations",
            "mean_ci95", "ratio_to_lower_bound", "median_candidates", "median_checks", "median_wall_ms",
            "median_cost", "median_forward_passes"]
    others = other_planner_rows(results)
    text = (f"# Sampler comparison: every table\n\nThe short version is [{SUMMARY}]({SUMMARY}). "
            f"Iterations to first solution (cap {c.protocol.max_iterations}); the expert and the exact route "
            "reference are privileged references.\n\n"
            "## Results at a glance\n\nRRT on the test split: median iterations to the first solution (success "
            "rate in brackets). Best goal bias: the bias tuned for the map set. Ablations: the learned sampler "
            "with its learning removed.\n\n" + markdown_table(w["glance"]) +
            "\n## Time to solution at a glance\n\n" + _clock_note(results) + "\n\n" + markdown_table(w["clock"]) +
            "\n## How much of the room learning closes\n\nThe room is what separates a sampler's ablation from "
            "the exact reference (the same sampler on the exact cost-to-go); the share closed is (ablation - learned) "
            "/ (ablation - exact). Below 20% of the ablation's median the room is too small to judge.\n\n"
            + (markdown_table(w["room"]) if w["room"] else "No exact reference ran, so the room cannot be shown.\n")
            + "\n## Targets for carrying the gain to unlike maps\n\n" + "".join(f"- {g}\n" for g in w["goals"]) +
            "\n## RRT: learned policy vs best-tuned goal bias and vs the tuned constant-distribution ablation\n\n"
            "The ablation draws the policy's own action classes (frontier, or the cell straight ahead) with a "
            "constant distribution and no network; its frontier probability is tuned on the tuning split. The "
            f"{FOLLOWER} has no learning either: it samples a step ahead of the vertex nearest the goal, "
            "straight at the goal, and turns to the frontier after 4 iterations without progress. The "
            f"{ROUTE} ({c.route}) follows its predicted cost-to-go the same way (settings chosen on "
            f"validation maps); the {ROUTE_ABLATION} is that sampler with the straight-line distance in place "
            "of the prediction, its target distance ahead and spread tuned for it on the same maps.\n\n"
            + markdown_table(w["head"], w["hcols"]) +
            f"\n## The policy's batch, tuned\n\nSamples per decision, chosen on the tuning maps "
            f"({POLICY_TUNING_SEEDS} seeds each) by the lowest sum of log median iterations; scores within "
            f"{BATCH_TIE:g} of it count as tied and the largest batch among them wins. Chosen: **{results.batch}**. "
            "The ablation decides as often.\n\n"
            + markdown_table([{"batch": b, "sum of log medians": f"{v:.3f}"}
                              for b, v in sorted(results.batch_scores.items())]) +
            f"\n## Targets for the learned policy: {met} of {total} met\n\n" + markdown_table(targets) +
            f"\n## Targets for the {ROUTE}: {route_met} of {route_total} met\n\n"
            f"Its ablation is the {ROUTE_ABLATION}: the same sampler without the encoder (tuned for itself).\n\n"
            + markdown_table(route_targets) +
            f"\n## Which targets can be reached: the privileged expert meets {reach_met} of {reach_total}\n\n"
            "The expert knows the shortest path (a grid search the learned sampler may not run); held to the same "
            "iteration and success targets, it shows which of them perfect route knowledge reaches at all.\n\n"
            + markdown_table(reach))
    if others:
        text += ("\n## Other planners\n\nEvery other planner on the test split (one seed per query), by group of "
                 "map sets: uniform sampling, its classical option (the goal bias tuned for each set on its tuning "
                 f"split for a tree; OB-PRM's obstacle-based sampling, `{OBSTACLE_BASED}`, for a roadmap), the policy, "
                 f"each route encoder, the {LAZY_ROUTE} (RRT*: the straight line first, RRT-Connect and the "
                 "roadmaps: their uniform sampling first, then the field), its ablation and the exact reference, "
                 "as the sampler registry builds them. "
                 "Iterations are samples for a roadmap; checks include the sampler's own.\n\n" + markdown_table(others))
    for name, (_, report) in results.parts.items():
        text += f"\n## {name}\n\n{report.markdown.rstrip()}\n"
    return text + "\n## All cells\n\n" + markdown_table([{k: r[k] for k in cols} for r in rows], cols)


def record(results, settings: dict) -> dict:
    """``map-sets.json``: the map sets, the settings and what was tuned."""
    c = results.comparison
    out = {"map sets": sorted({q.map_set for q in c.queries}), "settings": settings, "policy_batch": results.batch,
           "tuned goal bias": {f"{m} / {p}": v for (m, p), v in sorted(results.best.items())},
           "tuned ablation frontier": {f"{m} / {p}": v for (m, p), v in sorted(results.constants.items())}}
    if c.map_set is not None:
        out["map set"] = c.map_set.record()
    if results.unseen:
        out["unseen"] = {"families": results.unseen, "size": c.protocol.size,
                         "maps per family": c.protocol.unseen_maps, "seeds from": UNSEEN_SEED0,
                         "generator": "planners.maps.unseen.generate_unseen",
                         "settings": f"tuned on the {GENERATED_POOL}"}
    if results.parts:
        out["parts"] = sorted(results.parts)
        scenes = {part.name: part.scenes.record() for part in _rigid_parts(results)}
        if scenes:  # the 6-DoF parts' scene sets (a mesh set's OMPL.app files by digest)
            out["scene sets"] = scenes
    return out


def _rigid_parts(results) -> list:
    """The comparison's 6-DoF parts (``RigidPart``) that ran."""
    from learning.evaluation.rigid import RigidPart

    return [p for p in results.comparison.parts if isinstance(p, RigidPart) and p.name in results.parts]


def _rigid_figures(results, out_dir: Path) -> list[Path]:
    """The 6-DoF parts' ECDFs of iterations and time and a solved passage in 3-D (``save_rigid_figures``)."""
    from learning.evaluation.rigid import save_rigid_figures

    paths: list[Path] = []
    for part in _rigid_parts(results):
        paths += save_rigid_figures(part.rows(results.parts[part.name][0]), out_dir, part.scenes,
                                    user_samplers=part.users)
    return paths


def write_outputs(results, out: Path, settings: dict) -> list[Path]:
    """Every file of the output set, swapped into ``out`` together; returns the figures' paths."""
    c = results.comparison
    extra = [CONSTANT, FOLLOWER, ROUTE, LAZY_ROUTE, ROUTE_ABLATION, *c.routes, *c.samplers]
    with output_set(out) as tmp:
        write_runs_csv(results.all_runs, tmp / "runs.csv")
        plots = save_plots([r for r in results.runs if r.map not in results.movingai] + results.pool, results.rows,
                           results.best, tmp, extra=extra)
        plots += _rigid_figures(results, tmp)
        stems: set[str] = set()  # one file per map set, the parts' included
        write_ompl_logs(results.runs + results.pool, results.best, tmp / "ompl", c.protocol, stems)
        for runs, report in results.parts.values():  # each part's logs under the protocol its runs were made by
            write_ompl_logs(runs, results.best, tmp / "ompl", report.protocol or c.protocol, stems)
        atomic_write_text(tmp / "map-sets.json", json.dumps(record(results, settings), indent=1, default=str) + "\n")
        atomic_write_text(tmp / SUMMARY, summary_markdown(results))
        atomic_write_text(tmp / DETAILS, details_markdown(results, results.wide))
    return [out / p.name for p in plots]


def printed(results, out: Path | str | None = None) -> str:
    """What the command line prints at the end: the short table, the findings, then the wide tables.

    With other planners, every planner's rows by group (``details.md``'s "Other planners": each sampler, the
    learned ones, their ablations and the exact reference) and ``summary.md``'s "Which planner and sampler".
    """
    if _parts_only(results):
        text = "\n".join(["", *(f"- {f}" for f in findings(results)), "",
                          *(report.markdown.rstrip() + "\n" for _, report in results.parts.values())])
        return text + (f"\nsummary: {Path(out) / SUMMARY}; every table: {Path(out) / DETAILS}; raw runs: "
                       f"{Path(out) / 'runs.csv'}" if out is not None else "")
    w = results.wide
    (_, met, total), (_, route_met, route_total), (_, reach_met, reach_total) = (w["targets"], w["route_targets"],
                                                                                 w["reach"])
    lines = ["", markdown_table(glance_short(results)), *(f"- {f}" for f in findings(results)), "",
             "Per map set (median iterations, success):", markdown_table(w["glance"]),
             "Time to solution per query, median ms (the sampler's own work included):\n" + markdown_table(w["clock"]),
             _left_out_note(results) + "."]
    if w["room"]:
        lines.append("How much of the room between ablation and exact reference learning closes:\n"
                     + markdown_table(w["room"]))
    lines += [*w["goals"], "", markdown_table(w["head"], w["hcols"]),
              f"policy batch {results.batch}, tuned: "
              + ", ".join(f"{b}: {v:.3f}" for b, v in sorted(results.batch_scores.items())),
              f"\nTargets: the learned policy meets {met} of {total}, the {ROUTE} {route_met} of {route_total}; the "
              f"privileged expert meets {reach_met} of its {reach_total} ({DETAILS} has which)"]
    others = other_planner_rows(results)
    if others:
        lines.append("\nOther planners on the test split, by group of map sets (iterations are samples for a roadmap; "
                     "checks include the sampler's own):\n" + markdown_table(others))
    which = which_planner(results)
    if which:
        lines.append("Which planner and sampler, per group (the privileged references left out; a roadmap's "
                     "iterations are samples):\n" + markdown_table(which))
    if out is not None:
        out = Path(out)
        lines.append(f"summary: {out / SUMMARY}; every table: {out / DETAILS}; raw runs: {out / 'runs.csv'}; plots: "
                     f"{out / 'medians.png'}, {out / 'ecdf.png'}, {out / 'ecdf-time.png'}; OMPL benchmark logs: "
                     f"{out / 'ompl'}")
    return "\n".join(lines)
