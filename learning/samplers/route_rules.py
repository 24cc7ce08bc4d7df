"""The route field's rule for each planner family: one field, read as each kind of planner needs it.

``RouteSampler`` follows the tree vertex of lowest cost-to-go, which is what RRT needs. The same field (the
route encoder's cost-to-go over the whole map; the straight line for its ablation; the exact grid distance for
the reference) serves the other planners through ``RouteSampler.for_planner``, which every planner calls
before binding (``planners.base.samplers``), so ``make_sampler("route")`` does the right thing whatever it is
handed to:

- ``BidirectionalRouteSampler`` (RRT-Connect): the start tree follows the field to the goal and the goal tree
  a field to the start, each by ``RouteSampler``'s rule, uniform floor included; each draw serves the tree whose
  turn it is (``TreeView.tree``). The field to the start is read off the route sampler's walk down the field to the
  goal from the start (``walk_field_to_start``: along the walk its length from the start, off it the way back to
  the walk; where the walk ends out of the goal's sight, the walk as far as it went), so both trees take one pass.
  Its draws run inside RRT-Connect's compiled loop (``planners.fused.connect_loop``), as the route sampler's run
  inside RRT's.
- ``CorridorSampler`` (PRM, Lazy-PRM, OB-PRM): first a chain along the route (``route_chain``: the corners of the
  route sampler's walk down the field from the start, each in sight of the one before), then over the cells whose
  cost from the start plus cost to the goal is within ``margin`` of the lowest, a corridor around the routes the
  field calls short, a cell in a passage (walls within half a step on two opposite sides, ``walled_between``)
  drawn ``1 + tight`` times as often as another, with a ``floor`` share of uniform samples so the roadmap stays
  complete; while the roadmap stays unconnected the corridor widens in stages, each once it has had ``fill``
  draws per step-sized square of its cells (``corridor_stages``), out to every cell the field reaches.
- ``ConvergingRouteSampler`` (RRT*, Informed RRT*): ``RouteSampler``'s rule to the first solution, then the
  corridor cells inside the informed set (the states that could lie on a shorter path), widening in the same
  stages, with a ``floor`` share from the informed set itself (``InformedSampler``). The corridor's field to the
  start is read off the walk down the field to the goal at the first draw after the first solution (a second pass
  only where that walk ends out of the goal's sight); the draws up to it run inside RRT*'s compiled loop
  (``planners.fused.rrtstar_loop``).

The settings (``CORRIDOR_SETTINGS``, ``CONVERGING_SETTINGS``; the straight-line ablation's own,
``ABLATION_CORRIDOR``, ``ABLATION_CONVERGING``) were chosen on validation maps
(``scripts/experiments/tune_route_rules.py``); the exact reference takes the learned field's.
"""

from __future__ import annotations

import copy
import math
from typing import TYPE_CHECKING

import numba as nb
import numpy as np

from learning.samplers.route import CachedField, RouteSampler, require_grid, route_draw
from planners import InformedSampler, OccupancyGrid, Problem
from planners.base.fileio import InputError, short_repr
from planners.base.samplers import (
    FAMILY_BIDIRECTIONAL,
    FAMILY_OPTIMIZING,
    FAMILY_ROADMAP,
    TREE_GOAL,
    SampleBatch,
    SamplerBase,
)
from planners.fused import (
    FusedConnect,
    FusedRRT,
    connect_loop,
    fuse_connect,
    fuse_rrtstar,
    nearest_distance,
    rrtstar_loop,
)
from planners.guidance.follow import last_in_sight, path_field, walk_path

if TYPE_CHECKING:
    from planners.base.planner import Planner

#: The roadmaps' corridor, chosen on the validation maps (``scripts/experiments/tune_route_rules.py``): cells on
#: routes within 30% of the shortest the field sees (plus one step), and 30% of the samples uniform; while the
#: roadmap stays unconnected it widens once each stage has had one draw per step-sized square of its cells (the
#: smallest fill of 1, 2, 4, 8 that leaves the validation maps' samples as they were). A cell with walls within
#: half a step on two opposite sides (a passage) is drawn 9 times as often as one without (``tight`` 8 of 0 to 16;
#: kept by validation maps no rule had looked at). Its first draws are a chain along the route, the walk's corners at
#: most 64 steps of walk apart (``chain`` 64 of 4, 16, 64: 0.25 of the samples without a chain on the validation
#: maps, 0.24 on fresh ones), each at its cell's centre (0.71 of the samples and 0.49 of the time of points uniform
#: in their cells, on validation maps no other rule had seen: a jittered point clips corners the walk's sight test
#: passed, and the corridor, with the second field, is paid). The exact reference takes the same settings.
CORRIDOR_SETTINGS = {"margin": 0.3, "floor": 0.3, "fill": 1.0, "tight": 8.0, "chain": 64.0}
#: The straight-line ablation's corridor, tuned for it on the same maps: an ellipse about the start and the
#: goal, 60% longer than the straight line; it widens as the learned field's does; a passage cell drawn 17 times
#: as often (``tight`` 16, chosen for it the same way). No chain: along the straight line none of 4, 16 or 64
#: steps took it under 0.9 of the samples without one on the validation maps (0.96 at best).
ABLATION_CORRIDOR = {"margin": 0.6, "floor": 0.3, "fill": 1.0, "tight": 16.0, "chain": 0.0}
#: RRT*'s corridor after the first solution, chosen on the validation maps (``tune_route_rules.py --rrtstar``):
#: cells within 10% of the shortest route the field sees, and a tenth of the samples from the informed set; it
#: widens once each stage has had 8 draws per step-sized square (the smallest fill of 1 to 32 that leaves the
#: validation maps' iterations to within 5% as they were).
CONVERGING_SETTINGS = {"margin": 0.1, "floor": 0.1, "fill": 8.0}
#: The straight-line ablation's, tuned for it on the same maps: an ellipse twice as long as the straight line;
#: it widens as the learned field's does.
ABLATION_CONVERGING = {"margin": 1.0, "floor": 0.1, "fill": 8.0}
#: Where RRT*'s corridor takes its field to the start (``ConvergingRouteSampler``'s ``start_field``): read off the walk
#: down the field to the goal, chosen on the validation maps (``tune_route_rules.py --rrtstar --start-fields pass
#: walk``): to within 5% and 1% of the best cost in a geometric mean of 899 and 2,150 iterations against the second
#: pass's 984 and 2,377 (2 maps a family), and 872 and 2,250 against 901 and 2,218 on 6 maps a family no rule had
#: looked at (at most 1.05 times the pass's, and one pass fewer).
CONVERGING_START_FIELD = "walk"
#: Where the roadmaps' corridor takes its field to the start (``CorridorSampler``'s ``start_field``): "pass", the
#: field's second pass with start and goal swapped, or "walk", read off the walk down the field to the goal (the pass
#: where that walk ends out of the goal's sight). "walk" by the rule RRT*'s corridor was chosen by, fixed before the
#: runs (``tune_route_rules.py --start-fields pass walk``: at most 1.05 times the pass's samples, as many runs
#: connected): on the validation maps at 128, 256 and 512 cells (6, 16 and 8 a family), 12 fresh ones a family and
#: the MovingAI tuning scenarios (``--movingai-tuning``), PRM and Lazy-PRM take the same median samples either way
#: (geometric means 3.1, 3.6, 3.9, 3.5 and 12.7), every run connected: the chain along the route connects those
#: roadmaps before the corridor is built, so the rule decides where the chain does not (a roadmap the lazy sampler's
#: uniform phase left in pieces), with one pass fewer.
CORRIDOR_START_FIELD = "walk"
#: Corridor cells are those within ``margin`` times the shortest route plus this many steps.
WIDTH_STEPS = 1.0
#: Samples per draw once RRT* has a solution (the informed set shrinks as the solution improves).
CONVERGING_BATCH = 64


