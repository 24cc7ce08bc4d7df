"""``PolicySampler``: a trained sampler policy as a planner ``Sampler``, outside any environment.

    sampler = PolicySampler.load()  # the shipped policy
    RRT(problem, step_size=4.0, sampler=sampler, seed=0).solve(max_iterations=20000)

One forward pass of the policy (compiled, see ``learning.models.fast_policy``) yields a distribution over
the guided actions; ``batch`` samples are drawn from it at once and handed to the planner. Egocentric
samples are offsets resolved against the tree's progress vertex when used, so the batch follows the
tree. The distribution is reused for further batches while the progress vertex stays the same and
fewer than ``reuse`` iterations have passed since the forward pass, the stretches in which the
observation's decisive parts (the windows around that vertex) barely change; a distribution that
puts at least ``hold`` of its mass on the frontier is kept until the progress vertex moves. That
is the policy's answer to a tree stuck behind a wall, and it does not change while the tree stays
stuck (the expert it imitates labels every such state "frontier"), so the passes it would take
every ``reuse`` iterations there are skipped (a third to six sevenths of all passes on the
generated families other than forest, where trees rarely stick; on 400 validation runs not one
iteration count changed). A ``uniform_floor``
share of samples is uniform: probabilistic completeness is kept. When the tree has made no progress
towards the goal for ``patience`` iterations the uniform share grows with the time stuck (up to
``max_floor``): a tree pinned against a wall by its own biased samples gets RRT's Voronoi bias back,
which cuts the heavy tail of failures on narrow passages without changing the medians. The policy
sees only its observation: the map, the tree, start and goal.

A whole draw (observation update, forward pass, class and sample draws) is one compiled call,
``policy_draw``. With ``RRT`` the sampler goes further and fuses it into the planner's loop
(``Sampler.fuse``): a solve then never returns to Python between batches, which is what makes the
learned sampler cheaper per solve than goal bias. The fused loop draws exactly what ``draw`` would,
from the same generator, so results do not depend on which path ran.
"""

from __future__ import annotations

import os
from typing import NamedTuple

import numba as nb
import numpy as np

from learning.models.checkpoint import read_sb3_zip
from learning.models.fast_policy import FastActor, actor_logits, softmax_cdf
from learning.models.shipped import SHIPPED_POLICY, SHIPPED_POLICY_BATCH
from learning.samplers.route import require_grid
from planners import SampleBatch, SamplerBase
from planners.base.fileio import InputError, check_number
from planners.base.planner import Planner
from planners.base.samplers import check_sampler_params
from planners.fused import CHUNK, FusedRRT, fuse_rrt, growing_floor, next_double, rng_address, rrt_loop
from planners.guidance.egocentric import EGO_VECTOR, add_vertices, build_pyramid, observe_windows
from planners.guidance.frontier import cdf_search, frontier_arrays, frontier_shape
from planners.guidance.guided import FRONTIER, FRONTIER_TAU, N_ACTIONS, SCALES, WINDOW, fill_from_cdf, scale_cells

#: Keys of the training config a checkpoint must carry.
CONFIG_KEYS = ("step_size", "uniform_floor", "batch", "obs_version")
OBS_VERSION = 1

class DrawState(NamedTuple):
    """The bound sampler's mutable state: counters (``S_*`` slots), floats, the last forward pass, scratch."""

    ints: np.ndarray  # S_* slots below
    floats: np.ndarray  # best goal distance seen, total of the class CDF, the frontier class's share of it
    logits: np.ndarray  # last forward pass: class logits
    cdf: np.ndarray  # and their CDF
    local: np.ndarray  # last observation: egocentric windows
    vector: np.ndarray  # and vector features
    u: np.ndarray  # uniforms of one batch
    fcdf: np.ndarray  # frontier CDF scratch


class PolicyKernel(NamedTuple):
    """Everything ``policy_draw`` reads, as one struct (see ``PolicySampler._setup``)."""

    ego: tuple  # pyramid levels, layout, window size, resolution, grid origin, start, goal
    frontier: tuple  # world, frontier arrays, cell size, goal preference
    actor: tuple  # weights, scratch
    params: tuple  # step, temperature, floors, patience, reuse, hold, max iterations, sampling box
    state: DrawState


