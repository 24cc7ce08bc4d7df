"""Choose how often the policy decides (``PolicySampler(batch=...)``) on the tuning split.

    python scripts/tune_policy_batch.py                  # batches 8 (shipped), 2 and 1; 20 maps per family, 3 seeds
    python scripts/tune_policy_batch.py --batches 8 4 2 1 --maps 10

Runs RRT with the shipped policy at each batch on the generated families' tuning maps (the split on
which ``evaluate.py`` tunes goal bias and the ablation; never its test maps) and names the batch with
the lowest sum over families of log median iterations; batches within ``TIE`` of it count as tied,
and the largest of them wins (it costs less time).
``scripts/policy_variants.py`` has the batches 1 and 2 for ``evaluate.py --sampler``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from learning import PolicySampler
from learning import evaluation as E
from planners import make_planner
from planners.base.fileio import InputError, check_int_flags
from planners.maps.generators import FAMILIES
from planners.tools.benchmark import markdown_table
from planners.tools.parallel import add_backend_arguments, check_backend_arguments, make_backend

DEFAULT_POLICY = Path(__file__).resolve().parents[1] / "checkpoints" / "guided.zip"
TIE = 0.01  # in the sum of log medians: 1% of one family's median


_SAMPLERS: dict[int, PolicySampler] = {}  # one per batch and process: binding reuses its per-map geometry


def _run(task: tuple, context: dict) -> tuple[int, float]:
    """(iterations to solution or the cap, wall seconds of binding and solving) of the policy at one batch."""
    query, batch, seed = task
    base = context["policy"]
    if batch not in _SAMPLERS:
        _SAMPLERS[batch] = PolicySampler(base.actor, base.config, batch=batch)
    sampler = _SAMPLERS[batch]
    problem = query.problem(None, 4.0)
    t0 = time.perf_counter()
    r = make_planner("RRT", problem, extension_step=base.step_size, sampler=sampler,
                     seed=seed).solve(max_iterations=context["max_iterations"])
    return (r.first_solution_iteration if r.solved else context["max_iterations"]), time.perf_counter() - t0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--policy", type=Path, default=DEFAULT_POLICY)
    ap.add_argument("--batches", type=int, nargs="+", default=[8, 2, 1])
    ap.add_argument("--maps", type=int, default=20, help="tuning maps per family (evaluate.py's --tuning-maps)")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--max-iterations", type=int, default=20000)
    add_backend_arguments(ap, processes=2, backend_help="where the runs execute", processes_help="workers for them")
    args = ap.parse_args(argv)
    check_backend_arguments(ap, args)
    try:
        check_int_flags(args, ("maps", "seeds", "max_iterations"))
        for b in args.batches:
            if b < 1:
                raise InputError(f"--batches must be positive integers, got {b}")
    except InputError as exc:
        ap.error(str(exc))
    policy = PolicySampler.load(args.policy)
    queries = [q for q in E.generated_queries(FAMILIES, 128, 0, args.maps) if q.split == "tuning"]
    tasks = [(q, b, s) for b in args.batches for q in queries for s in range(args.seeds)]
    backend = make_backend(args.backend, processes=args.processes, address=args.address, worker_init=E.worker_init)
    t0 = time.perf_counter()
    try:
        out = backend.map(_run, tasks, context={"policy": policy, "max_iterations": args.max_iterations},
                          progress=False)
    finally:
        backend.close()
    rows, score = [], {}
    for b in args.batches:
        row = {"batch": b}
        logs = []
        for f in FAMILIES:
            its = [n for (q, bb, _), (n, _) in zip(tasks, out, strict=True) if bb == b and q.family == f]
            row[f] = f"{np.median(its):,.0f}"
            logs.append(np.log(np.median(its)))
        score[b] = float(np.sum(logs))
        row["sum of log medians"] = f"{score[b]:.3f}"
        walls = [w for (_, bb, _), (_, w) in zip(tasks, out, strict=True) if bb == b]
        row["median wall ms"] = f"{np.median(walls) * 1e3:.2f}"
        rows.append(row)
    low = min(score.values())
    best = max(b for b in score if score[b] <= low + TIE)
    print(markdown_table(rows))
    print(f"\nchosen batch: {best} ({len(tasks)} runs on the tuning maps, {time.perf_counter() - t0:.0f} s)")
    return best


if __name__ == "__main__":
    main()
