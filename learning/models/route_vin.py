"""The value-iteration route encoder: learned local move costs, and value iteration over them, on the block grid.

``RouteVIN`` reads a map in blocks of one planner step or a whole fraction of one (``RouteNet`` reads blocks
of one step), and its reach grows with the map instead of being fixed by its layers. A small convolutional
network looks at each block and its neighbours (every cell of each, so a 1-cell gap is not averaged away)
and predicts what it costs, in blocks, to move from that block into each of its 8 neighbours. Value
iteration, as in value-iteration networks (Tamar et al., 2016), then carries the goal's cost-to-go across the
block grid: each iteration is one layer of shared weights, ``V = min over moves of (cost of the move + V of
the block it reaches)``, and the iterations run until the values settle (at most one per block of the grid).
That fixed point is the shortest path over the move costs, so the encoder computes it directly, by a compiled
Dijkstra (``RouteVIN.settle``): the same values bit for bit, in one pass over the blocks.
A last local head turns the block values into a cost-to-go for every cell. The goal enters the local network
as one block's mark, which reaches only the features within ``depth`` blocks of it, so at inference the encoder
keeps each map's parts (``MapParts``: the cost head's output, the cell head's first layer, the step walls) and a
later query on the same map recomputes the local network over the goal's window only (``RouteVIN.reusing_field``,
``map_cache_bytes``): the same field up to rounding, at a fraction of the pass. On the CPU everything after the
convolutions runs compiled (``RouteVIN.compiled_field``).
Nothing in it depends on the map's size or on where on the map a block lies: it learns local geometry (which
cells let a robot through, at what cost) and composes it.

The learned parts are the move costs and the cell head. Training fits the move costs to the grid search's
cost-to-go directly (every block's cost-to-go minus its best neighbour's is the cost of that move, and no
move may cost less than the drop it makes), and the cell head to every cell's cost-to-go given the block
values. At inference it sees only the map and the goal; the grid search is a training target only. Two rules
of inference keep value iteration from leaking through walls: a move priced above ``WALL_COST`` blocks per block
of its length is a wall, and so is a block move that no free cell can step (``cell_steps``, the grid's own step
rule; ``RouteVIN.step_walls``).
"""

from __future__ import annotations

import contextlib
import hashlib
import math
from collections import OrderedDict
from typing import NamedTuple

import numpy as np
import torch
from torch import nn

from learning.models import local_net, vin_query
from learning.models.cell_head import padded_free_cells
from learning.models.field import FieldEncoder, batch_of, check_start, route_input
from learning.models.threads import planning_threads
from planners.maps.gridsearch import MOVES, move_cost_field, padded_block_steps, work_array

#: The moves' lengths in blocks (``MOVES``: the 8 moves of the block grid, the grid search's own order).
LENGTHS = tuple(math.hypot(dr, dc) for dr, dc in MOVES)
#: The value of a block the goal does not reach (in blocks): above any cost-to-go a map can have.
UNREACHED = 1e6
#: The most a move may cost, in log blocks per block of length (a wall: any route around is cheaper).
WALL_LOG = math.log(1000.0)
#: At inference, a move priced above this many blocks per block of its length is a wall. Training asks every move
#: to cost at least the drop in cost-to-go it makes, up to ``learning.training.vin_losses.WALL`` (64): so a move
#: through a wall learns a price just above the detours of the training maps, which a longer detour on a larger
#: map exceeds, and value iteration would leak through the wall there. A move the robot can make costs about its
#: length. None: no threshold.
WALL_COST: float | None = 32.0
#: How many blocks of cost-to-go either side of a block the cell head reads (its neighbours' values relative
#: to its own).
REACH = 4.0


def shifted(v: torch.Tensor, fill: float) -> list[torch.Tensor]:
    """``v`` (B, h, w) padded once and viewed 8 ways, in ``MOVES`` order.

    Each view holds, at every block, the value of its neighbour in that move's direction (``fill`` off the map).
    """
    h, w = v.shape[-2:]
    p = nn.functional.pad(v, (1, 1, 1, 1), value=fill)
    return [p[..., 1 + dr:1 + dr + h, 1 + dc:1 + dc + w] for dr, dc in MOVES]


def neighbours(v: torch.Tensor, fill: float) -> torch.Tensor:
    """(B, 8, h, w): each block's 8 neighbours' values, in ``MOVES`` order."""
    return torch.stack(shifted(v, fill), 1)


def cell_steps(x: torch.Tensor, block: int) -> torch.Tensor:
    """(B, 8, h, w) bool, in ``MOVES`` order: whether some free cell of a block can step into the neighbouring block.

    From ``route_input``'s cell channels (B, block**2 + ..., h, w). A step goes from a free cell to one of its 8
    neighbours that is free, a diagonal one only if both cells beside it are free (the grid's own rule, no corner
    cutting): a block move no step makes crosses a wall, however the network prices it. Compiled
    (``planners.maps.gridsearch.padded_block_steps``), on the CPU whatever the device.
    """
    return torch.from_numpy(block_moves(x.cpu().numpy(), block)).to(x.device)


def block_moves(cells: np.ndarray, block: int) -> np.ndarray:
    """``cell_steps`` of ``route_input``'s channels as a numpy array (B, block**2 + ..., h, w): (B, 8, h, w) bool."""
    return batch_of([padded_block_steps(padded_free_cells(c[:block * block], block), block) for c in cells])


def _patched(kept: np.ndarray, window: tuple[int, int, int, int], values: np.ndarray) -> np.ndarray:
    """A copy of ``kept`` (B, C, h, w) with the blocks of ``window`` (rows ``k0:k1``, columns ``j0:j1``) set to
    ``values``.
    """
    k0, k1, j0, j1 = window
    out = kept.copy()
    out[:, :, k0:k1, j0:j1] = values
    return out


class MapParts(NamedTuple):
    """What a pass computes from a map, kept for the next query on the same map (``RouteVIN``).

    Numpy arrays on the CPU, which no query writes into. ``costs``: the learned move costs, before inference's walls
    (1, 8, h, w); ``hidden``: the cell head's first layer on the local features, before the block values join
    (``RouteVIN.head_inputs``, 1, C, h, w); ``steps``: ``cell_steps`` (1, 8, h, w). ``goal_window``: the blocks (rows
    ``k0:k1``, columns ``j0:j1``) where ``costs`` and ``hidden`` still hold the first query's goal (they were kept from
    its whole pass), or None where they hold the map alone everywhere; ``goal_block``: that goal's block (row,
    column), where ``goal_window`` is not None.
    """

    costs: np.ndarray
    hidden: np.ndarray
    steps: np.ndarray
    goal_window: tuple[int, int, int, int] | None = None
    goal_block: tuple[int, int] | None = None

    def nbytes(self) -> int:
        return self.costs.nbytes + self.hidden.nbytes + self.steps.nbytes


class Reach:
    """A query's start, whose route a compiled pass checks before its cell head (``RouteVIN.predict_reaching``).

    ``cell``: the start's (row, column) in the map's cells; ``scale``: steps per block of the cell head's values
    (``block / step``); ``limit``: the field's value there, in steps, at or above which the learned walls have shut
    every route from it (half ``unreached_steps``, as ``FieldEncoder.shuts`` reads it); ``opened``: set by the pass
    where they had, and it searched again without them.
    """

    def __init__(self, cell: tuple[int, int], scale: float, limit: float) -> None:
        self.cell, self.scale, self.limit = (int(cell[0]), int(cell[1])), scale, limit
        self.opened = False

    def shut(self, value: float) -> bool:
        """Whether a start whose cell head gives ``value`` (blocks, float32) sees no route: as ``FieldEncoder.shuts``
        reads ``predict``'s field (float64, in steps: the value times ``scale``).
        """
        return float(np.float64(value) * self.scale) >= self.limit


