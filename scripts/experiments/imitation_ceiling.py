"""How far can imitation take the learned sampler? Its teacher's own labels, executed, on validation maps.

    python scripts/experiments/imitation_ceiling.py                  # 5 families, 40 validation maps each, 128x128
    python scripts/experiments/imitation_ceiling.py --maps 10 --families bugtrap maze

The policy is trained to imitate labels: the guided class holding the privileged expert's target, or
the frontier once the tree has been stuck for ``stuck_threshold`` iterations (``learning.training.imitation``).
A policy that imitated them perfectly would plan as the labels do when executed; that is the recipe's
ceiling. Rows (RRT, step and tolerance 4, median iterations-to-solution, unsolved runs at the cap):

- ``constant``: the ablation at the best frontier probability *on these maps* (the strongest ablation);
- ``policy``: the checkpoint;
- ``labels``: the expert's labels executed (the imitation target, stuck threshold as in training);
- ``labels, no frontier fallback``: the same without the stuck rule (the action space given the route);
- ``constant, frontier by geodesic distance``: the ablation with its frontier ranked by exact cost-to-go
  (best frontier probability here): what the frontier class gains from knowing the route;
- ``expert``: the privileged expert itself (samples along the shortest path, not through the classes).
- ``straight-line follower``: ``RouteSampler(None)``, the rule without learning that ``evaluate.py`` runs;
- ``exact corridor + uniform`` / ``+ follower``: a share q (best here) of samples uniform over the cells
  of near-shortest paths (``learning.references.expert.CorridorSampler``), the rest uniform or from the follower:
  the best that a network predicting the region the path runs through could give.

Each is also given over the iteration lower bound (grid shortest path / step, per run) and over the
constant. A second table shows where the policy departs from its labels, in the states it visits
itself (DAgger with the policy in control): the share of decisions labelled "frontier", the policy's
probability of the label, and how often its most likely cell points within one of the 16 directions
of the labelled cell. Validation maps only: these numbers choose what to try next, never what to ship.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from learning import PolicySampler
from learning import evaluation as E
from learning.models.shipped import SHIPPED_POLICY
from learning.samplers.ablation import FRONTIER_GRID
from learning.training.imitation import collect
from planners.base.fileio import InputError, check_int_flags
from planners.guidance.guided import ANGLES, FRONTIER
from planners.maps.generators import FAMILIES, MIN_SIZE, VALIDATION_SEED0
from planners.tools.benchmark import markdown_table
from planners.tools.parallel import add_backend_arguments, check_backend_arguments, make_backend

sys.path.insert(0, str(Path(__file__).resolve().parent))  # this folder's modules, in workers too
from reference_samplers import Corridor, GeodesicFrontier  # noqa: E402

DEFAULT_POLICY = SHIPPED_POLICY
#: Shares of corridor samples tried per base sampler; the best on these maps is reported.
CORRIDOR_Q = {"uniform": (0.5, 0.8, 0.95), "follower": (0.1, 0.3, 0.5)}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--policy", type=Path, default=DEFAULT_POLICY)
    ap.add_argument("--families", nargs="+", choices=FAMILIES, default=list(FAMILIES))
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--maps", type=int, default=40, help="validation maps per family (one planner seed each)")
    ap.add_argument("--max-iterations", type=int, default=E.Protocol.max_iterations)
    add_backend_arguments(ap, processes=2, backend_help="where the runs execute", processes_help="workers for them")
    args = ap.parse_args(argv)
    check_backend_arguments(ap, args)
    try:
        check_int_flags(args, ("size", "maps", "max_iterations"))
        if args.size < MIN_SIZE:
            raise InputError(f"--size must be at least {MIN_SIZE} (the smallest generated map), got {args.size}")
    except InputError as exc:
        ap.error(str(exc))

    config = PolicySampler.load(args.policy).config
    protocol = E.Protocol(step=float(config["step_size"]), max_iterations=args.max_iterations)
    step = protocol.step
    stuck = int(config.get("stuck_threshold", 16))
    queries = [E.Query(f, VALIDATION_SEED0 + i, args.size, "validation") for f in args.families
               for i in range(args.maps)]
    geodesic = {p: f"geodesic frontier={p:g}" for p in FRONTIER_GRID}
    corridor = {base: {q: f"corridor+{base}={q:g}" for q in qs} for base, qs in CORRIDOR_Q.items()}
    bases = {"uniform": E.SamplerSpec.of("uniform"), "follower": E.SamplerSpec.of("follower", step_size=step)}
    # (label, sampler): the registry's samplers by their specs, this probe's references by its own builders
    samplers = [("policy", E.policy_spec(str(args.policy), None)),
                ("expert (reference)", E.SamplerSpec.of("expert", step_size=step)),
                *((E.constant_sampler(p), E.constant_spec(p, protocol, 8)) for p in FRONTIER_GRID),
                *((label, GeodesicFrontier(p, step)) for p, label in geodesic.items()),
                (E.FOLLOWER, bases["follower"]),
                *((label, Corridor(q, bases[base])) for base, qs in corridor.items() for q, label in qs.items())]
    tasks = [E.Task(q, "RRT", sampler, i, label) for label, sampler in samplers for i, q in enumerate(queries)]
    backend = make_backend(args.backend, processes=args.processes, address=args.address, worker_init=E.worker_init)
    t0 = time.perf_counter()
    its: dict[tuple[str, str], np.ndarray] = {}
    lb: dict[str, np.ndarray] = {}
    runs = E.run_all(tasks, protocol, backend, progress=False)
    for s, _ in samplers:
        for f in args.families:
            rs = [r for r in runs if r.sampler == s and r.map == f]
            its[(f, s)] = np.array([r.iterations for r in rs], dtype=float)
            lb[f] = np.array([r.lower_bound for r in rs], dtype=float)
    labelled = {"labels": stuck, "labels, no frontier fallback": 10**9}
    for name, threshold in labelled.items():
        for f in args.families:
            problems = [protocol.problem(q) for q in queries if q.family == f]
            # RRT seeds 0.. per problem, as the runs above (collect seeds problem i with seed + i)
            _, n = collect(problems, None, 1.0, seed=0, batch=int(config["batch"]), step_size=step,
                           stuck_threshold=threshold, uniform_floor=float(config["uniform_floor"]),
                           max_iterations=args.max_iterations, gamma=0.99, reward_scale=1.0, backend=backend)
            its[(f, name)] = np.array(n, dtype=float)
    rows = []
    for f in args.families:
        best_p = min(FRONTIER_GRID, key=lambda p: np.median(its[(f, E.constant_sampler(p))]))
        const = its[(f, E.constant_sampler(best_p))]
        geo_p = min(FRONTIER_GRID, key=lambda p: np.median(its[(f, geodesic[p])]))
        cor = {base: min(qs.items(), key=lambda kv: np.median(its[(f, kv[1])])) for base, qs in corridor.items()}
        for label, key in ((f"constant (p={best_p:g}, best here)", E.constant_sampler(best_p)), ("policy", "policy"),
                           ("labels", "labels"), ("labels, no frontier fallback", "labels, no frontier fallback"),
                           (f"constant, frontier by geodesic distance (reference, p={geo_p:g})", geodesic[geo_p]),
                           ("expert (reference)", "expert (reference)"), (E.FOLLOWER, E.FOLLOWER),
                           *((f"exact corridor + {base} (reference, q={q:g})", name)
                             for base, (q, name) in cor.items())):
            x = its[(f, key)]
            rows.append({"family": f, "sampler": label, "median iterations": f"{np.median(x):,.0f}",
                         "solved": f"{np.mean(x < args.max_iterations):.2f}",
                         "/ lower bound": f"{np.median(x / np.maximum(lb[f], 1.0)):.1f}",
                         "/ constant": f"{np.median(x) / np.median(const):.2f}"})
    print(markdown_table(rows))
    print(markdown_table(departures(queries, args, config, backend)))
    print(f"\n{len(queries)} validation maps, {time.perf_counter() - t0:.0f} s")


def departures(queries, args, config, backend) -> list[dict]:
    """Per family: how the policy's decisions differ from the expert's labels in the policy's own states."""
    actor = PolicySampler.load(args.policy).actor
    rows = []
    for f in args.families:
        problems = [E.Protocol().problem(q) for q in queries if q.family == f]
        data, _ = collect(problems, actor, 0.0, seed=0, batch=int(config["batch"]),
                          step_size=float(config["step_size"]),
                          stuck_threshold=int(config.get("stuck_threshold", 16)),
                          uniform_floor=float(config["uniform_floor"]), max_iterations=args.max_iterations,
                          gamma=0.99, reward_scale=1.0, backend=backend)
        pairs = zip(data.local, data.vector, strict=True)
        logits = np.stack([actor.logits(loc, vec) for loc, vec in pairs]).astype(np.float64)
        p = np.exp(logits - logits.max(1, keepdims=True))
        p /= p.sum(1, keepdims=True)
        label = data.label
        ego = label != FRONTIER
        top = p[:, :FRONTIER].argmax(1)
        turn = np.abs(top % ANGLES - label % ANGLES)
        turn = np.minimum(turn, ANGLES - turn)
        p_label = p[np.arange(len(label)), label]
        rows.append({"family": f, "decisions": len(label), "labelled frontier": f"{1 - ego.mean():.2f}",
                     "p(label), frontier labels": f"{p_label[~ego].mean():.2f}",
                     "p(label), cell labels": f"{p_label[ego].mean():.2f}",
                     "top cell within 1 direction of the label": f"{(turn[ego] <= 1).mean():.2f}"})
    return rows


if __name__ == "__main__":
    main()
