"""Our RRT-Connect against OMPL's on generated mesh scenes: solved runs, time, tree states, iterations per second.

    PYTHONPATH=$PWD python scripts/experiments/mesh_vs_ompl.py --scenes 2 --seeds 2 --time-limit 20

Does our RRT-Connect need more tree states than OMPL's for the same 6-DoF problem? This runs both on the
*tuning* part of the training box-scene families written as mesh worlds (``mesh_scene``; never OMPL.app's
problems or a test scene), each run under ``--time-limit``: ours with its defaults (uniform sampling, the
exact motion check), OMPL's as ``planners.tools.ompl_bridge.ompl_rigid`` sets it up (SE(3) with quaternions,
OMPL's default range, its discrete motion check every 1% of the space's extent with no clearance asked,
each state checked by our ``is_valid`` through a Python call). It prints per family and planner the solved
runs, the median time (an unsolved run at the limit), the tree states of the solved runs and the median
iterations per second. Runs are spread over ``--processes`` worker processes, ours and OMPL's interleaved.
Needs the ``mesh`` and ``bench`` extras.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

_PROBLEMS: dict = {}


def _run(task: tuple) -> dict:
    who, family, scene_seed, seed, limit = task
    from planners import make_planner
    from planners.tools.ompl_bridge import ompl_rigid
    from planners.worlds.rigid_scenes import mesh_scene

    key = (family, scene_seed)
    if key not in _PROBLEMS:
        try:
            _PROBLEMS[key] = mesh_scene(family, scene_seed)
            make_planner("RRTConnect", _PROBLEMS[key], seed=0).solve(max_iterations=2)  # compile outside the timing
        except RuntimeError as e:  # the box scene's witness meets the meshes: not a mesh scene (as MeshSceneSet)
            _PROBLEMS[key] = str(e)
    problem = _PROBLEMS[key]
    row = {"planner": who, "family": family, "scene_seed": scene_seed, "seed": seed}
    if isinstance(problem, str):
        return {**row, "refused": problem}
    if who == "ours":
        planner = make_planner("RRTConnect", problem, seed=seed)
        t = time.perf_counter()
        r = planner.solve(time_limit=limit)
        seconds = time.perf_counter() - t - planner.compile_time
        return {**row, "solved": bool(r.solved), "seconds": seconds, "iterations": int(r.iterations),
                "states": int(r.num_vertices)}
    o = ompl_rigid(problem, "RRTConnect", seed=seed, time_limit=limit)
    return {**row, "solved": bool(o.solved), "seconds": float(o.time), "iterations": int(o.iterations),
            "states": int(o.num_vertices)}


def main(argv=None) -> int:
    from concurrent.futures import ProcessPoolExecutor

    from planners.worlds.rigid_scenes import TRAINING_FAMILIES, scene_seeds

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", type=int, default=2, help="tuning scenes per family")
    ap.add_argument("--seeds", type=int, default=2, help="planner seeds per scene")
    ap.add_argument("--time-limit", type=float, default=20.0)
    families = [f for f in TRAINING_FAMILIES if f != "clutter"]  # the mesh scene set leaves clutter out
    ap.add_argument("--families", nargs="+", default=families, choices=families)
    ap.add_argument("--processes", type=int, default=2)
    args = ap.parse_args(argv)
    if args.scenes < 1 or args.seeds < 1 or args.processes < 1 or not args.time_limit > 0:
        ap.error("--scenes, --seeds and --processes must be at least 1 and --time-limit positive")
    try:
        import ompl  # noqa: F401
    except ImportError:
        ap.error("OMPL's Python bindings are missing: pip install -e '.[bench]'")
    tasks = [(who, fam, s, seed, args.time_limit) for fam in args.families
             for s in scene_seeds(fam, "tuning", args.scenes) for seed in range(args.seeds) for who in ("ours", "OMPL")]
    with ProcessPoolExecutor(args.processes) as pool:
        rows = list(pool.map(_run, tasks))
    print("| family | planner | solved | median time (s) | tree states when solved | iterations per second |")
    print("|---|---|---|---|---|---|")
    for fam in args.families:
        for who in ("ours", "OMPL"):
            rs = [r for r in rows if r["family"] == fam and r["planner"] == who and "refused" not in r]
            if not rs:
                print(f"| {fam} | {who} | no mesh scene | | | |")
                continue
            times = [r["seconds"] if r["solved"] else args.time_limit for r in rs]
            states = ", ".join(f"{r['states']:,}" for r in rs if r["solved"]) or "-"
            rate = statistics.median(r["iterations"] / max(r["seconds"], 1e-9) for r in rs)
            print(f"| {fam} | {who} | {sum(r['solved'] for r in rs)}/{len(rs)} | {statistics.median(times):.2f} | "
                  f"{states} | {rate:,.0f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
