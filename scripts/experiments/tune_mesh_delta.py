"""Which motion resolution (``DEFAULT_DELTA_FRACTION``) a mesh world should default to, on generated mesh scenes.

    PYTHONPATH=$PWD python scripts/experiments/tune_mesh_delta.py --scenes 2 --seeds 2 --time-limit 10 \\
        --fractions 1e-3 5e-4 2.5e-4 1.25e-4 --out results/tune_mesh_delta.jsonl

Every pose a mesh world checks keeps the body ``delta / 2`` from the environment, so ``delta`` narrows each
passage by that much on each side; a smaller ``delta`` costs more poses per motion near the walls. This runs
our RRT-Connect (default settings, uniform sampling) under a time limit on the *tuning* part of the
training box-scene families written as mesh worlds (``mesh_scene(family, seed, delta=fraction x the bounds'
diagonal)``), never on OMPL.app's problems or a test scene, and prints per fraction the solved runs and the
median time (an unsolved run counts at the limit). A scene whose box witness meets its meshes is left out
(``mesh_scene`` refuses it), as the mesh scene set leaves it out. Runs are interleaved across fractions over
``--processes`` worker processes, so every fraction sees the same load.
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
    fraction, family, scene_seed, seed, limit = task
    import numpy as np

    from planners import make_planner
    from planners.worlds.rigid_scenes import mesh_scene, rigid_scene

    key = (fraction, family, scene_seed)
    if key not in _PROBLEMS:
        box = rigid_scene(family, scene_seed)
        lo, hi = box.world.low3, box.world.high3
        try:
            problem = mesh_scene(family, scene_seed, delta=fraction * float(np.linalg.norm(hi - lo)))
        except RuntimeError as e:  # the box scene's witness meets the meshes: not a mesh scene (as MeshSceneSet)
            _PROBLEMS[key] = str(e)
            return {"fraction": fraction, "family": family, "scene_seed": scene_seed, "seed": seed, "refused": str(e)}
        make_planner("RRTConnect", problem, seed=0).solve(max_iterations=2)  # compile outside the timing
        _PROBLEMS[key] = problem
    problem = _PROBLEMS[key]
    if isinstance(problem, str):
        return {"fraction": fraction, "family": family, "scene_seed": scene_seed, "seed": seed, "refused": problem}
    planner = make_planner("RRTConnect", problem, seed=seed)
    t = time.perf_counter()
    r = planner.solve(time_limit=limit)
    seconds = time.perf_counter() - t - planner.compile_time
    return {"fraction": fraction, "family": family, "scene_seed": scene_seed, "seed": seed,
            "delta": problem.world.delta,
            "solved": bool(r.solved), "iterations": int(r.iterations), "checks": int(r.collision_checks),
            "seconds": float(seconds), "exact_poses": int(problem.world.exact_poses)}


def main(argv=None) -> int:
    from planners.base.fileio import atomic_write_text
    from planners.worlds.rigid_scenes import TRAINING_FAMILIES, scene_seeds

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", type=int, default=2, help="tuning scenes per family")
    ap.add_argument("--seeds", type=int, default=2, help="planner seeds per scene")
    ap.add_argument("--time-limit", type=float, default=10.0)
    ap.add_argument("--fractions", type=float, nargs="+", default=[1e-3, 5e-4, 2.5e-4, 1.25e-4])
    ap.add_argument("--families", nargs="+", default=list(TRAINING_FAMILIES), choices=list(TRAINING_FAMILIES))
    ap.add_argument("--processes", type=int, default=2)
    ap.add_argument("--out", type=Path, required=True, help="a JSON-lines file of every run (written at the end)")
    args = ap.parse_args(argv)
    if args.out.exists() and args.out.is_dir():
        ap.error(f"--out {args.out} is a folder; give a file name")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tasks = [(f, fam, s, seed, args.time_limit) for fam in args.families
             for s in scene_seeds(fam, "tuning", args.scenes) for seed in range(args.seeds) for f in args.fractions]
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
    print("\n| fraction | solved | median time (s), unsolved at the limit | median iterations | median checks |\n"
          "|---|---|---|---|---|")
    for f in args.fractions:
        rs = [r for r in rows if r["fraction"] == f]
        if not rs:
            print(f"| {f:g} | no scene | | | |")
            continue
        t = statistics.median(r["seconds"] if r["solved"] else args.time_limit for r in rs)
        print(f"| {f:g} | {sum(r['solved'] for r in rs)}/{len(rs)} | {t:.2f} | "
              f"{statistics.median(r['iterations'] for r in rs):,.0f} | "
              f"{statistics.median(r['checks'] for r in rs):,.0f} |")
    by_family = {}
    for r in rows:
        by_family.setdefault((r["family"], r["fraction"]), []).append(r["solved"])
    print("\nsolved by family: " + "; ".join(f"{fam} {f:g}: {sum(v)}/{len(v)}" for (fam, f), v in by_family.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
