"""Does the route encoder on a GPU give the CPU's field, and what does a query cost there?

    PYTHONPATH=$PWD python scripts/experiments/gpu_route.py --out results/gpu-route.json   # on a machine with CUDA

On a GPU the encoder's convolutions and cell head run on the device and its fixed point (the compiled Dijkstra)
on the machine's CPU. Three questions, each with cuDNN's TF32 convolutions (torch's default on a GPU) and
without them (full float32, as the CPU computes; ``FieldEncoder.full_float32``, the default):

1. Agreement: the shipped encoder's field on the GPU against the CPU's on validation maps of every generated
   family (``--sides``, ``--maps`` per family), over the cells both reach: the largest and the median
   difference in steps, the largest relative to the route's length, and the cells one reaches and the other not;
   and ``predict_many`` (the batched path) against single queries on the GPU.
2. Cost: one query at a time and ``--batch`` queries together on a winding maze at each of ``--time-sides``
   (median of ``--repeat`` calls after a warm-up), with the part spent in the fixed point on the CPU.
3. Planning: RRT with ``make_sampler("route")`` at the shipped settings on ``--queries`` validation queries per
   family at 128 cells, the encoder on the CPU (one thread) and on the GPU: median time to solution (the
   encoder's pass included, loading excluded) and how many runs take the same iterations.

Writes one JSON file (``--out``) and prints it. Exit status: 0 done, 2 bad input (no CUDA GPU included).
"""
from __future__ import annotations

import argparse
import json
import platform
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import torch

from learning.device import move_to, resolve_device
from learning.models.route_net import load_route_net
from learning.models.route_vin import RouteVIN
from learning.models.shipped import SHIPPED_ROUTE
from learning.samplers.registry import make_sampler
from planners import RRT
from planners.base.fileio import atomic_write_text, check_flags, check_int, check_output_place
from planners.maps.generators import FAMILIES, VALIDATION_SEED0, generate


def switch() -> str:
    """The switch ``learning.device.full_float32`` turns on this torch."""
    conv = getattr(torch.backends.cudnn, "conv", None)
    if conv is not None and hasattr(conv, "fp32_precision"):
        return "torch.backends.cudnn.conv.fp32_precision"
    return "torch.backends.cudnn.allow_tf32"


def _difference(net, a: np.ndarray, b: np.ndarray) -> dict:
    side = max(a.shape)
    unreached = net.unreached_steps * (side / net.trained_side if net.trained_side and side > net.trained_side else 1)
    reached_a, reached_b = a < unreached / 2, b < unreached / 2  # a field's value where the encoder sees no route
    both = reached_a & reached_b
    d = np.abs(a[both] - b[both])
    return {"max": float(d.max()) if d.size else 0.0, "median": float(np.median(d)) if d.size else 0.0,
            "max_relative": float(d.max() / max(1.0, a[both].max())) if d.size else 0.0,
            "reach_differs": int((reached_a != reached_b).sum()), "cells": int(both.sum())}


def agreement(cpu, gpu, sides: list[int], maps: int) -> list[dict]:
    rows = []
    for side in sides:
        for family in FAMILIES:
            for i in range(maps):
                p = generate(family, VALIDATION_SEED0 + i, side)
                obstacles, goal = np.asarray(p.world.obstacles), p.world.cell_of(p.goal)
                ref = cpu.predict(obstacles, goal)
                row = {"side": side, "family": family, "seed": VALIDATION_SEED0 + i}
                for mode in ("tf32", "ieee"):
                    gpu.full_float32 = mode == "ieee"
                    row[mode] = _difference(cpu, ref, gpu.predict(obstacles, goal))
                rows.append(row)
                print(json.dumps(row), flush=True)
    return rows


def batched_agreement(gpu, side: int, n: int) -> dict:
    p = generate("maze", VALIDATION_SEED0, side)
    obstacles = np.asarray(p.world.obstacles)
    free = np.argwhere(~obstacles.astype(bool))
    picks = np.random.default_rng(0).choice(len(free), size=n, replace=False)
    queries = [(obstacles, (int(free[i][0]), int(free[i][1]))) for i in picks]
    out = {}
    for mode in ("tf32", "ieee"):
        gpu.full_float32 = mode == "ieee"
        many = gpu.predict_many(queries)
        single = [gpu.predict(*q) for q in queries]
        out[mode] = max(_difference(gpu, a, b)["max"] for a, b in zip(single, many, strict=True))
    return out


