"""How many poses a mesh world's motion check asks, by where its walk places the next pose (``WALK_GUESS``).

    PYTHONPATH=$PWD python scripts/experiments/walk_poses.py --omplapp DIR
    PYTHONPATH=$PWD python scripts/experiments/walk_poses.py --omplapp DIR --problems Twistycool --guesses 1 0.99 0.9

For each problem: RRT-Connect grows a tree for ``--iterations`` iterations (``--seed``); then ``--motions`` motions
like its extensions (from the nearest of a sample of the tree's states towards a uniform state, cut at the planner's
step) are checked by a copy of ``planners.kernels.mesh.mesh_motion_free`` in Python that calls the compiled pieces
(the grid's bound, the exact test's ladder, the contact test) and counts them, once per candidate placement of the
walk's next pose (the last clearance times each of ``--guesses``). Prints per problem and guess, per motion: the
walk's poses, those of them the exact test decides, the gaps (a pose whose clearance did not reach back over the
covered stretch), and how many motions were free; the copy's verdicts at the shipped ``WALK_GUESS`` are checked
against the compiled check's, motion by motion.

With ``--costs``, a second table times the compiled pieces on the same motions (best of 7 passes, one thread): the
grid's bound (``clearance_bound``) on every pose the walk at ``WALK_GUESS`` asks it about, by its answer (the
bounding sphere proves the pose clear, the cover points do, or undecided, where the exact test follows), and the
compiled motion check per motion.
"""

from __future__ import annotations

import argparse
import sys
import time

import numba as nb
import numpy as np

from planners import make_planner
from planners.base.fileio import InputError, check_flags, check_int
from planners.kernels import geometry
from planners.kernels import mesh as M
from planners.kernels.rigid import motion_pieces
from planners.kernels.space import SPACE_RIGID, interpolate
from planners.worlds.omplapp import load_omplapp, omplapp_dir


