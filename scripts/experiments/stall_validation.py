"""Which validation queries the route samplers leave unsolved, and what a change of their stall rule does to them.

    python scripts/experiments/stall_validation.py                          # shipped settings
    python scripts/experiments/stall_validation.py --maps 40 --sides 64 128 256 --set patience=100

RRT (step 4, tolerance 4, cap 20,000; planner seeds 0 and 1) on validation maps of the five test families
(seeds from ``VALIDATION_SEED0 + 1000``; never test maps), for the route encoder, the route ablation and the exact
route reference, each with its own settings updated by ``--set NAME=VALUE`` (a ``RouteSampler`` keyword). Prints a
row per family and side (median iterations and unsolved runs per sampler) and every unsolved run.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from learning.references.expert import GeodesicRouteSampler
from learning.samplers.route import ABLATION_SETTINGS, SHIPPED_SETTINGS, RouteSampler
from planners import make_planner
from planners.maps.generators import FAMILIES, VALIDATION_SEED0, generate
from planners.tools.benchmark import MAX_ITERATIONS, STEP


def setting(text: str) -> tuple[str, float]:
    name, _, value = text.partition("=")
    try:
        return name, json.loads(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected NAME=VALUE with a JSON value") from None


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--maps", type=int, default=40, help="validation maps per family and side")
    ap.add_argument("--offset", type=int, default=1000, help="first validation seed after VALIDATION_SEED0")
    ap.add_argument("--sides", type=int, nargs="+", default=[64, 128, 256])
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--families", nargs="+", default=list(FAMILIES))
    ap.add_argument("--set", type=setting, action="append", default=[], metavar="NAME=VALUE",
                    help="a RouteSampler keyword for all three samplers (repeatable)")
    args = ap.parse_args(argv)
    extra = dict(args.set)
    net = RouteSampler.load().net
    samplers = {
        "encoder": lambda: RouteSampler(net, **{**SHIPPED_SETTINGS, **extra}),
        "ablation": lambda: RouteSampler(None, **{**ABLATION_SETTINGS, **extra}),
        "exact": lambda: GeodesicRouteSampler(**{**SHIPPED_SETTINGS, **extra}),
    }
    print(f"settings changed: {extra or 'none'}")
    print("| family | side | " + " | ".join(f"{n} median | {n} unsolved" for n in samplers) + " |")
    print("|---|---|" + "---|---|" * len(samplers))
    failures, totals = [], dict.fromkeys(samplers, 0)
    for family in args.families:
        for side in args.sides:
            its: dict[str, list[int]] = {name: [] for name in samplers}
            for i in range(args.maps):
                seed0 = VALIDATION_SEED0 + args.offset + i
                p = generate(family, seed0, side)
                for name, make in samplers.items():
                    for seed in range(args.seeds):
                        r = make_planner("RRT", p, extension_step=STEP, sampler=make(), seed=seed).solve(
                            max_iterations=MAX_ITERATIONS)
                        its[name].append(r.first_solution_iteration if r.solved else MAX_ITERATIONS)
                        if not r.solved:
                            failures.append(f"{name} {family} {side} map seed {seed0} planner seed {seed}")
                            totals[name] += 1
            cells = " | ".join(f"{np.median(v):g} | {sum(x >= MAX_ITERATIONS for x in v)}" for v in its.values())
            print(f"| {family} | {side} | {cells} |", flush=True)
    print("unsolved in all:", totals)
    for f in failures:
        print("unsolved:", f)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
