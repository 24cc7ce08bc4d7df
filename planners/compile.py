"""Compile every planner's kernels into the cache ahead of use: ``python -m planners.compile``.

For each registered planner and each world kind (occupancy grid, circles and rectangles, 6-DoF rigid
body among boxes, and among triangle meshes where the ``mesh`` extra is installed) and metric, one short
seeded solve on a small problem runs every kernel that kind of run uses, so a later first solve loads
them from the cache in a fraction of a second. From then on the classical samplers (uniform, goal bias)
draw inside RRT's, RRT-Connect's and RRT*'s compiled loops on the 2-D world kinds
(``draw_classical_in_loops``). The cache folder and how it stays honest are described in
``docs/compiling.md`` (``planners.kernels.cache``).

    python -m planners.compile               # everything installed, with a progress bar
    python -m planners.compile --planners RRT RRTConnect --worlds grid
    python -m planners.compile --worlds mesh # the mesh worlds' kernels (OMPL.app's problems use them)
    python -m planners.compile --list        # what would be compiled, and where
    python -m planners.compile --jobs 1      # in this process only

The jobs come in groups that share kernels (one world family, 2-D or 6-DoF, and one metric: the same
nearest-neighbour search and world checks), and run in worker processes, by default one a group and at most one a
CPU the process may use (``--jobs N`` sets how many): a process runs its group's jobs one after another, so that
what they share compiles once, then takes the largest group not begun, else joins the one with the most jobs left.
numba replaces each cache file whole, so processes writing side by side leave no broken file (at worst a later run
compiles a function again).

A combination the planner refuses (Informed RRT* on the rigid body) is skipped.
"""

from __future__ import annotations

import argparse
import importlib.util
import multiprocessing
import os
import queue
import signal
import sys
import time
from collections.abc import Callable, Iterable, Iterator

import numpy as np

from planners.base.problem import Problem
from planners.base.registry import make_planner, planner_names
from planners.base.samplers import GoalBiasedSampler, draw_classical_in_loops
from planners.kernels import cache
from planners.worlds.grid import OccupancyGrid
from planners.worlds.rigid3d import thin_wall_scene
from planners.worlds.shapes import Circle, GeometricWorld, Rectangle


def _grid(metric: str) -> Problem:
    obs = np.zeros((24, 32), dtype=bool)
    obs[4:20, 14:17] = True
    return Problem(OccupancyGrid(obs), (2.5, 2.5), (29.5, 21.5), goal_tolerance=1.5, metric=metric)


def _shapes(metric: str) -> Problem:
    world = GeometricWorld(32.0, 24.0, [Circle(10.0, 12.0, 4.0), Rectangle(18.0, 4.0, 21.0, 20.0)])
    return Problem(world, (2.5, 2.5), (29.5, 21.5), goal_tolerance=1.5, metric=metric)


def _rigid(metric: str) -> Problem:
    return thin_wall_scene(hole=4.0, metric=metric)


def _mesh(metric: str) -> Problem:
    """The rigid kind's thin-wall scene written as triangle meshes (a mesh world needs no mesh file)."""
    from planners.worlds.rigid_scenes import as_mesh_scene

    return as_mesh_scene(_rigid(metric))


def mesh_installed() -> bool:
    """Whether the ``mesh`` extra (trimesh and FCL) is installed, so mesh worlds can be built."""
    return all(importlib.util.find_spec(m) is not None for m in ("trimesh", "fcl"))


#: world kind -> (problem maker, metrics compiled by default)
WORLDS: dict[str, tuple[Callable[[str], Problem], tuple[str, ...]]] = {
    "grid": (_grid, ("euclidean",)),
    "shapes": (_shapes, ("euclidean",)),
    "rigid": (_rigid, ("cossin", "se3")),
    "mesh": (_mesh, ("cossin", "se3")),
}
#: World kinds that need an extra, by the check that says it is installed and the extra's name.
NEEDS = {"mesh": (mesh_installed, "mesh")}
#: World kinds on which the classical samplers draw inside the compiled loops once compiled: the 2-D ones, where a
#: return to Python per refill is a tenth of a solve's time or more; a 6-DoF iteration's checks take a hundred times
#: longer than that return, so there the loops would add compiling and no speed.
CLASSICAL_WORLDS = ("grid", "shapes")
#: Samples per solve: enough to reach a first solution (path extraction compiles then) on these maps.
ITERATIONS = 400