def is_straight_line(route: RouteSampler) -> bool:
    """Whether ``route`` is the straight-line ablation (no encoder, the plain route sampler): its rules take their own
    settings, and its field to the start costs no pass.
    """
    return route.net is None and type(route) is RouteSampler


def whole_walk(field: np.ndarray, blocked: np.ndarray, cell: int, ripple: float, growth: float) -> np.ndarray:
    """The route sampler's walk down ``field`` from ``cell`` as far as it goes (``walk_path``): its cells, in order."""
    visited = np.empty(blocked.size + 2, np.int64)
    return visited[:walk_path(field, blocked, cell, float(blocked.size), ripple, growth, visited)]


def in_sight(blocked: np.ndarray, a: int, b: int) -> bool:
    """Whether the centres of flat cells ``a`` and ``b`` see each other (``last_in_sight`` of the two)."""
    return last_in_sight(blocked, np.array([a, b], dtype=np.int64), 2) == b


def rule_for(route: RouteSampler, family: str) -> SamplerBase:
    """``route``'s rule for planner ``family`` (``RouteSampler.for_planner``); ``route`` itself for RRT."""
    if family == FAMILY_BIDIRECTIONAL:
        return BidirectionalRouteSampler(route)
    straight = is_straight_line(route)
    if family == FAMILY_ROADMAP:
        return CorridorSampler(route, **(ABLATION_CORRIDOR if straight else CORRIDOR_SETTINGS))
    if family == FAMILY_OPTIMIZING:
        return ConvergingRouteSampler(route, **(ABLATION_CONVERGING if straight else CONVERGING_SETTINGS))
    return route


def reversed_query(problem: Problem) -> Problem:
    """``problem`` with start and goal swapped: the query whose cost-to-go is a cost from the start."""
    return problem.with_query(problem.goal, problem.start)


def query_cells(problem: Problem) -> tuple:
    """The grid cells (row, col) of ``problem``'s start and goal: where ``route_sums`` reads the route's length."""
    return problem.world.cell_of(problem.start), problem.world.cell_of(problem.goal)


def _check_share(who: str, name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.floating) or not 0 <= value <= 1:
        raise InputError(f"{who}: {name} = {short_repr(value)}, expected a share from 0 to 1")
    return float(value)


def _check_nonnegative(who: str, name: str, value, meaning: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.floating) or not 0 <= value < math.inf:
        raise InputError(f"{who}: {name} = {short_repr(value)}, expected a finite number >= 0 ({meaning})")
    return float(value)


def route_sums(to_goal: np.ndarray, to_start: np.ndarray, ends: tuple | None = None
               ) -> tuple[np.ndarray, np.ndarray, float]:
    """The cells a route passes and ``to_start + to_goal`` there: ``(cells, sums, length)``.

    ``cells``: flat indices of the cells where the sum is finite, ascending; ``sums``: their sums; ``length``: the
    route's length as the two fields give it, the larger of ``to_goal`` at the start's cell and ``to_start`` at the
    goal's cell (``ends``: their (row, col); None: the lowest sum alone), never below the lowest sum (which it equals
    for an exact field; a learned field's sum can dip below it off the route). No cell finite: no cells, length
    ``inf``.
    """
    total = (to_goal + to_start).ravel()
    cells = np.flatnonzero(np.isfinite(total))
    sums = total[cells]
    if not len(cells):
        return cells, sums, math.inf
    said = []
    if ends is not None:
        (rs, cs), (rg, cg) = ends
        said = [v for v in (float(to_goal[rs, cs]), float(to_start[rg, cg])) if math.isfinite(v)]
    return cells, sums, max([float(sums.min())] + said)