def cost(gpu, sides: list[int], repeat: int, batch: int, batch_max_side: int) -> list[dict]:
    spent = [0.0]
    settle = RouteVIN.settle

    def timed_settle(costs, goal, walls):
        torch.cuda.synchronize()
        t = time.perf_counter()
        v = settle(costs, goal, walls)
        spent[0] += time.perf_counter() - t
        return v

    rows = []
    RouteVIN.settle = staticmethod(timed_settle)
    try:
        for side in sides:
            p = generate("maze", VALIDATION_SEED0, side)
            obstacles, goal = np.asarray(p.world.obstacles), p.world.cell_of(p.goal)
            free = np.argwhere(~obstacles.astype(bool))
            for mode in ("tf32", "ieee"):
                gpu.full_float32 = mode == "ieee"
                torch.cuda.reset_peak_memory_stats()
                gpu.predict(obstacles, goal)
                torch.cuda.synchronize()
                times, fixed = [], []
                for _ in range(repeat):
                    spent[0] = 0.0
                    t = time.perf_counter()
                    gpu.predict(obstacles, goal)
                    torch.cuda.synchronize()
                    times.append(time.perf_counter() - t)
                    fixed.append(spent[0])
                row = {"side": side, "mode": mode, "ms_per_query": 1000 * float(np.median(times)),
                       "best_ms": 1000 * min(times), "fixed_point_ms": 1000 * float(np.median(fixed)),
                       "peak_mb": torch.cuda.max_memory_allocated() / 2**20}
                if batch > 1 and side <= batch_max_side:
                    picks = np.random.default_rng(side).choice(len(free), size=batch, replace=False)
                    queries = [(obstacles, (int(free[i][0]), int(free[i][1]))) for i in picks]
                    gpu.predict_many(queries)
                    many = []
                    for _ in range(max(1, repeat // 2)):
                        spent[0] = 0.0
                        t = time.perf_counter()
                        gpu.predict_many(queries)
                        torch.cuda.synchronize()
                        many.append((time.perf_counter() - t, spent[0]))
                    total, fixed_part = (1000 * float(np.median([m[k] for m in many])) / batch for k in (0, 1))
                    row[f"ms_per_query_batch_{batch}"] = total
                    row[f"fixed_point_ms_per_query_batch_{batch}"] = fixed_part
                rows.append(row)
                print(json.dumps(row), flush=True)
    finally:
        RouteVIN.settle = staticmethod(settle)
    return rows


def planning(queries: int) -> dict:
    samplers = {"cpu": make_sampler("route", device="cpu"), "cuda": make_sampler("route", device="cuda")}
    warm = generate("maze", VALIDATION_SEED0 + 900, 128)  # first calls: compilation, CUDA set-up
    for sampler in samplers.values():
        RRT(warm, step_size=4.0, sampler=sampler, seed=1).solve(max_iterations=20000)
    out: dict = {}
    for mode in ("tf32", "ieee"):
        samplers["cuda"].net.full_float32 = mode == "ieee"
        per_family = {}
        for family in FAMILIES:
            runs: dict = {"cpu": [], "cuda": []}
            for i in range(queries):
                p = generate(family, VALIDATION_SEED0 + i, 128)
                for name, sampler in samplers.items():
                    sampler.net.clear_map_cache()
                    t = time.perf_counter()
                    r = RRT(p, step_size=4.0, sampler=sampler, seed=1).solve(max_iterations=20000)
                    runs[name].append((time.perf_counter() - t, r.iterations, r.solved))
            per_family[family] = {
                "cpu_ms": 1000 * float(np.median([r[0] for r in runs["cpu"]])),
                "cuda_ms": 1000 * float(np.median([r[0] for r in runs["cuda"]])),
                "cpu_iterations": float(np.median([r[1] for r in runs["cpu"]])),
                "cuda_iterations": float(np.median([r[1] for r in runs["cuda"]])),
                "same_iterations": sum(a[1] == b[1] for a, b in zip(runs["cpu"], runs["cuda"], strict=True)),
                "solved": [sum(r[2] for r in runs["cpu"]), sum(r[2] for r in runs["cuda"])], "runs": queries}
            print(json.dumps({"mode": mode, family: per_family[family]}), flush=True)
        out[mode] = per_family
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sides", type=int, nargs="+", default=[128, 512], help="agreement's map sides")
    ap.add_argument("--maps", type=int, default=2, help="agreement's maps per family and side")
    ap.add_argument("--time-sides", type=int, nargs="+", default=[128, 512, 1024, 4096])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--batch", type=int, default=64)
    ap.add_argument("--batch-max-side", type=int, default=1024, help="largest side timed batched")
    ap.add_argument("--queries", type=int, default=10, help="planning's validation queries per family")
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args(argv)

    def check() -> None:
        for name in ("maps", "repeat", "batch", "queries"):
            check_int(getattr(args, name), f"--{name}")
        for side in [*args.sides, *args.time_sides]:
            check_int(side, "--sides", low=32)
        check_output_place(args.out, "--out", folder=False)
        resolve_device("cuda")

    check_flags(check)
    torch.set_num_threads(1)
    cpu = load_route_net(SHIPPED_ROUTE)
    gpu = move_to(load_route_net(SHIPPED_ROUTE), torch.device("cuda"))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = {"gpu": torch.cuda.get_device_name(), "torch": torch.__version__, "cpu": platform.processor(),
                  "switch": switch()}
        t = time.perf_counter()
        result["agreement"] = agreement(cpu, gpu, args.sides, args.maps)
        result["batched_vs_single_max"] = batched_agreement(gpu, 128, 16)
        result["cost"] = cost(gpu, args.time_sides, args.repeat, args.batch, args.batch_max_side)
        result["planning"] = planning(args.queries)
        result["seconds"] = time.perf_counter() - t
    result["warnings"] = sorted({f"{w.category.__name__}: {w.message}" for w in caught})
    atomic_write_text(args.out, json.dumps(result, indent=1))
    print(json.dumps({k: result[k] for k in ("gpu", "torch", "switch", "batched_vs_single_max", "seconds",
                                             "warnings")}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
