"""Route context: a map encoder that tells the sampler where the route runs, and a sampler that follows it.

The learned policy fails where the route turns away from the goal: its windows do not show which
gap, door or maze branch leads on (``scripts/experiments/imitation_ceiling.py``). ``RouteNet`` looks at the whole
map once per query and predicts the cost-to-go of every cell. It works on blocks of a planner step
(the shipped ``RouteVIN``: of half a step); its input is every cell of each block (so a 1-cell gap is not
averaged away) and the goal, and there is no search at inference. The grid search only makes its training
targets, as it does the expert's (``learning.training.route``).

``RouteSampler`` uses the prediction as the expert (``learning.references.expert``) uses the distance field:
its progress vertex is the tree vertex of lowest predicted cost-to-go, and it samples about one step
ahead of it down the predicted field. Where the prediction is wrong the tree stops making progress;
after ``stuck`` iterations the sampler turns to the tree's frontier until it does again, so a wrong
prediction costs iterations, not the solution.

The shipped encoder (``learning/data/route.pt``, ``shipped_sampler``) is the value-iteration encoder
(``learning.models.route_vin.RouteVIN``), one pass per query; ``shipped_ablation`` is the same sampler
on the straight-line distance, which is what its learning is measured against.
"""

from __future__ import annotations

import hashlib
import math
import os
from collections import OrderedDict
from collections.abc import Sequence
from typing import NamedTuple

import numba as nb
import numpy as np

from learning.device import move_to, resolve_device
from learning.models.field import FieldEncoder
from learning.models.route_net import load_route_net
from learning.models.shipped import SHIPPED_ROUTE
from learning.models.threads import planning_thread_count
from planners import OccupancyGrid, Problem, SamplerBase
from planners.base.fileio import InputError, short_repr
from planners.base.planner import Planner, work_clock
from planners.base.samplers import check_sampler_params
from planners.fused import FusedRRT, fuse_rrt, growing_floor, next_double, rng_address, rrt_loop
from planners.guidance.follow import frontier_costs, last_in_sight, lowest_vertex_cell, walk_path
from planners.guidance.frontier import NO_COST, Frontier, frontier_memo, frontier_sample, update_frontier
from planners.maps.coarsen import coarsest_keeping, free_at
from planners.worlds.grid import resample_obstacles, resampled_shape

#: The shipped encoder (package data; its recipe and time are in ``learning/data/route.json``).
SHIPPED = SHIPPED_ROUTE


def require_grid(who: str, world) -> OccupancyGrid:
    """``world`` if it is a 2-D occupancy map, else an ``InputError`` saying what it is and which sampler fits it."""
    if not isinstance(world, OccupancyGrid):
        raise InputError(f"{who} plans on 2-D occupancy maps (OccupancyGrid), got a {type(world).__name__}; for the "
                         f"6-DoF body take make_sampler(\"rigid_route\")")
    return world


#: How the shipped encoder is used, chosen on the validation maps (README): its field ranks the tree's
#: vertices and places the target 3 steps ahead (spread half a step), walking across the field's ripples
#: up to a tenth of a step deep plus a hundredth of the cost-to-go and ending where the walk leaves the
#: progress cell's sight, and ranks the frontier, which takes over after one iteration without progress at a
#: temperature of half a step; a search whose progress has stalled ``patience`` iterations widens to a frontier of
#: grid cells (``widen``; chosen on the validation maps with ``scripts/experiments/stall_validation.py``).
SHIPPED_SETTINGS = {"stuck": 1, "tau": 0.5, "lookahead": 3.0, "sigma": 0.5, "ripple": 0.1, "ripple_growth": 0.01,
                    "sight": True, "widen": "stalled"}


#: The ablation's own settings: the same rule, its lookahead and spread tuned on the same validation
#: grid as the encoder's (a baseline tuned as carefully as what it is compared with). Its walk goes strictly
#: downhill (``ripple`` 0): on the validation maps that took it fewer iterations than crossing ripples; it is
#: cut at the sight line as the encoder's is, which took it fewer iterations there too. It widens a stalled
#: search as the encoder does (on the same validation maps that left none of its runs unsolved, from 3 of 3,000).
ABLATION_SETTINGS = {"stuck": 1, "tau": 0.5, "lookahead": 2.5, "sigma": 0.5, "ripple": 0.0, "ripple_growth": 0.0,
                     "sight": True, "widen": "stalled"}
#: The straight-line follower of the comparison (``make_sampler("follower")``): one step ahead of the
#: vertex nearest the goal, the frontier after 4 iterations without progress, at a temperature of a step; it
#: does not widen (it is the policy's baseline, as published).
FOLLOWER_SETTINGS = {"lookahead": 1.0, "stuck": 4, "tau": 1.0, "ripple": 0.0, "ripple_growth": 0.0, "sight": False,
                     "widen": "off"}


#: ``RouteSampler``'s ``coarse_side``: a map of at least 256 of the encoder's cells a side is read coarser, down to
#: 128 a side, where that closes no passage. Chosen on validation maps of 256 and 512 cells by the rule of
#: ``scripts/experiments/coarse_fields.py`` (iterations at a geometric mean of 1.04 times full resolution's, the time
#: of a query at 0.43 times; 64 a side took 1.13 times the iterations, read up to 8 times coarser, and 1.07 at most 4).
COARSE_SIDE = 128
#: ``RouteSampler``'s ``coarse_most``: a coarse cell at most a planner step across (4 of the encoder's cells). On
#: validation maps of 1,024 cells (the same script, ``--sides 1024 --maps 4 --most 4``, then ``--most 64``) reading them
#: 4 times coarser took 1.04 times full resolution's iterations at 0.29 of the time, and 8 times 1.11 (the worst row
#: 1.23) at 0.25.
COARSE_MOST = 4


#: ``RouteSampler``'s ways to widen a stalled search (its ``widen``; see ``route_draw``): never; the frontier of
#: one-grid-cell cells while the step-wide frontier is empty; that, and half the frontier's samples from it once
#: the field's progress has stalled ``patience`` iterations.
WIDEN_MODES = ("off", "empty", "stalled")

# slots of RouteSampler's integer state (``R_GSEEN``, ``R_GCOUNT``: the fine frontier's, see ``route_draw``)
R_SEEN, R_CELL, R_PROGRESS, R_CLOSER, R_FSEEN, R_FCOUNT, R_GSEEN, R_GCOUNT = range(8)


@nb.njit(cache=True, inline="always")
def _straight_at(r, c, gx, gy, res, step):
    # the distance from (gx, gy) to the centre of cell (r, c), times res / step
    dx, dy = c + 0.5 - gx, r + 0.5 - gy
    return math.sqrt(dx * dx + dy * dy) * res / step


