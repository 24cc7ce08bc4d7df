"""How many iterations does RRT-Connect need on an OMPL.app problem when it is given long enough: ours at several
motion resolutions, and OMPL's with the same state check.

    PYTHONPATH=$PWD python scripts/experiments/omplapp_long_runs.py --omplapp DIR --problem Twistycool \\
        --seeds 10 --time-limit 60 --fractions 1e-3 2.5e-4 --ompl-time-limit 120 --out results/long_runs.jsonl

A benchmark run stops at the ``.cfg``'s time limit, so where most runs fail there it says only that the median
lies beyond it. This runs each seed until it solves or reaches a much longer limit and reports what a solve takes:
iterations, tree states, collision checks and time. Ours is RRT-Connect with the default settings, uniform
sampling and each of ``--samplers`` (a registry sampler, bound in the timed run), on the problem read with
``delta`` at each ``--fractions`` of the bounds' diagonal and each ``--bands`` (every checked pose keeps the body
the band from the environment, so the band narrows each passage; the defaults are ``DEFAULT_DELTA_FRACTION`` and
``DEFAULT_BAND_FRACTION``). OMPL's
(``--ompl-time-limit``, the ``bench`` extra) is RRT-Connect as ``benchmark_planners.py --rigid --rigid-ompl`` sets
it up: SE(3) with quaternions, our ``is_valid`` per state, OMPL's discrete motion check every 1% of the space's extent
with no clearance asked; each of its solutions is replayed as OMPL moves the body (``slerp_poses``), a pose
wherever a body point has moved ``delta / 10``, and the motions that put the body in contact there are counted. A
diagnostic: it chooses nothing (the problems are test problems); a resolution is chosen on the generated scenes'
tuning part (``tune_mesh_delta.py``). The runs are made one after another in this process; the iterations do not
depend on the machine's load, the times do.

With ``--luby UNIT`` each of our runs restarts (``planners.solve_with_restarts``): a fresh planner, its sampler
bound again, on a seed drawn from the run's seed and the attempt, after Luby, Sinclair and Zuckerman's universal
sequence (1, 1, 2, 1, 1, 2, 4, ...) times ``UNIT`` iterations, the time limit over all attempts: what restarts
give a sampler whose runs either solve soon or stall (heavy-tailed run times, as Wedge and Branicky found for
RRT). Whatever the distribution of run times, the sequence's expected time is within a logarithmic factor of the
best fixed cut's (Luby et al.), so ``UNIT`` matters less than a fixed cut would.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np


def _median(values: list[float], solved: list[bool]) -> str:
    """The median, an unsolved run counting as beyond every solved one ("> x" where half or more are unsolved)."""
    order = sorted(zip(values, solved, strict=True), key=lambda vs: (not vs[1], vs[0]))
    k = (len(order) - 1) // 2
    value, ok = order[k]
    beyond = not ok or (len(order) % 2 == 0 and not order[k + 1][1])
    if beyond:  # beyond every solved run and beyond what the run at the median reached
        value = max([v for v, s in order if s] + [value])
        return f"> {value:,.0f}" if value >= 100 else f"> {value:.1f}"
    if len(order) % 2 == 0:
        value = 0.5 * (value + order[k + 1][0])
    return f"{value:,.0f}" if value >= 100 else f"{value:.2f}"


def slerp_poses(a: np.ndarray, b: np.ndarray, step: float, radius: float) -> np.ndarray:
    """Poses along OMPL's motion from ``a`` to ``b`` (position linear, rotation by the shortest turn, as OMPL's SE(3)
    interpolates), as ``(x, y, z, tx, ty, tz)``, so that no body point moves more than ``step`` between two."""
    from planners.worlds.omplapp import axis_angle_matrix
    from planners.worlds.rigid3d import euler_from_matrix, rotation_matrix

    Ra, Rb = rotation_matrix(*a[3:]), rotation_matrix(*b[3:])
    rel = Ra.T @ Rb
    theta = math.acos(min(1.0, max(-1.0, 0.5 * (np.trace(rel) - 1.0))))
    axis = np.array([1.0, 0.0, 0.0])
    if theta > 1e-12:
        values, vectors = np.linalg.eig(rel)
        axis = np.real(vectors[:, np.argmin(np.abs(values - 1.0))])
        if not np.allclose(axis_angle_matrix(axis, theta), rel, atol=1e-6):
            axis = -axis
    travel = float(np.linalg.norm(b[:3] - a[:3])) + radius * theta
    n = max(1, math.ceil(travel / step))
    out = np.empty((n + 1, 6))
    for i, t in enumerate(np.linspace(0.0, 1.0, n + 1)):
        out[i, :3] = a[:3] + t * (b[:3] - a[:3])
        out[i, 3:] = euler_from_matrix(Ra @ axis_angle_matrix(axis, t * theta))
    return out


def motions_through(world, path: np.ndarray, step: float) -> int:
    """How many of a solution's motions, replayed as OMPL moves (``slerp_poses``), put the body in contact."""
    return sum(not all(world.is_valid(q) for q in slerp_poses(a, b, step, world.radius))
               for a, b in zip(path[:-1], path[1:], strict=True))


