"""Choose the learned sampler's ``max_floor`` on tuning queries: how far the uniform share grows when stuck.

    python scripts/experiments/tune_stuck_floor.py                       # MovingAI tuning scenarios + validation maps
    python scripts/experiments/tune_stuck_floor.py --scenarios 5 --floors 0.2 0.3 0.5
    python scripts/evaluate.py --sampler cap=tune_stuck_floor:policy_with_cap_0_3   # 0.3 on the test split

``PolicySampler`` raises its uniform share when the tree has made no progress for ``patience``
iterations, up to ``max_floor``. That choice only matters for runs stuck for thousands of
iterations: the large MovingAI maps. This measures it on the MovingAI *tuning* scenarios (the split the
comparison tunes goal bias on, never its test scenarios) and names the setting a rule picks: the
highest smallest per-map success rate (maps no setting solves are left out), then the highest mean
success, then the lowest pooled median. The generated families' validation maps are printed
alongside: their runs are rarely stuck that long. ``PolicySampler`` keeps 0.5; the README says why.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from learning import PolicySampler
from learning import evaluation as E
from learning.models.shipped import SHIPPED_POLICY
from planners import make_planner, movingai_dir
from planners.base.fileio import InputError, check_int_flags
from planners.maps.generators import FAMILIES, VALIDATION_SEED0
from planners.tools.benchmark import markdown_table
from planners.tools.parallel import add_backend_arguments, check_backend_arguments, make_backend

DEFAULT_POLICY = SHIPPED_POLICY
FLOORS = (0.05, 0.1, 0.2, 0.3, 0.4, 0.5)


def policy_with_cap_0_3() -> PolicySampler:
    """The shipped policy with the cap the rule picks (``evaluate.py --sampler``, see the module docstring)."""
    return PolicySampler.load(DEFAULT_POLICY, max_floor=0.3)


def _run(task: tuple, context: dict) -> int:
    """Iterations to solution (the cap if unsolved) of the policy at one ``max_floor``."""
    query, floor, seed = task
    base = context["policy"]
    sampler = PolicySampler(base.actor, base.config, max_floor=floor)
    protocol = context["protocol"]
    problem = protocol.problem(query, context["scenarios"])
    r = make_planner("RRT", problem, extension_step=base.step_size, sampler=sampler, seed=seed).solve(
        max_iterations=protocol.max_iterations)
    return r.first_solution_iteration if r.solved else protocol.max_iterations


def choose(success: dict[float, dict[str, float]], medians: dict[float, float]) -> float:
    """The rule of the module docstring, over ``success[floor][map]`` and pooled ``medians[floor]``."""
    maps = [m for m in next(iter(success.values())) if any(s[m] > 0 for s in success.values())]
    return max(success, key=lambda f: (min(success[f][m] for m in maps), np.mean([success[f][m] for m in maps]),
                                       -medians[f]))


def main(argv=None) -> float:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--policy", default=str(DEFAULT_POLICY))
    ap.add_argument("--movingai", default=None, help="MovingAI folder (default: as scripts/evaluate.py)")
    ap.add_argument("--floors", type=float, nargs="+", default=list(FLOORS))
    ap.add_argument("--scenarios", type=int, default=30, help="tuning scenarios per MovingAI map")
    ap.add_argument("--seeds", type=int, default=3, help="planner seeds per query")
    ap.add_argument("--maps", type=int, default=40, help="validation maps per generated family")
    ap.add_argument("--max-iterations", type=int, default=E.Protocol.max_iterations)
    add_backend_arguments(ap, processes=2, backend_help="where the runs execute", processes_help="workers for them")
    args = ap.parse_args(argv)
    check_backend_arguments(ap, args)
    try:
        check_int_flags(args, ("scenarios", "seeds", "maps", "max_iterations"))
        for f in args.floors:
            if not 0.0 <= f <= 1.0:
                raise InputError(f"--floors must lie in [0, 1], got {f}")
        directory = str(movingai_dir(args.movingai))
        policy = PolicySampler.load(args.policy)
    except (InputError, FileNotFoundError) as exc:
        ap.error(str(exc))
    maps = sorted(p.stem for p in Path(directory).glob("*.map"))
    protocol = E.Protocol(max_iterations=args.max_iterations, movingai_dir=directory)
    loaded: dict = {}
    tuning = [q for q in E.movingai_queries(directory, maps, 0, args.scenarios, protocol.tolerance, loaded)
              if q.split == "tuning"]
    validation = [E.Query(f, VALIDATION_SEED0 + i, protocol.size, "validation") for f in FAMILIES
                  for i in range(args.maps)]
    tasks = [(q, f, s) for f in args.floors for q in tuning + validation for s in range(args.seeds)]
    backend = make_backend(args.backend, processes=args.processes, address=args.address, worker_init=E.worker_init)
    t0 = time.perf_counter()
    context = {"policy": policy, "protocol": protocol, "scenarios": loaded}
    its = backend.map(_run, tasks, context=context, progress=False)
    cap = args.max_iterations
    by = {}
    for (q, f, _), n in zip(tasks, its, strict=True):
        by.setdefault((f, q.family), []).append(n)
    success = {f: {m: float(np.mean(np.array(by[(f, m)]) < cap)) for m in maps} for f in args.floors}
    medians = {f: float(np.median([n for m in maps for n in by[(f, m)]])) for f in args.floors}
    rows = []
    for m in [*maps, *FAMILIES]:
        row = {"map": m + ("" if m in maps else " (validation)")}
        for f in args.floors:
            x = np.array(by[(f, m)])
            row[f"max_floor {f:g}"] = f"{np.median(x):,.0f} ({np.mean(x < cap):.2f})"
        rows.append(row)
    print("Median iterations (success rate); MovingAI tuning scenarios, then generated validation maps")
    print(markdown_table(rows))
    best = choose(success, medians)
    print(f"\nthe rule picks max_floor {best:g} ({len(tasks)} runs, {time.perf_counter() - t0:.0f} s)")
    return best


if __name__ == "__main__":
    main()