@nb.njit(cache=True)
def straight_field(blocked, gx, gy, res, step):
    """The distance from ``(gx, gy)`` to every cell centre of the grid ``blocked``, times ``res / step``; ``inf`` on
    its obstacles (nonzero cells).

    Compiled, one pass, and a square root rather than ``hypot`` (which guards against overflow these distances
    cannot reach), because it was most of a straight-line query's set-up: 0.13 ms at 128 x 128 with numpy's
    ``hypot``, against goal bias's whole 0.3 ms query; setting the obstacles by a boolean mask afterwards cost about
    as much as the field again.
    """
    H, W = blocked.shape
    out = np.empty((H, W))
    for r in range(H):
        for c in range(W):
            out[r, c] = math.inf if blocked[r, c] else _straight_at(r, c, gx, gy, res, step)
    return out


@nb.njit(cache=True)
def _ranked_where_unreached(field, blocked, gx, gy, res, step, unreached):
    H, W = field.shape
    cut, top = False, -math.inf
    for r in range(H):
        for c in range(W):
            v = field[r, c]
            if math.isfinite(v):
                if v >= unreached:
                    cut = True
                elif v > top:
                    top = v
    if not cut:
        return field
    base = top if top > -math.inf else 0.0
    out = np.empty((H, W))
    for r in range(H):
        for c in range(W):
            v = field[r, c]
            if math.isfinite(v) and v >= unreached:
                out[r, c] = base + (math.inf if blocked[r, c] else _straight_at(r, c, gx, gy, res, step))
            else:
                out[r, c] = v
    return out