# slots of the sampler's integer state
S_SEEN = 0  # vertices already counted into the observation's tree pyramid
S_PROGRESS = 1  # iteration at which the progress vertex last came closer to the goal
S_ANCHOR = 2  # progress vertex of the last forward pass
S_SINCE = 3  # iteration of the last forward pass
S_FORWARD = 4  # forward passes so far
S_FSEEN = 5  # vertices already added to the frontier
S_FRONT = 6  # frontier cells
N_STATE = 7
#: The smallest step a checkpoint's config may carry, in world units: a step that small would need
#: millions of iterations on any map and windows of millions of cells (the map's cell is the judge of
#: a step, and no reader map's cell is this small).
MIN_STEP = 1e-3
#: Softmax temperature of the action distribution: the policy's own (1), as trained.
TEMPERATURE = 1.0


@nb.njit(cache=True)
def sample_classes(logits, temperature, u):
    """Indices drawn from softmax(logits / temperature) by inverse CDF, one per uniform in ``u``."""
    cdf = np.empty(logits.shape[0])
    acc = softmax_cdf(logits, temperature, cdf)
    out = np.empty(u.shape[0], dtype=np.int64)
    for k in range(u.shape[0]):
        out[k] = cdf_search(cdf, logits.shape[0], u[k] * acc)
    return out


@nb.njit(cache=True)
def policy_draw(kernel_state, X, n, best_v, best_d, iteration, rng, pts, anch):
    """Run the policy if due and draw ``len(pts)`` samples from its action distribution into ``pts``/``anch``.

    The draw of ``planners.fused``'s contract: ``rng`` is the address of the planner's generator
    (``planners.fused.rng_address``), ``kernel_state`` the sampler's compiled state (see
    ``PolicySampler._setup``). The tree enters as its vertices ``X[:n]``, progress vertex and
    distance. The observation's tree counts are brought up to date only for a forward pass, the
    frontier only for a frontier sample.
    """
    ego, front, actor, params, state = kernel_state
    levels_obs, levels_tree, layout, size, res, origin, start, goal = ego
    weights, scratch = actor
    step, temperature, floor0, max_floor, patience, reuse, hold, max_iterations, low, high = params
    sampler_ints, sampler_floats, logits, cdf, local, vector, u, fcdf = state
    m = pts.shape[0]
    if best_d < sampler_floats[0] - 1e-9:
        sampler_floats[0] = best_d
        sampler_ints[S_PROGRESS] = iteration
    if (sampler_ints[S_FORWARD] == 0 or best_v != sampler_ints[S_ANCHOR]
            or (iteration - sampler_ints[S_SINCE] >= reuse and sampler_floats[2] < hold)):
        if n > sampler_ints[S_SEEN]:
            add_vertices(levels_tree, layout, X[sampler_ints[S_SEEN]:n], res, origin)
            sampler_ints[S_SEEN] = n
        observe_windows(levels_obs, levels_tree, layout, size, res, origin, step, X[best_v, :2], best_v == 0, start,
                        goal, n, iteration, sampler_ints[S_PROGRESS], max_iterations, local, vector)
        actor_logits(local, vector, *weights, scratch, logits)
        sampler_floats[1] = softmax_cdf(logits, temperature, cdf)  # one softmax per forward pass, not per batch
        sampler_floats[2] = (cdf[FRONTIER] - cdf[FRONTIER - 1]) / sampler_floats[1]  # the frontier's share
        sampler_ints[S_ANCHOR] = best_v
        sampler_ints[S_SINCE] = iteration
        sampler_ints[S_FORWARD] += 1
    floor = growing_floor(floor0, max_floor, patience, iteration - sampler_ints[S_PROGRESS])
    for k in range(m):  # row by row, as Generator.random((m, 6)) fills
        for j in range(6):
            u[k, j] = next_double(rng)
    fill_from_cdf(cdf, sampler_floats[1], u[:m], low, high, step, floor, front, sampler_ints[S_FSEEN:S_FRONT + 1], X,
                  n, fcdf, pts, anch)


@nb.njit(cache=True)
def policy_rrt_loop(budget, kernel_state, buffers, rng, loop):
    """RRT's compiled loop drawing from ``policy_draw`` (``planners.fused``)."""
    return rrt_loop(budget, policy_draw, kernel_state, buffers, rng, loop)


