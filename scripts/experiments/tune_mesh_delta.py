"""Which motion resolution (``DEFAULT_DELTA_FRACTION``) and band (``DEFAULT_BAND_FRACTION``) a mesh world should
default to, on generated mesh scenes.

    PYTHONPATH=$PWD python scripts/experiments/tune_mesh_delta.py --scenes 2 --seeds 2 --time-limit 10 \\
        --fractions 1e-3 5e-4 2.5e-4 1.25e-4 --bands 1 --out results/tune_mesh_delta.jsonl

Every pose a mesh world checks keeps the body the band from the environment, so the band narrows each passage
by that much on each side; a smaller ``delta`` or band costs more poses per motion near the walls. This runs
our RRT-Connect (default settings, uniform sampling) under a time limit on the *tuning* part of the
training box-scene families written as mesh worlds (``mesh_scene(family, seed, delta=fraction x the bounds'
diagonal)``), never on OMPL.app's problems or a test scene, and prints per fraction the solved runs and the
median time (an unsolved run counts at the limit). A scene whose box witness meets its meshes is left out
(``mesh_scene`` refuses it), as the mesh scene set leaves it out. Runs are interleaved across fractions over
``--processes`` worker processes, so every fraction sees the same load.

``--bands SHARE ...`` gives the band every checked pose keeps (``MeshWorld``'s ``band``) as shares of ``delta / 2``
(default 0.25, ``MeshWorld``'s default ``delta / 8``); a scene is left out where the widest band, ``delta / 2``,
refuses its witness, so every band plans the same scenes.

``--part validation`` runs the validation part's scenes instead, where a choice made on the tuning part is
confirmed (never the test part).

``--planner RRT`` runs RRT (its default, uniform sampling; ``--sampler goal_bias`` for the bias) instead of
RRT-Connect. ``--steps SHARE ...`` gives the planner's step as shares of OMPL's default range (0.2 of the state box's
diagonal, ``planners.base.world.DEFAULT_RANGE_FRACTION``), so a command names the same steps whatever the world's
default; without it the planner takes its default step (a mesh world's is 0.1 of that range).

``--sampler NAME`` runs every run with a registry sampler instead of uniform sampling (a fresh one per run, bound
in the timed run), and ``--restarts UNIT ...`` adds candidates that restart each run by Luby's sequence times
``UNIT`` iterations (``planners.solve_with_restarts``; 0: none), the time limit over all attempts:

    PYTHONPATH=$PWD python scripts/experiments/tune_mesh_delta.py --scenes 4 --seeds 2 --time-limit 20 \\
        --fractions 1e-3 --sampler rigid_route --restarts 0 1000 --out results/mesh_restarts.jsonl
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

_PROBLEMS: dict = {}


def _run(task: tuple) -> dict:
    fraction, share, family, scene_seed, seed, limit, sampler, restarts, step_share, planner = task
    import numpy as np

    from planners import make_planner, solve_with_restarts
    from planners.base.planner import compile_seconds
    from planners.worlds.rigid_scenes import as_mesh_scene, mesh_scene, rigid_scene

    key = (fraction, share, family, scene_seed)
    if key not in _PROBLEMS:
        box = rigid_scene(family, scene_seed)
        lo, hi = box.world.low3, box.world.high3
        delta = fraction * float(np.linalg.norm(hi - lo))
        try:
            problem = mesh_scene(family, scene_seed, delta=delta, band=0.5 * delta)
        except RuntimeError as e:  # the box scene's witness meets the meshes: not a mesh scene (as MeshSceneSet)
            _PROBLEMS[key] = str(e)
            return {"fraction": fraction, "band": share, "family": family, "scene_seed": scene_seed, "seed": seed,
                    "refused": str(e)}
        if share != 1:  # the same scene (accepted at the widest band) with the band asked
            problem = as_mesh_scene(box, delta, share * 0.5 * delta)
        make_planner(planner, problem, seed=0).solve(max_iterations=2)  # compile outside the timing
        _PROBLEMS[key] = problem
    problem = _PROBLEMS[key]
    if isinstance(problem, str):
        return {"fraction": fraction, "band": share, "family": family, "scene_seed": scene_seed, "seed": seed,
                "refused": problem}

    def kwargs() -> dict:  # a fresh sampler for each run (bound in the timed run), the step asked
        from planners.algorithms.rrt import diagonal_step
        from planners.base.world import DEFAULT_RANGE_FRACTION

        out = {} if step_share is None else {"step_size": step_share * diagonal_step(problem, DEFAULT_RANGE_FRACTION)}
        if sampler == "uniform":
            return out
        from learning.samplers.registry import make_sampler

        return {**out, "sampler": make_sampler(sampler)}

    make_planner(planner, problem, seed=0, **kwargs()).solve(max_iterations=2)  # the sampler's kernels
    t, c = time.perf_counter(), compile_seconds()
    if restarts:
        r = solve_with_restarts(planner, problem, seed=seed, unit=restarts, time_limit=limit, **kwargs())
    else:
        r = make_planner(planner, problem, seed=seed, **kwargs()).solve(time_limit=limit)
    seconds = time.perf_counter() - t - (compile_seconds() - c)
    return {"planner": planner, "fraction": fraction, "band": share, "restarts": restarts, "step": step_share,
            "family": family,
            "scene_seed": scene_seed,
            "seed": seed, "delta": problem.world.delta, "sampler": sampler,
            "solved": bool(r.solved), "iterations": int(r.iterations), "checks": int(r.collision_checks),
            "seconds": float(seconds)}


def _step(share: float | None) -> str:
    return "default" if share is None else f"{share:g}"


def main(argv=None) -> int:
    from planners.base.fileio import atomic_write_text
    from planners.worlds.rigid_scenes import TRAINING_FAMILIES, scene_seeds

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", type=int, default=2, help="scenes per family")
    ap.add_argument("--part", choices=["tuning", "validation"], default="tuning",
                    help="the scene sets' part the scenes come from (default tuning)")
    ap.add_argument("--seeds", type=int, default=2, help="planner seeds per scene")
    ap.add_argument("--time-limit", type=float, default=10.0)
    ap.add_argument("--fractions", type=float, nargs="+", default=[1e-3, 5e-4, 2.5e-4, 1.25e-4])
    ap.add_argument("--bands", type=float, nargs="+", default=[0.25], metavar="SHARE",
                    help="the band every checked pose keeps, as shares of delta / 2 (default 0.25: delta / 8)")
    ap.add_argument("--families", nargs="+", default=list(TRAINING_FAMILIES), choices=list(TRAINING_FAMILIES))
    ap.add_argument("--sampler", default="uniform", help="a registry sampler for every run (default uniform)")
    ap.add_argument("--restarts", type=int, nargs="+", default=[0], metavar="UNIT",
                    help="candidates: restart by Luby's sequence times UNIT iterations (0: none; default 0)")
    ap.add_argument("--steps", type=float, nargs="+", default=[None], metavar="SHARE",
                    help="candidates: the planner's step as shares of OMPL's default range (default: its own default)")
    ap.add_argument("--planner", choices=["RRTConnect", "RRT"], default="RRTConnect",
                    help="the planner of every run, at its default settings (default RRTConnect)")
    ap.add_argument("--processes", type=int, default=2)
    ap.add_argument("--out", type=Path, required=True, help="a JSON-lines file of every run (written at the end)")
    args = ap.parse_args(argv)
    if args.out.exists() and args.out.is_dir():
        ap.error(f"--out {args.out} is a folder; give a file name")
    if args.sampler != "uniform":
        from learning.samplers.registry import sampler_names

        if args.sampler not in sampler_names():
            ap.error(f"--sampler {args.sampler}: no such sampler (known: {', '.join(sampler_names())})")
    if any(not 0 < b <= 1 for b in args.bands):
        ap.error(f"--bands must lie in (0, 1], got {args.bands}")
    if any(x is not None and not 0 < x <= 4 for x in args.steps):
        ap.error(f"--steps must lie in (0, 4], got {args.steps}")
    if any(u < 0 for u in args.restarts):
        ap.error(f"--restarts takes 0 (none) or numbers of iterations, got {args.restarts}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tasks = [(f, b, fam, s, seed, args.time_limit, args.sampler, u, x, args.planner) for fam in args.families
             for s in scene_seeds(fam, args.part, args.scenes) for seed in range(args.seeds) for f in args.fractions
             for b in args.bands for u in args.restarts for x in args.steps]
    rows = []
    with ProcessPoolExecutor(args.processes) as pool:
        for row in pool.map(_run, tasks):
            rows.append(row)
            print(json.dumps(row), flush=True)
    atomic_write_text(args.out, "".join(json.dumps(r) + "\n" for r in rows))
    refused = sorted({f"{r['family']}-{r['scene_seed']}" for r in rows if "refused" in r})
    rows = [r for r in rows if "refused" not in r]
    if refused:
        print(f"\nleft out (the box scene's witness meets its meshes): {', '.join(refused)}")
    print(f"\n{args.planner}, {args.sampler} sampling\n\n| fraction | band (of delta / 2) | restarts (unit) | "
          "step (of OMPL's range) | solved | median time (s), unsolved at the limit | median iterations | "
          "median checks |\n"
          "|---|---|---|---|---|---|---|---|")
    for f, b, u, x in [(f, b, u, x) for f in args.fractions for b in args.bands for u in args.restarts
                       for x in args.steps]:
        rs = [r for r in rows if r["fraction"] == f and r["band"] == b and r["restarts"] == u and r["step"] == x]
        if not rs:
            print(f"| {f:g} | {b:g} | {u or 'none'} | {_step(x)} | no scene | | | |")
            continue
        t = statistics.median(r["seconds"] if r["solved"] else args.time_limit for r in rs)
        print(f"| {f:g} | {b:g} | {u or 'none'} | {_step(x)} | {sum(r['solved'] for r in rs)}/{len(rs)} | {t:.2f} | "
              f"{statistics.median(r['iterations'] for r in rs):,.0f} | "
              f"{statistics.median(r['checks'] for r in rs):,.0f} |")
    by_family = {}
    for r in rows:
        by_family.setdefault((r["family"], r["fraction"], r["band"], r["restarts"], r["step"]), []).append(r["solved"])
    print("\nsolved by family: " + "; ".join(f"{fam} {f:g}" + f" band {b:g}" + (f" restarts {u}" if u else "")
                                            + (f" step {x:g}" if x is not None else "") + f": {sum(v)}/{len(v)}"
                                            for (fam, f, b, u, x), v in by_family.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
