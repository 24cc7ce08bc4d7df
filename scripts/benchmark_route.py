"""What the route encoder costs per query, by map side, thread count and device.

    python scripts/benchmark_route.py                                  # shipped encoder, CPU, 1 thread: 30 s
    python scripts/benchmark_route.py --sides 128 512 --threads 1 2 --batch 16
    python scripts/benchmark_route.py --device cuda --sides 128 256 512 1024 --batch 64
    python scripts/benchmark_route.py --sides 128 512 1024 4096 --repeat 3      # up to the largest map it takes
    python scripts/benchmark_route.py --value-iteration                          # the fixed point the former way
    python scripts/benchmark_route.py --torch-inference                          # no compiled part after the network
    python scripts/benchmark_route.py --dense-convolutions                       # the 3x3 layers as training runs them
    python scripts/benchmark_route.py --sides 128 --kept 800                     # first queries with 800 maps kept
    python scripts/benchmark_route.py --sides 128 512 --two-fields               # a new map's fields to goal and start
    python scripts/benchmark_route.py --sides 256 512 1024 4096 --sampler        # and what a planner gets: the sampler

Each row is one map side and family (a generated forest, and a maze, whose route winds furthest;
``--families``; ``--symmetries`` passes, the goal in a free cell):
the median and the best of ``--repeat`` timed ``predict`` calls after one untimed warm-up call, each the first
query on its map (nothing of the map kept), with the encoder's own planning threads (``--threads``); for an
encoder that keeps a map's goal-free parts (``RouteVIN.map_cache_bytes``), the median and best of as many later
queries on the same map, each to another goal (``later_ms``: a robot planning again on its map); and, with
``--batch N``, the time per query when N queries of that side go through ``predict_many`` together (the
evaluation's batched path on a GPU); with ``--kept N``, the median and best first query on a new map (generated,
other seeds) after the parts of N other maps are kept, each queried twice (``kept_ms``: a robot's maps, or a
comparison's with several queries each, where the kept maps may number hundreds); with ``--two-fields``, the
median and best time of a new map's first two queries, to its goal and then to its start, as a bidirectional planner
or a roadmap binds the route sampler (``two_fields_ms``); with ``--sampler``, the median and best time of the route
sampler's bind on a first query of the map (``make_sampler("route")`` as a planner binds it: the field the planner
gets, its set-up around it, and the map read coarser where that closes no passage, ``coarser`` times; nothing of the
map kept, ``sampler_ms``).
Peak memory is the process's resident peak after the row (CPU; sides in increasing order), or the
GPU's allocated peak for the row. A side above the encoder's block limit is shown as refused, with the
limit's message. Times are wall times in one process; the machine's load is printed beside them.
``--value-iteration`` computes the encoder's fixed point by value iteration, as it was computed before the
compiled Dijkstra (``RouteVIN.fixed_point``; the same values bit for bit): the time the direct way saves.
``--torch-inference`` runs the pass through torch after the convolutions (``RouteVIN.compiled_inference`` off: the
walls written into the move costs, the cell head in torch, the convolutions in one piece up to ``strip_blocks``; the
same fields up to rounding): the time the CPU's compiled inference saves. ``--dense-convolutions`` runs the local
network's 3x3 layers on torch's dense tensors, as training does (``RouteVIN.prepacked`` off; fields within 1.2e-4
steps): the time the prepacked weights save.
"""

from __future__ import annotations

import argparse
import os
import resource
import time
from pathlib import Path

import numpy as np
import torch

from learning.device import DEVICES, resolve_device
from learning.models.route_net import load_route_net
from learning.models.shipped import SHIPPED_ROUTE
from learning.samplers.route import shipped_sampler
from planners.base.fileio import InputError, check_flags, check_int, check_int_flags
from planners.maps.coarsen import forget_kept
from planners.maps.generators import FAMILIES, TEST_SEED0, generate
from planners.tools.benchmark import markdown_table


def _load() -> str:
    try:
        return " / ".join(f"{x:.1f}" for x in os.getloadavg())
    except OSError:
        return "unknown"


def _timed(call, repeat: int, sync) -> list[float]:
    call()  # warm-up: first-call allocations, lazy CUDA set-up
    sync()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        call()
        sync()
        times.append(time.perf_counter() - start)
    return times