@nb.njit(cache=True)
def _new_state(obstacles, factors, H, W, n_scratch, batch):
    """All arrays of a bound sampler in one compiled call: pyramid, frontier, draw state, actor scratch."""
    layout, levels_obs, levels_tree = build_pyramid(obstacles, factors)
    counts, free, cov, pos, front, dist = frontier_arrays(obstacles, H, W)
    sampler_floats = np.empty(3)
    sampler_floats[0] = np.inf  # best goal distance seen
    sampler_floats[1] = 0.0  # total of the class CDF
    sampler_floats[2] = 0.0  # the frontier class's share of it
    return (layout, levels_obs, levels_tree, counts, free, cov, pos, front, dist, np.zeros(N_STATE, dtype=np.int64),
            sampler_floats, np.empty(N_ACTIONS), np.empty(N_ACTIONS), np.empty((2 * factors.shape[0], WINDOW,
                                                                                WINDOW), np.uint8),
            np.empty(len(EGO_VECTOR), np.float32), np.empty(n_scratch, np.float32), np.empty((batch, 6)),
            np.empty(H * W))


def check_config(config, source: str = "policy config") -> dict:
    """The sampler part of a training config, every value checked; ``InputError`` naming ``source`` if not."""
    if not isinstance(config, dict):
        raise InputError(f"{source}: the SamplerGym config is a {type(config).__name__}, expected an object")
    missing = [k for k in CONFIG_KEYS if k not in config]
    if missing:
        raise InputError(f"{source}: the SamplerGym config lacks {missing}")
    if config["obs_version"] != OBS_VERSION:
        raise InputError(f"{source}: obs_version = {config['obs_version']!r}: the policy was trained on another "
                         f"observation, this SamplerGym builds version {OBS_VERSION}")
    out = dict(config)
    out["step_size"] = check_number(source, "step_size", config["step_size"], low=MIN_STEP)
    out["uniform_floor"] = check_number(source, "uniform_floor", config["uniform_floor"], low=0.0, high=1.0)
    out["batch"] = check_number(source, "batch", config["batch"], integer=True, low=1, high=CHUNK)
    out["max_iterations"] = check_number(source, "max_iterations", config.get("max_iterations", 20000),
                                         integer=True, low=1)
    return out


