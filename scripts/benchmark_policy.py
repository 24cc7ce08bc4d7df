"""What a learned sampler costs: forward-pass time and per-query wall time against goal bias.

    python scripts/benchmark_policy.py                                   # the shipped checkpoint
    python scripts/benchmark_policy.py --policy old.zip learning/data/guided.zip --family bugtrap --bias 0.05
    python scripts/benchmark_policy.py --sampler mine=user_ppo.zip@SamplerGym/RRT-Forest-v2 --family forest

For each checkpoint: its actor's parameters, microseconds per forward pass on observations taken
from real runs, and on held-out 128x128 maps of one family the median wall time per query (binding
included), iterations and forward passes of RRT with the policy, with the policy without its
frontier hold, and with goal bias, and the wall time per iteration (sampler and planner together), also
for --sampler (specs as in evaluate.py). One process: absolute times are quieter than evaluate.py's.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from learning import evaluation as E
from learning.evaluation.speed import forward_pass_us, observations, query_times
from learning.models.shipped import SHIPPED_POLICY
from learning.samplers.policy import PolicySampler
from planners.base.fileio import check_flags, check_int_flags, check_number
from planners.maps.generators import (
    FAMILIES,
    TEST_SEED0,
    generate,
)
from planners.tools.benchmark import markdown_table

DEFAULT_POLICY = SHIPPED_POLICY


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--policy", nargs="+", type=Path, default=[DEFAULT_POLICY])
    ap.add_argument("--family", default="bugtrap", choices=FAMILIES)
    ap.add_argument("--bias", type=float, default=0.05, help="goal bias to compare with (evaluate.py tunes it)")
    ap.add_argument("--maps", type=int, default=40, help="test maps of the family")
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--sampler", action="append", default=[], metavar="NAME=SPEC",
                    help="also time this sampler (repeatable; specs as in scripts/evaluate.py --sampler)")
    args = ap.parse_args(argv)

    def check() -> None:
        check_int_flags(args, ("maps", "seeds"))
        check_number("command line", "--bias", args.bias, low=0.0, high=1.0)

    check_flags(check)
    extra = {}
    for arg in args.sampler:
        try:
            name, spec = E.parse_user_sampler(arg)
            extra[name] = E.user_sampler(spec)
        except (ValueError, FileNotFoundError) as exc:
            ap.error(str(exc))
    for path in args.policy:
        if not path.is_file():
            ap.error(f"policy checkpoint {path} not found")
    problems = [generate(args.family, TEST_SEED0 + i, 128) for i in range(args.maps)]
    obs_maps = [generate(f, TEST_SEED0 + i, 128) for f in FAMILIES for i in range(4)]
    rows = []
    for path in args.policy:
        policy = PolicySampler.load(path)
        local, vector = observations(policy, obs_maps)
        pass_us = forward_pass_us(policy.actor, local, vector)
        times = query_times(policy, args.bias, problems, args.seeds, extra=extra)
        for name, t in times.items():
            rows.append({"checkpoint": path.name, "parameters": sum(w.size for w in policy.actor.weights),
                         "us_per_pass": pass_us, "observations": len(local), "sampler": name, **t})
    print(f"{args.family}, {args.maps} test maps x {args.seeds} seeds; forward passes timed on the observations "
          f"of {len(obs_maps)} runs (4 test maps per family)\n")
    print(markdown_table(rows, ["checkpoint", "parameters", "us_per_pass", "observations", "sampler", "wall_ms",
                                "iterations", "forward_passes", "us_per_iteration"]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