def jobs(planners: list[str], worlds: list[str], metrics: list[str] | None = None) -> list[tuple[str, str, str]]:
    """(planner, world kind, metric) triples to compile; ``metrics`` None: each world's defaults."""
    out = []
    for w in worlds:
        for m in metrics if metrics is not None else WORLDS[w][1]:
            out += [(p, w, m) for p in planners]
    return out


#: The world kinds whose jobs share a space (and so a nearest-neighbour search): 2-D or 6-DoF.
FAMILY = {"grid": "2d", "shapes": "2d", "rigid": "6dof", "mesh": "6dof"}


def default_jobs() -> int:
    """The most worker processes by default: the CPUs this process may run on (``os.sched_getaffinity``, else all)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on every platform
        return max(1, os.cpu_count() or 1)


def job_groups(todo: list[tuple[str, ...]]) -> list[list[tuple[str, ...]]]:
    """``todo`` in groups of jobs that share compiled kernels (one world family and metric, the jobs' second and third
    entries), in ``todo``'s order.
    """
    groups: dict[tuple[str, str], list[tuple[str, ...]]] = {}
    for job in todo:
        groups.setdefault((FAMILY[job[1]], job[2]), []).append(job)
    return list(groups.values())


#: Where a worker takes its jobs: a group, and whether from its end (a second worker in a group).
Place = tuple[int, bool]


class JobQueue:
    """Hands a worker its next job: more of its own group, else the first job of the largest group not begun, else
    the last job of the group with the most left (a second worker in a group goes on from the other end, where the
    first worker's jobs are least alike its own).
    """

    def __init__(self, groups: list[list[tuple[str, str, str]]]) -> None:
        self.left = [list(g) for g in groups]
        self.begun = [False] * len(groups)

    def next(self, place: Place | None) -> tuple[Place, tuple[str, str, str]] | None:
        """The next job for a worker whose last job came from ``place`` (None: none yet), and where it came from;
        None when every job is handed out.
        """
        if place is not None and self.left[place[0]]:
            group, from_end = place
        elif fresh := [i for i, g in enumerate(self.left) if g and not self.begun[i]]:
            group, from_end = max(fresh, key=lambda i: len(self.left[i])), False  # ties: the earliest
        elif busy := [i for i, g in enumerate(self.left) if g]:
            group, from_end = max(busy, key=lambda i: len(self.left[i])), True
        else:
            return None
        self.begun[group] = True
        return (group, from_end), self.left[group].pop(-1 if from_end else 0)


def _quiet_worker() -> None:
    cache.set_compile_notice(False)  # the parent's progress says it
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the parent, which stops the workers


def run_jobs(todo: list[tuple[str, ...]], workers: int,
             compile: Callable[..., float | None] | None = None) -> Iterator[tuple[tuple[str, ...], float | None,
                                                                                  list[tuple[str, ...]]]]:
    """Compile ``todo`` in ``workers`` processes (``JobQueue``'s order), yielding ``(job, seconds, running)`` as each
    job ends, ``running`` the jobs still under way (1 worker: in this process, in ``todo``'s order, ``running`` the
    next job). A job that fails, or an interrupt, stops the workers (what they compiled stays in the cache) and
    raises.

    ``compile`` runs one job, ``compile(*job)`` (default ``compile_one``: jobs of (planner, world kind, metric); a
    module-level function, so a worker process can receive it); the world kind and metric come second and third,
    as they group the jobs (``job_groups``).
    """
    compile = compile_one if compile is None else compile
    if workers <= 1:
        for i, job in enumerate(todo):
            yield job, compile(*job), todo[i + 1:i + 2]
        return
    jobs = JobQueue(job_groups(todo))
    context = multiprocessing.get_context("spawn")  # a fresh interpreter: nothing of this process's state is copied
    # one pool of one process a worker, so that a worker keeps what it compiled in memory for its group's next job
    pools = [context.Pool(1, initializer=_quiet_worker) for _ in range(min(workers, len(todo)))]
    ended: queue.SimpleQueue = queue.SimpleQueue()  # (lane, place, job, seconds, error), from the pools' threads
    running: dict[int, tuple[str, ...]] = {}

    def submit(lane: int, place: Place, job: tuple[str, ...]) -> None:
        running[lane] = job
        pools[lane].apply_async(compile, job,
                                callback=lambda s, a=(lane, place, job): ended.put((*a, s, None)),
                                error_callback=lambda e, a=(lane, place, job): ended.put((*a, None, e)))

    try:
        for lane in range(len(pools)):
            if (nxt := jobs.next(None)) is not None:
                submit(lane, *nxt)
        while running:
            lane, place, job, seconds, error = ended.get()
            del running[lane]
            if error is not None:
                raise RuntimeError(f"compiling {' '.join(job)} failed: {error}") from error
            if (nxt := jobs.next(place)) is not None:
                submit(lane, *nxt)
            yield job, seconds, list(running.values())
    finally:
        for pool in pools:
            pool.terminate()
        for pool in pools:
            pool.join()


def compile_one(planner: str, world: str, metric: str) -> float | None:
    """Run one short solve so its kernels compile into the cache; the seconds it took, or None if the
    planner does not run on that world (Informed RRT* needs a Euclidean real-vector space).

    On a 2-D world kind (``CLASSICAL_WORLDS``) a planner with a compiled loop (RRT, RRT-Connect, RRT*) then has the
    classical samplers draw inside it (``draw_classical_in_loops``) and solves with uniform sampling and with goal
    bias (``plan.py``'s default for RRT and RRT*).
    """
    t0 = time.perf_counter()
    problem = WORLDS[world][0](metric)
    try:
        p = make_planner(planner, problem, seed=0)
    except ValueError:
        return None
    classical = p.fusable_loop is not None and world in CLASSICAL_WORLDS
    if classical:
        draw_classical_in_loops(problem, (p.fusable_loop,))
        p.clear()  # bound again: its sampler draws in the loop from here
    p.solve(max_iterations=ITERATIONS)
    if classical:
        make_planner(planner, problem, sampler=GoalBiasedSampler(0.05), seed=0).solve(max_iterations=ITERATIONS)
    return time.perf_counter() - t0


def installed_worlds(wanted: Iterable[str]) -> list[str]:
    """The world kinds of ``wanted`` whose extras are installed, in ``WORLDS``' order; one line on stderr for each
    one left out, naming the extra that brings it.
    """
    wanted = set(wanted)
    for w in (w for w in NEEDS if w in wanted and not NEEDS[w][0]()):
        print(f"{w} worlds: not compiled, the {NEEDS[w][1]} extra is not installed "
              f"(pip install -c constraints.txt -e '.[{NEEDS[w][1]}]')", file=sys.stderr)
    return [w for w in WORLDS if w in wanted and (w not in NEEDS or NEEDS[w][0]())]


def command_parser(prog: str, doc: str) -> argparse.ArgumentParser:
    """A compile command's parser with the options every compile command takes (``--planners``, ``--list``,
    ``--no-progress``, ``--jobs``); ``doc``'s first line describes it.
    """
    names = list(planner_names())
    ap = argparse.ArgumentParser(prog=prog, description=doc.split("\n")[0])
    ap.add_argument("--planners", nargs="+", default=names, metavar="NAME", help=f"default: all ({', '.join(names)})")
    ap.add_argument("--list", action="store_true", help="print what would be compiled and the cache folder, then exit")
    ap.add_argument("--no-progress", action="store_true", help="no progress bar (one line per job instead)")
    ap.add_argument("--jobs", type=int, default=None, metavar="N",
                    help="worker processes (default: one per group of jobs that share kernels, at most one per CPU "
                         "this process may use; 1: in this process)")
    return ap


def refusal(args: argparse.Namespace, values: dict[str, tuple[list[str], list[str]]]) -> str | None:
    """Why a compile command's ``args`` are refused (``--jobs`` below 1, ``--planners`` or an option of ``values``,
    ``{flag: (given, allowed)}``, naming what is not allowed), or None.
    """
    if args.jobs is not None and args.jobs < 1:
        return f"--jobs: must be at least 1, got {args.jobs}"
    for label, (given, allowed) in {"--planners": (args.planners, list(planner_names())), **values}.items():
        if bad := [v for v in given if v not in allowed]:
            return f"{label}: unknown value {bad[0]!r}; expected one of {', '.join(allowed)}"
    return None


def main(argv: list[str] | None = None) -> int:
    """Command line entry point."""
    ap = command_parser("python -m planners.compile", __doc__)
    ap.add_argument("--worlds", nargs="+", default=None, metavar="KIND",
                    help=f"default: all whose extras are installed ({', '.join(WORLDS)})")
    ap.add_argument("--metrics", nargs="+", default=None, metavar="METRIC",
                    help="default: each world's own (grid, shapes: euclidean; rigid: cossin, se3)")
    args = ap.parse_args(argv)
    if why := refusal(args, {"--worlds": (args.worlds or [], list(WORLDS))}):
        print(why, file=sys.stderr)
        return 2
    missing = [w for w in NEEDS if not NEEDS[w][0]()]
    if args.worlds is None:
        args.worlds = installed_worlds(WORLDS)
    elif absent := [w for w in args.worlds if w in missing]:
        w = absent[0]
        print(f"--worlds {w}: needs the {NEEDS[w][1]} extra (pip install -c constraints.txt -e '.[{NEEDS[w][1]}]')",
              file=sys.stderr)
        return 2
    todo = jobs(args.planners, args.worlds, args.metrics)
    for _, w, m in todo:  # checked before any compiling starts
        try:
            WORLDS[w][0](m)
        except ValueError as e:
            print(f"--metrics: {m!r} does not fit the {w} world ({e})", file=sys.stderr)
            return 2
    return run_command(todo, args.jobs, list_only=args.list, no_progress=args.no_progress)


def run_command(todo: list[tuple[str, ...]], jobs: int | None, *, list_only: bool = False, no_progress: bool = False,
                compile: Callable[..., float | None] | None = None, what: str = "planner/world/metric") -> int:
    """What a compile command does once its arguments are checked: say where the cache is, then list ``todo``
    (``list_only``) or compile it (``compile_all``, in ``jobs`` processes; None: one a group of jobs that share
    kernels, at most one a CPU) and say how long it took; the exit status (130 when interrupted).
    """
    print(f"compiled kernels are cached in {cache.cache_dir()}", file=sys.stderr)
    if list_only:
        for job in todo:
            print(" ".join(job))
        return 0
    cache.set_compile_notice(False)  # the progress bar says it
    # by default one process a group (so that nothing a group shares compiles twice), at most one a CPU
    workers = min(default_jobs(), len(job_groups(todo))) if jobs is None else min(jobs, len(todo))
    t0 = time.perf_counter()
    try:
        compile_all(todo, workers, no_progress, compile)
    except KeyboardInterrupt:
        print("interrupted: what compiled so far stays in the cache", file=sys.stderr)
        return 130
    processes = f" ({workers} processes)" if workers > 1 else ""
    print(f"compiled {len(todo)} {what} combinations in {time.perf_counter() - t0:.0f} s{processes}", file=sys.stderr)
    return 0


def compile_all(todo: list[tuple[str, ...]], workers: int, no_progress: bool,
                compile: Callable[..., float | None] | None = None) -> None:
    """``run_jobs`` with a progress bar, or one line per job (``no_progress``)."""
    if no_progress:
        for i, (job, seconds, _) in enumerate(run_jobs(todo, workers, compile)):
            took = "does not run there, skipped" if seconds is None else f"{seconds:.1f} s"
            print(f"[{i + 1}/{len(todo)}] {' '.join(job)}: {took}", file=sys.stderr, flush=True)
        return
    from tqdm import tqdm

    with tqdm(total=len(todo), desc="compiling kernels", unit="job", file=sys.stderr) as bar:
        bar.set_postfix_str(f"{workers} processes" if workers > 1 else " ".join(todo[0]) if todo else "")
        for _, _, running in run_jobs(todo, workers, compile):
            bar.set_postfix_str("; ".join(" ".join(j) for j in running))
            bar.update(1)


if __name__ == "__main__":
    sys.exit(main())