class PolicySampler(SamplerBase):
    """A learned sampler for ``OccupancyGrid`` problems of any size.

    Args:
        actor: The compiled actor (from ``load``).
        config: Training config (``step_size``, ``uniform_floor``, ``batch``, ...).
        step_size: The planner's step in world units; default: the training step.
        batch: Samples per batch; default: the training batch.
        reuse: Longest stretch of iterations one forward pass may serve (1: a pass per batch).
        hold: Frontier share at or above which a pass serves until the progress vertex moves (> 1: never).
        patience: Iterations without progress after which the uniform share starts to grow.
        max_floor: The largest uniform share that growth reaches. It matters only for trees stuck for
            thousands of iterations (large MovingAI maps), and trades one map for another there:
            ``scripts/experiments/tune_stuck_floor.py`` and the README have the figures.
        fuse: Run inside RRT's compiled loop (same samples, less time); False keeps ``draw`` calls.
        source: Where ``config`` and ``actor`` came from, for error messages.
    """

    def __init__(self, actor: FastActor, config: dict, *, step_size: float | None = None, batch: int | None = None,
                 reuse: int = 32, hold: float = 0.9, patience: int = 200,
                 max_floor: float = 0.5, fuse: bool = True, source: str = "policy config") -> None:
        config = check_config(config, source)
        problem = actor.check_input(2 * len(SCALES), WINDOW, len(EGO_VECTOR), N_ACTIONS)
        if problem:
            raise InputError(f"{source}: {problem}")
        self.actor, self.config = actor, dict(config)
        check_sampler_params("PolicySampler", step_size=step_size, batch=batch)
        self.step_size = float(step_size if step_size is not None else config["step_size"])
        self.batch = int(batch if batch is not None else config["batch"])
        self.reuse = int(reuse)
        self.hold = float(hold)
        self.patience, self.max_floor = int(patience), float(max_floor)
        self.fused = bool(fuse)
        if not (self.step_size > 0 and self.batch >= 1 and self.reuse >= 1 and self.hold > 0 and self.patience >= 1
                and 0.0 <= self.max_floor <= 1.0):
            raise InputError(f"need step_size, batch, reuse, hold, patience > 0 and 0 <= max_floor <= 1, "
                             f"got {self.step_size}, {self.batch}, {self.reuse}, {self.hold}, "
                             f"{self.patience}, {self.max_floor}")
        # per-query constants, prepared once: a bind runs on every query
        self._params = (self.step_size, TEMPERATURE, float(self.config["uniform_floor"]), self.max_floor,
                        self.patience, self.reuse, self.hold, int(self.config["max_iterations"]))
        self._n_scratch = actor.scratch_size(2 * len(SCALES), WINDOW)
        self._geometry: dict = {}  # (resolution, map shape) -> (cells per pixel per scale, frontier rows, columns)
        self._kernel = None

    @classmethod
    def load(cls, path: str | os.PathLike | None = None, **kwargs) -> PolicySampler:
        """Load a checkpoint written by ``scripts/train.py`` (an SB3 zip carrying the SamplerGym config).

        Without ``path``, the shipped policy at the batch it was validated at (``SHIPPED_POLICY_BATCH``
        unless ``batch`` is given); with a path, the checkpoint's own settings unless overridden.

        Safe for files from anyone: only JSON and tensors are read (``learning.models.checkpoint``), nothing
        in the file is unpickled. Every problem with the file is an ``InputError`` naming it.
        """
        if path is None:
            path = SHIPPED_POLICY
            kwargs.setdefault("batch", SHIPPED_POLICY_BATCH)
        data, state = read_sb3_zip(path)
        config = data.get("samplergym_config")
        if not isinstance(config, dict):
            raise InputError(f"{path} is a Stable-Baselines3 model without a SamplerGym config: "
                             "was it trained by scripts/train.py?")
        try:
            actor = FastActor(state)
        except ValueError as exc:
            raise InputError(f"{path}: {exc}") from None
        return cls(actor, config, source=str(path), **kwargs)

    @property
    def forward_passes(self) -> int:
        """Forward passes since the sampler was bound."""
        return 0 if self._kernel is None else int(self._kernel.state.ints[S_FORWARD])

    def last_observation(self) -> dict[str, np.ndarray] | None:
        """What the policy saw at its last forward pass (``local`` windows, ``vector``), copied; None before one."""
        if self._kernel is None or self.forward_passes == 0:
            return None
        return {"local": self._kernel.state.local.copy(), "vector": self._kernel.state.vector.copy()}

    def _setup(self) -> None:
        # the guided geometry of planners.guidance.guided.GuidedSampling (the training environment's), built
        # without its objects: a bind is paid on every query, and built in Python it cost about a
        # tenth of a bugtrap query
        grid = require_grid("PolicySampler", self.problem.world)
        key = (grid.resolution, grid.shape)
        geometry = self._geometry.get(key)
        if geometry is None:  # shared with the other copies bound from the same sampler
            factors = np.array(scale_cells(self.step_size, grid.resolution), dtype=np.int64)
            geometry = self._geometry[key] = (factors, *frontier_shape(grid, self.step_size))
        factors, H, W = geometry
        (layout, levels_obs, levels_tree, counts, free, cov, pos, front, dist, sampler_ints, sampler_floats, logits,
         cdf, local, vector,
         scratch, u, fcdf) = _new_state(grid.kernel.grid, factors, H, W, self._n_scratch, self.batch)
        start = np.ascontiguousarray(self.problem.start[:2], dtype=np.float64)
        goal = np.ascontiguousarray(self.problem.goal[:2], dtype=np.float64)
        self._kernel = PolicyKernel(
            (levels_obs, levels_tree, layout, WINDOW, grid.resolution,
             np.ascontiguousarray(grid.origin, dtype=np.float64), start, goal),
            (grid.kernel, counts, self.step_size, W, goal, free, cov, pos, front, dist, FRONTIER_TAU),
            (self.actor.weights, scratch),
            (*self._params, self.low, self.high),
            DrawState(sampler_ints, sampler_floats, logits, cdf, local, vector, u, fcdf),
        )

    def draw(self, rng, n, view):
        m = min(n, self.batch)
        pts = np.empty((m, 2))
        anch = np.empty(m, dtype=np.int8)
        policy_draw(self._kernel, view.vertices, view.num_vertices, view.best_vertex, view.best_distance,
                    view.iteration, rng_address(rng), pts, anch)
        return SampleBatch(pts, anch)

    def fuse(self, planner: Planner) -> FusedRRT | None:
        """The planner's loop with this sampler's draws compiled in, for RRT; None for other planners."""
        return fuse_rrt(planner, policy_rrt_loop, self._kernel, self.batch) if self.fused else None

    def __repr__(self) -> str:
        return f"PolicySampler(step_size={self.step_size:g}, batch={self.batch})"
