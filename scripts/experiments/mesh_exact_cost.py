"""Where a mesh world's planning time goes: FCL's distance queries, its contact tests, and the rest.

    PYTHONPATH=$PWD python scripts/experiments/mesh_time_split.py --omplapp DIR --problem cubicles --seeds 5
    PYTHONPATH=$PWD python scripts/experiments/mesh_time_split.py --omplapp DIR --problem cubicles --poses 400 --coal

Runs our RRT-Connect (defaults, uniform sampling) on an OMPL.app problem, seeds 0 upwards, each to its solution or
``--time-limit``, with FCL's two module functions that the world calls (``fcl.distance``, ``fcl.collide``) wrapped
in timers, and prints per run the time to solution, the iterations, the calls of each and the seconds in each: the
rest is the compiled planner, the broad phase and Python around the calls.

``--coal`` (where the ``coal`` package, the maintained successor of hpp-fcl, is importable: it is not a
dependency of this project) times, on ``--poses`` random poses whose clearance lies between 0 and ten times the
world's ``delta``, coal's distance query beside FCL's, and coal's collision test with a security margin of
``delta / 2``, which answers whether the clearance exceeds the band every checked pose must keep, with the same
triangles in the same frame.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time


def timed(functions: dict[str, list[float]], module, name: str) -> None:
    """Wrap ``module.name`` so that each call's seconds are appended to ``functions[name]``."""
    real = getattr(module, name)

    def wrapper(*args):
        t0 = time.perf_counter()
        try:
            return real(*args)
        finally:
            functions[name].append(time.perf_counter() - t0)

    setattr(module, name, wrapper)


def near_poses(world, n: int, seed: int):
    """``n`` random states whose clearance (FCL) lies in (0, 10 delta), with their clearances."""
    import numpy as np

    rng = np.random.default_rng(seed)
    low, high = world.bounds
    states, clearances = [], []
    for _ in range(200 * n):
        q = low + rng.random(6) * (high - low)
        c = world.clearance(q)
        if 0 < c < 10 * world.delta:
            states.append(q)
            clearances.append(c)
            if len(states) == n:
                break
    return np.array(states), np.array(clearances)


def coal_costs(world, states, clearances) -> dict[str, float]:
    """Microseconds per pose of coal's distance and of its collision test at a margin of delta / 2."""
    import coal
    import numpy as np

    from planners.kernels.rigid import rotation_matrix

    def model(vertices, faces):
        m = coal.BVHModelOBBRSS()
        m.beginModel(len(faces), len(vertices))
        m.addVertices(np.asarray(vertices, dtype=float))
        m.addTriangles(np.asarray(faces, dtype=np.int64))
        m.endModel()
        return m

    body, env, identity = model(world.body_vertices, world.body_faces), model(world.env_vertices, world.env_faces), \
        coal.Transform3s()
    poses = [coal.Transform3s(np.asarray(rotation_matrix(q[3], q[4], q[5])), q[:3].copy()) for q in states]
    dreq, dres = coal.DistanceRequest(), coal.DistanceResult()

    def distances_with(rel_err: float) -> tuple[np.ndarray, float]:
        """coal's distance at every pose, allowed ``rel_err`` (its traversal may stop early), and its microseconds."""
        dreq.rel_err = rel_err
        t0 = time.perf_counter()
        out = []
        for T in poses:
            dres.clear()
            out.append(coal.distance(body, T, env, identity, dreq, dres))
        return np.array(out), (time.perf_counter() - t0) / len(poses) * 1e6

    distances, distance_us = distances_with(0.0)
    loose, loose_us = distances_with(0.5)
    creq, cres = coal.CollisionRequest(), coal.CollisionResult()
    creq.security_margin = world.delta / 2
    t0 = time.perf_counter()
    within = []
    for T in poses:
        cres.clear()
        within.append(bool(coal.collide(body, T, env, identity, creq, cres)))
    margin_us = (time.perf_counter() - t0) / len(poses) * 1e6
    agree = sum(w == (c <= world.delta / 2) for w, c in zip(within, clearances, strict=True))
    # the lower bound on the distance that a collision test without a margin reports for a pose it finds free
    creq.security_margin = 0.0
    bounds = []
    for T in poses:
        cres.clear()
        coal.collide(body, T, env, identity, creq, cres)
        bounds.append(cres.distance_lower_bound)
    free = clearances > 0
    return {"distance_us": distance_us, "margin_us": margin_us,
            "max_distance_error": float(np.max(np.abs(distances - clearances))),
            "margin_agrees": agree, "within_band": int(sum(within)), "loose_us": loose_us,
            "loose_ratio": float(np.median(loose[free] / clearances[free])),
            "bound_ratio": float(np.median(np.array(bounds)[free] / clearances[free]))}