def motions(problem, iterations: int, count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``count`` motions (starts, ends) like RRT-Connect's extensions on ``problem`` (see the module docstring)."""
    planner = make_planner("RRTConnect", problem, seed=seed)
    planner.solve(max_iterations=iterations)
    states = planner.planner_data().vertices
    rng = np.random.default_rng(seed)
    tree = states[rng.choice(len(states), size=min(len(states), 400), replace=False)]
    low, high = problem.world.bounds
    starts, ends = [], []
    for _ in range(count):
        x = rng.uniform(low, high)
        d = np.array([problem.distance(v, x) for v in tree])
        v = tree[int(np.argmin(d))]
        if d.min() > planner.step_size:
            q = np.empty(6)
            interpolate(SPACE_RIGID, v, x, planner.step_size / d.min(), q)
            x = q
        starts.append(v)
        ends.append(np.asarray(x, dtype=np.float64))
    return np.array(starts), np.array(ends)


def walk(kernel, a, b, guess: float, counts: dict, asked: list | None = None) -> bool:
    """``mesh_motion_free(a, b)`` with the next pose ``guess`` times the last clearance on, counting into ``counts``
    (and each pose the grid's bound is asked about, with its margin, appended to ``asked`` where given)."""
    grid, clusters, body, params = kernel.grid, kernel.geom, kernel.body, kernel.params
    cover = body[:int(params[M.P_PARTS])]
    hint = np.full(2, -1, dtype=np.int64)

    def pose(q, need, low_first, where):
        if asked is not None:
            asked.append(np.r_[q, need])
        c = M.clearance_bound(grid, cover, clusters, params, q, need)
        if c > need:
            return c
        counts[where + " exact"] = counts.get(where + " exact", 0) + 1
        return M.exact_clearance(body, params, q, need, np.bool_(low_first), hint)

    n, length = motion_pieces(params, a, b)
    margin = params[M.P_BAND]
    least = 2.0 * margin
    cb = pose(b, margin, True, "end")
    if not cb > margin:
        return False
    q = np.empty(6)
    if n >= M.PROBE_MIN_PIECES:
        for f in M.PROBE_FRACTIONS:
            interpolate(SPACE_RIGID, a, b, f, q)
            if not M.sphere_free(grid, params, q, 0.0) and not M.exact_apart(body, params, q, 0.0, hint):
                return False
    end, covered, island_lo, island_hi, last, s = length - cb, -1.0, -1.0, -1.0, 0.0, 0.0
    while True:
        interpolate(SPACE_RIGID, a, b, s / length, q)
        counts["walk"] = counts.get("walk", 0) + 1
        c = pose(q, margin, False, "walk")
        if not c > margin:
            return False
        if covered < 0.0 or s - c < covered:
            covered, last = s + c, s
            if 0.0 <= island_lo < covered:
                covered = max(covered, island_hi)
            if covered > end:
                return True
            s = max(last + least, min(covered + guess * c, 0.5 * (covered + end)))
        else:
            counts["gaps"] = counts.get("gaps", 0) + 1
            if s + c > end:
                end = s - c
            else:
                island_lo, island_hi = s - c, s + c
            s = max(covered, last + least)
        if s >= end:
            s = 0.5 * (covered + end)


@nb.njit
def _bounds(grid, cover, clusters, params, asked):
    """``clearance_bound`` at each row ``(q, need)`` of ``asked``, in one compiled loop."""
    out = np.empty(asked.shape[0])
    for i in range(asked.shape[0]):
        out[i] = M.clearance_bound(grid, cover, clusters, params, asked[i, :6], asked[i, 6])
    return out


def _best(f, *args, repeat: int = 7) -> float:
    f(*args)
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        f(*args)
        best = min(best, time.perf_counter() - t0)
    return best


def costs(name: str, kernel, a: np.ndarray, b: np.ndarray) -> str:
    """The ``--costs`` row of one problem (see the module docstring)."""
    rows: list = []
    for x, y in zip(a, b, strict=True):
        walk(kernel, x, y, M.WALK_GUESS, {}, rows)
    asked = np.array(rows)
    grid, clusters, params = kernel.grid, kernel.geom, kernel.params
    cover = kernel.body[:int(params[M.P_PARTS])]
    got = _bounds(grid, cover, clusters, params, asked)
    sphere = np.array([M.sphere_free(grid, params, q[:6], q[6]) for q in asked])
    kinds = {"sphere": sphere, "cover points": ~sphere & (got > asked[:, 6]), "undecided": got <= asked[:, 6]}
    cells = []
    for mask in kinds.values():
        part = np.ascontiguousarray(asked[mask])
        each = _best(_bounds, grid, cover, clusters, params, part) / len(part) * 1e6 if len(part) else np.nan
        cells.append(f"{mask.sum() / len(a):.2f}, {each:.2f}")
    out = np.zeros(len(a), dtype=np.bool_)
    motion = _best(geometry.motions_free, kernel, a, b, out) / len(a) * 1e6
    return f"| {name} | {len(asked) / len(a):.2f} | " + " | ".join(cells) + f" | {motion:.2f} |"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--omplapp", help="OMPL.app's resources/3D folder (or SAMPLERGYM_OMPLAPP_DIR)")
    ap.add_argument("--problems", nargs="+", default=["Twistycool", "cubicles", "Easy"])
    ap.add_argument("--guesses", type=float, nargs="+", default=[1.0, 0.999, 0.99, 0.95, 0.9, 0.85])
    ap.add_argument("--iterations", type=int, default=20000, help="RRT-Connect's iterations before the motions")
    ap.add_argument("--motions", type=int, default=3000)
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--costs", action="store_true", help="also time the compiled pieces (module docstring)")
    args = ap.parse_args(argv)
    folder = None

    def check() -> None:
        nonlocal folder
        check_int(args.iterations, "--iterations")
        check_int(args.motions, "--motions")
        check_int(args.seed, "--seed", low=0)
        for g in args.guesses:
            if not 0.0 < g <= 1.0:
                raise InputError(f"--guesses {g}: expected a share of the last clearance in (0, 1]")
        folder = omplapp_dir(args.omplapp)
        if folder is None:
            raise InputError("OMPL.app's problems not found: pass --omplapp DIR (its resources/3D) or set "
                             "SAMPLERGYM_OMPLAPP_DIR")
        for name in args.problems:
            if not (folder / f"{name}.cfg").is_file():
                raise InputError(f"--problems {name}: no {name}.cfg in {folder}")

    check_flags(check)
    print("| problem | guess | walk poses per motion | of them exact | gaps | free motions |")
    print("|---|---|---|---|---|---|")
    rows = []
    for name in args.problems:
        problem = load_omplapp(folder / f"{name}.cfg").problem
        kernel = problem.world.kernel
        a, b = motions(problem, args.iterations, args.motions, args.seed)
        if args.costs:
            rows.append(costs(name, kernel, a, b))
        compiled = np.zeros(len(a), dtype=np.bool_)
        geometry.motions_free(kernel, a, b, compiled)
        for guess in args.guesses:
            counts: dict = {}
            free = np.array([walk(kernel, x, y, guess, counts) for x, y in zip(a, b, strict=True)])
            if guess == M.WALK_GUESS and not np.array_equal(free, compiled):
                print(f"error: the copy of the walk differs from the compiled check on {name}", file=sys.stderr)
                return 1
            per = {k: v / len(a) for k, v in counts.items()}
            print(f"| {name} | {guess:g} | {per.get('walk', 0):.2f} | {per.get('walk exact', 0):.2f} | "
                  f"{per.get('gaps', 0):.2f} | {int(free.sum())} of {len(a)} |", flush=True)
    if rows:
        print("\n| problem | grid bounds asked per motion | sphere proves: per motion, us each | cover points prove: "
              "per motion, us each | undecided: per motion, us each | motion check, us per motion |")
        print("|---|---|---|---|---|---|")
        print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