def _first_bound(sums: np.ndarray, margin: float, width: float) -> float:
    """The first corridor's bound on a cell's sum: ``(1 + margin)`` x the lowest + ``width`` (no sums: inf)."""
    return float(sums.min()) * (1.0 + margin) + width if len(sums) else math.inf


def corridor_cells(to_goal: np.ndarray, to_start: np.ndarray, margin: float, width: float = WIDTH_STEPS) -> np.ndarray:
    """Flat indices of the cells whose ``to_start + to_goal`` is within ``(1 + margin)`` x the lowest + ``width``.

    The first stage of ``corridor_stages``. The fields are in steps, ``inf`` where blocked or unreached; no cell
    finite: none.
    """
    cells, sums, _ = route_sums(to_goal, to_start)
    return cells[sums <= _first_bound(sums, margin, width)]


def corridor_stages(to_goal: np.ndarray, to_start: np.ndarray, ends: tuple, margin: float, fill: float | None,
                    square: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A corridor that widens in stages: ``(cells, counts, starts)``.

    Stage 0 is ``corridor_cells`` (the cells within ``(1 + margin)`` x the lowest sum, plus ``WIDTH_STEPS``); with
    ``L`` the route's length as the fields give it (``route_sums``; ``ends``: the start's and the goal's (row, col)),
    stage 1 holds those within ``(1 + margin) x L`` and each later stage doubles that bound, until every cell the
    fields reach is in. ``cells``: flat indices of the cells some stage holds, by the first stage that holds them
    (index order within it), so stage ``j`` is ``cells[:counts[j]]``; stage ``j`` starts at draw ``starts[j]`` and
    lasts ``fill`` draws per ``square`` of its cells (cells in a step-sized square). ``fill`` None: stage 0 only,
    for good.
    """
    cells, sums, length = route_sums(to_goal, to_start, ends)
    bounds = [_first_bound(sums, margin, WIDTH_STEPS)]
    while fill is not None and len(sums) and bounds[-1] < sums.max():
        # at least a step before doubling, so a route of length 0 (start and goal in one cell) widens too
        bounds.append(max(length * (1.0 + margin), 1.0) * 2.0 ** (len(bounds) - 1) + WIDTH_STEPS)
    stage = np.searchsorted(np.asarray(bounds), sums, side="left")
    order = np.argsort(stage, kind="stable")
    counts = np.searchsorted(stage[order], np.arange(len(bounds)), side="right")
    lasts = [math.ceil(fill * c / square) for c in counts[:-1]] if fill is not None else []
    return (cells[order][:counts[-1]], counts,  # cells no stage holds are never drawn
            np.concatenate([[0], np.cumsum(lasts, dtype=np.int64)]).astype(np.int64))


def _check_fill(who: str, value) -> float | None:
    if value is not None and (isinstance(value, bool) or not isinstance(value, int | float | np.floating)
                              or not 0 < value < math.inf):
        raise InputError(f"{who}: fill = {short_repr(value)}, expected a finite number > 0 (draws per step-sized "
                         "square of the corridor) or None")
    return None if value is None else float(value)


def walled_between(grid: OccupancyGrid, h: int, cells: np.ndarray | None = None) -> np.ndarray:
    """1.0 where a cell has blocked cells within ``h`` on both sides along one of four axes (a passage), else 0.0.

    For the flat cell indices ``cells`` (None: every cell, in the grid's order); outside the map counts as blocked.
    The work follows ``len(cells)``, not the map's size (``walled_cells``, compiled).
    """
    blocked = np.asarray(grid.obstacles, dtype=bool)
    flat = np.arange(blocked.size, dtype=np.int64) if cells is None else np.asarray(cells, dtype=np.int64)
    out = np.zeros(len(flat), dtype=np.float64)
    walled_cells(blocked, int(h), flat, out)
    return out


@nb.njit(cache=True)
def _blocked_at(blocked, r, c):
    return r < 0 or c < 0 or r >= blocked.shape[0] or c >= blocked.shape[1] or blocked[r, c]


@nb.njit(cache=True)
def walled_cells(blocked, h, cells, out):
    """``walled_between``'s loop: ``out[i]`` = 1.0 where flat cell ``cells[i]`` has a blocked cell (or the map's
    edge) within ``h`` cells ahead and one within ``h`` behind along a row, a column or a diagonal.
    """
    W = blocked.shape[1]
    for i in range(cells.shape[0]):
        r, c = cells[i] // W, cells[i] % W
        for d in range(4):
            dr, dc = (0, 1) if d == 0 else ((1, 0) if d == 1 else ((1, 1) if d == 2 else (1, -1)))
            ahead = False
            for k in range(1, h + 1):
                if _blocked_at(blocked, r + k * dr, c + k * dc):
                    ahead = True
                    break
            if not ahead:
                continue
            for k in range(1, h + 1):
                if _blocked_at(blocked, r - k * dr, c - k * dc):
                    out[i] = 1.0
                    break
            if out[i] == 1.0:
                break


def cell_points(grid: OccupancyGrid, cells: np.ndarray, u: np.ndarray, low: np.ndarray, high: np.ndarray,
                counts: np.ndarray | int | None = None, cum: np.ndarray | None = None) -> np.ndarray:
    """States in the grid's ``cells`` (flat indices, not empty) from uniforms ``u`` (m, 3): a cell, then a point in it.

    ``counts``: each state's cell is among the first ``counts`` of ``cells`` (per state, or one for all; None: any,
    each at least 1). ``cum``: the cells' weights summed in order (a cell drawn in proportion to its weight); None:
    every cell alike. The states are kept inside the sampling box ``[low, high)``.
    """
    counts = len(cells) if counts is None else counts
    last = np.asarray(counts) - 1
    if cum is None:
        pick = cells[np.minimum((u[:, 0] * counts).astype(np.int64), last)]
    else:
        pick = cells[np.minimum(np.searchsorted(cum, u[:, 0] * cum[last], side="right"), last)]
    rows, cols = np.divmod(pick, grid.width)
    pts = np.stack([cols + u[:, 1], rows + u[:, 2]], axis=1) * grid.resolution + np.asarray(grid.origin)
    return np.minimum(np.maximum(pts, low), np.nextafter(high, low))


def sight_chain(field: np.ndarray, blocked: np.ndarray, cell: int, link: int, ripple: float,
                growth: float) -> tuple[list[int], int]:
    """The corners of the walk down ``field`` from ``cell``: each point the last of the walk in sight of the one before.

    The walk is the route sampler's (``planners.guidance.follow.walk_path``: down the field, crossing ripples
    shallower than ``ripple`` and ``growth``), as far as it goes; from ``cell`` each next point is the last cell of the
    walk's next ``link`` cells still in sight of the point before it (``last_in_sight``), so the segment between two
    points meets no wall (``walk_corners``, compiled). Returns the points (flat indices; ``cell`` not among them) and
    the walk's last cell.
    """
    visited = whole_walk(field, blocked, cell, ripple, growth)
    corners = np.empty(len(visited), dtype=np.int64)
    count = walk_corners(blocked, visited, min(int(link), len(visited)), corners)
    return corners[:count].tolist(), int(visited[-1])


@nb.njit(cache=True)
def walk_corners(blocked, visited, link, corners):
    """``sight_chain``'s loop over the walk ``visited``: writes the corners to ``corners``; their number.

    From the walk's first cell, the next corner is the last of the walk's next ``link`` cells in sight of the corner
    before (the next cell of the walk where not even that one is), until the walk's last cell.
    """
    moves = visited.shape[0]
    count = 0
    at = 0
    while at < moves - 1:
        end = min(moves, at + link + 1)
        corner = last_in_sight(blocked, visited[at:end], end - at)
        ahead = at + 1
        if corner != visited[at]:
            for j in range(at + 1, end):
                if visited[j] == corner:
                    ahead = j
                    break
        corners[count] = visited[ahead]
        count += 1
        at = ahead
    return count


def route_chain(to_goal: np.ndarray, to_start, blocked: np.ndarray, ends: tuple, link: int,
                ripple: float = 0.0, growth: float = 0.0) -> np.ndarray:
    """Flat indices of the cells of a chain along the route the fields give: the walk's corners (``sight_chain``).

    The walk down ``to_goal`` from the start's cell; where it ends out of the goal's sight (a pit of a learned
    field, or a wall across the straight line), the corners of the walk down ``to_start`` from the goal's cell
    follow, from the goal end. The goal's cell itself is left out (the goal is a vertex already). ``to_start``: the
    field, or a callable that returns it (called only where the walk from the start ends out of the goal's sight);
    ``ends``: the start's and the goal's (row, col); ``link``: the most cells of walk between two points.
    """
    (rs, cs), (rg, cg) = ((int(a), int(b)) for a, b in ends)
    cols = blocked.shape[1]
    goal = rg * cols + cg
    forward, last = sight_chain(to_goal, blocked, rs * cols + cs, link, ripple, growth)
    if not in_sight(blocked, last, goal):
        backward, _ = sight_chain(to_start() if callable(to_start) else to_start, blocked, goal, link, ripple, growth)
        forward += backward
    return np.asarray([c for c in forward if c != goal and c != rs * cols + cs], dtype=np.int64)


@nb.njit(cache=True)
def route_connect_loop(budget, state_a, state_b, buffers, rng, loop):
    """RRT-Connect's compiled loop drawing from ``route_draw`` for both trees (``planners.fused``)."""
    return connect_loop(budget, route_draw, state_a, state_b, buffers, rng, loop)


@nb.njit(cache=True)
def route_rrtstar_loop(budget, state, buffers, rng, loop):
    """RRT*'s compiled loop drawing from ``route_draw`` up to its first solution (``planners.fused``)."""
    return rrtstar_loop(budget, route_draw, state, buffers, rng, loop)


class WalkField(RouteSampler):
    """``route``'s rule and settings on a field handed to it (in steps) instead of the encoder's pass.

    ``BidirectionalRouteSampler`` binds it to the reversed query with the field to the start read off the walk down
    the field to the goal (``walk_field_to_start``): the goal tree follows it with no pass of its own.
    """

    def __init__(self, route: RouteSampler, field: np.ndarray) -> None:
        self.__dict__.update(route.__dict__)
        self.given = field

    def _fields(self, grid: OccupancyGrid) -> tuple[np.ndarray, np.ndarray]:
        return self.given.copy(), self.given.copy()


def walk_field_to_start(to_goal: np.ndarray, blocked: np.ndarray, ends: tuple, ripple: float = 0.0,
                        growth: float = 0.0, partial: bool = False) -> np.ndarray | None:
    """A field to the start (in cells) read off the walk down ``to_goal`` from the start, or None.

    The walk is the route sampler's (``walk_path``, crossing ripples shallower than ``ripple`` and ``growth``); where it
    ends in sight of the goal (the goal's cell then closing it), the field is ``planners.guidance.follow.path_field`` of
    it: along the walk its length from the start, off it the way back to the walk. Where the walk ends out of the
    goal's sight (a pit of a learned field), the walk says nothing of the route's last part: None, or with ``partial``
    the field of the walk as far as it went (from the goal, the way to the walk's nearest part, then along it).
    """
    (rs, cs), (rg, cg) = ((int(a), int(b)) for a, b in ends)
    cols = blocked.shape[1]
    goal = rg * cols + cg
    walk = whole_walk(to_goal, blocked, rs * cols + cs, ripple, growth)
    if walk[-1] != goal:
        if not in_sight(blocked, int(walk[-1]), goal):
            return path_field(blocked, walk, len(walk)) if partial else None
        walk = np.append(walk, goal)  # the segment to the goal's centre is free: a walk of cells would cross it
    return path_field(blocked, walk, len(walk))


def walk_field_steps(route: RouteSampler, problem: Problem, to_goal: np.ndarray,
                     partial: bool = False) -> np.ndarray | None:
    """``walk_field_to_start`` for ``route`` on ``problem`` from its field to the goal, in steps (with ``partial`` as
    there), ``inf`` on obstacles; None where it gives none, and for the straight-line ablation, whose own field to
    the start costs no pass.
    """
    if is_straight_line(route):
        return None
    grid = problem.world
    blocked = np.asarray(grid.obstacles, dtype=bool)
    cells = walk_field_to_start(to_goal, blocked, query_cells(problem), getattr(route, "ripple", 0.0),
                                getattr(route, "ripple_growth", 0.0), partial)
    return None if cells is None else cells * (grid.resolution / route.step_size)


#: Where RRT-Connect's goal tree takes its field to the start from (``BidirectionalRouteSampler``): "walk", read off the
#: walk down the field to the goal (no second pass), or "pass", the field's own second pass with start and goal
#: swapped. "walk" was chosen on the validation maps (``tune_route_rules.py --connect``): a geometric mean of 21.6
#: iterations over the five families against two passes' 24.6 (exact field: 22.5 against 24.8), 5.9 against 8.4 ms
#: a first query, and on 12 maps a family no rule had looked at 23.5 against 23.0 (exact: 24.8 against 23.5). Where
#: the walk ends out of the goal's sight, its field as far as it went (``partial``) rather than the pass: on validation
#: maps of 256 and 512 cells (16 and 8 a family, where 10% and 12% of the walks end so), 36.9 against 36.1 and 73.8
#: against 72.8 iterations, every run solved (at 128 cells no validation walk ends so).
GOAL_TREE_FIELDS = ("walk", "pass")


def _check_field_source(name: str, value) -> str:
    """``value`` where it is one of ``GOAL_TREE_FIELDS`` (where a field to the start comes from), else an ``InputError``
    naming the setting ``name``.
    """
    if value not in GOAL_TREE_FIELDS:
        raise InputError(f"{name} = {short_repr(value)}, expected one of {', '.join(GOAL_TREE_FIELDS)}")
    return value


def corridor_field_to_start(route: RouteSampler, problem: Problem, to_goal: np.ndarray,
                            source: str) -> tuple[CachedField, bool]:
    """A corridor's field to the start of ``problem``, and whether it was read off the walk (no pass).

    With ``source`` "walk", read off the walk down ``to_goal`` (``walk_field_steps``) where that walk ends in the goal's
    sight; otherwise (and with "pass") ``route``'s field of the query with start and goal swapped (``cost_to_go``).
    """
    walked = walk_field_steps(route, problem, to_goal) if source == "walk" else None
    if walked is not None:
        return CachedField(walked, 0.0, False), True
    return route.cost_to_go(reversed_query(problem)), False


class BidirectionalRouteSampler(SamplerBase):
    """RRT-Connect's rule: each tree follows the field to the other end (see the module docstring).

    Args:
        route: The route sampler whose rule and field each tree follows (at the planner's step).
        backward: The sampler the goal tree follows, bound to the query with start and goal swapped; None:
            ``route`` (its field to the start, as ``goal_tree`` says).
        goal_tree: Where the goal tree's field to the start comes from without a ``backward`` (``GOAL_TREE_FIELDS``):
            "walk" reads it off the route sampler's walk down the field to the goal from the start
            (``walk_field_to_start``, as far as the walk goes), one pass for both trees; "pass" takes the second pass.
            The straight-line ablation's field to the start costs no pass: it takes its own.
    """

    def __init__(self, route: RouteSampler, backward: RouteSampler | None = None, goal_tree: str = "walk") -> None:
        self.route, self.backward, self.goal_tree = route, backward, _check_field_source("goal_tree", goal_tree)

    def _setup(self) -> None:
        p = self.problem
        require_grid("BidirectionalRouteSampler", p.world)
        self.to_goal = self.route.bind(p)
        self.to_start = self._goal_tree_sampler(p).bind(reversed_query(p))
        self._start = np.asarray(p.start, dtype=np.float64)
        self._seen, self._closest = 0, math.inf  # goal-tree vertices looked at, their closest distance to the start

    def _goal_tree_sampler(self, p: Problem) -> RouteSampler:
        if self.backward is not None:
            return self.backward
        field = walk_field_steps(self.route, p, self.to_goal.field, partial=True) if self.goal_tree == "walk" else None
        return self.route if field is None else WalkField(self.route, field)

    @property
    def forward_passes(self) -> int:
        """The encoder's passes this query took (two fields, or one where the goal tree's is read off the walk)."""
        return self.to_goal.forward_passes + self.to_start.forward_passes

    @property
    def reused_seconds(self) -> float:
        """Encoder seconds of fields taken from a cache (see ``RouteSampler``)."""
        return self.to_goal.reused_seconds + self.to_start.reused_seconds

    def draw(self, rng, n, view):
        # the trees take turns, so each has drawn ``iteration // 2`` times before: its own iteration count
        if view.tree == TREE_GOAL and view.goal_tree is not None:
            X = view.goal_tree
            m = len(X)  # only the vertices added since the last look
            self._closest, self._seen = min(self._closest, nearest_distance(X, self._seen, m, self._start)), m
            return self.to_start.draw_tree(rng, n, X, m, self._closest, view.iteration // 2)
        return self.to_goal.draw_tree(rng, n, view.vertices, view.num_vertices, view.best_distance,
                                      view.iteration // 2)

    def fuse(self, planner: Planner) -> FusedConnect | None:
        """RRT-Connect's loop with both trees' draws compiled in (the same samples as ``draw``, less time)."""
        return fuse_connect(planner, route_connect_loop, self.to_goal.draw_state, self.to_start.draw_state,
                            (self.to_goal.batch, self.to_start.batch))

    def __repr__(self) -> str:
        return f"BidirectionalRouteSampler({self.route!r}, goal_tree={self.goal_tree!r})"


class _CorridorRule(SamplerBase):
    """What the corridor's rules share: the route sampler, and the corridor's ``margin``, ``floor`` and ``fill``."""

    def __init__(self, route: RouteSampler, margin: float, floor: float, fill: float | None,
                 tight: float = 0.0) -> None:
        who = type(self).__name__
        self.route = route
        self.margin = _check_nonnegative(who, "margin", margin, "a share of the route")
        self.floor = _check_share(who, "floor", floor)
        self.fill = _check_fill(who, fill)
        self.tight = _check_nonnegative(who, "tight", tight, "the extra weight of a corridor cell in a passage")

    def _stages(self, to_goal: np.ndarray, to_start: np.ndarray) -> None:
        """Set ``cells``, ``counts`` and ``starts``: ``corridor_stages`` at this rule's settings and route step.

        The corridor's cells by stage, the cells of each stage (a prefix of them), and the draw each stage starts at.
        """
        p = self.problem
        step_cells = self.route.step_size / p.world.resolution
        self.cells, self.counts, self.starts = corridor_stages(
            to_goal, to_start, query_cells(p), self.margin, self.fill, step_cells ** 2)
        weights = self.cell_weights(p.world, step_cells, self.cells) if len(self.cells) else None
        #: the corridor cells' weights summed in stage order (None: every cell alike)
        self.cum = None if weights is None else np.cumsum(np.asarray(weights, dtype=np.float64))

    def cell_weights(self, grid: OccupancyGrid, step_cells: float, cells: np.ndarray) -> np.ndarray | None:
        """The weights of ``cells`` (flat indices) in the corridor's draws; None where ``tight`` is 0: all alike.

        The weight is ``1 + tight`` where the cell has walls within half a step on two opposite sides
        (``walled_between``), else 1.
        """
        if self.tight == 0:
            return None
        return 1.0 + self.tight * walled_between(grid, max(1, round(step_cells / 2)), cells)

    def __repr__(self) -> str:
        return (f"{type(self).__name__}({self.route!r}, margin={self.margin:g}, floor={self.floor:g}, "
                f"fill={self.fill}, tight={self.tight:g})")


class CorridorSampler(_CorridorRule):
    """Roadmaps' rule: uniform over the corridor where the field says a short route runs, with a uniform floor.

    The corridor is the free cells whose cost from the start plus cost to the goal (two passes of the field,
    the second with start and goal swapped) is within ``margin`` of the lowest (``corridor_cells``). With a
    ``chain``, the second pass waits until the chain needs it (its walk ended out of the goal's sight) or a draw
    goes past the chain (``build_corridor``), so a roadmap that the chain connects pays one pass; a draw before
    that returns the chain's samples only. While the
    roadmap stays unconnected the corridor widens in stages: with ``L`` the route's length as the fields give it
    (``route_sums``), stage 1 holds the cells within ``(1 + margin) x L`` (plus one step) and each later stage
    doubles that bound, until every cell the field reaches is in; each stage lasts until it has had ``fill``
    draws per step-sized square of its own cells. A learned field whose sum dips below its own route length
    somewhere makes a narrow first corridor, which is right where the field is right and is soon filled where
    it is not; a wide corridor is kept for as long as it takes to fill. Every sample takes 4 uniforms from the
    planner's generator, and its stage depends on its place in the stream, so the stream does not depend on
    batch sizes.

    Args:
        route: The route sampler whose field is read.
        margin: How much longer than the shortest route a route through a corridor cell may be (0.3: 30%).
        floor: Share of samples uniform over the whole sampling box.
        fill: Draws per step-sized square of a stage's cells before the corridor widens; None: never.
        tight: A corridor cell with walls within half a step on two opposite sides (a passage) is drawn with
            weight ``1 + tight``, any other with weight 1 (0: every cell alike).
        chain: The first draws are a chain along the route the fields give (``route_chain``): the corners of
            the route sampler's walk down the field to the goal from the start (and, where that walk stops short,
            down the field to the start from the goal), each in sight of the one before and at most ``chain``
            steps of walk after it, each at its cell's centre; the corridor's draws follow (the chain's count
            toward its stages). 0: no chain.
    """

    def __init__(self, route: RouteSampler, margin: float = CORRIDOR_SETTINGS["margin"],
                 floor: float = CORRIDOR_SETTINGS["floor"], fill: float | None = CORRIDOR_SETTINGS["fill"],
                 tight: float = CORRIDOR_SETTINGS["tight"], chain: float = CORRIDOR_SETTINGS["chain"],
                 start_field: str = CORRIDOR_START_FIELD) -> None:
        super().__init__(route, margin, floor, fill, tight)
        self.chain = _check_nonnegative(type(self).__name__, "chain", chain,
                                        "the most steps of walk between two points of the chain")
        self.start_field = _check_field_source("start_field", start_field)
        #: the roadmap's longest edge (``at_edge``; None: no limit): no link of the chain is longer
        self.edge: float | None = None
        #: a second chain's longest link (``second_chain``; None: no second chain), drawn after the first
        self.second_link: float | None = None

    def at_edge(self, length: float | None) -> CorridorSampler:
        """This corridor for a roadmap whose edges are at most ``length`` long (None: no limit; ``Sampler``).

        The chain's links are then at most ``length`` apart: a link of ``k`` moves of the walk spans at most
        ``k`` cell diagonals, so it takes at most ``length / (sqrt(2) * resolution)`` moves (none: no chain).
        """
        out = copy.copy(self)
        out.edge = None if length is None else float(length)
        return out

    def second_chain(self, length: float | None) -> CorridorSampler:
        """This corridor with a second chain along the same route, its links at most ``length`` long (None: none).

        The second chain's points follow the first chain's, before the corridor's draws: a roadmap that the first
        chain's long links leave unconnected (each new point is connected to its nearest vertices, which need not
        include the point before) gets links short enough to be tried. Its links keep to the roadmap's longest edge
        as well.
        """
        if length is not None and not (isinstance(length, (int, float, np.number)) and not isinstance(length, bool)
                                       and math.isfinite(length) and length > 0):
            raise ValueError(f"{type(self).__name__}.second_chain: the second chain's longest link must be a positive "
                             f"finite number or None, got {length!r}")
        out = copy.copy(self)
        out.second_link = None if length is None else float(length)
        return out

    def _moves(self, length: float) -> int:
        """The most moves of the walk a link no longer than ``length`` may take (a move spans a cell's diagonal)."""
        return math.floor(length / (math.sqrt(2.0) * self.problem.world.resolution))

    def _links(self, moves: int) -> np.ndarray:
        """The chain's cells (flat indices) with at most ``moves`` moves of the walk a link (none below one move)."""
        p = self.problem
        if moves <= 0:
            return np.empty(0, dtype=np.int64)
        return route_chain(self._to_goal.field, lambda: self.field_to_start().field,
                           np.asarray(p.world.obstacles, dtype=bool), query_cells(p), moves,
                           getattr(self.route, "ripple", 0.0), getattr(self.route, "ripple_growth", 0.0))

    def _setup(self) -> None:
        p = self.problem
        require_grid("CorridorSampler", p.world)
        self._to_goal, self._to_start, self._start_walked = self.route.cost_to_go(p), None, False
        self.built = False  # the corridor: built where the chain needs the field to the start, or after the chain
        link = math.ceil(self.chain * self.route.step_size / p.world.resolution)  # in moves of the walk
        if self.edge is not None:  # no link longer than the roadmap's longest edge
            link = min(link, self._moves(self.edge))
        #: the chain's cells (flat indices), drawn first, in order (then the second chain's, ``second_chain``)
        self.links = self._links(link)
        if self.second_link is not None and len(self.links):
            shorter = min(link, self._moves(self.second_link))
            if shorter < link:
                self.links = np.concatenate([self.links, self._links(shorter)])
        self.drawn = 0
        if not len(self.links) or self._to_start is not None:
            self.build_corridor()

    def field_to_start(self) -> CachedField:
        """The field to the start, once, when first needed: read off the walk down the field to the goal where
        ``start_field`` is "walk" and that walk ends in the goal's sight, else the field's pass of the query with start
        and goal swapped.
        """
        if self._to_start is None:
            self._to_start, self._start_walked = corridor_field_to_start(self.route, self.problem,
                                                                         self._to_goal.field, self.start_field)
        return self._to_start

    def build_corridor(self) -> None:
        """The corridor's stages (``cells``, ``counts``, ``starts``, ``cum``): once, from both fields.

        Without a chain, or where the chain needs the field to the start, at ``bind``; otherwise at the first draw
        after the chain, so that a roadmap the chain connects never pays the second field.
        """
        if not self.built:
            self._stages(self._to_goal.field, self.field_to_start().field)
            self.built = True

    def __getattr__(self, name: str):
        # the corridor's stages, read before the first draw that needs them: built then (``build_corridor``)
        if name in ("cells", "counts", "starts", "cum") and "_to_goal" in self.__dict__ and not self.built:
            self.build_corridor()
            return self.__dict__[name]
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    @property
    def forward_passes(self) -> int:
        """The encoder's passes this query took: the field to the goal, and the field to the start once computed."""
        second = self._to_start is not None and not self._start_walked
        return 0 if self.route.net is None else (1 + second) * self.route.symmetry_passes

    @property
    def reused_seconds(self) -> float:
        """Encoder seconds of fields taken from a cache (``RouteSampler.reused_seconds``)."""
        return sum(f.seconds for f in (self._to_goal, self._to_start) if f is not None and f.reused)

    def draw(self, rng, n, view):
        if not self.built:
            if self.drawn < len(self.links):  # the chain alone: the corridor waits until it is drawn
                m = min(n, len(self.links) - self.drawn)
                pts = self.chain_points(self.drawn, rng.random((m, 4))[:, 2:4])  # 4 uniforms a sample, as every draw
                self.drawn += m
                return pts
            self.build_corridor()
        u = rng.random((n, 4))
        pts = self._uniform(u[:, 2:4].copy())
        if self.counts[0]:
            stage = np.searchsorted(self.starts, self.drawn + np.arange(n), side="right") - 1
            guided = u[:, 0] >= self.floor
            pts[guided] = cell_points(self.problem.world, self.cells, u[guided, 1:4], self.low, self.high,
                                      self.counts[stage[guided]], self.cum)
        linked = min(n, max(0, len(self.links) - self.drawn))
        if linked:  # the chain's points (a chain that needed both fields at bind)
            pts[:linked] = self.chain_points(self.drawn, u[:linked, 2:4])
        self.drawn += n
        return pts

    def chain_points(self, first: int, u: np.ndarray) -> np.ndarray:
        """The chain's points ``first`` to ``first + len(u)`` (``links``): the centres of their cells, where the walk's
        sight test ran, so that the segments between them are the ones it found free (``u``: the samples' uniforms
        for a point within the cell, unused here; a subclass may place the points by them).
        """
        m = len(u)
        centres = np.column_stack([(np.arange(m) + 0.5) / m, np.full((m, 2), 0.5)])
        return cell_points(self.problem.world, self.links[first:first + m], centres, self.low, self.high)

    def __repr__(self) -> str:
        edge = f", edge={self.edge:g}" if self.edge is not None else ""
        edge += f", second_link={self.second_link:g}" if self.second_link is not None else ""
        return super().__repr__()[:-1] + (f", chain={self.chain:g}" if self.chain else "") + edge + ")"


class ConvergingRouteSampler(_CorridorRule):
    """RRT*'s rule: ``RouteSampler``'s to the first solution, then the corridor inside the informed set.

    Once a solution of cost ``c`` exists, a sample is, with probability ``floor``, from the informed set
    (``InformedSampler``: states with ``|x - start| + |x - goal| <= c + tolerance``), and otherwise uniform
    over the corridor cells (``CorridorSampler``'s, at ``margin``, its stages counted in the draws since the
    first solution) whose centre lies in that set, within half a cell's diagonal. Where no corridor cell of the
    stage is left in it, the sample is informed.

    Args:
        route: The route sampler whose rule runs to the first solution and whose field makes the corridor.
        margin, floor, fill: As ``CorridorSampler``'s, after the first solution.
        start_field: Where the corridor's field to the start comes from (``GOAL_TREE_FIELDS``): "pass", the field's
            second pass with start and goal swapped; "walk", read off the walk down the field to the goal
            (``walk_field_to_start``; the pass where that walk ends out of the goal's sight).
    """

    def __init__(self, route: RouteSampler, margin: float = CONVERGING_SETTINGS["margin"],
                 floor: float = CONVERGING_SETTINGS["floor"], fill: float | None = CONVERGING_SETTINGS["fill"],
                 start_field: str = CONVERGING_START_FIELD) -> None:
        super().__init__(route, margin, floor, fill)
        self.start_field = _check_field_source("start_field", start_field)

    def _setup(self) -> None:
        self.first = self.route.bind(self.problem)  # refuses a world that is not an OccupancyGrid
        self._start_reused = 0.0  # the field to the start's encoder seconds, where a cache gave it
        self.built = False  # the corridor: built at the first draw after the first solution (``build_corridor``)

    @property
    def reused_seconds(self) -> float:
        """Encoder seconds of fields taken from a cache (``RouteSampler.reused_seconds``), both fields so far."""
        return self.first.reused_seconds + self._start_reused

    def build_corridor(self) -> None:
        """The field to the start, the corridor's stages and the informed set: once, at the first draw after a solution.

        A run that stops at its first solution never pays the second field.
        """
        if self.built:
            return
        p = self.problem
        to_start, walked = corridor_field_to_start(self.route, p, self.first.field, self.start_field)
        self._start_passes = 0 if walked or self.route.net is None else self.route.symmetry_passes
        self._start_reused = to_start.seconds if to_start.reused else 0.0
        self._stages(self.first.field, to_start.field)
        self.informed = InformedSampler().bind(p)
        grid = p.world
        rows, cols = np.divmod(self.cells, grid.width)
        centres = (np.stack([cols, rows], axis=1) + 0.5) * grid.resolution + np.asarray(grid.origin)
        # each corridor cell's start-to-goal distance through its centre, less half a cell's diagonal
        self._through = (np.linalg.norm(centres - p.start, axis=1) + np.linalg.norm(centres - p.goal, axis=1)
                         - math.sqrt(2.0) * grid.resolution)
        self._cost, self._inside, self._held = math.inf, self.cells, self.counts
        self.drawn = 0  # draws since the first solution
        self.built = True

    @property
    def forward_passes(self) -> int:
        """The encoder's passes this query took (the field to the goal; the field to the start once built)."""
        return self.first.forward_passes + (self._start_passes if self.built else 0)

    def fuse(self, planner: Planner) -> FusedRRT | None:
        """RRT*'s loop with the route rule's draws compiled in up to the first solution (the same samples as ``draw``).

        The corridor after it draws through ``draw``.
        """
        return fuse_rrtstar(planner, route_rrtstar_loop, self.first.draw_state, self.first.batch)

    def draw(self, rng, n, view):
        if not math.isfinite(view.best_cost):
            return self.first.draw(rng, n, view)
        self.build_corridor()
        c = view.best_cost + self.problem.goal_tolerance
        if c < self._cost:  # the informed set shrank: keep the corridor cells still in it, stage by stage
            inside = self._through <= c
            self._cost, self._inside = c, self.cells[inside]
            self._held = np.concatenate([[0], np.cumsum(inside)])[self.counts]  # each stage's cells still inside
        m = min(n, CONVERGING_BATCH)
        u = rng.random((m, 4))
        held = self._held[np.searchsorted(self.starts, self.drawn + np.arange(m), side="right") - 1]
        self.drawn += m
        informed = (u[:, 0] < self.floor) | (held == 0)
        k = int(informed.sum())
        pts = [cell_points(self.problem.world, self._inside, u[~informed, 1:4], self.low, self.high,
                           held[~informed])] if k < m else []
        cands = [np.ones(m - k, dtype=np.int64)] if k < m else []
        while k > 0:  # the informed sampler returns at most its own batch per draw
            got = self.informed.draw(rng, k, view)
            pts.append(got.points if isinstance(got, SampleBatch) else got)
            cands.append(got.candidates if isinstance(got, SampleBatch) and got.candidates is not None
                         else np.ones(len(pts[-1]), dtype=np.int64))
            k -= len(pts[-1])
        return SampleBatch(np.concatenate(pts), None, np.concatenate(cands))
