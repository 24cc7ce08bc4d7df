"""What running on Ray costs against the local pool: per-task overhead, shipping, runs per second.

    python scripts/benchmark_backends.py                 # 2 workers each, this machine (72 s on 2 quiet cores)
    python scripts/benchmark_backends.py --processes 8

1. Scheduling overhead per task: empty tasks, one per scheduling unit (chunksize 1), on each backend; the
   difference between 2,000 and 200 of them, so a map() call's fixed cost (the local pool's start) drops out.
2. Shipping the world once: a context of the MovingAI maps' scenarios and the policy, put in Ray's
   object store once and fetched once per worker.
3. Runs per second on the comparison's own runs (RRT, uniform, goal bias and the policy on 25 generated
   test maps per family, 2 seeds), the first call with fresh workers, the second again (the local backend
   starts a pool per call; Ray keeps its workers).
Iteration counts are checked equal across backends.
"""

from __future__ import annotations

import argparse
import pickle
import time
from dataclasses import asdict

from learning import evaluation as E
from learning.models.shipped import SHIPPED_POLICY
from planners import movingai_dir
from planners.base.fileio import check_flags, check_int_flags
from planners.maps.generators import FAMILIES
from planners.tools.parallel import make_backend


def _noop(task, context):
    return task


def _strip(runs):
    return [{k: v for k, v in asdict(r).items() if k not in ("wall_time", "us_per_iteration")} for r in runs]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--processes", type=int, default=2)
    ap.add_argument("--empty-tasks", type=int, default=2000)
    args = ap.parse_args(argv)
    check_flags(lambda: check_int_flags(args, ("processes", "empty_tasks")))
    n = args.processes
    mdir = movingai_dir(None, required=False)
    protocol = E.Protocol(movingai_dir="" if mdir is None else str(mdir))
    queries = E.generated_queries(list(FAMILIES), protocol.size, 25, 0)
    policy = E.policy_spec(str(SHIPPED_POLICY), None)
    samplers = [E.bias_spec(0), *(E.bias_spec(b) for b in E.GOAL_BIASES), policy]
    tasks = [E.Task(q, "RRT", s, seed) for q in queries for s in samplers for seed in range(2)]
    names = [] if mdir is None else sorted({p.name.split(".")[0].replace("-random-1", "") for p in mdir.glob("*.scen")})
    mai = E.movingai_queries(str(mdir), names, 1, 0, protocol.tolerance) if names else []
    world = E.shared_context([E.Task(q, "RRT", policy, 0) for q in mai] + tasks[:1], protocol)
    print(f"{n} workers per backend; {len(tasks)} comparison runs; context {len(pickle.dumps(world)) / 1e6:.1f} MB "
          f"({len(world.scenarios)} MovingAI maps' scenarios and the policy)\n")
    print("| backend | empty task, us (chunksize 1) | runs/s cold | runs/s warm | context to every worker, s |")
    print("|---|---|---|---|---|")
    results = {}
    for name in ("local", "ray"):
        backend = make_backend(name, processes=n, worker_init=E.worker_init)
        try:
            t = time.perf_counter()
            runs = E.run_all(tasks, protocol, backend, progress=False)
            cold = time.perf_counter() - t
            t = time.perf_counter()
            runs = E.run_all(tasks, protocol, backend, progress=False)
            warm = time.perf_counter() - t
            # the difference of two batch sizes leaves out what a map() call pays once (the local pool's start)
            few = args.empty_tasks // 10
            t = time.perf_counter()
            backend.map(_noop, range(few), chunksize=1)
            t_few = time.perf_counter() - t
            t = time.perf_counter()
            backend.map(_noop, range(args.empty_tasks), chunksize=1)
            per_task = (time.perf_counter() - t - t_few) / (args.empty_tasks - few)
            t = time.perf_counter()
            backend.map(_noop, range(n), context=world, chunksize=1)
            ship = time.perf_counter() - t
        finally:
            backend.close()
        results[name] = _strip(runs)
        print(f"| {name} | {per_task * 1e6:.0f} | {len(tasks) / cold:.0f} | {len(tasks) / warm:.0f} | {ship:.2f} |",
              flush=True)
    print(f"\niteration counts equal across backends: {results['local'] == results['ray']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
