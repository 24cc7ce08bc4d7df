"""Samplers on the validation maps: where their settings are chosen, never the test maps.

    python scripts/experiments/validate_samplers.py --sampler ranked=route_variants:ranked \
        --sampler ablation=route_variants:ranked_ablation          # 20 maps per family, 3 seeds, 128x128
    python scripts/experiments/validate_samplers.py --sampler exact=route_variants:ranked_exact \
        --families narrow_passage --maps 100

Each ``--sampler`` is a spec as ``evaluate.py`` takes it (``NAME=module:callable`` or an SB3 model).
RRT, step and tolerance 4, on the generated families' validation seeds; per family the median
iterations-to-solution (unsolved runs at the cap), its median ratio to the iteration lower bound, the
success rate and the median wall time per query.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.append(os.getcwd())  # --sampler NAME=module:callable finds modules in the working directory

from learning import evaluation as E
from learning.samplers.registry import checked_user_samplers
from planners.base.fileio import InputError, check_int_flags
from planners.maps.generators import FAMILIES, MIN_SIZE, VALIDATION_SEED0
from planners.tools.benchmark import markdown_table
from planners.tools.parallel import add_backend_arguments, check_backend_arguments


def main(argv=None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sampler", action="append", required=True, metavar="NAME=SPEC", help="repeatable")
    ap.add_argument("--families", nargs="+", choices=FAMILIES, default=list(FAMILIES))
    ap.add_argument("--maps", type=int, default=20, help="validation maps per family")
    ap.add_argument("--seeds", type=int, default=3, help="planner seeds per map")
    ap.add_argument("--size", type=int, default=E.Protocol.size)
    ap.add_argument("--max-iterations", type=int, default=E.Protocol.max_iterations)
    add_backend_arguments(ap, processes=2, backend_help="where the runs execute", processes_help="workers for them")
    args = ap.parse_args(argv)
    check_backend_arguments(ap, args)
    try:
        check_int_flags(args, ("maps", "seeds", "size", "max_iterations"))
        if args.size < MIN_SIZE:
            raise InputError(f"--size must be at least {MIN_SIZE} (the smallest generated map), got {args.size}")
        samplers = checked_user_samplers(args.sampler, "--sampler", E.BUILTIN_SAMPLERS)
    except (ValueError, FileNotFoundError) as exc:
        ap.error(str(exc))
    protocol = E.Protocol(max_iterations=args.max_iterations)
    queries = [E.Query(f, VALIDATION_SEED0 + i, args.size, "validation") for f in args.families
               for i in range(args.maps)]
    tasks = [E.Task(q, "RRT", E.SamplerSpec.user(name, spec), seed) for name, spec in samplers.items()
             for q in queries for seed in range(args.seeds)]
    t0 = time.perf_counter()
    runs = E.run_on_backend_args(tasks, protocol, args)
    rows = []
    for name in samplers:
        row = {"sampler": name}
        for f in args.families:
            rs = [r for r in runs if r.sampler == name and r.map == f]
            its = np.array([r.iterations for r in rs], dtype=float)
            lb = np.array([max(r.lower_bound, 1) for r in rs], dtype=float)
            row[f] = (f"{np.median(its):,.0f} ({np.median(its / lb):.1f}x, {np.mean([r.solved for r in rs]):.2f}, "
                      f"{np.median([r.wall_time for r in rs]) * 1e3:.2f} ms)")
        rows.append(row)
    print(markdown_table(rows))
    print(f"\nper family: median iterations (/ lower bound, success, median wall per query); {len(runs)} runs on "
          f"{len(queries)} validation maps, {time.perf_counter() - t0:.0f} s")
    return rows


if __name__ == "__main__":
    main()
