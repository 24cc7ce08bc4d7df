"""What drawing inside the compiled loops buys the classical samplers, and where the lazy route sampler stands.

    PYTHONPATH=$PWD python scripts/experiments/fused_classical.py --maps 6 --seeds 2

The classical samplers (``UniformSampler``, ``GoalBiasedSampler``) draw inside the planners' compiled loops
(``planners.fused``, ``planners.kernels.draws``), as the learned samplers do. ``DrawnUniform`` and ``DrawnGoalBias``
are the same samplers drawn through Python, one ``draw`` call per refill of the planner's buffer, so the runs are the
same run for run (checked) and only the time differs. On the comparison's held-apart maps (``planner_maps``: shifted,
unseen and MovingAI test queries, ``--maps`` of each family or map), one process and one thread, each (query, seed)
run both ways in turn after a warm-up, RRT with goal bias 0.05, RRT-Connect with uniform sampling and RRT* (to its
first solution) with goal bias 0.05, step 4: prints per planner and map set the median time per query both ways and
their ratio, and the ratio pooled. With ``--lazy`` the lazy route sampler (``make_sampler("route_lazy")``) runs each
(query, seed) too, and its median time is given over each way's.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time

from planners.base.samplers import GoalBiasedSampler, UniformSampler, draw_classical_in_loops


class DrawnUniform(UniformSampler):
    """``UniformSampler`` drawn through Python, one ``draw`` call per refill of the planner's buffer (never fused)."""

    fuse = None


class DrawnGoalBias(GoalBiasedSampler):
    """``GoalBiasedSampler`` drawn through Python (never fused)."""

    fuse = None


#: (planner, the classical sampler drawn through Python, the same drawn in the compiled loop).
SETUPS = (("RRT", lambda: DrawnGoalBias(0.05), lambda: GoalBiasedSampler(0.05)),
          ("RRTConnect", DrawnUniform, UniformSampler),
          ("RRTstar", lambda: DrawnGoalBias(0.05), lambda: GoalBiasedSampler(0.05)))


def run(planner_name: str, problem, sampler, seed: int) -> tuple[float, tuple]:
    """Seconds from building the planner to its first solution (or 20,000 iterations), and what must match.

    RRT* stopped at its first solution runs on to the end of the samples in hand either way (the fused loop's
    batch, the planner's slice), so there only the first solution's iteration and whether it came must match.
    """
    from planners import make_planner

    star = planner_name == "RRTstar"
    draw_classical_in_loops(problem)  # the library's classical samplers draw in the loops; the Drawn ones never
    t0 = time.perf_counter()
    planner = make_planner(planner_name, problem, sampler=sampler, seed=seed, extension_step=4.0,
                           **({"stop_on_first_solution": True} if star else {}))
    r = planner.solve(max_iterations=20000)
    seconds = time.perf_counter() - t0
    return seconds, ((r.solved, r.first_solution_iteration) if star else
                     (r.solved, r.iterations, r.collision_checks, r.num_vertices))


def main(argv=None) -> int:
    from learning.evaluation.every_planner import planner_maps
    from learning.models.threads import planning_threads

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--maps", type=int, default=6, help="queries of each family or MovingAI map (default 6)")
    ap.add_argument("--seeds", type=int, default=2, help="planner seeds per query (default 2)")
    ap.add_argument("--sets", nargs="+", default=["shifted", "unseen", "movingai"],
                    choices=["validation", "shifted", "unseen", "movingai"], help="map sets (default the held-apart)")
    ap.add_argument("--lazy", action="store_true", help="also the lazy route sampler, against both ways")
    args = ap.parse_args(argv)
    if args.maps < 1 or args.seeds < 1:
        ap.error("--maps and --seeds must be at least 1")
    groups = {}
    for which in args.sets:
        try:
            groups.update(planner_maps(which, args.maps))
        except Exception as e:  # the MovingAI maps are not shipped: said, and left out
            print(f"{which}: left out ({e})")
    lazy = None
    if args.lazy:
        from learning.samplers.registry import make_sampler

        lazy = make_sampler("route_lazy")
    print("| planner | map set | through Python (ms) | in the compiled loop (ms) | ratio |"
          + (" lazy route (ms) | lazy / through Python | lazy / in the loop |" if lazy else "")
          + "\n|---|---|---|---|---|" + ("---|---|---|" if lazy else ""))
    with planning_threads(1):
        for planner_name, drawn, fused in SETUPS:
            warm = next(iter(groups.values()))[0]
            run(planner_name, warm, drawn(), 0)
            run(planner_name, warm, fused(), 0)
            if lazy:
                run(planner_name, warm, lazy, 0)
            pooled = []
            for name, problems in groups.items():
                a, b, c = [], [], []
                for p in problems:
                    for seed in range(args.seeds):
                        ta, key_a = run(planner_name, p, drawn(), seed)
                        tb, key_b = run(planner_name, p, fused(), seed)
                        if key_a != key_b:
                            raise SystemExit(f"{planner_name} on {p.name}, seed {seed}: the fused run differs "
                                             f"({key_a} against {key_b})")
                        a.append(ta)
                        b.append(tb)
                        if lazy:
                            c.append(run(planner_name, p, lazy, seed)[0])
                ma, mb = statistics.median(a), statistics.median(b)
                pooled += list(zip(a, b, strict=True))
                row = f"| {planner_name} | {name} | {1e3 * ma:.3f} | {1e3 * mb:.3f} | {mb / ma:.2f} |"
                if lazy:
                    mc = statistics.median(c)
                    row += f" {1e3 * mc:.3f} | {mc / ma:.2f} | {mc / mb:.2f} |"
                print(row)
            ratio = statistics.median([y for _, y in pooled]) / statistics.median([x for x, _ in pooled])
            geo = math.exp(statistics.mean(math.log(y / x) for x, y in pooled))
            print(f"| {planner_name} | pooled | | | {ratio:.2f} (geometric mean of run ratios {geo:.2f}) |"
                  + (" | | |" if lazy else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
