"""Compile the learned samplers' kernels into the cache ahead of use: ``python -m learning.compile``.

``python -m planners.compile`` compiles every planner's own kernels; a learned sampler's compiled parts (the route
field's draw inside each planner's loop, the encoder's Dijkstra and cell head, the policy's network, the 6-DoF
route's search) compile at their first use, without a notice: after ``planners.compile`` alone, a first
``plan.py --sampler route`` still waits about 27 s for them on a 2-core machine. This runs, for each learned sampler
and each planner, two short seeded solves (a query and the reverse one on the same map) on ``planners.compile``'s
small problems (the 2-D samplers on the
occupancy grid, the 6-DoF ones on the rigid body among boxes and, with the ``mesh`` extra, among triangle meshes), in
worker processes as ``planners.compile`` runs its jobs, into the same cache folder; the planners' own kernels compile
on the way where they were not compiled before.

    python -m learning.compile                      # every learned sampler with every planner, a progress bar
    python -m learning.compile --samplers route route_lazy --planners RRT RRTConnect
    python -m learning.compile --list               # what would be compiled, and where
    python -m learning.compile --jobs 1             # in this process only

A combination that the sampler or the planner refuses is skipped.
"""

from __future__ import annotations

import sys
import time

from planners.base.fileio import InputError
from planners.base.registry import make_planner
from planners.compile import ITERATIONS, WORLDS, command_parser, installed_worlds, refusal, run_command

#: The learned samplers (and their ablations and references) of the 2-D maps, compiled on the occupancy grid.
GRID_SAMPLERS = ("route", "route_lazy", "route_ablation", "follower", "exact_route", "expert", "policy",
                 "policy_ablation")
#: The 6-DoF ones, compiled on the rigid body among boxes and among meshes (the world's default metrics).
RIGID_SAMPLERS = ("rigid_route", "rigid_route_ablation", "rigid_workspace_route")
#: Sampler -> the world kinds it is compiled on.
SAMPLER_WORLDS = {**{s: ("grid",) for s in GRID_SAMPLERS}, **{s: ("rigid", "mesh") for s in RIGID_SAMPLERS}}


def jobs(samplers: list[str], planners: list[str], installed: list[str]) -> list[tuple[str, str, str, str]]:
    """(planner, world kind, metric, sampler) jobs: each sampler with each planner on each of its world kinds
    among ``installed``, at each of the world's default metrics.
    """
    out = []
    for s in samplers:
        for w in SAMPLER_WORLDS[s]:
            if w in installed:
                out += [(p, w, m, s) for m in WORLDS[w][1] for p in planners]
    return out


def compile_sampler(planner: str, world: str, metric: str, sampler: str) -> float | None:
    """One short seeded solve of ``planner`` with ``sampler`` on ``world``'s small problem, so that what the pair runs
    compiles into the cache; the seconds it took, or None where the sampler or the planner refuses the problem.
    """
    from learning.samplers.registry import make_sampler

    t0 = time.perf_counter()
    problem = WORLDS[world][0](metric)
    try:
        learned = make_sampler(sampler)
        p = make_planner(planner, problem, sampler=learned, seed=0)
    except (InputError, ValueError):
        return None
    p.solve(max_iterations=ITERATIONS)
    # a later query on the same map with the same sampler: what it runs over what it keeps of a map (the route
    # encoder's window of the goal)
    make_planner(planner, problem.with_query(problem.goal, problem.start), sampler=learned, seed=0).solve(
        max_iterations=ITERATIONS)
    if (sampler, world, planner) == ("route", "grid", "RRT"):  # a map the encoder reads coarser (its coarsening and
        # the field's interpolation; at the step the encoder reads a step as its own)
        make_planner(planner, coarse_problem(), sampler=learned, step_size=4.0, seed=0).solve(max_iterations=ITERATIONS)
    return time.perf_counter() - t0


def coarse_problem():
    """A map large enough, and open enough, that the route encoder reads it coarser (``RouteSampler.coarse_side``):
    a wall across, with a wide gap.
    """
    import numpy as np

    from learning.samplers.route import COARSE_SIDE
    from planners import OccupancyGrid, Problem

    side = 2 * COARSE_SIDE
    obstacles = np.zeros((side, side), dtype=bool)
    obstacles[side // 2, side // 8:] = True
    return Problem(OccupancyGrid(obstacles), [side - 8.5, 8.5], [side - 8.5, side - 8.5], goal_tolerance=4.0)


def main(argv: list[str] | None = None) -> int:
    """Command line entry point."""
    learned = list(SAMPLER_WORLDS)
    ap = command_parser("python -m learning.compile", __doc__)
    ap.add_argument("--samplers", nargs="+", default=learned, metavar="NAME",
                    help=f"default: all ({', '.join(learned)})")
    args = ap.parse_args(argv)
    if why := refusal(args, {"--samplers": (args.samplers, learned)}):
        print(why, file=sys.stderr)
        return 2
    todo = jobs(args.samplers, args.planners, installed_worlds(w for s in args.samplers for w in SAMPLER_WORLDS[s]))
    return run_command(todo, args.jobs, list_only=args.list, no_progress=args.no_progress, compile=compile_sampler,
                       what="planner/world/metric/sampler")


if __name__ == "__main__":
    sys.exit(main())