class KeptMaps:
    """Maps' kept parts by key, the most recently used last, with their bytes in total kept as they change.

    (A sum over every kept map at each query cost more than the query's own search once hundreds were kept.) A map
    queried once is held apart (``recent``) until another map's first query takes its place, and the keys of maps
    queried once are noted (``seen``, at most ``SEEN`` of them): a map's parts enter the kept maps at its second
    query, so a run of one query per map keeps one map's parts at a time, and its passes use the same memory again
    instead of fresh memory (a first query at 128 x 128 cells costs a fifth to a third more in fresh memory), while
    a second query right after the first (a bidirectional planner's field to the start) still finds them.
    """

    #: How many maps queried once are remembered (their keys only).
    SEEN = 4096

    def __init__(self) -> None:
        self.parts: OrderedDict[tuple, MapParts] = OrderedDict()
        self.bytes = 0
        self.seen: OrderedDict[tuple, None] = OrderedDict()
        self.recent: tuple[tuple, MapParts] | None = None

    def __len__(self) -> int:
        return len(self.parts)

    def seen_before(self, key: tuple) -> bool:
        """Whether the map ``key`` was queried before (and its parts are not kept); notes it as queried now."""
        if key in self.seen:
            self.seen.move_to_end(key)
            return True
        self.seen[key] = None
        if len(self.seen) > self.SEEN:
            self.seen.popitem(last=False)
        return False

    def pop(self, key: tuple) -> MapParts | None:
        """Take the parts kept (or held as the recent map's) under ``key`` out (None where there are none)."""
        parts = self.parts.pop(key, None)
        if parts is not None:
            self.bytes -= parts.nbytes()
            return parts
        if self.recent is not None and self.recent[0] == key:
            parts, self.recent = self.recent[1], None
        return parts

    def hold(self, key: tuple, parts: MapParts, max_bytes: int) -> None:
        """Hold ``parts`` as the recent map's in place of the one held before (none if they alone are too large)."""
        self.recent = (key, parts) if parts.nbytes() <= max_bytes else None

    def put(self, key: tuple, parts: MapParts, max_bytes: int) -> None:
        """Keep ``parts`` under ``key``, most recently used, then drop the least recently used past ``max_bytes``."""
        self.pop(key)
        self.parts[key] = parts
        self.bytes += parts.nbytes()
        while self.bytes > max_bytes:  # the least recently used first (this one too, if it alone is too large)
            self.bytes -= self.parts.popitem(last=False)[1].nbytes()

    def clear(self) -> None:
        self.parts.clear()
        self.seen.clear()
        self.recent = None
        self.bytes = 0