def summary(rows: list[dict]) -> str:
    """A Markdown table of the runs, one row per variant."""
    out = ["| variant | solved | median iterations | median tree states | median checks | median time (s) |",
           "|---|---|---|---|---|---|"]
    for variant in dict.fromkeys(r["variant"] for r in rows):
        rs = [r for r in rows if r["variant"] == variant]
        ok = [r["solved"] for r in rs]
        checks = _median([r["checks"] for r in rs], ok) if all(r["checks"] >= 0 for r in rs) else ""
        out.append(f"| {variant} | {sum(ok)}/{len(rs)} | {_median([r['iterations'] for r in rs], ok)} | "
                   f"{_median([r['states'] for r in rs], ok)} | {checks} | "
                   f"{_median([r['seconds'] for r in rs], ok)} |")
    return "\n".join(out) + "\n"


def main(argv=None) -> int:
    from planners import make_planner, solve_with_restarts
    from planners.base.fileio import InputError, atomic_write_text
    from planners.base.planner import compile_seconds
    from planners.tools import ompl_bridge
    from planners.worlds.mesh import DEFAULT_BAND_FRACTION
    from planners.worlds.omplapp import load_omplapp, omplapp_dir

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--omplapp", required=True, metavar="DIR", help="OMPL.app's resources/3D folder")
    ap.add_argument("--problem", default="Twistycool", help="the .cfg's name")
    ap.add_argument("--seeds", type=int, default=10, help="runs per variant, seeds 0 upwards")
    ap.add_argument("--time-limit", type=float, default=60.0, help="our runs' limit (s)")
    ap.add_argument("--fractions", type=float, nargs="*", default=[1e-3],
                    help="delta as fractions of the diagonal; none: OMPL's runs only")
    ap.add_argument("--bands", type=float, nargs="+", default=[0.25], metavar="SHARE",
                    help="the band every checked pose keeps, as shares of delta / 2 (MeshWorld's band; default 0.25: "
                         "delta / 8)")
    ap.add_argument("--samplers", nargs="*", default=[], metavar="NAME",
                    help="registry samplers to run beside uniform sampling (make_sampler(NAME), bound per run)")
    ap.add_argument("--no-uniform", action="store_true", help="run only the --samplers, not uniform sampling")
    ap.add_argument("--luby", type=int, default=0, metavar="UNIT",
                    help="restart our runs at Luby's sequence times UNIT iterations (0: no restarts)")
    ap.add_argument("--ompl-time-limit", type=float, default=0.0, help="OMPL's runs' limit (s); 0 runs none")
    ap.add_argument("--out", type=Path, required=True, help="a JSON-lines file of every run (written at the end)")
    args = ap.parse_args(argv)
    if not args.fractions and not args.ompl_time_limit:
        ap.error("nothing to run: give --fractions, --ompl-time-limit or both")
    if args.luby < 0:
        ap.error(f"--luby must be 0 (no restarts) or a number of iterations, got {args.luby}")
    if args.seeds < 1 or args.time_limit <= 0 or args.ompl_time_limit < 0:
        ap.error("--seeds must be at least 1, --time-limit positive and --ompl-time-limit 0 or more")
    if any(not 0 < f < 0.1 for f in args.fractions):
        ap.error(f"--fractions must lie in (0, 0.1), got {args.fractions}")
    if any(not 0 < b <= 1 for b in args.bands):
        ap.error(f"--bands must lie in (0, 1], got {args.bands}")
    if args.out.exists() and args.out.is_dir():
        ap.error(f"--out {args.out} is a folder; give a file name")
    cfg = omplapp_dir(args.omplapp) / f"{args.problem}.cfg"
    if not cfg.is_file():
        raise InputError(f"--problem {args.problem}: no {cfg.name} in {cfg.parent}")
    samplers = ([] if args.no_uniform else [None]) + list(args.samplers)
    if args.fractions and not samplers:
        ap.error("--no-uniform needs --samplers")
    if args.samplers:
        from learning.samplers.registry import make_sampler, sampler_names

        if unknown := [n for n in args.samplers if n not in sampler_names()]:
            ap.error(f"--samplers {unknown[0]}: no such sampler (known: {', '.join(sampler_names())})")
    if args.ompl_time_limit and not ompl_bridge.available():
        ap.error("--ompl-time-limit needs OMPL (pip install -c constraints.txt -e '.[bench]')")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    rows = []
    world = load_omplapp(cfg).problem.world
    for fraction, share in [(f, b) for f in args.fractions for b in args.bands]:
        delta = fraction * float(np.linalg.norm(world.high3 - world.low3))
        problem = load_omplapp(cfg, delta=delta, band=share * 0.5 * delta).problem
        for name in samplers:
            kwargs = lambda name=name: {} if name is None else {"sampler": make_sampler(name)}  # noqa: E731
            make_planner("RRTConnect", problem, seed=0, **kwargs()).solve(max_iterations=2)  # compile first
            variant = (f"ours, delta {fraction:g} of the diagonal"
                       + ("" if share == 2 * DEFAULT_BAND_FRACTION else f", band {share:g} delta / 2")
                       + ("" if name is None else f", {name}"))
            if args.luby:
                variant += f", Luby restarts x {args.luby}"
            for seed in range(args.seeds):
                t, c = time.perf_counter(), compile_seconds()
                if args.luby:  # every attempt's bind is timed
                    r = solve_with_restarts("RRTConnect", problem, seed=seed, unit=args.luby,
                                            time_limit=args.time_limit, **kwargs())
                else:
                    planner = make_planner("RRTConnect", problem, seed=seed, **kwargs())  # a sampler's bind is timed
                    r = planner.solve(time_limit=args.time_limit)
                row = {"variant": variant, "seed": seed, "solved": bool(r.solved),
                       "iterations": int(r.iterations), "states": int(r.num_vertices),
                       "checks": int(r.collision_checks),
                       "seconds": time.perf_counter() - t - (compile_seconds() - c),
                       "delta": problem.world.delta, "band": problem.world.band, "restarts": int(r.restarts)}
                rows.append(row)
                print(json.dumps(row), flush=True)
    if args.ompl_time_limit:
        problem = load_omplapp(cfg).problem
        for seed in range(args.seeds):
            o = ompl_bridge.ompl_rigid(problem, "RRTConnect", seed=seed, time_limit=args.ompl_time_limit)
            row = {"variant": "OMPL", "seed": seed, "solved": bool(o.solved), "iterations": int(o.iterations),
                   "states": int(o.num_vertices), "checks": -1, "seconds": float(o.time)}
            if o.solved:  # OMPL checks a motion's poses every 1% of the extent: replayed with a pose every delta / 10
                row["motions"] = len(o.path) - 1
                row["motions_in_contact"] = motions_through(problem.world, o.path, 0.1 * problem.world.delta)
            rows.append(row)
            print(json.dumps(row), flush=True)
    atomic_write_text(args.out, "".join(json.dumps(r) + "\n" for r in rows))
    limits = ([f"ours within {args.time_limit:g} s"] if args.fractions else []) + \
        ([f"OMPL's within {args.ompl_time_limit:g} s"] if args.ompl_time_limit else [])
    print(f"\n{args.problem}, RRT-Connect, seeds 0 to {args.seeds - 1}; {', '.join(limits)} (an unsolved run counts "
          f"as beyond every solved one)\n")
    print(summary(rows))
    replayed = [r for r in rows if "motions" in r]
    if replayed:
        print("OMPL's solutions replayed as OMPL moves, a pose wherever a body point has moved delta / 10: "
              f"{sum(r['motions_in_contact'] for r in replayed)} of {sum(r['motions'] for r in replayed)} motions "
              f"put the body in contact ({sum(r['motions_in_contact'] > 0 for r in replayed)} of {len(replayed)} "
              f"solutions)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
