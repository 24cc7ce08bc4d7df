"""The shipped route encoder with other arithmetic for its convolutions: prepacked, compiled, channels-last, bfloat16.

    python scripts/experiments/cheap_arithmetic.py --check fields        # how far each variant's field moves
    python scripts/experiments/cheap_arithmetic.py --check iterations    # bfloat16's RRT iterations (vin_validation)
    python scripts/experiments/cheap_arithmetic.py --check iterations --variant prepacked
    python scripts/experiments/cheap_arithmetic.py --check iterations --variant compiled --sides 32 64 128
    python scripts/experiments/cheap_arithmetic.py --check iterations --variant "compiled heads"
    python scripts/experiments/cheap_arithmetic.py --check time          # a pass at 128 cells, each way

The variants keep the shipped weights and change only how the local network's 3x3 convolutions (and its two 1x1
heads) run at inference, each against the dense float32 layers that training runs, heads through torch
(``RouteVIN.prepacked`` off, ``numba_local_blocks`` 0, ``compiled_heads`` off): on weights prepacked for oneDNN, the
activations in its blocked layout from layer to layer (``prepacked``), with the two 1x1 heads compiled too
(``compiled heads``: what the library ships on larger maps); compiled in numba with the heads (``compiled``: what it
ships on small maps and later queries' windows); on channels-last tensors in float32 (another memory layout, so
oneDNN sums in another order); or in bfloat16 on channels-last tensors (the heads, the fixed point and everything
after stay float32). bfloat16 is fast only on a CPU that computes it natively (AMX, AVX-512 BF16).

``fields``: on the validation maps (the training families, seeds from ``VALIDATION_SEED0 + 500``, ``--maps``
per family at each of ``--sides``, each map's own goal), the largest difference from the dense field at any
cell the goal reaches, first and later queries, per variant. ``iterations``: the route sampler's median RRT
iterations (step 4, cap 20,000, planner seeds 0 and 1) on the same maps, the dense convolutions against
``--variant`` as ``vin_validation.py --samplers "route encoder"`` runs them, with each row's ratio and the
geometric mean.
``time``: the best of 15 first queries at 128 cells, each way.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
import torch

from learning.models.route_net import load_route_net
from learning.models.route_vin import WALL_LOG, RouteVIN
from learning.models.shipped import SHIPPED_ROUTE
from learning.samplers.route import SHIPPED_SETTINGS, RouteSampler
from planners import make_planner
from planners.maps.generators import TRAINING_FAMILIES, VALIDATION_SEED0, generate
from planners.tools.benchmark import MAX_ITERATIONS, STEP


class CheapConvolutions(RouteVIN):
    """``RouteVIN`` whose local network holds its weights in ``dtype`` on channels-last tensors (``encoder`` converts
    them): its inputs are cast to that type and layout and its features come back in float32 (inference only)."""

    dtype = torch.float32

    def _cheap(self, x: torch.Tensor) -> torch.Tensor:
        return x.to(self.dtype).contiguous(memory_format=torch.channels_last)

    def move_costs(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        f = self.local(self._cheap(x)).float()
        return f, self.lengths * (0.5 + torch.exp(self.cost(f).clamp_max(WALL_LOG)))

    def local_window(self, x: torch.Tensor, window: tuple[int, int, int, int]) -> torch.Tensor:
        return super().local_window(self._cheap(x), window).float()


class ChannelsLast(CheapConvolutions):
    dtype = torch.float32


class BFloat16(CheapConvolutions):
    dtype = torch.bfloat16


class Prepacked(RouteVIN):
    """``RouteVIN`` with the local network prepacked for oneDNN on every map (as shipped on maps of at least
    ``prepacked_blocks`` blocks), never compiled, its heads through torch.
    """

    prepacked = True
    numba_local_blocks = 0
    compiled_heads = False


class PrepackedCompiledHeads(Prepacked):
    """``Prepacked`` with its two 1x1 heads compiled (``RouteVIN.compiled_heads``): as shipped on maps of at least
    ``prepacked_blocks`` blocks.
    """

    compiled_heads = True


class CompiledLocal(RouteVIN):
    """``RouteVIN`` with the local network and its heads compiled on every map and window
    (``learning.models.local_net``; as shipped on regions of at most ``numba_local_blocks`` blocks).
    """

    prepacked = False
    numba_local_blocks = 1 << 62


VARIANTS = {"prepacked": Prepacked, "compiled heads": PrepackedCompiledHeads, "compiled": CompiledLocal,
            "channels-last float32": ChannelsLast, "bfloat16": BFloat16}


def encoder(variant: type[RouteVIN] | None = None) -> RouteVIN:
    """The shipped encoder, its arithmetic changed to ``variant``'s (its weights and settings kept); without one,
    the dense float32 convolutions as training runs them."""
    net = load_route_net(SHIPPED_ROUTE).eval()
    if variant is None:
        net.prepacked, net.numba_local_blocks, net.compiled_heads = False, 0, False
        return net
    net.__class__ = variant  # the same module, its inference methods swapped: an experiment, not the library
    if issubclass(variant, CheapConvolutions):
        net.local.to(dtype=variant.dtype, memory_format=torch.channels_last)
    return net


def validation_problems(family: str, side: int, maps: int):
    """The first ``maps`` validation maps of one family and side (seeds from ``VALIDATION_SEED0 + 500``)."""
    return [generate(family, VALIDATION_SEED0 + 500 + i, side) for i in range(maps)]


def check_fields(args) -> None:
    dense = encoder()
    nets = {name: encoder(cls) for name, cls in VARIANTS.items()}
    worst = {name: (0.0, "") for name in nets}
    problems = [p for side in args.sides for family in args.families
                for p in validation_problems(family, side, args.maps)]
    for p in problems:
        obstacles = np.asarray(p.world.obstacles, dtype=bool)
        goal = tuple(int(v) for v in p.world.cell_of(p.goal))
        dense.clear_map_cache()
        ref = dense.predict(obstacles, goal)
        reach = ref < 1e5
        for name, net in nets.items():
            net.clear_map_cache()
            first, later = net.predict(obstacles, goal), net.predict(obstacles, goal)
            d = max(float(np.abs(first - ref)[reach].max()), float(np.abs(later - ref)[reach].max()))
            if d > worst[name][0]:
                worst[name] = (d, p.name)
    print("| variant | largest difference from the dense field (steps) | on |")
    print("|---|---|---|")
    for name, (d, where) in worst.items():
        print(f"| {name} | {d:.3g} | {where} |")


def check_iterations(args) -> None:
    nets = {"dense": encoder(), args.variant: encoder(VARIANTS[args.variant])}
    print(f"| family | side | dense | {args.variant} | ratio | unsolved (dense, {args.variant}) |")
    print("|---|---|---|---|---|---|")
    logs = []
    for family in args.families:
        for side in args.sides:
            its = {name: [] for name in nets}
            for p in validation_problems(family, side, args.maps):
                for name, net in nets.items():
                    for seed in (0, 1):
                        r = make_planner("RRT", p, extension_step=STEP, sampler=RouteSampler(net, **SHIPPED_SETTINGS),
                                         seed=seed).solve(max_iterations=MAX_ITERATIONS)
                        its[name].append(r.first_solution_iteration if r.solved else MAX_ITERATIONS)
            a, b = (float(np.median(its[k])) for k in nets)
            logs.append(math.log(b / a))
            unsolved = ", ".join(str(sum(x >= MAX_ITERATIONS for x in v)) for v in its.values())
            print(f"| {family} | {side} | {a:g} | {b:g} | {b / a:.2f} | {unsolved} |", flush=True)
    print(f"\ngeometric mean of the ratios: {math.exp(sum(logs) / len(logs)):.3f}")


def check_time(args) -> None:
    p = generate("maze", 123, 128)
    obstacles = np.asarray(p.world.obstacles, dtype=bool)
    goal = tuple(int(v) for v in p.world.cell_of(p.goal))
    for name, net in {"dense": encoder(), **{k: encoder(v) for k, v in VARIANTS.items()}}.items():
        def first_query(net=net):
            net.clear_map_cache()
            return net.predict(obstacles, goal)

        first_query()
        times = []
        for _ in range(15):
            t0 = time.perf_counter()
            first_query()
            times.append(time.perf_counter() - t0)
        print(f"{name}: best {1e3 * min(times):.2f} ms, median {1e3 * float(np.median(times)):.2f} ms a first query")


def main(argv: list[str] | None = None) -> int:
    """Command line entry point."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--check", choices=("fields", "iterations", "time"), required=True)
    ap.add_argument("--variant", choices=("bfloat16", "prepacked", "compiled heads", "compiled"), default="bfloat16",
                    help="--check iterations: the variant run against the dense convolutions (default bfloat16)")
    ap.add_argument("--maps", type=int, default=6, help="validation maps per family and side (default 6)")
    ap.add_argument("--sides", type=int, nargs="+", default=[128, 256])
    ap.add_argument("--families", nargs="+", choices=TRAINING_FAMILIES, default=list(TRAINING_FAMILIES))
    args = ap.parse_args(argv)
    if args.maps < 1 or min(args.sides) < 16:
        ap.error(f"--maps takes a count >= 1 and --sides map sides >= 16 cells, got {args.maps} and {args.sides}")
    torch.set_num_threads(1)
    {"fields": check_fields, "iterations": check_iterations, "time": check_time}[args.check](args)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
