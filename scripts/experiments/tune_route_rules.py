"""The route field's rules for other planners, chosen on validation maps.

    python scripts/experiments/tune_route_rules.py --maps 6 --seeds 2                 # the roadmaps' corridor
    python scripts/experiments/tune_route_rules.py --fields route --margins 0.3 --floors 0.3 --fills 1 2 4 8 none
    python scripts/experiments/tune_route_rules.py --fields route --margins 0.3 --floors 0.3 --fills 1 \
        --tights 0 1 2 4 8 16 --tight-kind between                                      # passages weighted
    python scripts/experiments/tune_route_rules.py --first-map 6 --maps 12 --fields route --margins 0.3 \
        --floors 0.3 --fills 1 --tights 0 8                                             # on maps not looked at
    python scripts/experiments/tune_route_rules.py --fields route --margins 0.3 --floors 0.3 --fills 1 \
        --chains 0 4 16 64                                                              # a chain along the route
    python scripts/experiments/tune_route_rules.py --first-map 18 --maps 12 --fields route --margins 0.3 \
        --floors 0.3 --fills 1 --chains 64 --chain-points jitter                        # its points anywhere in a cell
    python scripts/experiments/tune_route_rules.py --maps 6 --seeds 2 --connect       # RRT-Connect: one tree or two
    python scripts/experiments/tune_route_rules.py --maps 2 --seeds 2 --rrtstar       # RRT*'s rule after a solution

``--connect``: RRT-Connect with the RRT rule handed as it is (it guides the start tree, and its samples on the goal
tree's turns pull the goal tree towards the start tree's target) against both trees guided, each by its own field
(``BidirectionalRouteSampler(goal_tree="pass")``: two passes), against one field read both ways (the goal tree
follows the field to the goal mirrored, ``MirroredField``), against the goal tree on the field read off the walk down
the field to the goal (``goal_tree="walk"``, shipped: one pass; ``WalkElsePass``: a second pass where the walk ends
out of the goal's sight), and against the goal tree on the straight-line field to the start (the ablation's: no
second pass), for each field, on validation maps of ``--size`` cells; prints median iterations per family and their
geometric mean, and the geometric mean of the median time per query (each run a first query on its map: the
encoder's kept map parts are cleared first).

``--rrtstar``: RRT* with ``ConvergingRouteSampler`` at each margin, floor, fill and ``--start-fields`` (floor 1: the
RRT rule, then the informed set only), and the RRT rule throughout; prints the median iterations to within 5% and 1% of
the best cost any of them reached (``learning.evaluation.every_planner.convergence``), per family, and their geometric
means.

For each field (the route encoder, its straight-line ablation, the exact cost-to-go) and each corridor
``margin``, uniform ``floor``, ``fill`` (``--fills``: draws per step-sized square of a stage of the
corridor before it widens) and ``tight`` (``--tights``, ``--tight-kind``: the extra weight of a corridor cell where the
map is tight; by default each field's own) of the grid, PRM and Lazy-PRM run on the five families' validation maps
(``learning.evaluation.every_planner.planner_maps("validation")``, from each family's ``--first-map``-th; never
test maps); prints the median samples per
family and their geometric mean, the score the settings are chosen by (lowest), with the success share.
"""

from __future__ import annotations

import argparse
import itertools

import numpy as np

from learning.evaluation.every_planner import Setup, convergence, planner_maps, run_setup, summarize_runs
from learning.evaluation.protocol import MOVINGAI_MAPS, Protocol, movingai_queries
from learning.samplers.registry import ModelCache, make_sampler
from learning.samplers.route import RouteSampler
from learning.samplers.route_rules import (
    ABLATION_CORRIDOR,
    CORRIDOR_SETTINGS,
    BidirectionalRouteSampler,
    ConvergingRouteSampler,
    CorridorSampler,
    WalkField,
    cell_points,
    reversed_query,
    walk_field_steps,
)
from planners import OccupancyGrid, SamplerBase, movingai_dir