def bench_side(net, side: int, *, symmetries: int, threads: int, repeat: int, batch: int, device,
               family: str = "forest", kept: int = 0, two_fields: bool = False, sampler: bool = False) -> dict:
    """One row: the encoder's time per query on a ``side`` x ``side`` map of ``family`` (see the module docstring)."""
    problem = generate(family, TEST_SEED0, side)
    obstacles = np.asarray(problem.world.obstacles)
    goal = problem.world.cell_of(problem.goal)
    row: dict = {"family": family, "side": side, "threads": threads}
    try:
        net.check_size(obstacles.shape)
    except InputError as exc:
        row["ms_per_query"] = "refused"
        row["note"] = str(exc)
        return row
    cuda = device.type == "cuda"
    sync = torch.cuda.synchronize if cuda else (lambda: None)
    if cuda:
        torch.cuda.reset_peak_memory_stats()
    forget = getattr(net, "clear_map_cache", lambda: None)

    def first_query() -> None:  # the first query on this map: nothing of it kept
        forget()
        net.predict(obstacles, goal, symmetries, threads=threads)

    times = _timed(first_query, repeat, sync)
    row["ms_per_query"] = round(1000 * float(np.median(times)), 1)
    row["best_ms"] = round(1000 * min(times), 1)
    free = np.argwhere(~obstacles.astype(bool))
    if getattr(net, "map_cache_bytes", 0) > 0:
        # later queries on the same map: other goals (seeded free cells), the map's goal-free parts kept
        picks = np.random.default_rng(side + 1).choice(len(free), size=repeat + 1, replace=len(free) <= repeat)
        goals = iter([(int(free[i][0]), int(free[i][1])) for i in picks])
        net.predict(obstacles, goal, symmetries, threads=threads)
        later = _timed(lambda: net.predict(obstacles, next(goals), symmetries, threads=threads), repeat, sync)
        row["later_ms"] = round(1000 * float(np.median(later)), 2)
        row["later_best_ms"] = round(1000 * min(later), 2)
    if kept > 0 and getattr(net, "map_cache_bytes", 0) > 0:
        forget()
        queries = []
        for i in range(kept + repeat + 1):  # the maps to keep, then a new one for each timed call and the warm-up
            other = generate(family, TEST_SEED0 + 1 + i, side)
            queries.append((np.asarray(other.world.obstacles), other.world.cell_of(other.goal)))
        for obs, cell in queries[:kept]:
            for _ in range(2):  # a map's parts are kept from its second query on
                net.predict(obs, cell, symmetries, threads=threads)
        fresh = iter(queries[kept:])
        times = _timed(lambda: net.predict(*next(fresh), symmetries, threads=threads), repeat, sync)
        row["kept_ms"] = round(1000 * float(np.median(times)), 2)
        row["kept_best_ms"] = round(1000 * min(times), 2)
        forget()
    if two_fields:
        pairs = []
        for i in range(repeat + 1):  # a new map for each timed call and the warm-up
            other = generate(family, TEST_SEED0 + 1 + kept + repeat + 1 + i, side)
            pairs.append((np.asarray(other.world.obstacles), other.world.cell_of(other.goal),
                          other.world.cell_of(other.start)))
        fresh_pairs = iter(pairs)

        def both() -> None:
            obs, to_goal, to_start = next(fresh_pairs)
            net.predict(obs, to_goal, symmetries, threads=threads)
            net.predict(obs, to_start, symmetries, threads=threads)

        times = _timed(both, repeat, sync)
        row["two_fields_ms"] = round(1000 * float(np.median(times)), 2)
        row["two_fields_best_ms"] = round(1000 * min(times), 2)
    if sampler:
        route = shipped_sampler(net, float(net.step), device=str(device), threads=threads)

        def bind() -> None:  # a first query on the map: nothing of it kept, its passages checked again
            forget()
            forget_kept()
            route.bind(problem)

        times = _timed(bind, repeat, sync)
        row["sampler_ms"] = round(1000 * float(np.median(times)), 1)
        row["sampler_best_ms"] = round(1000 * min(times), 1)
        row["coarser"] = route.bind(problem).coarsening
    if batch > 1:
        picks = np.random.default_rng(side).choice(len(free), size=batch, replace=len(free) < batch)
        queries = [(obstacles, (int(free[i][0]), int(free[i][1]))) for i in picks]
        many = _timed(lambda: net.predict_many(queries, symmetries, threads=threads), max(1, repeat // 2), sync)
        row[f"ms_per_query_batch_{batch}"] = round(1000 * float(np.median(many)) / batch, 2)
    if cuda:
        row["peak_mb"] = round(torch.cuda.max_memory_allocated() / 2**20)
    else:
        row["peak_mb"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
    row["load"] = _load()
    return row


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--route", type=Path, default=SHIPPED_ROUTE, help="route encoder file (default: the shipped one)")
    ap.add_argument("--sides", type=int, nargs="+", default=[128, 256, 512, 1024])
    ap.add_argument("--threads", type=int, nargs="+", default=[1], help="torch threads per query (default 1, "
                    "the library's planning default)")
    ap.add_argument("--symmetries", type=int,
                    help="passes per query (default: the encoder's own, as the route sampler takes: 8 for the U-Net, "
                         "1 for the value-iteration encoder)")
    ap.add_argument("--repeat", type=int, default=5, help="timed calls per row; the table shows their median")
    ap.add_argument("--batch", type=int, default=1, help="also time N queries per predict_many call")
    ap.add_argument("--kept", type=int, default=0,
                    help="also time first queries on new maps with N other maps' parts kept (default 0: not)")
    ap.add_argument("--two-fields", action="store_true",
                    help="also time a new map's fields to its goal and then its start (a bidirectional planner's)")
    ap.add_argument("--sampler", action="store_true",
                    help="also time the route sampler's bind on a first query (what a planner gets by default)")
    ap.add_argument("--device", default="cpu", choices=DEVICES, help="cpu (default), cuda, or auto as in SB3")
    ap.add_argument("--families", nargs="+", default=["forest", "maze"], choices=FAMILIES,
                    help="generated families to time on (default forest and maze)")
    ap.add_argument("--torch-inference", action="store_true",
                    help="the pass through torch after the convolutions, no compiled part (same fields up to rounding)")
    ap.add_argument("--dense-convolutions", action="store_true",
                    help="the 3x3 layers on dense tensors as training runs them, not prepacked (fields within 1.2e-4)")
    ap.add_argument("--value-iteration", action="store_true",
                    help="value iteration for the fixed point, as before the compiled Dijkstra (same values)")
    args = ap.parse_args(argv)

    def check() -> None:
        check_int_flags(args, ("repeat", "batch"))
        check_int(args.kept, "--kept", low=0)
        for side in args.sides:
            check_int(side, "--sides", low=32)  # the smallest generated map
        for n in args.threads:
            check_int(n, "--threads")
        if args.symmetries is not None:
            check_int(args.symmetries, "--symmetries")
        if args.symmetries is not None and args.symmetries > 8:
            raise InputError(f"--symmetries {args.symmetries}: expected 1 to 8")
        if not args.route.is_file():
            raise InputError(f"--route {args.route}: no such file")

    check_flags(check)
    device = None

    def pick() -> None:
        nonlocal device
        device = resolve_device(args.device)

    check_flags(pick)
    net = load_route_net(args.route).to(device)
    if args.value_iteration:
        if not hasattr(net, "fixed_point"):
            raise SystemExit(f"--value-iteration: {args.route} is not a value-iteration encoder")
        net.fixed_point = "iterate"
    if args.torch_inference:
        if not hasattr(net, "compiled_inference"):
            raise SystemExit(f"--torch-inference: {args.route} is not a value-iteration encoder")
        net.compiled_inference = False
    if args.dense_convolutions:
        if not hasattr(net, "prepacked"):
            raise SystemExit(f"--dense-convolutions: {args.route} is not a value-iteration encoder")
        net.prepacked = False
    if args.symmetries is None:
        args.symmetries = net.symmetries
    how = f", fixed point by {getattr(net, 'fixed_point', 'its own network')}"
    how += ", torch inference" if args.torch_inference else ""
    how += ", dense convolutions" if args.dense_convolutions else ""
    print(f"route encoder {args.route.name}, {args.symmetries} symmetries, device {device}{how}, "
          f"{os.cpu_count()} CPUs, torch {torch.__version__}\n", flush=True)
    rows = []
    for side in sorted(set(args.sides)):
        for family in args.families:
            for n in args.threads:
                rows.append(bench_side(net, side, symmetries=args.symmetries, threads=n, repeat=args.repeat,
                                       batch=args.batch, device=device, family=family, kept=args.kept,
                                       two_fields=args.two_fields, sampler=args.sampler))
                print(markdown_table([rows[-1]], [c for c in rows[-1] if c != "note"]).splitlines()[-1], flush=True)
    columns = ["family", "side", "threads", "ms_per_query", "best_ms"]
    if any("later_ms" in row for row in rows):
        columns += ["later_ms", "later_best_ms"]
    if any("kept_ms" in row for row in rows):
        columns += ["kept_ms", "kept_best_ms"]
    if any("two_fields_ms" in row for row in rows):
        columns += ["two_fields_ms", "two_fields_best_ms"]
    if any("sampler_ms" in row for row in rows):
        columns += ["sampler_ms", "sampler_best_ms", "coarser"]
    if args.batch > 1:
        columns.append(f"ms_per_query_batch_{args.batch}")
    columns += ["peak_mb", "load"]
    print(markdown_table(rows, columns))
    for row in rows:
        if "note" in row:
            print(f"\nside {row['side']}: {row['note']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