def main(argv=None) -> int:
    from planners import make_planner
    from planners.base.fileio import InputError
    from planners.worlds.omplapp import load_omplapp, omplapp_dir

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--omplapp", required=True, metavar="DIR", help="OMPL.app's resources/3D folder")
    ap.add_argument("--problem", default="cubicles", help="the .cfg's name")
    ap.add_argument("--seeds", type=int, default=5, help="runs, seeds 0 upwards (0: none)")
    ap.add_argument("--time-limit", type=float, default=20.0, help="each run's limit (s)")
    ap.add_argument("--coal", action="store_true", help="also time coal's queries on poses near the environment")
    ap.add_argument("--poses", type=int, default=400, help="poses for --coal and FCL's own distance (default 400)")
    args = ap.parse_args(argv)
    if args.seeds < 0 or args.time_limit <= 0 or args.poses < 1:
        ap.error("--seeds must be 0 or more, --time-limit positive and --poses at least 1")
    if args.coal:
        try:
            import coal  # noqa: F401
        except ImportError:
            ap.error("--coal needs the coal package (pip install coal), which this project does not depend on")
    cfg = omplapp_dir(args.omplapp) / f"{args.problem}.cfg"
    if not cfg.is_file():
        raise InputError(f"--problem {args.problem}: no {cfg.name} in {cfg.parent}")
    import fcl

    problem = load_omplapp(cfg).problem
    world = problem.world
    make_planner("RRTConnect", problem, seed=0).solve(max_iterations=2)  # compile outside the timing
    calls: dict[str, list[float]] = {"distance": [], "collide": []}
    timed(calls, fcl, "distance")
    timed(calls, fcl, "collide")
    if args.seeds:
        print("| seed | solved | time (s) | iterations | distance calls | distance (s) | contact tests | contact (s) | "
              "rest (s) |")
        print("|---|---|---|---|---|---|---|---|---|")
    shares = []
    for seed in range(args.seeds):
        for v in calls.values():
            v.clear()
        planner = make_planner("RRTConnect", problem, seed=seed)
        t0 = time.perf_counter()
        r = planner.solve(max_iterations=10**9, time_limit=args.time_limit)
        total = time.perf_counter() - t0
        d, c = sum(calls["distance"]), sum(calls["collide"])
        shares.append((d / total, c / total))
        print(f"| {seed} | {r.solved} | {total:.3f} | {r.iterations} | {len(calls['distance'])} | {d:.3f} | "
              f"{len(calls['collide'])} | {c:.3f} | {total - d - c:.3f} |")
    if shares:
        print(f"\nmedian shares of the time: FCL's distance {statistics.median(s[0] for s in shares):.0%}, its contact "
              f"test {statistics.median(s[1] for s in shares):.0%}")
    if args.coal:
        for v in calls.values():
            v.clear()
        states, clearances = near_poses(world, args.poses, seed=0)
        for q in states:
            world.clearance(q)
        fcl_us = statistics.mean(calls["distance"]) * 1e6
        costs = coal_costs(world, states, clearances)
        print(f"\n{len(states)} poses with clearance in (0, 10 delta): FCL's distance {fcl_us:.1f} us a pose, coal's "
              f"{costs['distance_us']:.1f} us (largest difference {costs['max_distance_error']:.1e}); coal's collision "
              f"test with a margin of delta / 2 {costs['margin_us']:.1f} us, agreeing with FCL's distance on "
              f"{costs['margin_agrees']} of {len(states)} poses ({costs['within_band']} within the band); coal's "
              f"distance allowed a relative error of 0.5 {costs['loose_us']:.1f} us (median {costs['loose_ratio']:.3f} "
              f"of the distance); the lower bound its collision test reports, median {costs['bound_ratio']:.3f} of "
              f"the distance")
    return 0


if __name__ == "__main__":
    sys.exit(main())
