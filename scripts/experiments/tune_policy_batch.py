"""Choose how often the policy decides (``PolicySampler(batch=...)``) on the tuning split.

    python scripts/experiments/tune_policy_batch.py  # batches 8 (trained), 2 and 1; 20 maps per family, 3 seeds
    python scripts/experiments/tune_policy_batch.py --batches 8 4 2 1 --maps 10

The tuning step of ``evaluate.py`` on its own (``learning.evaluation.policy_tuning_tasks`` and
``best_policy_batch``): RRT with the policy at each batch on the generated families' tuning maps,
never the test maps. It names the batch with the lowest sum over families of log median iterations;
batches within ``BATCH_TIE`` of it count as tied, and the largest of them wins (it costs less time).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from learning import PolicySampler
from learning import evaluation as E
from learning.models.shipped import SHIPPED_POLICY
from planners.base.fileio import InputError, check_int_flags
from planners.maps.generators import FAMILIES
from planners.tools.benchmark import markdown_table
from planners.tools.parallel import add_backend_arguments, check_backend_arguments

DEFAULT_POLICY = SHIPPED_POLICY


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--policy", type=Path, default=DEFAULT_POLICY)
    ap.add_argument("--batches", type=int, nargs="+", default=list(E.POLICY_BATCHES))
    ap.add_argument("--maps", type=int, default=20, help="tuning maps per family (evaluate.py's --tuning-maps)")
    ap.add_argument("--seeds", type=int, default=E.POLICY_TUNING_SEEDS)
    ap.add_argument("--max-iterations", type=int, default=E.Protocol.max_iterations)
    add_backend_arguments(ap, processes=2, backend_help="where the runs execute", processes_help="workers for them")
    args = ap.parse_args(argv)
    check_backend_arguments(ap, args)
    try:
        check_int_flags(args, ("maps", "seeds", "max_iterations"))
        for b in args.batches:
            if b < 1:
                raise InputError(f"--batches must be positive integers, got {b}")
        PolicySampler.load(args.policy)
    except (InputError, FileNotFoundError) as exc:
        ap.error(str(exc))
    protocol = E.Protocol(max_iterations=args.max_iterations)
    queries = E.generated_queries(FAMILIES, protocol.size, 0, args.maps)
    tasks = E.policy_tuning_tasks(queries, "RRT", str(args.policy), args.batches, args.seeds)
    t0 = time.perf_counter()
    runs = E.run_on_backend_args(tasks, protocol, args)
    best, score = E.best_policy_batch(runs)
    rows = []
    for b in args.batches:
        mine = [r for r in runs if r.sampler == E.policy_sampler(b)]
        rows.append({"batch": b, **{f: f"{np.median([r.iterations for r in mine if r.map == f]):,.0f}"
                                    for f in FAMILIES},
                     "sum of log medians": f"{score[b]:.3f}",
                     "median wall ms": f"{np.median([r.wall_time for r in mine]) * 1e3:.2f}"})
    print(markdown_table(rows))
    print(f"\nchosen batch: {best} ({len(runs)} runs on the tuning maps, {time.perf_counter() - t0:.0f} s)")
    return best


if __name__ == "__main__":
    main()