def blocked_shares(grid: OccupancyGrid, h: int) -> np.ndarray:
    """Each cell's share of blocked cells in the square of half side ``h`` about it (outside the map: blocked), flat."""
    blocked = np.pad(np.asarray(grid.obstacles, dtype=np.int64), h, constant_values=1)
    total = np.pad(blocked.cumsum(0).cumsum(1), ((1, 0), (1, 0)))  # summed-area table
    side = 2 * h + 1
    rows, cols = grid.shape
    inside = (total[side:side + rows, side:side + cols] - total[:rows, side:side + cols]
              - total[side:side + rows, :cols] + total[:rows, :cols])
    return (inside / float(side * side)).ravel()


class SharedCorridor(CorridorSampler):
    """The corridor with a cell weighted by its share of blocked cells within half a step (``--tight-kind share``).

    Tried beside the shipped rule (walls on two opposite sides, ``walled_between``): on the validation maps it moves
    samples next to any obstacle, a forest's trees among them, and loses there.
    """

    def cell_weights(self, grid, step_cells, cells):
        if self.tight == 0:
            return None
        return 1.0 + self.tight * blocked_shares(grid, max(1, round(step_cells / 2)))[cells]


class JitteredChain(CorridorSampler):
    """The corridor whose chain points lie uniform in their cells (``--chain-points jitter``).

    Tried beside the shipped rule (each point at its cell's centre): a point anywhere in its cell can clip a wall
    corner that the walk's centre-to-centre sight test passed, so the chain connects less often and more queries pay
    the corridor and the field to the start.
    """

    def chain_points(self, first, u):
        m = len(u)
        return cell_points(self.problem.world, self.links[first:first + m],
                           np.column_stack([(np.arange(m) + 0.5) / m, u]), self.low, self.high)


class MirroredField(RouteSampler):
    """Bound to a reversed query, the field to the start read off the one field to the goal: ``L - to_goal``.

    ``L`` is the field's value at the start (the bound problem's goal). Along the route it is the cost from the
    start; off it (a dead end) it is too low. One encoder pass serves both trees this way.
    """

    origin: type = RouteSampler  # the class whose field is mirrored (the route sampler's, or the exact reference's)

    def _fields(self, grid):
        forward = object.__new__(self.origin)
        forward.__dict__.update(self.__dict__)
        forward.problem = reversed_query(self.problem)
        forward, _ = forward._fields(grid)
        r, c = grid.cell_of(self.problem.goal)
        mirrored = np.maximum(forward[r, c] - forward, 0.0)
        mirrored[grid.obstacles] = np.inf  # the straight line's field comes with them at inf, its mirror without
        return mirrored, mirrored


def mirrored(route: RouteSampler) -> RouteSampler:
    """``route``'s settings and encoder on ``MirroredField``'s field."""
    out = object.__new__(MirroredField)
    out.__dict__.update(route.__dict__)
    out.origin = type(route)
    return out


class WalkElsePass(BidirectionalRouteSampler):
    """The goal tree on the walk's field where the walk reaches the goal's sight, else on the second pass (the shipped
    rule takes the walk's field as far as it went there)."""

    def _goal_tree_sampler(self, p):
        field = walk_field_steps(self.route, p, self.to_goal.field)
        return self.route if field is None else WalkField(self.route, field)


class StartTreeOnly(SamplerBase):
    """The route sampler's RRT rule handed to RRT-Connect as it is (no ``for_planner``): the start tree's."""

    def __init__(self, route) -> None:
        self.route = route

    def bind(self, problem):
        return self.route.bind(problem)

    def draw(self, rng, n, view):
        raise NotImplementedError("bound, this is the route sampler itself")


def geomean_row(label: str, per_family: list[dict]) -> str:
    """A printed row: the geometric mean of the families' median iterations, each, the lowest success, and the
    geometric mean of the families' median time per query (the sampler's set-up included)."""
    medians = [r["iterations"] for r in per_family]
    score = float(np.exp(np.mean(np.log(medians))))
    ms = float(np.exp(np.mean(np.log([max(r["time_ms"], 1e-3) for r in per_family]))))
    return (f"{label}  geomean {score:7.1f}  per family {' '.join(f'{m:6.0f}' for m in medians)}  "
            f"success {min(r['success'] for r in per_family):.2f}  time {ms:.2f} ms")


