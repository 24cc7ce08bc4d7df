"""What one pose's exact answer costs in a mesh world: the compiled test at each margin against FCL's (and coal's).

    PYTHONPATH=$PWD python scripts/experiments/mesh_exact_cost.py --omplapp DIR --problem cubicles
    PYTHONPATH=$PWD python scripts/experiments/mesh_exact_cost.py --omplapp DIR --problem Twistycool --coal

On ``--poses`` random poses of an OMPL.app problem whose clearance (FCL's distance) lies between 0 and ten times the
world's ``delta`` (the poses a motion check cannot settle with its grid), it prints the microseconds per pose of
FCL's contact test and distance (one Python call each), of the world's compiled exact test
(``planners.kernels.mesh.exact_apart``) with no margin and at each margin the walk asks (``CLEARANCE_LADDER``
times ``delta / 2`` above the world's band, and the band), and of ``exact_clearance`` as the walk asks it
(largest margin first), with how many poses each
margin clears and whether every answer agrees with FCL's distance. The compiled calls are timed from Python, so
each includes a call's overhead (about a microsecond) that the motion check, calling from compiled code, does not
pay.

``--coal`` (where the ``coal`` package, the maintained successor of hpp-fcl, is importable: it is not a
dependency of this project) also times coal's distance and its collision test with a security margin of
``delta / 2`` on the same poses, the same triangles in the same frame.
"""

from __future__ import annotations

import argparse
import sys
import time


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
    t0 = time.perf_counter()
    distances = []
    for T in poses:
        dres.clear()
        distances.append(coal.distance(body, T, env, identity, dreq, dres))
    distance_us = (time.perf_counter() - t0) / len(poses) * 1e6
    distances = np.array(distances)
    creq, cres = coal.CollisionRequest(), coal.CollisionResult()
    creq.security_margin = world.delta / 2
    t0 = time.perf_counter()
    within = []
    for T in poses:
        cres.clear()
        within.append(bool(coal.collide(body, T, env, identity, creq, cres)))
    margin_us = (time.perf_counter() - t0) / len(poses) * 1e6
    agree = sum(w == (c <= world.delta / 2) for w, c in zip(within, clearances, strict=True))
    return {"distance_us": distance_us, "margin_us": margin_us,
            "max_distance_error": float(np.max(np.abs(distances - clearances))), "margin_agrees": agree}


def per_pose_us(function, items) -> tuple[list, float]:
    """``function`` on every item: the answers and the microseconds per item."""
    t0 = time.perf_counter()
    out = [function(x) for x in items]
    return out, (time.perf_counter() - t0) / max(len(items), 1) * 1e6


def main(argv=None) -> int:
    from planners.base.fileio import InputError
    from planners.worlds.omplapp import load_omplapp, omplapp_dir

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--omplapp", required=True, metavar="DIR", help="OMPL.app's resources/3D folder")
    ap.add_argument("--problem", default="cubicles", help="the .cfg's name")
    ap.add_argument("--coal", action="store_true", help="also time coal's queries on the same poses")
    ap.add_argument("--poses", type=int, default=400, help="poses near the environment (default 400)")
    args = ap.parse_args(argv)
    if args.poses < 1:
        ap.error("--poses must be at least 1")
    if args.coal:
        try:
            import coal  # noqa: F401
        except ImportError:
            ap.error("--coal needs the coal package (pip install coal), which this project does not depend on")
    cfg = omplapp_dir(args.omplapp) / f"{args.problem}.cfg"
    if not cfg.is_file():
        raise InputError(f"--problem {args.problem}: no {cfg.name} in {cfg.parent}")
    import numpy as np

    from planners.kernels import mesh as mesh_kernels

    world = load_omplapp(cfg).problem.world
    k = world.kernel
    states, clearances = near_poses(world, args.poses, seed=0)
    need = world.band
    none = np.full(2, -1, dtype=np.int64)  # no hint: each pose tested on its own, as from Python
    mesh_kernels.exact_apart(k.body, k.params, states[0], need, none)  # compile outside the timing
    mesh_kernels.exact_clearance(k.body, k.params, states[0], need, np.bool_(False), none)
    rows = []
    _, us = per_pose_us(lambda q: world.pose_free_exact(q), states)
    rows.append(("FCL's contact test", us, "", ""))
    _, us = per_pose_us(world.clearance, states)
    rows.append(("FCL's distance", us, "", ""))
    agree = True
    rungs = [m for m in world.delta / 2 * mesh_kernels.CLEARANCE_LADDER if m > need * mesh_kernels.BAND_RAISE]
    for m in (0.0, need * mesh_kernels.BAND_RAISE, *rungs[::-1]):
        got, us = per_pose_us(lambda q, m=m: mesh_kernels.exact_apart(k.body, k.params, q, m, none), states)
        agree &= all(g == (c > m) for g, c in zip(got, clearances, strict=True) if abs(c - m) > 1e-9)
        rows.append((f"compiled test, margin {m / world.delta:.3g} delta", us, f"{np.mean(got):.2f}", ""))
    got, us = per_pose_us(lambda q: mesh_kernels.exact_clearance(k.body, k.params, q, need, np.bool_(False), none),
                              states)
    got = np.array(got)
    agree &= bool(np.all(got[got > need] < clearances[got > need]))
    rows.append(("exact_clearance (the walk's ladder)", us, f"{np.mean(got > need):.2f}",
                 f"median {np.median(got[got > need] / clearances[got > need]):.2f} of the distance"
                 if np.any(got > need) else ""))
    if args.coal:
        costs = coal_costs(world, states, clearances)
        rows.append(("coal's distance", costs["distance_us"], "",
                     f"largest difference {costs['max_distance_error']:.1e}"))
        rows.append(("coal's collision test, margin 0.5 delta", costs["margin_us"], "",
                     f"agrees with FCL on {costs['margin_agrees']} of {len(states)}"))
    print(f"{args.problem}: {len(states)} poses with clearance in (0, 10 delta), delta {world.delta:.4g}\n")
    print("| query | µs per pose | share of poses cleared | note |\n|---|---|---|---|")
    for name, us, share, note in rows:
        print(f"| {name} | {us:.1f} | {share} | {note} |")
    print(f"\nevery compiled answer agrees with FCL's distance: {agree}")
    return 0 if agree else 1


if __name__ == "__main__":
    sys.exit(main())