class RouteVIN(nn.Module, FieldEncoder):
    """Learned move costs and value iteration over the block grid (see the module docstring).

    Args:
        block: Cells per block side.
        channels: Width of the local network.
        depth: 3x3 convolutions of the local network: each block's costs read ``2 * depth + 1`` blocks across.
        step: The planner's step in cells, a whole number of blocks (default one block): ``predict`` gives the
            cost-to-go in steps. Blocks of half a step give each half of a step its own value, so a wall
            thinner than a step that splits one of its blocks need not join its two sides.
    """

    #: The route sampler takes one pass per query: value iteration carries the same local costs whichever way
    #: the map is turned, and on the validation maps the mean over 8 turns gave no fewer iterations at 8 times
    #: the cost.
    symmetries = 1
    #: Above how many blocks per block of length a learned move is a wall at inference (``WALL_COST``; None: none).
    wall_cost: float | None = WALL_COST
    #: Whether at inference a block move that no cell can step (``cell_steps``: the grid's own step rule, no
    #: corner cutting) is a wall, whatever its price: value iteration then cannot leak through a wall thinner
    #: than a block at a slant (see the research report, "The step walls"). Training never applies it.
    step_walls: bool = True
    #: How inference computes value iteration's fixed point: "dijkstra" (``settle``, the default) or "iterate"
    #: (``iterate`` to convergence: the same values, bit for bit, kept to measure what the direct way saves).
    fixed_point: str = "dijkstra"
    #: Above how many blocks per map a pass at inference through torch runs in strips of rows (``forward``), and
    #: keeps no map's parts (``infer``): up to it, one piece (every map of up to 1024 x 1024 cells at 2 cells per
    #: block). The compiled inference runs in strips of its own (``map_features``) on every map.
    strip_blocks: int = 512 * 512
    #: How many bytes of map parts (``MapParts``) inference keeps, the most recently used maps first:
    #: the goal reaches only the features of blocks within ``depth`` blocks of its own, so a later query on the
    #: same map recomputes the local network over that window only (``reusing_field``). 0: no reuse. The reuse
    #: runs the local network, the cost head and the cell head itself: a subclass that overrides ``move_costs`` or
    #: ``cell_field`` sets it to 0.
    map_cache_bytes: int = 256 << 20
    #: Whether inference on the CPU runs compiled after the convolutions (``compiled_field``): the walls gate the
    #: Dijkstra's moves, and the cell head runs in numba from ``map_features``' strips. False: the torch pass, the
    #: same fields up to rounding (kept to measure what the compiled one saves, and to check it).
    compiled_inference: bool = True
    #: Whether the compiled inference runs the local network's 3x3 convolutions on weights prepacked once into
    #: oneDNN's blocked layout (as ``torch.utils.mkldnn`` does), the activations kept in it from layer to layer, where
    #: torch has oneDNN. Another order of summation: the field moves by up to 1.2e-4 steps (the dense pass itself
    #: moves by up to 4.7e-4 between oneDNN's AVX2 and AVX-512 kernels), and a first query at 128 to 512 cells costs a
    #: tenth to a quarter less; chosen by the validation rule (see the research report, "Cheaper arithmetic for the
    #: same network"). False: the dense convolutions, as training runs them.
    prepacked: bool = True
    #: The least blocks a map's grid has for its pass to run prepacked (``prepacked``); a smaller map runs the dense
    #: layers: there oneDNN's layout costs more than it saves (a 32-cell map's first query 0.63 against 0.53 ms, equal
    #: at 64 cells), and each new map shape's first pass costs 0.6 ms more to set up against 0.1 to 0.3 dense.
    prepacked_blocks: int = 64 * 64
    #: The most blocks the local network reads in a compiled pass (the map, or a later query's window and its
    #: margin: at most ``(4 * depth + 1) ** 2``) for it and its heads to run compiled (``compiled_local``,
    #: ``learning.models.local_net``) rather than through torch: on small regions torch's cost is its calls, the
    #: more so where a query runs between planners, as in a planning loop. The same values up to rounding (up to
    #: 1.14e-4 steps on the validation maps, every validation median of iterations the same). Chosen by time in
    #: planning conditions (``scripts/experiments/compiled_local.py``: validation maps of 32 to 128 cells, a planner's
    #: run before each field): a first query at 32 to 112 cells takes 0.65 to 0.83 of torch's time, at 128 cells
    #: (torch's layers prepacked) 0.97 and 1.02; a later query's window 0.53 to 0.72 at every side.
    numba_local_blocks: int = 56 * 56
    #: Whether a compiled pass over a larger region, whose local network runs through torch, runs its two 1x1 heads
    #: compiled (``strip_parts``, ``learning.models.local_net.block_heads``): the same values up to rounding (the
    #: field within 1.03e-4 steps of the dense pass on the validation maps, every validation median the same), 0.90
    #: to 0.97 of a first query's time at 128 cells. False: ``prices`` and ``head_inputs`` through torch.
    compiled_heads: bool = True
    #: Whether a compiled pass over a map whose parts inference does not keep (one above ``strip_blocks``, or any
    #: map where ``map_cache_bytes`` is 0) writes its move costs, the head's first layer and the cell field into
    #: buffers the encoder keeps for the next such pass of the same shape (``buffer``), and the compiled search its
    #: working arrays likewise (``move_cost_field``'s ``work``), rather than into new memory: the same values,
    #: without the operating system's cost of mapping the memory afresh each pass (at 4096 x 4096 cells 0.68 GB, and
    #: 0.1 to 0.4 s of a 2.1 to 2.5 s pass on the 2-core machine, as its memory's state goes). They stay until
    #: ``release_buffers`` (or ``weights_changed``): at most what one pass holds at its peak anyway
    #: (``pass_bytes``). False: new memory each pass, nothing kept. Like the kept maps they belong to the encoder:
    #: threads that plan at once take an encoder each (or a lock).
    keep_buffers: bool = True

    def __init__(self, block: int = 4, channels: int = 48, depth: int = 4, step: int | None = None) -> None:
        super().__init__()
        step = block if step is None else step
        if step % block:
            raise ValueError(f"step = {step} cells, block = {block} cells: expected a step of whole blocks")
        self.block, self.channels, self.depth, self.step = block, channels, depth, step
        self.unreached_steps = UNREACHED * block / step  # a block's UNREACHED value, in steps
        self.attention_layers = 0  # as ``RouteNet`` names them: it has none
        self.trained_side = 0  # its field keeps its scale on any map: nothing to rescale
        inputs = block * block + 1  # every cell of the block, and whether the goal is in it
        convs: list[nn.Module] = []
        for i in range(depth):
            # each ReLU rectifies its convolution's output in place: the same values, one allocation fewer a layer
            convs += [nn.Conv2d(inputs if i == 0 else channels, channels, 3, padding=1), nn.ReLU(inplace=True)]
        self.local = nn.Sequential(*convs)
        self.cost = nn.Conv2d(channels, len(MOVES), 1)
        self.cells = nn.Sequential(nn.Conv2d(channels + len(MOVES), channels, 1), nn.ReLU(inplace=True),
                                   nn.Conv2d(channels, block * block, 1))
        self.register_buffer("lengths", torch.tensor(LENGTHS, dtype=torch.float32).view(1, -1, 1, 1))
        self._maps = KeptMaps()
        self._packed: list[tuple[torch.Tensor, torch.Tensor]] = []  # each 3x3 layer's weights for oneDNN, once made
        self._work: dict[str, np.ndarray] = {}  # a pass's buffers and the search's working arrays, by name
        self._arrays: dict[str, tuple[np.ndarray, ...]] = {}  # weights as the compiled inference reads them, once made

    def clear_map_cache(self) -> None:
        """Forget every map's kept parts (``map_cache_bytes``); the prepacked weights and a pass's buffers stay
        (``weights_changed``, ``release_buffers``).
        """
        self._maps.clear()

    def release_buffers(self) -> None:
        """Free the working buffers a pass keeps for the next one of the same shape (``keep_buffers``)."""
        self._work.clear()

    def buffer(self, name: str, shape: tuple[int, ...]) -> torch.Tensor:
        """The kept float32 CPU buffer ``name`` of ``shape`` (``keep_buffers``): the one the last pass used where its
        shape is the same, else a new one that replaces it (``work_array``). Its contents are whatever the last pass
        left.
        """
        return torch.from_numpy(work_array(self._work, name, tuple(shape), np.float32))

    def weights_changed(self) -> None:
        """Forget what inference keeps from the weights: every map's parts and the prepacked local network.

        ``train`` and ``load_state_dict`` call it; call it after changing the weights in place in evaluation mode
        by any other way.
        """
        self._maps.clear()
        self._packed.clear()
        self._arrays.clear()
        self.release_buffers()

    def train(self, mode: bool = True) -> RouteVIN:
        self.weights_changed()
        return super().train(mode)

    def load_state_dict(self, *args, **kwargs):
        self.weights_changed()
        return super().load_state_dict(*args, **kwargs)

    def __getstate__(self) -> dict:
        # a copy sent elsewhere starts with no kept maps or buffers, and packs its own weights
        return {**self.__dict__, "_maps": KeptMaps(), "_packed": [], "_work": {}, "_arrays": {}}

    def __setstate__(self, state: dict) -> None:
        # a copy pickled before the prepacked weights or the buffers existed; a copy keeps no maps
        super().__setstate__({"_packed": [], "_work": {}, "_arrays": {}, **state, "_maps": KeptMaps()})

    def inference_key(self) -> tuple:
        return (*super().inference_key(), self.wall_cost, self.step_walls, self.fixed_point)

    def open_walls(self) -> contextlib.AbstractContextManager | None:
        """Passes without the learned wall rule (``wall_cost`` None) inside the context; the step walls stay."""
        return None if self.wall_cost is None else self._without_learned_walls()

    @contextlib.contextmanager
    def _without_learned_walls(self):
        kept = self.__dict__.get("wall_cost")
        self.wall_cost = None
        try:
            yield self
        finally:
            if kept is None:
                del self.wall_cost  # back to the class's value
            else:
                self.wall_cost = kept

    def predict_reaching(self, obstacles: np.ndarray, goal_cell: tuple[int, int], start_cell: tuple[int, int] | None,
                         symmetries: int = 1, *, threads: int | None = None) -> tuple[np.ndarray, bool]:
        """``FieldEncoder.predict_reaching`` in one pass where the inference is compiled: the local network runs once
        (or its map's kept parts serve), the search runs with the learned walls (or a walk over their open moves finds
        the start unreached), the cell head is read at the start alone, and where no route leaves it the search runs
        again without them; the whole cell head then runs once, all of it after the convolutions in one compiled call.
        The same field and answer as the two ``predict`` calls (``compiled_field``'s ``reach``), without the first
        pass's cell head and a second pass's set-up. Elsewhere (symmetries, a GPU, the torch pass) the two calls.
        """
        one_pass = (start_cell is not None and type(symmetries) is int and symmetries == 1
                    and self.wall_cost is not None and self.compiles() and self.lengths.device.type == "cpu")
        if not one_pass:
            return super().predict_reaching(obstacles, goal_cell, start_cell, symmetries, threads=threads)
        self.check_size(obstacles.shape)
        H, W = obstacles.shape
        reach = Reach(check_start(obstacles, start_cell), self.block / self.step, 0.5 * self.unreached_steps)
        cells = route_input(obstacles, goal_cell, self.block)[None, :self.block * self.block + 1]
        h, w = cells.shape[-2:]
        if self.map_cache_bytes > 0 and self.strip_rows(h, w) >= h and self.local_compiles(cells):
            field = self.kept_field(cells, reach)  # every step compiled: no torch call at all
        else:
            with planning_threads(threads), torch.inference_mode():
                field = self.infer(torch.from_numpy(cells), reach).numpy()
        return self.in_steps(field[0, :H, :W].astype(np.float64)), reach.opened

    def goal_and_walls(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """From ``route_input``'s channels: (the goal's block, the blocks with no free cell), (B, h, w) bool each."""
        cells = self.block * self.block
        return x[:, cells] > 0.5, x[:, :cells].amin(1) > 0.5

    def move_costs(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(features (B, C, h, w), move costs (B, 8, h, w) in blocks, each at least half the move's length)."""
        f = self.local(x)
        return f, self.prices(f)

    def prices(self, f: torch.Tensor) -> torch.Tensor:
        """The move costs (B, 8, h, w) in blocks from the local features ``f``: each at least half its length."""
        if torch.is_grad_enabled():
            return self.lengths * (0.5 + torch.exp(self.cost(f).clamp_max(WALL_LOG)))
        c = self.cost(f)  # at inference the same operations in place, the same values: fewer tensors made
        return c.clamp_max_(WALL_LOG).exp_().add_(0.5).mul_(self.lengths)

    @staticmethod
    def iterate(costs: torch.Tensor, goal: torch.Tensor, walls: torch.Tensor, v: torch.Tensor | None = None, *,
                steps: int | None = None, check: int = 16) -> torch.Tensor:
        """Value iteration on ``costs`` (B, 8, h, w) towards the blocks where ``goal`` (B, h, w, bool) holds.

        A block with no free cell (``walls``, (B, h, w) bool) is never entered: its value stays ``UNREACHED``.
        From ``v`` (default: 0 at the goal, ``UNREACHED`` elsewhere), ``steps`` iterations, or (None) until
        the values stop changing (checked every ``check``; at most one iteration per block of the grid, the
        longest a route over the grid can be). Without ``steps`` each value only falls, so the goal keeps 0.
        """
        costs = costs.masked_fill(walls.unsqueeze(1), UNREACHED)  # nothing leaves a wall, so nothing enters one
        if v is None:
            v = torch.where(goal, 0.0, UNREACHED).to(costs.dtype)
        most = steps if steps is not None else v.shape[-2] * v.shape[-1] + check
        done = 0
        while done < most:
            prev = v
            for _ in range(min(check, most - done)):
                nxt = v if steps is None else None
                for a, there in enumerate(shifted(v, UNREACHED)):
                    there = costs[:, a] + there
                    nxt = there if nxt is None else torch.minimum(nxt, there)
                v = nxt.clamp_max(UNREACHED) if steps is None else torch.where(goal, 0.0, nxt.clamp_max(UNREACHED))
                done += 1
            if steps is None and torch.equal(prev, v):
                break
        return v

    @staticmethod
    def settle(costs: torch.Tensor, goal: torch.Tensor, walls: torch.Tensor) -> torch.Tensor:
        """``iterate`` run until the values settle, computed directly: the same values, bit for bit, far sooner.

        Value iteration's fixed point is the shortest path over the move costs, so a compiled Dijkstra
        (``planners.maps.gridsearch.move_cost_field``) gives it in one pass over the blocks instead of one sweep
        of the grid per block a route crosses. It runs on the CPU whatever the device (the values come back to
        ``costs``' device) and carries no gradient.
        """
        c = costs.detach().cpu().numpy()
        g, w = goal.cpu().numpy(), walls.cpu().numpy()
        v = np.stack([move_cost_field(c[i], g[i], w[i], UNREACHED) for i in range(len(c))])
        return torch.from_numpy(v).to(costs.device)

    def cell_field(self, f: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
        """Every cell's cost-to-go (B, H, W) from the block features and block values."""
        rel = (neighbours(v, UNREACHED) - v.unsqueeze(1)).clamp(-REACH, REACH)
        offsets = self.cells(torch.cat([f, rel], 1))
        return nn.functional.pixel_shuffle(v.unsqueeze(1) + offsets, self.block)[:, 0]

    def pass_bytes(self, h: int, w: int) -> int:
        """About how many bytes one pass over an ``h`` x ``w`` block grid holds at its peak (one symmetry).

        Measured on the shipped encoder (``scripts/benchmark_route.py``'s peak memory over the interpreter's own): in
        one piece about 1 kB per block (0.26 GB at 1024 x 1024 cells); in strips about 0.1 GB for a strip and, per
        block of the map, 240 bytes and 4 a channel, the buffers kept for the next pass included (``keep_buffers``;
        0.36 to 0.41 GB at 2048 x 2048 cells, 1.25 to 1.29 GB at 4096 x 4096).
        """
        blocks = h * w
        if blocks <= self.strip_blocks:
            return int(1_000 * self.channels / 48 * blocks)
        return int(100 * 2**20 + (240 + 4 * self.channels) * blocks)

    def strip_rows(self, h: int, w: int) -> int:
        """Block rows per strip of a pass over an ``h`` x ``w`` block grid: ``h`` (one piece) up to ``strip_blocks``."""
        if h * w <= self.strip_blocks:
            return h
        return max(1, self.strip_blocks // (2 * w))

    def inference_values(self, x: torch.Tensor, costs: torch.Tensor, goal: torch.Tensor,
                         walls: torch.Tensor, steps: torch.Tensor | None = None) -> torch.Tensor:
        """The block values at inference: the moves priced above ``wall_cost`` and those no cell steps are walls.

        ``steps``: ``cell_steps(x, block)`` where the caller has it already.
        """
        with torch.no_grad():
            return self.fixed_point_values(self.wall_rules(x, costs, steps), goal, walls)

    def wall_rules(self, x: torch.Tensor, costs: torch.Tensor, steps: torch.Tensor | None = None) -> torch.Tensor:
        """``costs`` with inference's walls: moves above ``wall_cost``, and (``step_walls``) those no cell makes."""
        if self.wall_cost is not None:
            costs = costs.masked_fill(costs > self.wall_cost * self.lengths, UNREACHED)
        if self.step_walls:
            costs = costs.masked_fill(~(cell_steps(x, self.block) if steps is None else steps), UNREACHED)
        return costs

    def fixed_point_values(self, costs: torch.Tensor, goal: torch.Tensor, walls: torch.Tensor) -> torch.Tensor:
        """Value iteration's fixed point over ``costs`` (walls applied), the way ``fixed_point`` says."""
        if self.fixed_point not in ("dijkstra", "iterate"):
            raise ValueError(f"RouteVIN.fixed_point = {self.fixed_point!r}: expected 'dijkstra' or 'iterate'")
        return (self.settle if self.fixed_point == "dijkstra" else self.iterate)(costs, goal, walls)

    def compiled(self, x: torch.Tensor) -> bool:
        """Whether this pass takes the compiled inference (``compiled_field``).

        It does where ``compiled_inference`` holds, on float32 input on the CPU, without gradients, with the fixed point
        by Dijkstra and the class's own cell head (a subclass that overrides ``cell_field`` keeps its own).
        """
        return (x.device.type == "cpu" and x.dtype == torch.float32 and not torch.is_grad_enabled()
                and self.compiles())

    def compiles(self) -> bool:
        """Whether this encoder's CPU inference without gradients is the compiled one (``compiled``):
        ``compiled_inference``, the fixed point by Dijkstra and the class's own cell head.
        """
        return (self.compiled_inference and self.fixed_point == "dijkstra"
                and type(self).cell_field is RouteVIN.cell_field)

    def head_inputs(self, f: torch.Tensor) -> torch.Tensor:
        """The cell head's first layer on the local features ``f`` (B, C, h, w), its bias included (``pre``)."""
        first = self.cells[0]
        return nn.functional.conv2d(f, first.weight[:, :self.channels], first.bias)

    def packs(self, x: torch.Tensor) -> bool:
        """Whether a compiled pass over the map ``x`` runs the local network prepacked (``prepacked``).

        It does on float32 input of at least ``prepacked_blocks`` blocks, where torch has oneDNN and the encoder keeps
        the class's own ``move_costs`` (one that overrides it keeps its own).
        """
        return (self.prepacked and x.dtype == torch.float32 and x.shape[-2] * x.shape[-1] >= self.prepacked_blocks
                and torch.backends.mkldnn.is_available()
                and getattr(self.move_costs, "__func__", None) is RouteVIN.move_costs)

    def packed_weights(self) -> list[tuple[torch.Tensor, torch.Tensor]]:
        """Each 3x3 layer's weight and bias in oneDNN's layout, converted once (until ``weights_changed``)."""
        if not self._packed:
            # ATen's reorder of a convolution's weights into oneDNN's blocked layout, as torch.utils.mkldnn does it
            reorder = torch.ops.aten.mkldnn_reorder_conv2d_weight
            self._packed.extend((reorder(m.weight.detach().to_mkldnn(), [1, 1], [1, 1], [1, 1], 1),
                                 m.bias.detach().to_mkldnn()) for m in self.local if isinstance(m, nn.Conv2d))
        return self._packed

    def packed_local(self, y: torch.Tensor) -> torch.Tensor:
        """``self.local(y)`` (dense float32, padded by one a layer), its activations in oneDNN's layout between
        layers (``packs``).
        """
        y = y.to_mkldnn()
        for weight, bias in self.packed_weights():
            y = torch.mkldnn_convolution(y, weight, bias, [1, 1], [1, 1], [1, 1], 1).relu_()
        return y.to_dense()

    def inference_costs(self, x: torch.Tensor, packed: bool) -> tuple[torch.Tensor, torch.Tensor]:
        """``move_costs`` as the compiled inference runs it over ``x`` (the map or a strip of it): prepacked where
        ``packed`` (``packs`` of the whole map).
        """
        if not packed:
            return self.move_costs(x)
        f = self.packed_local(x)
        return f, self.prices(f)

    #: About the bytes of one layer's activations a strip of ``map_features`` holds, so that they stay in the CPU's
    #: cache between layers. One thread, the 2-core machine: over a 1024 x 1024-cell map the convolutions took 60 to
    #: 64 ms in strips of 128 block rows (4 MB) against 105 to 136 ms in one piece, and 64 to 69 ms in strips of 2 to
    #: 32 MB; over 4096 x 4096 cells (the prepacked layers) 1.34 to 1.37 s in strips of 64 rows (8 MB) against 1.41 to
    #: 1.44 s in strips of 32 (whose margins are a quarter of their work), 1.48 to 1.53 s in strips of 128 and 2.3 s
    #: in strips of 256 (32 MB), out of the cache.
    feature_bytes: int = 8 << 20

    def map_features(self, x: torch.Tensor, reuse: bool = False) -> tuple[torch.Tensor, torch.Tensor]:
        """The learned move costs and the head's first layer (``head_inputs``) of every block, in strips of rows.

        Each strip reads the ``depth`` rows beyond it that its layers see, so every kept row is the whole pass's (up
        to the rounding of another shape); a strip's activations take about ``feature_bytes`` (at least ``8 *
        depth`` rows), so they stay in the CPU's cache from one layer to the next and a pass holds only the two
        outputs beyond one strip. ``reuse``: the two outputs are the kept buffers (``buffer``), which the next such
        pass overwrites.
        """
        if self.compiled_local(x):
            return tuple(torch.from_numpy(a) for a in self.local_parts(x.numpy(), reuse=reuse))
        h, w = x.shape[-2:]
        d = self.depth
        rows = max(8 * d, self.feature_bytes // (4 * self.channels * w * x.shape[0]))
        if rows >= h:
            return self.strip_parts(x, self.packs(x))
        packed = self.packs(x)  # decided on the whole map, so its later windows run as its strips do
        if reuse:
            costs = self.buffer("costs", (x.shape[0], len(MOVES), h, w))
            pre = self.buffer("pre", (x.shape[0], self.channels, h, w))
        else:
            costs = x.new_empty(x.shape[0], len(MOVES), h, w)
            pre = x.new_empty(x.shape[0], self.channels, h, w)
        for r0 in range(0, h, rows):
            r1 = min(h, r0 + rows)
            lo, hi = max(0, r0 - d), min(h, r1 + d)
            costs[:, :, r0:r1], pre[:, :, r0:r1] = self.strip_parts(x[:, :, lo:hi], packed, (r0 - lo, r1 - lo))
        return costs, pre

    def strip_parts(self, x: torch.Tensor, packed: bool, rows: tuple[int, int] | None = None
                    ) -> tuple[torch.Tensor, torch.Tensor]:
        """The move costs and the head's first layer of the blocks of ``x`` (the map or a strip of it; of its block
        rows ``rows`` only, where given) as the compiled inference computes them: the local network through torch
        (prepacked where ``packed``), and its two heads compiled (``learning.models.local_net.block_heads``) where
        ``compiled_heads`` holds and the encoder keeps the class's own network and heads (``owns_local``), else
        ``move_costs`` and ``head_inputs``.
        """
        a, b = (0, x.shape[-2]) if rows is None else rows
        if not (self.compiled_heads and self.owns_local() and x.dtype == torch.float32):
            f, costs = self.inference_costs(x, packed)
            return costs[:, :, a:b], self.head_inputs(f[:, :, a:b])
        f = (self.packed_local(x) if packed else self.local(x))[:, :, a:b].numpy()
        parts = [self.block_heads(one) for one in f]
        return (torch.from_numpy(batch_of([c for c, _ in parts])), torch.from_numpy(batch_of([p for _, p in parts])))

    def block_heads(self, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The move costs and the head's first layer of one query's local features ``f`` (C, h, w), compiled
        (``learning.models.local_net.block_heads`` on this encoder's weights).
        """
        w_cost, b_cost, w_pre, b_pre = self.local_arrays()[4:]
        return local_net.block_heads(f, self.channels, w_cost, b_cost, self.head_arrays()[0], WALL_LOG, w_pre, b_pre)

    def compiled_field(self, x: torch.Tensor, costs: torch.Tensor, pre: torch.Tensor,
                       steps: torch.Tensor | None = None, reuse: bool = False,
                       reach: Reach | None = None) -> torch.Tensor:
        """``cell_field`` of ``inference_values``, compiled: (B, H, W) on the CPU, from the learned ``costs``.

        Inference's walls gate the Dijkstra's moves (``move_cost_field``'s ``open_moves`` and ``most``) rather
        than being written into a copy of ``costs``, so the block values are ``inference_values``' bit for bit;
        the cell head runs compiled (``learning.models.cell_head``) from ``pre`` (``head_inputs``), the same
        values up to the rounding of another order of summation. Each query is one compiled call
        (``learning.models.vin_query.query_field``). ``steps``: ``cell_steps(x, block)`` where the caller has it
        already. ``reuse``: the field is written into the kept buffer ``"field"`` (``buffer``), which the next such
        pass overwrites, and the search keeps its working arrays for the next one (``search_work``). ``reach`` (a
        batch of one): where the learned walls shut every route from its start (the cell head read at the start
        alone; where a walk over the open moves finds the start's block unreached, from the walk alone), the search
        runs again without them (the step walls stay), as a pass inside ``open_walls`` would, and the cell head runs
        once, on those values (``reach.opened``).
        """
        return torch.from_numpy(self.query_fields(x.numpy(), costs.numpy(), pre.numpy(),
                                                  None if steps is None else steps.numpy(), reuse, reach))

    def query_fields(self, cells: np.ndarray, costs: np.ndarray, pre: np.ndarray, steps: np.ndarray | None = None,
                     reuse: bool = False, reach: Reach | None = None) -> np.ndarray:
        """``compiled_field`` on numpy arrays: ``route_input``'s channels (B, block**2 + 1, h, w), the learned
        ``costs``, ``pre`` and ``steps`` (``block_moves``; None: from ``cells``); (B, H, W) float32.
        """
        b = self.block
        n, _, h, w = costs.shape
        if reach is not None and n != 1:
            raise ValueError(f"a pass that checks a start's route takes one query, not {n}")
        if self.step_walls:
            gate = np.ascontiguousarray(block_moves(cells, b) if steps is None else steps)
        else:
            gate = np.ones(costs.shape, dtype=bool)
        c, p = np.ascontiguousarray(costs), np.ascontiguousarray(pre)
        field = (self.buffer("field", (n, h * b, w * b)).numpy() if reuse
                 else np.empty((n, h * b, w * b), dtype=np.float32))
        settings = self.query_settings(reach)
        work = self.search_work(h, w) if reuse else vin_query.NO_WORK
        for i in range(n):
            if vin_query.query_field(cells[i], b, c[i], p[i], gate[i], *settings, *work, field[i]):
                reach.opened = True
        return field

    def query_settings(self, reach: Reach | None) -> tuple:
        """What ``learning.models.vin_query`` reads besides a query's arrays: inference's learned walls (their caps
        and whether they apply), the cell head's weights on the block values and its last layer, ``REACH`` and
        ``UNREACHED`` in float32, and the start to check (``reach``; None: none).
        """
        lengths, w_rel, w_out, b_out = self.head_arrays()
        capped = self.wall_cost is not None
        most = np.float32(self.wall_cost) * lengths if capped else lengths
        check = reach is not None
        cell, scale, limit = (reach.cell, reach.scale, reach.limit) if check else ((0, 0), 1.0, 0.0)
        return (most, capped, w_rel, w_out, b_out, np.float32(REACH), np.float32(UNREACHED), check, cell[0], cell[1],
                float(scale), float(limit))

    def search_work(self, h: int, w: int) -> tuple[np.ndarray, ...]:
        """The compiled search's working arrays for an ``h`` x ``w`` block grid, kept for the next pass of the same
        shape (``keep_buffers``; ``work_array``).
        """
        n = (h + 2) * (w + 2)
        return tuple(work_array(self._work, name, shape, dtype) for name, shape, dtype in (
            ("incoming", (h * w, len(MOVES)), np.float32), ("dist", (n,), np.float32), ("state", (n,), np.int8),
            ("next", (n,), np.int32), ("previous", (n,), np.int32), ("where", (n,), np.int32),
            ("seen", (h * w,), np.uint8)))

    def window_field(self, cells: np.ndarray, parts: MapParts, window: tuple[int, int, int, int],
                     reach: Reach | None = None) -> np.ndarray:
        """``query_fields`` of ``window_parts`` patched into the map's kept ``parts`` (``kept_field``), in one
        compiled call (``learning.models.vin_query.window_field``): where the window runs compiled (``local_compiles``).
        The same values, bit for bit; ``parts`` are not written. ``cells``: the query's ``route_input`` channels (1,
        block**2 + 1, h, w); (1, H, W) float32.
        """
        h, w = cells.shape[-2:]
        b = self.block
        r0, r1, c0, c1 = self.window_region(cells, window)
        pads = (int(r0 == 0), int(r1 == h), int(c0 == 0), int(c1 == w))
        gate = parts.steps[0] if self.step_walls else np.ones((len(MOVES), h, w), dtype=bool)
        field = np.empty((1, h * b, w * b), dtype=np.float32)
        w0, b0, ws, bs, w_cost, b_cost, w_pre, b_pre = self.local_arrays()
        k0, k1, j0, j1 = window
        if vin_query.window_field(cells[0], b, (r0, r1, c0, c1), pads, (k0, k1, j0, j1), w0, b0, ws, bs,
                                  self.channels, w_cost, b_cost, self.head_arrays()[0], np.float32(WALL_LOG), w_pre,
                                  b_pre, parts.costs[0], parts.hidden[0], gate, *self.query_settings(reach),
                                  *vin_query.NO_WORK, field[0]):
            reach.opened = True
        return field

    def head_arrays(self) -> tuple[np.ndarray, ...]:
        """What the compiled search and cell head read of the weights, as numpy views made once (until
        ``weights_changed``): the moves' lengths, the cell head's weights on the block values, its last layer's
        weights and bias.
        """
        if "head" not in self._arrays:
            first, last = self.cells[0], self.cells[2]
            self._arrays["head"] = tuple(t.detach().numpy() for t in (
                self.lengths.view(-1), first.weight[:, self.channels:, 0, 0], last.weight[:, :, 0, 0], last.bias))
        return self._arrays["head"]

    def local_arrays(self) -> tuple[np.ndarray, ...]:
        """The local network and its two 1x1 heads as ``learning.models.local_net`` reads them, made once (until
        ``weights_changed``): the first 3x3 layer, the others stacked (``grouped``), the cost head's weights and bias,
        the cell head's first layer's weights on the features and its bias.
        """
        if "local" not in self._arrays:
            convs = [m for m in self.local if isinstance(m, nn.Conv2d)]
            w0, b0 = local_net.grouped(convs[0].weight.detach().numpy(), convs[0].bias.detach().numpy())
            rest = [local_net.grouped(m.weight.detach().numpy(), m.bias.detach().numpy(), len(w0)) for m in convs[1:]]
            ws = np.stack([w for w, _ in rest]) if rest else np.zeros((0, len(w0), len(w0), 3, 3), np.float32)
            bs = np.stack([b for _, b in rest]) if rest else np.zeros((0, len(w0)), np.float32)
            first = self.cells[0]
            self._arrays["local"] = (w0, b0, np.ascontiguousarray(ws), np.ascontiguousarray(bs),
                                     *(np.ascontiguousarray(t.detach().numpy(), dtype=np.float32) for t in (
                                         self.cost.weight[:, :, 0, 0], self.cost.bias,
                                         first.weight[:, :self.channels, 0, 0], first.bias)))
        return self._arrays["local"]

    def compiled_local(self, x: torch.Tensor, window: tuple[int, int, int, int] | None = None) -> bool:
        """Whether the compiled inference computes the local network and its heads over ``x`` (the map; over the region
        its ``window`` reads, where given) compiled (``learning.models.local_net``) rather than through torch: on
        float32 input, over a region of at most ``numba_local_blocks`` blocks, where the encoder keeps the class's own
        local network and heads.
        """
        return x.dtype == torch.float32 and self.compiled(x) and self.local_compiles(x, window)

    def local_compiles(self, x: torch.Tensor | np.ndarray, window: tuple[int, int, int, int] | None = None) -> bool:
        """``compiled_local`` of a pass already known to be compiled on float32 input: the region's size and the
        class's own local network and heads.
        """
        r0, r1, c0, c1 = self.window_region(x, window)
        return (r1 - r0) * (c1 - c0) <= self.numba_local_blocks and self.owns_local()

    def owns_local(self) -> bool:
        """Whether the encoder keeps the class's own local network and heads (``move_costs``, ``prices`` and
        ``head_inputs``; a subclass or an instance that overrides one keeps its own, through torch).
        """
        return all(getattr(getattr(self, name), "__func__", None) is getattr(RouteVIN, name)
                   for name in ("move_costs", "prices", "head_inputs"))

    def window_region(self, x: torch.Tensor, window: tuple[int, int, int, int] | None = None
                      ) -> tuple[int, int, int, int]:
        """The blocks (rows ``r0:r1``, columns ``c0:c1``) the local network reads for the blocks of ``window`` (the
        whole map where None): ``depth`` blocks beyond it, within the map.
        """
        h, w = x.shape[-2:]
        if window is None:
            return 0, h, 0, w
        k0, k1, j0, j1 = window
        d = self.depth
        return max(0, k0 - d), min(h, k1 + d), max(0, j0 - d), min(w, j1 + d)

    def local_parts(self, cells: np.ndarray, window: tuple[int, int, int, int] | None = None, reuse: bool = False
                    ) -> tuple[np.ndarray, np.ndarray]:
        """``map_features`` (``window`` None; ``reuse`` as it takes it) or ``window_parts`` of ``route_input``'s
        channels ``cells``, compiled (``local_compiles``), as numpy arrays.
        """
        h, w = cells.shape[-2:]
        k0, k1, j0, j1 = (0, h, 0, w) if window is None else window
        d = self.depth
        r0, r1, c0, c1 = self.window_region(cells, window)
        pads = (int(r0 == 0), int(r1 == h), int(c0 == 0), int(c1 == w))
        w0, b0, ws, bs = self.local_arrays()[:4]
        shapes = (len(cells), len(MOVES), k1 - k0, j1 - j0), (len(cells), self.channels, k1 - k0, j1 - j0)
        if reuse:
            costs, pre = self.buffer("costs", shapes[0]).numpy(), self.buffer("pre", shapes[1]).numpy()
        else:
            costs, pre = (np.empty(shape, dtype=np.float32) for shape in shapes)
        regions = cells[:, :, r0:r1, c0:c1]
        # where a side is not the map's edge the layers shrink the region by one block each: depth blocks in all
        r0, c0 = r0 + d * (1 - pads[0]), c0 + d * (1 - pads[2])
        for i, region in enumerate(regions):
            f = local_net.local_features(region, w0, b0, ws, bs, pads)[:, k0 - r0:k1 - r0, j0 - c0:j1 - c0]
            costs[i], pre[i] = self.block_heads(f)
        return costs, pre

    def map_key(self, x: torch.Tensor | np.ndarray) -> tuple:
        """The key of a map's kept parts: the input's shape, device and cells (not the goal).

        Cells of 0 and 1 only (``route_input``'s) are hashed as bits; any other values byte for byte. ``x``: a
        tensor, or a numpy array on the CPU.
        """
        numpy = isinstance(x, np.ndarray)
        cells, k = (x if numpy else x.cpu().numpy()), self.block * self.block
        flags = np.empty(len(cells) * k * cells.shape[-2] * cells.shape[-1], dtype=bool)
        data = np.packbits(flags) if vin_query.blocked_cells(cells, k, flags) else np.ascontiguousarray(cells[:, :k])
        digest = hashlib.blake2b(data.tobytes(), digest_size=16).digest()
        return tuple(x.shape), "cpu" if numpy else str(x.device), digest

    def keep_map(self, key: tuple, parts: MapParts) -> None:
        """Keep ``parts`` under ``key``, the most recently used last, within ``map_cache_bytes``."""
        self._maps.put(key, parts, self.map_cache_bytes)

    def _keep_or_hold(self, key: tuple, parts: MapParts, keep: bool) -> None:
        """A whole pass's parts: kept (``keep``: the map was queried before), else held as the recent map's."""
        if keep:
            self.keep_map(key, parts)
        else:
            self._maps.hold(key, parts, self.map_cache_bytes)

    def window_parts(self, cells: np.ndarray, window: tuple[int, int, int, int], compiled: bool
                     ) -> tuple[np.ndarray, np.ndarray]:
        """The move costs and the head's first layer over the blocks of ``window`` only, from ``route_input``'s
        channels ``cells``, as numpy arrays: compiled where the pass is and the window's region runs compiled
        (``local_compiles``), else through torch (``local_window``).
        """
        if compiled and self.local_compiles(cells, window):
            return self.local_parts(cells, window)
        f = self.local_window(torch.from_numpy(cells), window)
        return self.prices(f).numpy(), self.head_inputs(f).numpy()

    def goal_block(self, x: torch.Tensor | np.ndarray) -> tuple[int, int] | None:
        """The block (row, column) the goal's channel marks; None unless it marks exactly one (``x``: a tensor, or a
        numpy array).
        """
        at = vin_query.single_mark((x if isinstance(x, np.ndarray) else x.cpu().numpy())[0, self.block * self.block])
        return divmod(int(at), x.shape[-1]) if at >= 0 else None

    def goal_window(self, x: torch.Tensor, block: tuple[int, int]) -> tuple[int, int, int, int]:
        """The blocks whose features a goal in ``block`` (``goal_block(x)``) reaches: within ``depth`` of it."""
        h, w = x.shape[-2:]
        gr, gc = block
        d = self.depth
        return max(0, gr - d), min(h, gr + d + 1), max(0, gc - d), min(w, gc + d + 1)

    def local_window(self, x: torch.Tensor, window: tuple[int, int, int, int]) -> torch.Tensor:
        """``self.local(x)`` over the blocks of ``window`` (rows ``k0:k1``, columns ``j0:j1``) only.

        Each 3x3 layer runs unpadded over the region it must hand the next one, one block wider on every side that
        is not the map's edge (where the layer pads with zeros as over the whole map): the same values as the whole
        pass there, up to floating-point rounding, at the cost of the window and its ``depth``-block margin. Where
        the whole pass runs prepacked (``packs``), the region runs through the same prepacked layers, each padded by
        one as over the whole map: the zeros at a side that is not the map's edge reach ``depth`` blocks in after the
        last layer, the margin, so the window's features are what the whole pass computes.
        """
        h, w = x.shape[-2:]
        k0, k1, j0, j1 = window
        r0, r1, c0, c1 = self.window_region(x, window)
        y = x[:, :, r0:r1, c0:c1]
        if self.compiled(x) and self.packs(x):
            return self.packed_local(y)[:, :, k0 - r0:k1 - r0, j0 - c0:j1 - c0]
        for layer in self.local:
            if isinstance(layer, nn.Conv2d):
                # pad by one where this side of the region is the map's edge; elsewhere the region shrinks by one
                y = nn.functional.conv2d(nn.functional.pad(y, (int(c0 == 0), int(c1 == w), int(r0 == 0), int(r1 == h))),
                                         layer.weight, layer.bias)
                r0, r1, c0, c1 = r0 + (r0 > 0), r1 - (r1 < h), c0 + (c0 > 0), c1 - (c1 < w)
            else:
                y = layer(y)
        return y[:, :, k0 - r0:k1 - r0, j0 - c0:j1 - c0]

    def reusing_field(self, x: torch.Tensor, reach: Reach | None = None) -> torch.Tensor:
        """``forward`` of one query (``x``: (1, block**2 + 1, h, w)) over its map's kept parts (``MapParts``).

        The goal's channel reaches the local features of the blocks within ``depth`` blocks of the goal's block
        only (each 3x3 layer one block further), so those are computed again, from the input within ``2 * depth``
        blocks (where a crop's edge is not the map's, its zero padding reaches ``depth - 1`` blocks in; the kept
        window is ``depth`` blocks in), and the map's parts serve every other block. The first query on a map takes one
        whole pass, its parts held with its goal in them as the recent map's (``KeptMaps``); a later query finds them
        there or kept (or, where another map's first query took their place, takes a whole pass whose parts are kept),
        computes the held goal's window again without its goal, and puts in its own. The same values as one whole pass
        up to floating-point rounding. The same goal again (a ``predict`` inside ``open_walls``)
        reads the parts as they are: the whole pass's values (bit for bit on the compiled inference). A query whose goal
        channel marks other than one block takes the whole pass. ``reach``: as ``compiled_field`` takes it (the
        compiled inference only).
        """
        compiled = self.compiled(x)
        if reach is not None and not compiled:
            raise ValueError("a pass that checks a start's route runs compiled (RouteVIN.compiled)")
        return torch.from_numpy(self.kept_field(x.numpy(), reach, compiled))

    def kept_field(self, cells: np.ndarray, reach: Reach | None = None, compiled: bool = True) -> np.ndarray:
        """``reusing_field`` of ``route_input``'s channels ``cells`` (1, block**2 + 1, h, w) on the CPU, as numpy:
        (1, H, W) float32. ``compiled``: whether the pass is the compiled inference (``compiled``); a compiled pass over
        a map whose local network runs compiled (``local_compiles``) makes no torch call. ``reach``: compiled only.
        """
        b = self.block
        block = self.goal_block(cells)
        if block is None:
            if not compiled:
                return self.forward(torch.from_numpy(cells)).numpy()
            return self.query_fields(cells, *self.whole_parts(cells), reach=reach)
        window = self.goal_window(cells, block)
        key = self.map_key(cells)
        parts = self._maps.pop(key)
        if parts is None:  # one whole pass; its parts, with this goal in them, kept or held as the recent map's
            keep = self._maps.seen_before(key)
            if compiled:
                parts = MapParts(*self.whole_parts(cells), block_moves(cells, b), window, block)
                self._keep_or_hold(key, parts, keep)
                return self.query_fields(cells, parts.costs, parts.hidden, parts.steps, reach=reach)
            x = torch.from_numpy(cells)
            f, costs = self.move_costs(x)
            parts = MapParts(costs.numpy(), self.head_inputs(f).numpy(), block_moves(cells, b), window, block)
            self._keep_or_hold(key, parts, keep)
            steps = torch.from_numpy(parts.steps)
            return self.cell_field(f, self.inference_values(x, costs, *self.goal_and_walls(x), steps)).numpy()
        if parts.goal_window is not None and parts.goal_block == block:
            # the parts hold this very goal (the same query again, as a pass without the learned walls asks it): the
            # whole pass's own parts, read as they are (nothing here writes into them)
            self.keep_map(key, parts)
            return self.parts_field(cells, parts.costs, parts.hidden, parts.steps, reach, compiled)
        if parts.goal_window is not None:  # the first goal's window, without a goal, once
            free = cells.copy()
            free[:, b * b] = 0.0
            costs, hidden = self.window_parts(free, parts.goal_window, compiled)
            parts = MapParts(_patched(parts.costs, parts.goal_window, costs),
                             _patched(parts.hidden, parts.goal_window, hidden), parts.steps)
        self.keep_map(key, parts)
        if compiled and self.local_compiles(cells, window):
            return self.window_field(cells, parts, window, reach)
        costs, pre = self.window_parts(cells, window, compiled)
        return self.parts_field(cells, _patched(parts.costs, window, costs), _patched(parts.hidden, window, pre),
                                parts.steps, reach, compiled)

    def whole_parts(self, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``map_features`` of ``route_input``'s channels ``cells`` as numpy arrays, on a compiled pass: compiled where
        the map's local network is (``local_compiles``), else through torch.
        """
        if self.local_compiles(cells):
            return self.local_parts(cells)
        return tuple(t.numpy() for t in self.map_features(torch.from_numpy(cells)))

    def parts_field(self, cells: np.ndarray, costs: np.ndarray, pre: np.ndarray, steps: np.ndarray,
                    reach: Reach | None = None, compiled: bool = True) -> np.ndarray:
        """The field of the query ``cells`` from its map's learned ``costs``, the cell head's first layer ``pre`` and
        the ``steps`` (``kept_field``), none of them written into: ``query_fields`` where ``compiled``, else through
        torch.
        """
        if compiled:
            return self.query_fields(cells, costs, pre, steps, reach=reach)
        x, pre = torch.from_numpy(cells), torch.from_numpy(pre)
        v = self.inference_values(x, torch.from_numpy(costs), *self.goal_and_walls(x), torch.from_numpy(steps))
        # the cell head's 1x1 layers as matrix products over the blocks (cheaper than convolutions this thin)
        h, w = x.shape[-2:]
        first, last = self.cells[0], self.cells[2]
        rel = (neighbours(v, UNREACHED) - v.unsqueeze(1)).clamp(-REACH, REACH)
        hidden = torch.addmm(pre[0].reshape(self.channels, -1), first.weight[:, self.channels:, 0, 0],
                             rel[0].reshape(len(MOVES), -1)).relu_()
        offsets = torch.addmm(last.bias[:, None], last.weight[:, :, 0, 0], hidden).view(1, -1, h, w)
        return nn.functional.pixel_shuffle(v.unsqueeze(1) + offsets, self.block)[:, 0].numpy()

    def infer(self, x: torch.Tensor, reach: Reach | None = None) -> torch.Tensor:
        """``forward`` at inference (``FieldEncoder.predict``): on the CPU, over each map's kept parts where they fit.

        Each query of the batch takes ``reusing_field`` on the CPU when ``map_cache_bytes`` allows it and its map
        runs in one piece; otherwise, and on a GPU (where one batched pass costs little more than one query), the
        whole batch takes ``forward``, into the kept buffers where the pass is compiled and ``keep_buffers`` holds:
        then the result is the buffer ``"field"``, which the next such pass overwrites (``predict`` copies it).
        ``reach``: a query's start, as ``compiled_field`` takes it (one query, on the compiled inference).
        """
        h, w = x.shape[-2:]
        if x.device.type != "cpu" or self.map_cache_bytes <= 0 or self.strip_rows(h, w) < h:
            x = x[:, :self.block * self.block + 1]
            if self.compiled(x) and (self.keep_buffers or reach is not None):
                reuse = self.keep_buffers
                return self.compiled_field(x, *self.map_features(x, reuse=reuse), reuse=reuse, reach=reach)
            if reach is not None:
                raise ValueError("a pass that checks a start's route runs compiled (RouteVIN.compiled)")
            return self(x)
        with torch.no_grad():
            x = x[:, :self.block * self.block + 1]
            if reach is not None:
                return self.reusing_field(x, reach)
            return torch.cat([self.reusing_field(x[i:i + 1]) for i in range(x.shape[0])])

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """The cost-to-go of every cell (B, H, W), in blocks, from ``route_input``'s channels.

        A block grid above ``strip_blocks`` blocks runs its convolutions in strips of rows at inference: each
        strip reads the ``depth`` rows beyond it that its layers see, so every kept row is what one pass over
        the whole map computes (up to the rounding of another shape), and a pass holds one strip's activations
        rather than the whole map's. The local features are computed twice there (for the move costs, then for
        the cell head), which costs time for a bounded memory.
        """
        x = x[:, :self.block * self.block + 1]  # the cells and the goal's block; not the offsets to it
        goal, walls = self.goal_and_walls(x)
        h, w = x.shape[-2:]
        rows = self.strip_rows(h, w)
        if self.compiled(x):
            return self.compiled_field(x, *self.map_features(x))
        if rows >= h:
            f, costs = self.move_costs(x)
            return self.cell_field(f, self.inference_values(x, costs, goal, walls))
        if torch.is_grad_enabled():
            raise ValueError(f"a {h} x {w} block grid runs in strips, at inference only (torch.no_grad): "
                             f"train on maps of at most {self.strip_blocks} blocks")
        d, b = self.depth, self.block
        parts = []
        for r0 in range(0, h, rows):
            r1 = min(h, r0 + rows)
            lo, hi = max(0, r0 - d), min(h, r1 + d)
            parts.append(self.move_costs(x[:, :, lo:hi])[1][:, :, r0 - lo:r1 - lo])
        v = self.inference_values(x, torch.cat(parts, 2), goal, walls)
        del parts
        out = torch.empty(x.shape[0], h * b, w * b, dtype=v.dtype, device=v.device)
        for r0 in range(0, h, rows):
            r1 = min(h, r0 + rows)
            a, z = max(0, r0 - 1), min(h, r1 + 1)  # the cell head reads the values one block row either side
            lo, hi = max(0, a - d), min(h, z + d)
            f = self.move_costs(x[:, :, lo:hi])[0][:, :, a - lo:z - lo]
            out[:, r0 * b:r1 * b] = self.cell_field(f, v[:, a:z])[:, (r0 - a) * b:(r1 - a) * b]
        return out
