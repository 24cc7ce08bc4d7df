"""Cost of one pose check on OMPL.app's mesh problems: FCL alone against the world's compiled check.

    python scripts/benchmark_mesh.py --omplapp DIR                       # cubicles and Twistycool
    python scripts/benchmark_mesh.py --omplapp DIR --problems Easy Home --motions 300
    python scripts/benchmark_mesh.py --omplapp DIR --solutions     # replay every shipped .path instead
    python scripts/benchmark_mesh.py --omplapp DIR --time-limit 1  # each planner under a 1 s limit instead

The motions are seeded random collision-free ones (so each is followed to its end): from a valid
state, a move of up to ``--reach`` of the bounds' diagonal along each axis and up to 0.5 rad about
each. For each problem it prints: the poses per motion a travel of ``delta`` apart; FCL alone at
each of them (a collision test and, where free, a distance test against the band every checked pose
keeps, ``delta / 8`` by default; one Python call per pose), per pose and per motion; the world's motion
check (the grid's bounds, the compiled exact test at a few margins where they do not suffice, steps as
long as the clearance certified), per motion and per pose a travel of ``delta`` apart; and the cost of single states (a
collision test, no clearance), FCL alone and the world's check.

With ``--solutions`` it replays instead every ``.path`` solution OMPL.app ships beside a ``.cfg`` of the
same name: its states, how many are valid here, and the smallest clearance among them. With
``--time-limit T`` it runs each planner once (``--seed``) under that limit on each problem and prints the
seconds it took, after the same run once untimed so that nothing it runs is compiled inside the timing.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from planners.base.fileio import InputError, check_int_flags


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--omplapp", help="OMPL.app's root or resources/3D folder (default $SAMPLERGYM_OMPLAPP_DIR)")
    ap.add_argument("--problems", nargs="+", default=["cubicles", "Twistycool"], help="names of .cfg files")
    ap.add_argument("--motions", type=int, default=200, help="tree edges timed per problem")
    ap.add_argument("--states", type=int, default=2000, help="random states timed per problem")
    ap.add_argument("--reach", type=float, default=0.02,
                    help="largest move along each axis, as a fraction of the bounds' diagonal")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--solutions", action="store_true", help="replay OMPL.app's .path solutions instead")
    ap.add_argument("--time-limit", type=float, help="run each planner under this limit instead")
    args = ap.parse_args(argv)
    try:
        check_int_flags(args, ("motions", "states"))
        check_int_flags(args, ("seed",), low=0)
        from planners.worlds.omplapp import load_omplapp, omplapp_dir

        folder = omplapp_dir(args.omplapp)
        if folder is None:
            raise InputError("give --omplapp DIR or set SAMPLERGYM_OMPLAPP_DIR (OMPL.app's root or resources/3D)")
        if args.solutions:
            return replay(folder)
        if args.time_limit is not None:
            return time_limits(folder, args)
        print("| problem | triangles (env / robot) | poses per motion at delta | FCL alone, us per pose | FCL alone, "
              "ms per motion | motion check, ms per motion | motion check, us per pose at delta | FCL state test, us | "
              "state check, us |")
        print("|---|---|---|---|---|---|---|---|---|")
        for name in args.problems:
            row = measure(load_omplapp(folder / f"{name}.cfg").problem, args)
            print(f"| {name} | " + " | ".join(row) + " |", flush=True)
    except (InputError, ImportError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


TIMED = ("RRT", "RRTConnect", "RRTstar", "PRM", "LazyPRM", "OBPRM")


def time_limits(folder, args) -> int:
    """Each planner once under ``args.time_limit`` on each problem: the seconds it took, compilation left out."""
    from planners import make_planner
    from planners.worlds.omplapp import load_omplapp

    if not (args.time_limit > 0):
        raise InputError(f"--time-limit must be a positive number of seconds, got {args.time_limit}")
    print(f"| problem | planner | seconds under time_limit={args.time_limit:g} | iterations | solved |")
    print("|---|---|---|---|---|")
    for name in args.problems:
        problem = load_omplapp(folder / f"{name}.cfg").problem
        for planner_name in TIMED:
            # the same solve once before, so that everything it compiles (a solved run's path included) is compiled
            make_planner(planner_name, problem, seed=args.seed).solve(time_limit=args.time_limit)
            planner = make_planner(planner_name, problem, seed=args.seed)
            t = time.perf_counter()
            r = planner.solve(time_limit=args.time_limit)
            spent = time.perf_counter() - t - planner.compile_time
            print(f"| {name} | {planner_name} | {spent:.3f} | {r.iterations} | {r.solved} |", flush=True)
    return 0


def replay(folder) -> int:
    """Print, for every .path beside a .cfg, how many of its states are valid here.

    A problem that does not load (a start or goal in collision) is replayed in its world alone, the reason noted.
    """
    from planners.worlds.omplapp import load_omplapp, load_omplapp_world, read_omplapp_path

    print("| problem | solution states | valid here | smallest clearance | note |")
    print("|---|---|---|---|---|")
    for solution in sorted(folder.glob("*.path"), key=lambda p: p.name.lower()):
        cfg = solution.with_suffix(".cfg")
        if not cfg.is_file():
            continue
        note = ""
        try:
            w = load_omplapp(cfg).problem.world
        except InputError as e:
            note = f"problem not loaded: {str(e).removeprefix(f'{cfg}: ')}"
            try:
                w = load_omplapp_world(cfg)
            except InputError as e:
                print(f"| {cfg.stem} | | | | not loaded: {str(e).removeprefix(f'{cfg}: ')} |", flush=True)
                continue
        Q = read_omplapp_path(solution)
        valid = sum(w.is_valid(q) for q in Q)
        clearance = min(w.clearance(q) for q in Q)
        print(f"| {cfg.stem} | {len(Q)} | {valid} | {clearance:.3g} | {note} |", flush=True)
    return 0


def free_motions(world, count: int, rng: np.random.Generator, reach: float) -> tuple[np.ndarray, np.ndarray]:
    """``count`` collision-free motions: from a random valid state, a move of up to ``reach`` along each axis
    and up to 0.5 rad about each, kept when the motion check passes."""
    low, high = world.bounds
    A, B = [], []
    while len(A) < count:
        a = low + (high - low) * rng.random(6)
        if not world.is_valid(a):
            continue
        b = a + np.concatenate([rng.uniform(-reach, reach, 3), rng.uniform(-0.5, 0.5, 3)])
        b[:3] = np.clip(b[:3], low[:3], high[:3])
        if world.check_motion(a, b):
            A.append(a)
            B.append(b)
    return np.array(A), np.array(B)


def measure(problem, args) -> list[str]:
    w = problem.world
    rng = np.random.default_rng(args.seed)
    reach = args.reach * float(np.linalg.norm(w.bounds[1][:3] - w.bounds[0][:3]))
    A, B = free_motions(w, args.motions, rng, reach)
    dense = np.concatenate([w.motion_poses(a, b) for a, b in zip(A, B, strict=True)])
    poses = len(dense)
    assert w.check_motions(A, B).all()
    # the world's check: the grid's bounds, the exact test where they do not suffice, steps as long as the clearance
    t = time.perf_counter()
    w.check_motions(A, B)
    ours = time.perf_counter() - t
    # FCL alone, one call per pose, at every pose a travel of delta apart
    t = time.perf_counter()
    assert all(w.pose_free_exact(q, w.band) for q in dense)
    fcl_alone = time.perf_counter() - t
    # single states: a collision test only
    low, high = w.bounds
    S = low + (high - low) * rng.random((args.states, 6))
    w.check_motions(S[:2], S[:2])
    t = time.perf_counter()
    w.check_motions(S, S)
    state_ours = (time.perf_counter() - t) / len(S) * 1e6
    t = time.perf_counter()
    for q in S:
        w.pose_free_exact(q)
    state_fcl = (time.perf_counter() - t) / len(S) * 1e6
    return [f"{len(w.env_faces):,} / {len(w.body_faces):,}", f"{poses / len(A):.0f}", f"{fcl_alone / poses * 1e6:.1f}",
            f"{fcl_alone / len(A) * 1e3:.2f}", f"{ours / len(A) * 1e3:.2f}", f"{ours / poses * 1e6:.1f}",
            f"{state_fcl:.1f}", f"{state_ours:.1f}"]


if __name__ == "__main__":
    sys.exit(main())