def connect_probe(field: str, wrap, problem, seed: int, models: ModelCache) -> dict:
    """One RRT-Connect run of ``wrap(make_sampler(field))``, timed as a first query on its map: the encoder keeps no
    map's parts from earlier runs (``RouteVIN.clear_map_cache``), so each rule pays its passes in full."""
    route = make_sampler(field, models=models)
    if getattr(route, "net", None) is not None:
        route.net.clear_map_cache()
    return run_setup(Setup(field, "RRTConnect", field), problem, seed, models=models, sampler=wrap(route))


def movingai_tuning_maps(directory: str) -> dict[str, list]:
    """The tuning scenarios of the comparison's MovingAI maps in ``directory`` (its split), by map."""
    protocol, cache = Protocol(), {}
    d = str(movingai_dir(directory))
    queries = [q for q in movingai_queries(d, MOVINGAI_MAPS, protocol.scenarios, protocol.tuning_scenarios,
                                           protocol.tolerance, cache) if q.split == "tuning"]
    return {m: [q.problem(d, protocol.tolerance, cache) for q in queries if q.family == m] for m in MOVINGAI_MAPS}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--maps", type=int, default=6, help="validation maps per family")
    ap.add_argument("--seeds", type=int, default=2, help="planner seeds per map")
    ap.add_argument("--margins", type=float, nargs="+", default=[0.1, 0.3, 0.6, 1.0])
    ap.add_argument("--floors", type=float, nargs="+", default=[0.1, 0.3])
    ap.add_argument("--fills", nargs="+", default=[None], type=lambda v: None if v == "none" else float(v),
                    help="draws per step-sized square of a stage of the roadmaps' corridor before it widens "
                    "('none': never)")
    ap.add_argument("--tights", type=float, nargs="+", default=None,
                    help="the roadmaps' corridor: extra weight of a cell by its tightness within half a step "
                    "(CorridorSampler's tight; 0: every corridor cell alike; default: each field's own)")
    ap.add_argument("--chains", type=float, nargs="+", default=None,
                    help="the roadmaps' corridor: the most steps of walk between two points of its chain along the "
                    "route (CorridorSampler's chain; 0: none; default: each field's own)")
    ap.add_argument("--chain-points", default="centre", choices=["centre", "jitter"],
                    help="where the chain's points lie in their cells: the centre (the shipped rule) or uniform")
    ap.add_argument("--tight-kind", default="between", choices=["between", "share"],
                    help="tightness: walls on two opposite sides of a cell (the shipped rule), or the share of "
                    "blocked cells about it")
    ap.add_argument("--first-map", type=int, default=0,
                    help="each family's validation maps from its K-th on (fresh maps beside ones already looked at)")
    ap.add_argument("--fields", nargs="+", default=["route", "route_ablation", "exact_route"])
    ap.add_argument("--planners", nargs="+", default=["PRM", "LazyPRM"])
    ap.add_argument("--connect", action="store_true", help="RRT-Connect: the start tree guided, or both")
    ap.add_argument("--rrtstar", action="store_true", help="RRT*: the rule after the first solution")
    ap.add_argument("--budget", type=int, default=3000, help="RRT* iterations per run with --rrtstar")
    ap.add_argument("--start-fields", nargs="+", default=["pass"], choices=["pass", "walk"],
                    help="the corridor's field to the start (RRT*'s with --rrtstar, else the roadmaps'): a second "
                    "pass, or read off the walk down the field to the goal")
    ap.add_argument("--size", type=int, default=128, help="the validation maps' side in cells (default 128)")
    ap.add_argument("--movingai-tuning", metavar="DIR", default=None,
                    help="instead of the validation maps, the tuning scenarios of the comparison's MovingAI maps "
                    "in DIR (its tuning split, never its test scenarios), by map")
    args = ap.parse_args(argv)
    if args.first_map < 0:
        ap.error(f"--first-map must be >= 0, got {args.first_map}")
    if args.size < 32:
        ap.error(f"--size takes a map side of at least 32 cells, got {args.size}")
    if args.movingai_tuning is not None:
        maps = movingai_tuning_maps(args.movingai_tuning)
    else:
        maps = {f: problems[args.first_map:] for f, problems in
                planner_maps("validation", args.first_map + args.maps, size=args.size).items()}
    models = ModelCache()
    if args.rrtstar:
        for field in args.fields:
            setups = [Setup("RRT rule throughout", "RRTstar", field, make=lambda f=field: StartTreeOnly(
                make_sampler(f, models=models)))]
            setups += [Setup(f"margin {m:g} floor {fl:g} fill {fi} start {sf}", "RRTstar", field,
                             make=lambda f=field, m=m, fl=fl, fi=fi, sf=sf: ConvergingRouteSampler(
                                 make_sampler(f, models=models), m, fl, fi, start_field=sf))
                       for m, fl, fi, sf in itertools.product(args.margins, args.floors, args.fills,
                                                              args.start_fields)]
            rows = convergence(maps, setups, seeds=tuple(range(args.seeds)), budget=args.budget)
            for s in setups:
                mine = [r for r in rows if r["sampler"] == s.label]
                for share in ("0.05", "0.01"):
                    its = [r[f"iterations_{share}"] for r in mine]
                    mean = float(np.exp(np.mean(np.log(its))))
                    print(f"RRTstar {field:15s} {s.label:30s} within {share}: geomean {mean:7.0f}  "
                          f"per family {' '.join(f'{i:5.0f}' for i in its)}", flush=True)
        return 0
    if args.connect:
        for field in args.fields:
            rules = (("start tree only", StartTreeOnly),
                     ("both trees", lambda r: BidirectionalRouteSampler(r, goal_tree="pass")),
                     ("one field, mirrored", lambda r: BidirectionalRouteSampler(r, mirrored(r))),
                     ("goal tree on walk", lambda r: BidirectionalRouteSampler(r, goal_tree="walk")),
                     ("walk, else a pass", WalkElsePass),
                     ("goal tree straight", lambda r: BidirectionalRouteSampler(
                         r, make_sampler("route_ablation", models=models))))
            for rule, wrap in rules:
                per_family = [summarize_runs([connect_probe(field, wrap, p, s, models)
                                              for p in problems for s in range(args.seeds)])
                              for problems in maps.values()]
                print(geomean_row(f"RRTConnect {field:15s} {rule:16s}", per_family), flush=True)
        return 0
    for planner in args.planners:
        for field, margin, floor, fill, tight, chain, start in itertools.product(
                args.fields, args.margins, args.floors, args.fills, args.tights or [None], args.chains or [None],
                args.start_fields):
            own = ABLATION_CORRIDOR if field == "route_ablation" else CORRIDOR_SETTINGS
            tight = own["tight"] if tight is None else tight
            chain = own["chain"] if chain is None else chain
            kind = CorridorSampler if args.tight_kind == "between" else SharedCorridor
            if args.chain_points == "jitter":
                if args.tight_kind != "between":
                    ap.error("--chain-points jitter takes the shipped --tight-kind between")
                kind = JitteredChain
            per_family = [summarize_runs([run_setup(Setup(field, planner, field), p, s, models=models,
                                                    sampler=kind(make_sampler(field, models=models),
                                                                 margin, floor, fill, tight, chain, start))
                                          for p in problems for s in range(args.seeds)])
                          for problems in maps.values()]
            print(geomean_row(f"{planner:8s} {field:15s} margin {margin:4.2f} floor {floor:4.2f} fill {fill} "
                              f"tight {tight:g} {args.tight_kind} chain {chain:g} {args.chain_points} start {start}",
                              per_family),
                  flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