@nb.njit(cache=True)
def route_draw(state, X, n, best_vertex, best_distance, iteration, rng, pts, anchored):
    """Fill ``pts`` with samples of ``RouteSampler`` (see its docstring): the draw of ``planners.fused``'s contract.

    ``rng`` is the address of the planner's generator (``planners.fused.rng_address``); every sample
    takes 7 of its doubles whatever its kind, so the stream does not depend on the branch taken.
    ``state`` is ``RouteSampler._state``: the fields, the frontier, the progress state (``ints``:
    ``R_*`` slots; ``floats``: lowest predicted cost, closest straight-line distance to the goal),
    the parameters, and scratch buffers for a batch's uniforms and frontier points and the walk's visited
    cells, allocated once per query rather than once per iteration. Samples are absolute: ``anchored`` is left alone.
    """
    field, blocked, res, origin, step, frontier, fine, ints, floats, params, scratch, low, high = state
    world, counts, cell, fgoal, free, cov, pos, front, dist, tau, fw, forigin, fcost, fmemo = frontier
    lookahead, sigma, stuck, floor0, max_floor, patience, ripple, ripple_growth, sight, widen = params
    W = field.shape[1]
    if n > ints[R_SEEN]:
        best, c = lowest_vertex_cell(field, X[ints[R_SEEN]:n], res, origin, floats[0], ints[R_CELL])
        if best < floats[0] - 1e-9:
            floats[0], ints[R_CELL], ints[R_PROGRESS] = best, c, iteration
        ints[R_SEEN] = n
    if best_distance < floats[1] - 1e-9:
        floats[1], ints[R_CLOSER] = best_distance, iteration
    floor = growing_floor(floor0, max_floor, patience, iteration - ints[R_CLOSER])
    frontier_mode = iteration - ints[R_PROGRESS] >= stuck
    if frontier_mode and n > ints[R_FSEEN]:
        ints[R_FCOUNT] = update_frontier(world, counts, X[ints[R_FSEEN]:n], cell, fgoal, free, cov, pos, front, dist,
                                         ints[R_FCOUNT], fcost)
        ints[R_FSEEN] = n
    # The step-wide frontier is blind to a passage narrower than a step whose cells next to the tree have blocked
    # centres: the frontier of one-grid-cell cells sees into it. It gives every frontier sample while the step-wide
    # one is empty (``widen`` >= 1), and half of them once the field's progress has stalled ``patience``
    # iterations (``widen`` 2: the step-wide frontier may hold only cells no extension can enter).
    coarse = ints[R_FCOUNT] > 0
    fine_all = frontier_mode and widen >= 1 and not coarse
    fine_half = frontier_mode and widen >= 2 and coarse and iteration - ints[R_PROGRESS] >= patience
    if (fine_all or fine_half) and n > ints[R_GSEEN]:
        if ints[R_GSEEN] == 0:  # its first use
            ready_fine_frontier(fine, blocked, step, res)
        ints[R_GCOUNT] = update_frontier(world, counts, X[ints[R_GSEEN]:n], res, fgoal, fine[0], fine[1], fine[2],
                                         fine[3], fine[4], ints[R_GCOUNT], fine[5])
        ints[R_GSEEN] = n
    fine_all = fine_all and ints[R_GCOUNT] > 0
    fine_half = fine_half and ints[R_GCOUNT] > 0
    m = pts.shape[0]
    U, F, u_pick, u_xy, G = scratch[0][:m], scratch[1][:m], scratch[2][:m], scratch[3][:m], scratch[5][:m]
    visited = scratch[4]
    for k in range(m):  # row by row, as Generator.random((m, 7)) fills
        for j in range(7):
            U[k, j] = next_double(rng)
    if frontier_mode and (coarse or fine_all):  # one frontier CDF for the whole batch
        u_pick[:] = U[:, 3]
        u_xy[:] = U[:, 1:3]
        if coarse:
            frontier_sample(front, ints[R_FCOUNT], fw, cell, forigin, dist, tau, u_pick, u_xy, F, fmemo)
        if fine_all or fine_half:
            frontier_sample(fine[3], ints[R_GCOUNT], blocked.shape[1], res, forigin, fine[4], tau * step / res,
                            u_pick, u_xy, G, fine[6])
    for k in range(m):
        u = U[k]
        if frontier_mode and u[0] >= floor and (coarse or fine_all):
            if fine_all or (fine_half and u[4] < 0.5):  # u[4], the walk's jitter, is unused in frontier mode
                x, y = G[k, 0], G[k, 1]
            else:
                x, y = F[k, 0], F[k, 1]
        elif frontier_mode or u[0] < floor:
            x, y = low[0] + (high[0] - low[0]) * u[1], low[1] + (high[1] - low[1]) * u[2]
        else:
            moves = walk_path(field, blocked, ints[R_CELL], lookahead * (0.5 + u[4]) * step / res, ripple,
                              ripple_growth, visited)
            v = last_in_sight(blocked, visited, moves) if sight else visited[moves - 1]
            r = sigma * step * math.sqrt(-2.0 * math.log(1.0 - u[5]))  # Box-Muller: two normals from two uniforms
            x = origin[0] + (v % W + 0.5) * res + r * math.cos(2.0 * math.pi * u[6])
            y = origin[1] + (v // W + 0.5) * res + r * math.sin(2.0 * math.pi * u[6])
        pts[k, 0] = min(max(x, low[0]), np.nextafter(high[0], low[0]))
        pts[k, 1] = min(max(y, low[1]), np.nextafter(high[1], low[1]))


@nb.njit(cache=True)
def route_rrt_loop(budget, state, buffers, rng, loop):
    """RRT's compiled loop drawing from ``route_draw`` (``planners.fused``)."""
    return rrt_loop(budget, route_draw, state, buffers, rng, loop)


def straight_where_unreached(field: np.ndarray, straight: np.ndarray, unreached: float) -> np.ndarray:
    """``field`` with its finite cells at or above ``unreached`` ranked by ``straight`` instead.

    The encoder sees no route to the goal from those cells. They take the straight-line distance to the goal
    (``straight``, in steps) plus the highest value the field reaches elsewhere, so every cell with a route stays
    ahead of every cell without one, and among the latter the sampler follows what its ablation follows instead of
    a flat plateau.
    """
    finite = np.isfinite(field)
    cut = finite & (field >= unreached)
    if not cut.any():
        return field
    reached = field[finite & ~cut]
    return np.where(cut, (reached.max() if reached.size else 0.0) + straight, field)


def ranked_where_unreached(field: np.ndarray, blocked: np.ndarray, gx: float, gy: float, res: float, step: float,
                           unreached: float) -> np.ndarray:
    """``straight_where_unreached(field, straight_field(blocked, gx, gy, res, step), unreached)``, compiled: the same
    values, in two passes over the map, the straight line computed only at the cells it ranks (``field`` itself where
    there are none). ``field``: float64, the grid's shape.
    """
    return _ranked_where_unreached(np.asarray(field, dtype=np.float64), blocked, float(gx), float(gy), float(res),
                                   float(step), float(unreached))


@nb.njit(cache=True)
def interpolated_field(coarse, shut, blocked, factor, cell, unreached):
    """A field over the grid ``blocked`` (H, W) from ``coarse``, the field of the same map read ``factor`` times coarser
    (whole, ``shut`` its blocked cells), in the field's unit; ``cell`` is a grid cell's length in it.

    A free cell of a free coarse cell takes the bilinear interpolation between the centres of the coarse cells around
    it, over those that are free, have a value below ``unreached`` and meet its own coarse cell along a side or
    through a free one (a coarse cell's own value at or above ``unreached``, where the encoder sees no route, is
    kept): read nearest-cell, a coarse field is flat over each coarse cell, and a walk down it wanders on the flats.
    A free cell of a blocked coarse cell (beside a wall) takes its nearest valued free neighbour's value plus the
    way to it (two sweeps each way of a distance transform over those cells); ``inf`` on obstacles and where no value
    reaches. Returns the field and whether a finite value at or above ``unreached`` is in it.
    """
    H, W = blocked.shape
    h, w = coarse.shape
    own_row, low_row, up_row = _coarse_axis(H, h, factor)
    own_col, low_col, up_col = _coarse_axis(W, w, factor)
    ok = np.empty((h, w), dtype=np.bool_)  # the coarse cells that serve an interpolation
    for i in range(h):
        for j in range(w):
            ok[i, j] = not shut[i, j] and coarse[i, j] < unreached
    quad = np.zeros((h + 1, w + 1), dtype=np.bool_)  # [i + 1, j + 1]: whether cells i..i+1, j..j+1 all serve
    for i in range(h - 1):
        for j in range(w - 1):
            quad[i + 1, j + 1] = ok[i, j] and ok[i + 1, j] and ok[i, j + 1] and ok[i + 1, j + 1]
    out = np.empty((H, W))
    band = np.empty(H * W, dtype=np.int32)  # the free cells of blocked coarse cells
    n = 0
    high = False  # whether a value at or above unreached was written
    for r in range(H):
        ia, i0, fy = own_row[r], low_row[r], up_row[r]
        for c in range(W):
            ja = own_col[c]
            if blocked[r, c]:
                out[r, c] = math.inf
                continue
            if shut[ia, ja]:
                out[r, c] = math.inf
                band[n] = r * W + c
                n += 1
                continue
            own = coarse[ia, ja]
            if not own < unreached:
                out[r, c] = own
                high = high or own < math.inf
                continue
            j0, fx = low_col[c], up_col[c]
            if quad[i0 + 1, j0 + 1]:  # the four serve: bilinear as it stands
                top = coarse[i0, j0] + fx * (coarse[i0, j0 + 1] - coarse[i0, j0])
                bottom = coarse[i0 + 1, j0] + fx * (coarse[i0 + 1, j0 + 1] - coarse[i0 + 1, j0])
                out[r, c] = top + fy * (bottom - top)
                high = high or out[r, c] >= unreached
                continue
            total, weight = 0.0, 0.0
            for di in range(2):
                i = i0 + di
                wy = fy if di else 1.0 - fy
                for dj in range(2):
                    j = j0 + dj
                    if i < 0 or j < 0 or i >= h or j >= w or not ok[i, j]:
                        continue
                    if i != ia and j != ja and shut[i, ja] and shut[ia, j]:
                        continue  # meets the cell's own only at a corner
                    wt = wy * (fx if dj else 1.0 - fx) + 1e-12
                    total += wt * coarse[i, j]
                    weight += wt
            out[r, c] = total / weight
            high = high or out[r, c] >= unreached
    diagonal = cell * math.sqrt(2.0)
    # which of its 8 neighbours each band cell reads (bit k: the k-th of rows -1..1 by columns -1..1, itself left out):
    # free, on the map and, diagonally, with no corner cut; found once for the four sweeps
    reads = np.empty(n, dtype=np.uint8)
    for m in range(n):
        r, c = band[m] // W, band[m] % W
        bits, bit = 0, 1
        for dr in range(-1, 2):
            for dc in range(-1, 2):
                if dr == 0 and dc == 0:
                    continue
                r2, c2 = r + dr, c + dc
                if not (r2 < 0 or c2 < 0 or r2 >= H or c2 >= W or blocked[r2, c2]
                        or (dr != 0 and dc != 0 and (blocked[r2, c] or blocked[r, c2]))):
                    bits |= bit
                bit <<= 1
        reads[m] = bits
    flat = out.ravel()
    for sweep in range(4):  # the cells beside walls, twice each way (a wall's coarse cell: a few cells to cross)
        for m in range(n):
            if sweep % 2:
                m = n - 1 - m
            v, bits = band[m], reads[m]
            best = flat[v]
            if bits & 1:
                best = min(best, flat[v - W - 1] + diagonal)
            if bits & 2:
                best = min(best, flat[v - W] + cell)
            if bits & 4:
                best = min(best, flat[v - W + 1] + diagonal)
            if bits & 8:
                best = min(best, flat[v - 1] + cell)
            if bits & 16:
                best = min(best, flat[v + 1] + cell)
            if bits & 32:
                best = min(best, flat[v + W - 1] + diagonal)
            if bits & 64:
                best = min(best, flat[v + W] + cell)
            if bits & 128:
                best = min(best, flat[v + W + 1] + diagonal)
            flat[v] = best
            if sweep == 3:  # its last value
                high = high or unreached <= best < math.inf
    return out, high


@nb.njit(cache=True)
def _coarse_axis(N, n, factor):
    """Per grid row (or column) of ``N``: the coarse one its centre lies in (of ``n``), the coarse centre at or before
    it and its share of the way to the next one (the bilinear interpolation's lower index and weight).
    """
    own = np.empty(N, dtype=np.int64)
    low = np.empty(N, dtype=np.int64)
    up = np.empty(N)
    for r in range(N):
        own[r] = min(int((r + 0.5) / factor), n - 1)
        y = (r + 0.5) / factor - 0.5
        low[r] = math.floor(y)
        up[r] = y - math.floor(y)
    return own, low, up


#: ``fine_frontier``'s ranking where there is none (the straight line)
_NO_RANKING = np.empty((0, 0))


def fine_frontier(grid: OccupancyGrid, ranking: np.ndarray | None = None) -> tuple:
    """The frontier of one-grid-cell cells that ``route_draw`` widens a stalled search to (``RouteSampler.widen``).

    ``(free, cov, pos, front, dist, cost, memo, ranking)``: the first seven as
    ``planners.guidance.frontier.Frontier``'s, over the grid's own cells, ranked by ``ranking`` (a route field,
    float64, per grid cell, in steps; None: the straight line), which the eighth keeps. Nothing is written: most runs
    never need this frontier, so its positions and its ranking are made at its first use (``ready_fine_frontier``).
    """
    H, W = grid.height, grid.width
    source = _NO_RANKING if ranking is None else np.ascontiguousarray(ranking, dtype=np.float64)
    return (np.zeros((H, W), dtype=np.uint8), np.zeros((H, W), dtype=np.bool_), np.empty((H, W), dtype=np.int64),
            np.empty(H * W, np.int64), np.empty(H * W), NO_COST if ranking is None else np.empty(H * W),
            frontier_memo(H * W), source)


@nb.njit(cache=True)
def ready_fine_frontier(fine, blocked, step, res):
    """Make ``fine_frontier``'s positions (``-1``: no cell in the frontier yet) and ranking, in one pass: the ranking
    per grid cell in grid cells, flat (``ranking * step / res``; 1e9 on the obstacles ``blocked`` and where it is not
    finite). The step-wide frontier reads the same values through ``frontier_costs``' ``times``, ``over`` and
    ``blocked``.
    """
    pos, cost, ranking = fine[2], fine[5], fine[7]
    H, W = pos.shape
    ranked = cost.shape[0] > 0
    for r in range(H):
        for c in range(W):
            pos[r, c] = -1
            if ranked:
                v = math.inf if blocked[r, c] else ranking[r, c] * step / res
                cost[r * W + c] = v if math.isfinite(v) else 1e9


@nb.njit(cache=True)
def obstacles_at_inf(field, blocked):
    """``field[blocked] = inf``, in place, in one pass (``field`` float64, the shape of ``blocked``)."""
    H, W = blocked.shape
    for r in range(H):
        for c in range(W):
            if blocked[r, c]:
                field[r, c] = math.inf


class CachedField(NamedTuple):
    """A field from ``FieldCache.get``: a copy the caller may change, the encoder time it took, and whether it was kept.

    ``seconds`` is the wall time of the passes that computed it (its share of a batch's, ``FieldCache.fill``), numba's
    compiling left out (``work_clock``);
    ``reused`` is True when it came from the cache rather than from passes run by this call (where some did and
    some did not, ``seconds`` holds the cache's part alone); ``opened``: the field is the one without the encoder's
    learned wall rule, which shut the query's start (``FieldEncoder.predict_reaching``).
    """

    field: np.ndarray
    seconds: float
    reused: bool
    opened: bool = False


class FieldCache:
    """The route encoder's fields by query, kept for later binds of the same query: an LRU bounded in bytes.

    A query is the map's obstacles (their bytes' hash, shape and type), the goal cell, the symmetries
    averaged over, and the encoder (the object, kept alive while the cache holds its fields, and the
    device it is on). ``RouteSampler(..., fields=cache)`` consults it before running the encoder, so runs
    of one query that differ only by planner seed run it once; ``fill`` computes the fields of many
    queries ahead, their passes batched together (``RouteNet.predict_many``) on a GPU.

    A field computed on a miss is ``predict``'s, bit for bit. A batch of several queries on the CPU may
    differ from one query at a time by floating-point rounding, which can change an iteration count, so
    ``fill`` batches queries together only when the encoder is off the CPU (or when told to). A copy of
    a cache goes without its fields (pickled for a worker, it starts empty there). The torch thread count
    is not part of a query: one cache serves passes at one thread count.

    Args:
        max_bytes: The most bytes of fields kept; the least recently used go first. A field larger
            than this is returned but not kept.
    """

    def __init__(self, max_bytes: int = 256 << 20) -> None:
        if isinstance(max_bytes, bool) or not isinstance(max_bytes, int) or max_bytes < 0:
            raise InputError(f"FieldCache max_bytes = {short_repr(max_bytes)}: expected a whole number of bytes >= 0")
        self.max_bytes = max_bytes
        self._clear()

    def _clear(self) -> None:
        self._fields: OrderedDict[tuple, tuple[np.ndarray, float, bool]] = OrderedDict()  # field, seconds, opened
        self._nets: dict[int, FieldEncoder] = {}  # keeps each keyed encoder alive, so its id is not reused
        self.bytes = self.hits = self.misses = 0

    def __getstate__(self) -> dict:
        return {"max_bytes": self.max_bytes}

    def __setstate__(self, state: dict) -> None:
        self.max_bytes = state["max_bytes"]
        self._clear()

    def __len__(self) -> int:
        return len(self._fields)

    def key(self, net: FieldEncoder, obstacles: np.ndarray, goal_cell: tuple[int, int], symmetries: int) -> tuple:
        """The key of a query's field (see the class docstring)."""
        obstacles = np.ascontiguousarray(obstacles)
        # a boolean map hashed as bits (with its shape in the key, the same map gives the same bits): an eighth of
        # the bytes, a quarter of a millisecond less a query at 512 x 512 cells
        data = np.packbits(obstacles) if obstacles.dtype == np.bool_ else obstacles.view(np.uint8)
        digest = hashlib.blake2b(data.data, digest_size=16).digest()
        device = str(next(net.parameters()).device)
        return (id(net), device, net.inference_key(), digest, obstacles.shape, obstacles.dtype.str,
                (int(goal_cell[0]), int(goal_cell[1])), int(symmetries))

    def has(self, net: FieldEncoder, obstacles: np.ndarray, goal_cell: tuple[int, int], symmetries: int,
            start_cell: tuple[int, int] | None = None) -> bool:
        """Whether the query's field is kept (with ``start_cell``: ``get``'s field for that start, or the field that
        answers it).
        """
        key = self.key(net, obstacles, goal_cell, symmetries)
        return key in self._fields or (start_cell is not None and self._reaching(key, start_cell) in self._fields)

    @staticmethod
    def _reaching(key: tuple, start_cell: tuple[int, int]) -> tuple:
        return (*key, "reaching", (int(start_cell[0]), int(start_cell[1])))

    def get(self, net: FieldEncoder, obstacles: np.ndarray, goal_cell: tuple[int, int], symmetries: int, *,
            threads: int | None = None, start_cell: tuple[int, int] | None = None) -> CachedField:
        """``net.predict(obstacles, goal_cell, symmetries, threads=threads)``, from the cache where it is there.

        With ``start_cell``, ``net.predict_reaching``'s field for that start (``opened`` says which): the field kept
        for the goal where ``fill`` computed it (then, where it shuts the start, the field without the learned walls,
        kept or computed as ``predict`` would), else one kept for this start, else computed and kept for it.
        """
        key = self.key(net, obstacles, goal_cell, symmetries)
        if start_cell is not None and key in self._fields:
            walled = self.get(net, obstacles, goal_cell, symmetries, threads=threads)
            opened = net.open_walls() if net.shuts(walled.field, start_cell) else None
            if opened is None:
                return walled
            with opened:
                out = self.get(net, obstacles, goal_cell, symmetries, threads=threads)
            return CachedField(out.field, walled.seconds + (out.seconds if out.reused else 0.0), True, True)
        if start_cell is not None:
            key = self._reaching(key, start_cell)
        if key in self._fields:
            self.hits += 1
            self._fields.move_to_end(key)
            field, seconds, opened = self._fields[key]
            return CachedField(field.copy(), seconds, True, opened)
        self.misses += 1
        t0 = work_clock()
        field, opened = net.predict_reaching(obstacles, goal_cell, start_cell, symmetries, threads=threads)
        seconds = work_clock() - t0
        self._keep(key, net, field, seconds, opened)
        return CachedField(field.copy(), seconds, False, opened)

    def fill(self, net: FieldEncoder, queries: Sequence[tuple[np.ndarray, tuple[int, int]]], symmetries: int, *,
             threads: int | None = None, batch: bool | None = None) -> int:
        """Compute the fields of the (obstacles, goal cell) ``queries`` not yet kept; the number computed.

        ``batch``: run their passes together in one ``predict_many`` (True; each field is charged an
        equal share of the batch's time), one query at a time (False, each field then ``predict``'s bit
        for bit), or together only when ``net`` is off the CPU (None). Queries beyond what the cache keeps
        are computed and dropped, so pass at most as many as it holds.
        """
        todo: dict[tuple, tuple[np.ndarray, tuple[int, int]]] = {}
        for obstacles, goal_cell in queries:
            key = self.key(net, obstacles, goal_cell, symmetries)
            if key not in self._fields:
                todo.setdefault(key, (obstacles, goal_cell))
        if not todo:
            return 0
        if batch is None:
            batch = next(net.parameters()).device.type != "cpu"
        if batch:
            t0 = work_clock()
            fields = net.predict_many(list(todo.values()), symmetries, threads=threads)
            share = (work_clock() - t0) / len(todo)
            for key, field in zip(todo, fields, strict=True):
                self._keep(key, net, field, share)
        else:
            for key, (obstacles, goal) in todo.items():
                t0 = work_clock()
                field = net.predict(obstacles, goal, symmetries, threads=threads)
                self._keep(key, net, field, work_clock() - t0)
        self.misses += len(todo)
        return len(todo)

    def _keep(self, key: tuple, net: FieldEncoder, field: np.ndarray, seconds: float, opened: bool = False) -> None:
        if field.nbytes > self.max_bytes:
            return
        self._fields[key] = (field, seconds, opened)
        self._nets[id(net)] = net
        self.bytes += field.nbytes
        while self.bytes > self.max_bytes:
            _, (old, _, _) = self._fields.popitem(last=False)
            self.bytes -= old.nbytes


class RouteSampler(SamplerBase):
    """Samples one step ahead of the tree along a route encoder's predicted cost-to-go; the frontier when stuck.

    The progress vertex is the tree vertex of lowest predicted cost-to-go; the target is ``lookahead``
    steps (jittered 0.5-1.5x) further down the predicted field, and samples scatter ``sigma`` steps
    around it. A learned field has shallow pits (ripples) where a strictly downhill walk stops short of
    the route; the walk crosses those less than ``ripple + ripple_growth * cost-to-go`` steps deep
    (``planners.guidance.follow.walk_field``), and ends where it leaves the progress cell's sight.
    When progress has stalled for ``stuck`` iterations, samples go to the tree's frontier
    (``planners.guidance.frontier``; cells of lower predicted cost-to-go preferred) until the tree
    makes progress again. A ``uniform_floor`` share of samples is uniform; it grows, as the policy's
    does, once the tree has come no closer to the goal for ``patience`` iterations (up to
    ``max_floor``): a wrong prediction can keep the tree busy in a dead end that looks like progress
    on the predicted field. The prediction is averaged over the encoder's symmetries (``symmetry_passes``).

    With ``net=None`` the field is the straight-line distance to the goal: the same sampler with the
    learning removed, its ablation (``straight_line_sampler``).

    The defaults are the shipped configuration, chosen on the validation maps (``SHIPPED_SETTINGS``):
    ``RouteSampler(RouteSampler.load().net)`` and ``RouteSampler.load()`` are ``shipped_sampler()``.
    The comparison's straight-line follower pins its own settings (``FOLLOWER_SETTINGS``).

    Args:
        net: The trained encoder (``load_route_net``); its ``step`` must be the planner's step in cells.
        step_size: The planner's step.
        lookahead, sigma: Target distance ahead and spread, in steps.
        stuck: Iterations without progress before the frontier takes over.
        uniform_floor: Share of uniform samples.
        batch: Samples per draw. The target moves with every new vertex only at 1; at 8, samples of a
            batch chase a target the tree has already reached, and validation runs took 2-3x the iterations.
        patience, max_floor: Iterations without coming closer to the goal after which the uniform share
            grows, and the largest share it reaches.
        tau: Temperature of the frontier's preference, in steps (``planners.guidance.frontier``).
        device: Where the encoder runs: "auto" (CUDA when torch sees it, else the CPU), "cpu", "cuda" or
            "cuda:N" (``learning.device.resolve_device``);
            the encoder is moved there. On the CPU the iteration counts are the validated ones.
        threads: torch threads for the encoder's passes (``learning.models.threads``): default
            ``SAMPLERGYM_TORCH_THREADS`` or 1; the caller's setting is restored after each pass.
        fields: Where the encoder's fields are taken from when there and kept (``FieldCache``); None:
            computed at every bind. ``forward_passes`` counts the passes a query's field takes either way;
            ``reused_seconds`` is the encoder time of a field taken from the cache (0 when this bind
            computed it), which the evaluation adds to a run's wall time so each run costs its query's field.
        ripple, ripple_growth: How far the walk to the target may rise above the lowest value ``low`` it
            has reached: ``ripple + ripple_growth * low`` steps; both 0 walk strictly downhill.
        sight: Cut the walk where it first leaves the sight of the progress cell's centre
            (``planners.guidance.follow.last_in_sight``): round a corner, the target is the last cell the
            progress vertex can reach in a straight line, not one behind the wall the extension would hit.
        widen: How a stalled search widens (``WIDEN_MODES``): the step-wide frontier cannot see into a passage
            narrower than a step whose cells next to the tree have blocked centres; ``"empty"`` turns to a frontier
            of one-grid-cell cells while the step-wide one is empty, ``"stalled"`` also draws half the frontier's
            samples from it once the field's progress has stalled ``patience`` iterations.
        coarse_side, coarse_most: The encoder reads a map whose longer side is at least twice ``coarse_side`` of its
            cells coarser, by the largest power of two up to ``coarse_most`` that keeps that side at least
            ``coarse_side`` long, closes no passage and leaves the start and the goal free
            (``planners.maps.coarsen``); ``coarse_side`` 0: every map at full resolution.
    """

    #: Where the encoder's field replaces the straight line: the progress and the frontier's ranking.
    #: (Experiments that place it elsewhere subclass, ``scripts/experiments/route_variants.py``.)
    _uses = "both"
    #: How many of the square's symmetries the prediction is averaged over (``FieldEncoder.predict``); None:
    #: the encoder's own ``symmetries`` (8 for ``RouteNet``, 1 for ``RouteVIN``).
    _symmetries: int | None = None

    @property
    def symmetry_passes(self) -> int:
        """How many of the square's symmetries the encoder's field is averaged over (its passes per query)."""
        return self._symmetries or self.net.symmetries

    def __init__(self, net: FieldEncoder | None, *, step_size: float = 4.0, lookahead: float = 3.0, sigma: float = 0.5,
                 stuck: int = 1, uniform_floor: float = 0.05, batch: int = 1, patience: int = 200,
                 max_floor: float = 0.5, tau: float = 0.5, device: str = "auto", threads: int | None = None,
                 fields: FieldCache | None = None, ripple: float = 0.1,
                 ripple_growth: float = 0.01, sight: bool = True, widen: str = "stalled",
                 coarse_side: int = COARSE_SIDE, coarse_most: int = COARSE_MOST) -> None:
        if not (ripple >= 0 and ripple_growth >= 0):
            raise InputError(f"ripple = {short_repr(ripple)}, ripple_growth = {short_repr(ripple_growth)}: expected a "
                             f"depth in steps >= 0 and a growth per step of cost-to-go >= 0")
        if not (step_size > 0 and lookahead > 0 and sigma >= 0 and stuck >= 1 and patience >= 1 and batch >= 1
                and 0 <= uniform_floor <= max_floor <= 1 and tau > 0):
            raise InputError(f"need step_size, lookahead, stuck, patience, batch, tau > 0, sigma >= 0 and "
                             f"0 <= uniform_floor <= max_floor <= 1; got {step_size}, {lookahead}, {stuck}, "
                             f"{patience}, {batch}, {tau}, {sigma}, {uniform_floor}, {max_floor}")
        self.net, self.step_size, self.lookahead, self.sigma = net, float(step_size), float(lookahead), float(sigma)
        self.stuck, self.uniform_floor, self.batch = int(stuck), float(uniform_floor), int(batch)
        self.patience, self.max_floor, self.tau = int(patience), float(max_floor), float(tau)
        self.ripple, self.ripple_growth = float(ripple), float(ripple_growth)
        if not isinstance(sight, bool | np.bool_):
            raise InputError(f"sight = {short_repr(sight)}: expected True or False")
        self.sight = bool(sight)
        if widen not in WIDEN_MODES:
            raise InputError(f"widen = {short_repr(widen)}: expected one of {', '.join(WIDEN_MODES)}")
        self.widen = widen
        if isinstance(coarse_side, bool) or not isinstance(coarse_side, int | np.integer) or coarse_side < 0:
            raise InputError(f"coarse_side = {short_repr(coarse_side)}: expected a whole number of the encoder's cells "
                             f">= 0 (0: read every map at full resolution)")
        if isinstance(coarse_most, bool) or not isinstance(coarse_most, int | np.integer) or coarse_most < 1:
            raise InputError(f"coarse_most = {short_repr(coarse_most)}: expected a whole number >= 1 (the most times "
                             f"coarser a map is read; 1: never)")
        self.coarse_side, self.coarse_most = int(coarse_side), int(coarse_most)
        self.device = resolve_device(device, "device =")
        if threads is not None:
            planning_thread_count(threads)  # refused now, by name, rather than at the first query
        self.threads, self.fields = threads, fields
        if net is not None:
            move_to(net, self.device)
        self.forward_passes, self.reused_seconds = 0, 0.0
        self.coarsening = 1  # how many times coarser the encoder read the last field's map (``coarse_side``)

    @classmethod
    def load(cls, path: str | os.PathLike = SHIPPED_ROUTE, **kwargs) -> RouteSampler:
        """A sampler over the encoder saved at ``path`` (default: the shipped one), at the validated settings.

        ``kwargs`` are the constructor's (``device``, ``threads``, ...).
        """
        return cls(load_route_net(path), **kwargs)

    def _straight(self, grid: OccupancyGrid) -> np.ndarray:
        """The straight-line distance to the goal of every grid cell's centre, in steps; ``inf`` on the obstacles."""
        return straight_field(grid.kernel.grid, *self._goal_in_cells(grid), grid.resolution, self.step_size)

    def _goal_in_cells(self, grid: OccupancyGrid) -> tuple[float, float]:
        """The goal's (x, y) in the grid's cells from its origin, where the straight line is measured from."""
        gx, gy = (self.problem.goal[:2] - grid.origin) / grid.resolution
        return gx, gy

    def at_step(self, step_size: float) -> RouteSampler:
        """This sampler measuring in the planner's step (``step_size``, world units): planners call it when bound.

        Every distance it takes in steps (lookahead, spread, the frontier's temperature) follows, and the encoder
        reads the map at that step (``_encoder_map``).
        """
        if type(step_size) is float and step_size == self.step_size:  # a planner's own step, as every query brings
            return self
        check_sampler_params(type(self).__name__, step_size=step_size)
        return self if float(step_size) == self.step_size else self._copy_with(step_size=float(step_size))

    def _encoder_map(self, grid: OccupancyGrid) -> tuple[np.ndarray, tuple[int, int], float, int]:
        """What the encoder reads for this query: (obstacles, goal cell, map cells per encoder cell, coarsening).

        The encoder was trained for a step of ``net.step`` cells. Where the step is another number of this map's
        cells, it reads the map resampled so that a step is ``net.step`` of its cells (``resample_obstacles``:
        a cell is blocked where any map cell it overlaps is, so a gap narrower than one can close, and no wall
        opens); its field is in steps either way. A large map it reads coarser still where that closes no passage
        (``coarse_side``): coarsened ``k`` times (the last element; 1: not), the field it gives is in steps of
        ``k`` planner steps.
        """
        goal, start = grid.cell_of(self.problem.goal), grid.cell_of(self.problem.start)
        factor = self._encoder_factor(grid)
        obstacles = grid.obstacles
        if factor != 1.0:
            obstacles = resample_obstacles(obstacles, factor)
            goal, start = ((min(int(r / factor), obstacles.shape[0] - 1), min(int(c / factor), obstacles.shape[1] - 1))
                           for r, c in (goal, start))
        k = self._coarsening(obstacles, (start, goal))
        if k == 1:
            return obstacles, goal, factor, 1
        return resample_obstacles(obstacles, k), (goal[0] // k, goal[1] // k), factor * k, k

    def _coarsening(self, obstacles: np.ndarray, cells: tuple) -> int:
        """How many times coarser the encoder reads ``obstacles`` (its own cells): the largest power of two up to
        ``coarse_most`` that keeps the longer side at least ``coarse_side`` cells, closes no passage and leaves
        ``cells`` free (``coarsest_keeping``, ``free_at``); 1 with ``coarse_side`` 0.
        """
        if not self.coarse_side:
            return 1
        most = min(max(obstacles.shape) // self.coarse_side, self.coarse_most)
        return free_at(obstacles, coarsest_keeping(obstacles, most), cells) if most >= 2 else 1

    def _encoder_factor(self, grid: OccupancyGrid) -> float:
        """Map cells per encoder cell at this sampler's step (1 at the step the encoder was trained for), once the
        map the encoder would read is shown not too large (``FieldEncoder.check_size``; an ``InputError`` if it is).
        """
        cells = self.step_size / grid.resolution
        if abs(cells - self.net.step) <= 1e-6 * self.net.step:
            self.net.check_size(grid.obstacles.shape)
            return 1.0
        factor = cells / self.net.step
        shape = resampled_shape(grid.obstacles.shape, factor)
        try:
            self.net.check_size(shape)
        except InputError as exc:
            raise InputError(f"the planner's step {self.step_size:g} is {cells:g} cells of this {grid.height} x "
                             f"{grid.width} map (resolution {grid.resolution:g}); the route encoder reads a step as "
                             f"{self.net.step} cells, so it reads the map resampled to {shape[0]} x {shape[1]} "
                             f"cells, and: {exc}. Take a larger step") from None
        return factor

    def _fields(self, grid: OccupancyGrid) -> tuple[np.ndarray, np.ndarray | None]:
        """Cost-to-go per grid cell in steps: (for the progress, for the frontier or None for the straight line)."""
        if self.net is None:
            return self._straight(grid), None
        obstacles, goal, factor, k = self._encoder_map(grid)
        self.coarsening = k
        # where the learned walls shut every route from the start, the field ranks without them (one more pass)
        learned, opened = self._predict(obstacles, goal, self._encoder_start(grid, factor, obstacles.shape))
        self.forward_passes = self.symmetry_passes * (2 if opened else 1)
        high = True  # whether a finite value may be at or above the unreached one
        if k != 1:  # in steps of k planner steps, interpolated between the coarse cells' centres
            unreached = math.inf if self.net.unreached_steps is None else 0.5 * self.net.unreached_steps * k
            learned, high = interpolated_field(np.asarray(learned, dtype=np.float64) * float(k), obstacles,
                                               grid.kernel.grid, factor, grid.resolution / self.step_size, unreached)
        elif factor != 1.0:  # each map cell takes the value of the encoder's cell its centre lies in
            rows = np.minimum(((np.arange(grid.height) + 0.5) / factor).astype(np.int64), learned.shape[0] - 1)
            cols = np.minimum(((np.arange(grid.width) + 0.5) / factor).astype(np.int64), learned.shape[1] - 1)
            learned = learned[rows][:, cols]
        if self.net.unreached_steps is not None and high:  # (with none, it returns the field as it is)
            learned = ranked_where_unreached(learned, grid.kernel.grid, *self._goal_in_cells(grid), grid.resolution,
                                             self.step_size, 0.5 * self.net.unreached_steps * k)
        progress = self._straight(grid) if self._uses == "frontier" else learned
        return progress, (None if self._uses == "progress" else learned)

    def _encoder_start(self, grid: OccupancyGrid, factor: float, shape: tuple[int, int]) -> tuple[int, int] | None:
        """The query's start in the cells the encoder reads (``_encoder_map``'s, of ``shape``), where the encoder can
        see no route from a cell (``unreached_steps``); else None.
        """
        if self.net.unreached_steps is None:
            return None
        row, col = grid.cell_of(self.problem.start)
        return min(int(row / factor), shape[0] - 1), min(int(col / factor), shape[1] - 1)

    def _predict(self, obstacles: np.ndarray, goal: tuple[int, int],
                 start: tuple[int, int] | None) -> tuple[np.ndarray, bool]:
        """The encoder's field of one query (``FieldEncoder.predict_reaching`` from ``start``, where given), and whether
        it opened the learned walls; from ``fields`` where kept (``reused_seconds``: what a kept one cost).
        """
        net, symmetries = self.net, self.symmetry_passes
        if self.fields is None:
            self.reused_seconds = 0.0
            return net.predict_reaching(obstacles, goal, start, symmetries, threads=self.threads)
        kept = self.fields.get(net, obstacles, goal, symmetries, threads=self.threads, start_cell=start)
        self.reused_seconds = kept.seconds if kept.reused else 0.0
        return kept.field, kept.opened

    def check_query(self, problem: Problem) -> None:
        """Refuse (``InputError``) a query this sampler cannot plan, before any pass.

        Off an ``OccupancyGrid``, or a map its encoder refuses at this step (too large: ``FieldEncoder.check_size``).
        """
        grid = require_grid(type(self).__name__, problem.world)
        if self.net is not None:
            self._encoder_factor(grid)  # the size alone: a map is resampled only for a pass

    def has_field(self, problem: Problem) -> bool:
        """Whether ``fields`` holds the encoder's field of ``problem`` (False without an encoder or a cache, or for a
        map the encoder refuses: its bind refuses it).
        """
        grid = problem.world
        if self.net is None or self.fields is None or not isinstance(grid, OccupancyGrid):
            return False
        try:
            probe = self._copy_with(problem=problem)
            obstacles, goal, factor, _ = probe._encoder_map(grid)
        except InputError:
            return False
        start = probe._encoder_start(grid, factor, obstacles.shape)
        return self.fields.has(self.net, obstacles, goal, self.symmetry_passes, start)

    def prefill(self, problems: Sequence[Problem], *, batch: bool | None = None) -> int:
        """Compute the encoder's fields of ``problems`` into ``fields`` ahead of their binds; the number computed.

        ``batch`` as for ``FieldCache.fill``: by default the passes of all of them run together on a GPU
        and one query at a time on the CPU. Problems off an ``OccupancyGrid``, or too large for the encoder at
        this sampler's step, are left to their binds (which refuse them). Needs an encoder and a ``fields`` cache.
        """
        if self.net is None or self.fields is None:
            raise InputError("RouteSampler.prefill needs an encoder and a fields cache (RouteSampler(net, fields=...))")
        queries = []
        for problem in problems:
            grid = problem.world
            if isinstance(grid, OccupancyGrid):
                try:
                    obstacles, goal, _, _ = self._copy_with(problem=problem)._encoder_map(grid)
                except InputError:
                    continue
                queries.append((obstacles, goal))
        return self.fields.fill(self.net, queries, self.symmetry_passes, threads=self.threads, batch=batch)

    def _copy_with(self, **attributes) -> RouteSampler:
        """A shallow copy with ``attributes`` set (a step, or a problem for its goal), without a bind's set-up."""
        out = object.__new__(type(self))
        out.__dict__.update(self.__dict__)
        out.__dict__.update(attributes)
        return out

    def _setup(self) -> None:
        grid = require_grid("RouteSampler", self.problem.world)
        self.forward_passes, self.reused_seconds = 0, 0.0
        field, ranking = self._fields(grid)
        res, origin = grid.resolution, np.ascontiguousarray(grid.origin, dtype=np.float64)
        # the field with its obstacles at inf (the straight line's comes so, and the interpolation of a map read
        # coarser sets them), and the frontiers ranked by ``ranking`` (None: the straight line)
        if self.net is not None and self.coarsening == 1:
            obstacles_at_inf(field, grid.obstacles)
        if ranking is None:
            fine, costs = fine_frontier(grid), None
        else:  # fields are float64 (``FieldEncoder.predict``, the straight line's, the exact one's)
            fine = fine_frontier(grid, ranking)
            costs = frontier_costs(ranking, grid, self.step_size, times=self.step_size, over=res,
                                   blocked=grid.obstacles)
        self.field = field
        r, c = grid.cell_of(self.problem.start)
        f = Frontier(self.problem, self.step_size, self.tau, costs)
        frontier = (f.world, f.counts, f.cell, f.goal, f.free, f.cov, f.pos, f.front, f.dist, f.tau, f.W,
                    np.ascontiguousarray(f.world.params[1:3]), f.cost, f.memo)
        ints = np.array([0, r * grid.width + c, 0, 0, 0, 0, 0, 0], dtype=np.int64)
        b = self.batch
        # the walk's visited cells: a walk covers less than 1.5 lookaheads of path (``route_draw``)
        walk = int(1.5 * self.lookahead * self.step_size / res) + 2
        scratch = (np.empty((b, 7)), np.empty((b, 2)), np.empty(b), np.empty((b, 2)), np.empty(walk, np.int64),
                   np.empty((b, 2)))
        floats = np.array([field[r, c], np.inf])
        params = np.array([self.lookahead, self.sigma, self.stuck, self.uniform_floor, self.max_floor, self.patience,
                           self.ripple, self.ripple_growth, float(self.sight), float(WIDEN_MODES.index(self.widen))],
                          dtype=np.float64)
        self._state = (field, grid.kernel.grid, res, origin, self.step_size, frontier, fine, ints, floats, params,
                       scratch, self.low, self.high)

    def draw(self, rng, n, view):
        pts = np.empty((min(n, self.batch), 2))
        route_draw(self._state, view.vertices, view.num_vertices, view.best_vertex, view.best_distance,
                   view.iteration, rng_address(rng), pts, _NO_ANCHORS)
        return pts

    @property
    def draw_state(self) -> tuple:
        """The per-query state ``route_draw`` reads and updates (a bound sampler's): for a loop that fuses it."""
        return self._state

    def fuse(self, planner: Planner) -> FusedRRT | None:
        """RRT's loop with this sampler's draws compiled in (same samples, less time); None for other planners."""
        return fuse_rrt(planner, route_rrt_loop, self._state, self.batch)

    def for_planner(self, family: str) -> SamplerBase:
        """This sampler's rule for a planner ``family`` (``planners.base.samplers``), on the same field.

        ``"tree"`` (RRT) and families it does not know: this sampler. ``"bidirectional"`` (RRT-Connect): each
        tree follows its own field (``BidirectionalRouteSampler``); ``"roadmap"`` (PRM, Lazy-PRM, OB-PRM): the
        corridor where the fields say a short route runs (``CorridorSampler``); ``"optimizing"`` (RRT*): this
        sampler to the first solution, then the corridor inside the informed set (``ConvergingRouteSampler``).
        Planners call it when given the sampler, so ``make_sampler("route")`` serves any of them.
        """
        from learning.samplers.route_rules import rule_for

        return rule_for(self, family)

    def draw_tree(self, rng: np.random.Generator, n: int, vertices: np.ndarray, num_vertices: int,
                  best_distance: float, iteration: int) -> np.ndarray:
        """``draw`` for a tree given by its parts (for a planner that grows more than one tree).

        The tree is ``vertices[:num_vertices]``, ``best_distance`` their closest distance to this problem's goal,
        and ``iteration`` the tree's own count of draws.
        """
        pts = np.empty((min(n, self.batch), 2))
        route_draw(self._state, vertices, num_vertices, 0, best_distance, iteration, rng_address(rng), pts,
                   _NO_ANCHORS)
        return pts

    def cost_to_go(self, problem: Problem) -> CachedField:
        """The field this sampler follows on ``problem``: cost-to-go to its goal of every grid cell, in steps.

        The encoder's pass (or the cache's field) as a bind takes it, without the rest of a bind's set-up: a fresh
        array, ``inf`` on obstacles, with the encoder seconds behind it and whether they were the cache's
        (``reused``, as ``reused_seconds``).
        """
        grid = require_grid("RouteSampler", problem.world)
        probe = self._copy_with(problem=problem)
        t0 = work_clock()
        field = np.array(probe._fields(grid)[0], dtype=np.float64)
        seconds = work_clock() - t0
        field[grid.obstacles] = np.inf
        reused = probe.reused_seconds > 0
        return CachedField(field, probe.reused_seconds if reused else seconds, reused)

    def __repr__(self) -> str:
        rest = (f"lookahead={self.lookahead:g}, sigma={self.sigma:g}, stuck={self.stuck}, tau={self.tau:g}, "
                f"ripple={self.ripple:g}, ripple_growth={self.ripple_growth:g}, sight={self.sight}, "
                f"widen={self.widen!r}")
        return f"RouteSampler({'None, ' if self.net is None else ''}{rest})"


#: ``route_draw``'s anchor codes in ``RouteSampler.draw``: it never anchors, so it never writes them.
_NO_ANCHORS = np.zeros(0, dtype=np.int8)


def shipped_sampler(encoder: FieldEncoder | str | os.PathLike = SHIPPED, step_size: float = 4.0, *,
                    device: str = "auto", threads: int | None = None, coarse_side: int = COARSE_SIDE) -> RouteSampler:
    """An encoder (loaded, or a file; default the shipped one) at the validated ``SHIPPED_SETTINGS``.

    ``evaluate.py``'s "route encoder"; ``device``, ``threads`` and ``coarse_side`` (0: every map at full resolution)
    as for ``RouteSampler``.
    """
    net = encoder if isinstance(encoder, FieldEncoder) else load_route_net(encoder)
    return RouteSampler(net, step_size=step_size, device=device, threads=threads, coarse_side=coarse_side,
                        **SHIPPED_SETTINGS)


def shipped_ablation(step_size: float = 4.0) -> RouteSampler:
    """``shipped_sampler`` with the encoder replaced by the straight-line distance: what its learning adds over.

    At ``ABLATION_SETTINGS``, tuned for it on validation as the encoder's settings were.
    """
    return RouteSampler(None, step_size=step_size, **ABLATION_SETTINGS)


def straight_line_sampler() -> RouteSampler:
    """The straight-line follower: ``RouteSampler`` with the encoder replaced by the straight-line distance.

    ``evaluate.py`` runs it as the "straight-line follower" (``make_sampler("follower")``).
    """
    return RouteSampler(None, **FOLLOWER_SETTINGS)
