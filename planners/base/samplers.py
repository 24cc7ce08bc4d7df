"""The one ``Sampler`` protocol every planner calls, and the classic samplers.

A sampler is a configuration object; a planner calls ``sampler.bind(problem)`` once and gets a
bound copy it owns (so one ``GoalBiasedSampler(0.05)`` can serve many planners). The planner then
calls ``draw(rng, n, view)`` whenever it needs samples:

* it returns 1..n samples, as an ``(m, dim)`` array or a ``SampleBatch``;
* one sample consumed is one planner iteration;
* samples that do not depend on the tree can be returned ``n`` at a time, so the compiled loop runs
  uninterrupted; tree-dependent samplers read ``view`` and may return fewer;
* a ``SampleBatch`` can mark samples as *anchored*: offsets from the tree vertex nearest the goal,
  in the world frame (``ANCHOR_WORLD``) or in the frame pointing from that vertex to the goal
  (``ANCHOR_GOAL``), resolved by the planner when the sample is used, so a batch keeps following the
  tree's progress; and it can say how many raw candidates each sample cost (for samplers that
  discard candidates).

A sampler whose draws are compiled may also define ``fuse(planner)``. A planner whose class names a
``fusable_loop`` (RRT's is ``"rrt"``, RRT-Connect's ``"connect"``, RRT*'s ``"rrtstar"``, up to its first solution)
calls it once per (re)start; it returns None, or a callable ``run(planner, n) -> used`` that runs up to ``n``
iterations with the sampler's draws inside the compiled loop, so a solve never returns to Python between batches.
``planners.fused`` is the way to build one: the sampler gives a compiled draw function and
``planners.fused.fuse_rrt`` (``fuse_connect``, ``fuse_rrtstar``) returns the ``run``, with the planner's refill
schedule and generator stream kept. The planner is passed at each call
rather than held by ``run``, so a planner and its loop form no reference cycle and are freed as soon as they go
out of scope. A fused loop must draw exactly what ``draw`` would: it changes the speed, never the run.

A sampler that measures in the planner's step (how far ahead it aims, what a map cell is worth) may also define
``at_step(step_size) -> Sampler``: the same sampler at that step. A planner of the RRT family (its step is
``step_size``) calls it with its own step before binding, so the step belongs to the planner and a user passes
it once, there.

A sampler whose rule depends on how the planner uses its samples may also define ``for_planner(family) ->
Sampler``: the sampler to bind for a planner of that family (``Planner.family``, one of ``PLANNER_FAMILIES``).
Every planner calls it, after ``at_step``, before binding, so one sampler object serves every planner and a user
never picks a per-planner variant. The families:

* ``"tree"`` (RRT): one tree grows from the start; samples pull it.
* ``"bidirectional"`` (RRT-Connect): two trees take turns; each draw is for one of them, and ``TreeView.tree``
  says which (``TREE_START`` or ``TREE_GOAL``), ``TreeView.goal_tree`` holds the goal tree's states. A sampler
  that reads them returns one sample per draw (a batch would span both trees' turns).
* ``"roadmap"`` (PRM, Lazy-PRM, OB-PRM): samples become roadmap vertices wherever they are free; no tree to follow.
* ``"optimizing"`` (RRT*, Informed RRT*): one tree, and after the first solution the samples should shorten it
  (``TreeView.best_cost``).

A family a sampler does not know should get its plain rule back (``for_planner`` returns ``self``).

A sampler whose samples must lie within a roadmap edge of each other (a chain of samples along a route) may also
define ``at_edge(length) -> Sampler``: the same sampler for a roadmap whose edges are at most ``length`` long (None:
no limit). A roadmap planner calls it, after ``for_planner``, before binding, with ``Planner.edge_limit``.
"""

from __future__ import annotations

import math
import numbers
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple, Protocol, runtime_checkable

import numpy as np

if TYPE_CHECKING:
    from planners.base.planner import TreeView
    from planners.base.problem import Problem


#: ``Planner.family`` values, told to a sampler's ``for_planner`` (see the module docstring).
FAMILY_TREE = "tree"
FAMILY_BIDIRECTIONAL = "bidirectional"
FAMILY_ROADMAP = "roadmap"
FAMILY_OPTIMIZING = "optimizing"
PLANNER_FAMILIES = (FAMILY_TREE, FAMILY_BIDIRECTIONAL, FAMILY_ROADMAP, FAMILY_OPTIMIZING)
#: ``TreeView.tree``: the tree the next sample extends.
TREE_START = 0
TREE_GOAL = 1

ANCHOR_NONE = 0
ANCHOR_WORLD = 1
ANCHOR_GOAL = 2

#: Most samples per decision a sampler's ``batch`` may ask for (the shipped policy takes 1 to 8).
MAX_BATCH = 4096
#: A sampler's ``step_size`` is at most this many times the diagonal of the map it is bound to:
#: samplers size their rings, windows and frontier grids in steps, and a step past the map's own
#: size has nothing left to measure (``inf`` or ``1e9`` would overflow or exhaust memory instead).
MAX_STEP_DIAGONALS = 4.0


def check_sampler_params(who: str, *, step_size=None, batch=None) -> None:
    """Refuse a sampler's ``step_size`` (a finite positive number) or ``batch`` (1..``MAX_BATCH``) by name.

    Raises:
        InputError: Naming ``who`` (the sampler), the parameter, its value and what is accepted.
    """
    from planners.base.fileio import InputError, check_number, short_repr

    if step_size is not None:
        check_number(who, "step_size", step_size, low=0, low_open=True)
    if batch is not None:
        if isinstance(batch, bool) or not isinstance(batch, (int, np.integer)) or not 1 <= batch <= MAX_BATCH:
            raise InputError(f"{who}: batch = {short_repr(batch)}, expected an integer from 1 to {MAX_BATCH}")


def _check_step_on_map(sampler, step, low: np.ndarray, high: np.ndarray) -> None:
    """Refuse a sampler's ``step_size`` that is not finite and positive, or longer than ``MAX_STEP_DIAGONALS`` maps."""
    diag = math.hypot(*(high - low))  # numpy's norm costs three times as much, on every bind
    if isinstance(step, bool) or not isinstance(step, numbers.Real) or not 0 < step <= MAX_STEP_DIAGONALS * diag:
        from planners.base.fileio import InputError

        raise InputError(f"{type(sampler).__name__}: step_size = {step!r} on a map whose diagonal is {diag:g} world "
                         f"units; expected a positive number of at most {MAX_STEP_DIAGONALS:g} times it")


@dataclass(frozen=True)
class SampleBatch:
    """Samples with optional per-sample flags.

    Attributes:
        points: (m, dim) states, or offsets where ``anchored`` is non-zero.
        anchored: (m,) int codes or bools, or None: ``ANCHOR_NONE`` (0, absolute), ``ANCHOR_WORLD``
            (1 or True, offset from the progress anchor) or ``ANCHOR_GOAL`` (2, offset whose first two
            coordinates are along and to the left of the anchor-to-goal direction).
        candidates: (m,) int or None; raw candidates drawn to produce each row (default 1).
    """

    points: np.ndarray
    anchored: np.ndarray | None = None
    candidates: np.ndarray | None = None


@runtime_checkable
class Sampler(Protocol):
    """Where a planner samples next."""

    def bind(self, problem: Problem) -> Sampler:
        """A copy of this sampler ready to draw for ``problem``."""
        ...

    def draw(self, rng: np.random.Generator, n: int, view: TreeView) -> np.ndarray | SampleBatch:
        """Return between 1 and ``n`` samples."""
        ...


def is_sampler(obj) -> bool:
    """Whether ``obj`` implements the ``Sampler`` protocol: callable ``bind`` and ``draw``.

    What ``isinstance(obj, Sampler)`` answers, in a tenth of a microsecond instead of about four: a planner asks it
    for every sampler it is built with, once per query.
    """
    return callable(getattr(obj, "bind", None)) and callable(getattr(obj, "draw", None))


class DrawInterrupted(Exception):
    """Raised by a sampler's ``draw`` that found its deadline (``SamplerBase.set_deadline``) passed before it finished.

    The planner that set the deadline catches it, puts its generator back where the draw began and returns: the
    draw is made again, whole, if the planner is asked to go on, so a timed run stays the run it would be untimed.
    """


class SamplerBase:
    """Default ``bind``: a shallow copy that remembers the problem and its bounds.

    ``set_deadline`` is the hook through which ``Planner.solve`` hands a time limit to a sampler whose
    draws can be long (those that test states, like OB-PRM's): such a draw looks at ``past_deadline``
    as it goes and raises ``DrawInterrupted`` once it is past.
    """

    problem: Problem | None = None
    _deadline_at: float | None = None
    _deadline_clock = None

    def bind(self, problem: Problem) -> SamplerBase:
        # a shallow copy; copy.copy's generic protocol costs ~15 us, and a bind is paid on every query
        bound = object.__new__(type(self))
        bound.__dict__.update(self.__dict__)
        bound.problem = problem
        low, high = problem.world.bounds
        bound.low, bound.high = np.asarray(low, dtype=np.float64), np.asarray(high, dtype=np.float64)
        step = self.__dict__.get("step_size")
        if step is not None:  # samplers that measure in steps: one past the map's size would overflow memory
            _check_step_on_map(self, step, bound.low, bound.high)
        bound._setup()
        return bound

    def _setup(self) -> None:
        """Hook for per-problem preparation in subclasses."""

    def set_deadline(self, at: float | None, clock=None) -> None:
        """From now on, a draw still under way at ``clock() > at`` may stop with ``DrawInterrupted`` (None: never)."""
        self._deadline_at = None if at is None else float(at)
        self._deadline_clock = clock

    def deadline_check(self):
        """``past_deadline`` while a deadline is set, else None: what ``draw_pooled``'s ``deadline`` takes."""
        return None if self._deadline_at is None else self.past_deadline

    def past_deadline(self) -> bool:
        """Whether the deadline ``set_deadline`` gave has passed (False without one)."""
        at = self._deadline_at
        return at is not None and self._deadline_clock() > at

    def _uniform(self, u: np.ndarray) -> np.ndarray:
        return self.low + (self.high - self.low) * u

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


#: The planners' compiled loops the classical samplers can draw in (``Planner.fusable_loop``).
CLASSICAL_LOOPS = ("rrt", "connect", "rrtstar")


def _classical_label(kind: str) -> str:
    return f"classical-draws-{kind}"


def draw_classical_in_loops(problem: Problem, kinds: tuple[str, ...] = CLASSICAL_LOOPS) -> None:
    """From now on, in this install, ``UniformSampler`` and ``GoalBiasedSampler`` draw inside the compiled loops of
    the planners named by ``kinds`` (RRT's ``"rrt"``, RRT-Connect's ``"connect"``, RRT*'s ``"rrtstar"``) on
    ``problem``'s world kind and space.

    Until then they draw through Python, one ``draw`` call per refill of the planner's buffer, so a first solve
    compiles the planner's kernels and nothing more. Either way the run is the same run; drawn in the loop it is
    10 to 20% sooner on a 2-D map (a 6-DoF iteration's checks take a hundred times longer than the return to Python,
    so there it changes nothing that shows), and each loop compiles once per install at its first use (one to three
    seconds). ``python -m planners.compile`` calls this for the 2-D world kinds it compiles, and the 2-D comparisons
    and benchmarks for the maps they time, so that the classical samplers they are timed against are at their
    fastest. The choice is a stamp in the compiled-kernel cache (``planners.kernels.cache``).
    """
    from planners.kernels import cache

    for kind in kinds:
        if kind not in CLASSICAL_LOOPS:
            raise ValueError(f"kinds: unknown loop {kind!r}; expected some of {', '.join(CLASSICAL_LOOPS)}")
        cache.mark_compiled(_classical_label(kind), problem.world.kernel, problem.space)


def _fuse_classical(sampler: SamplerBase, planner, own_draw, p: float, biased: bool):
    """``sampler``'s draws in ``planner``'s compiled loop (``planners.kernels.draws``); None where the planner has no
    loop, where this install has not chosen to draw there (``draw_classical_in_loops``), or where a subclass draws
    otherwise than ``own_draw`` (its ``draw`` is what it means).
    """
    kind = planner.fusable_loop
    if type(sampler).draw is not own_draw or kind not in CLASSICAL_LOOPS:
        return None
    from planners.kernels import cache

    problem = sampler.problem
    if not cache.is_compiled(_classical_label(kind), problem.world.kernel, problem.space):
        return None
    from planners import fused
    from planners.kernels import draws

    state = draws.classical_state(sampler.low, sampler.high, problem.goal, p, biased)
    if kind == "rrt":
        return fused.fuse_rrt(planner, draws.classical_rrt_loop, state, fused.CHUNK)
    if kind == "connect":
        return fused.fuse_connect(planner, draws.classical_connect_loop, state, state, (fused.CHUNK, fused.CHUNK))
    return fused.fuse_rrtstar(planner, draws.classical_rrtstar_loop, state, fused.CHUNK)


class UniformSampler(SamplerBase):
    """Uniform over the world's sampling box (obstacles included, as in OMPL's RRT).

    Where the planner has a compiled loop (RRT, RRT-Connect, RRT* to its first solution) and the install has chosen to
    draw there (``draw_classical_in_loops``; ``python -m planners.compile`` does) it draws the same samples inside it
    (``fuse``), as the learned samplers do: the same run, without a return to Python per refill.
    """

    def draw(self, rng, n, view):
        return self._uniform(rng.random((n, self.problem.dim)))

    def fuse(self, planner):
        """This sampler's draws in ``planner``'s compiled loop (``planners.fused``); None where it has none."""
        return _fuse_classical(self, planner, UniformSampler.draw, 0.0, biased=False)


class GoalBiasedSampler(SamplerBase):
    """The goal state with probability ``p``, otherwise uniform (OMPL's default ``p`` is 0.05); drawn inside the
    planner's compiled loop as ``UniformSampler`` is.

    Args:
        p: Goal bias in [0, 1].
    """

    def __init__(self, p: float = 0.05) -> None:
        p = float(p)
        if not (0.0 <= p <= 1.0) or math.isnan(p):
            raise ValueError(f"goal bias p must lie in [0, 1], got {p}")
        self.p = p

    def draw(self, rng, n, view):
        # one row of d + 1 uniforms per sample keeps the stream identical whatever the batch size
        u = rng.random((n, self.problem.dim + 1))
        pts = self._uniform(u[:, 1:])
        pts[u[:, 0] < self.p] = self.problem.goal
        return pts

    def fuse(self, planner):
        """This sampler's draws in ``planner``'s compiled loop (``planners.fused``); None where it has none."""
        return _fuse_classical(self, planner, GoalBiasedSampler.draw, self.p, biased=True)

    def __repr__(self) -> str:
        return f"GoalBiasedSampler({self.p:g})"


class InformedSampler(SamplerBase):
    """Uniform until a solution exists, then uniform over the informed set (Gammell et al. 2014).

    The informed set is the prolate hyperspheroid of states that could lie on a path shorter than
    the best found. A path may end anywhere in the goal ball, so the set is
    ``|x - start| + |x - goal| <= best_cost + goal_tolerance``. Real-vector, Euclidean spaces only.
    Points of the ellipsoid outside the sampling box are rejected and counted as candidates.
    """

    batch = 64

    def _setup(self) -> None:
        p = self.problem
        if p.world.space_kind != 0 or p.metric != "euclidean":
            raise ValueError("InformedSampler needs a real-vector world with the euclidean metric")
        d = p.dim
        s, g = np.asarray(p.start), np.asarray(p.goal)
        self._center = 0.5 * (s + g)
        self._cmin = float(np.linalg.norm(g - s))
        a1 = (g - s) / self._cmin if self._cmin > 0 else np.eye(d)[0]
        # rotation taking e1 to a1 (SVD construction of Gammell et al.)
        M = np.outer(a1, np.eye(d)[0])
        U, _, Vt = np.linalg.svd(M)
        D = np.eye(d)
        D[-1, -1] = np.linalg.det(U) * np.linalg.det(Vt.T)
        self._C = U @ D @ Vt

    def draw(self, rng, n, view):
        c_best = view.best_cost + self.problem.goal_tolerance
        d = self.problem.dim
        m = min(n, self.batch)  # small batches: the informed set shrinks as the solution improves
        if not np.isfinite(c_best) or c_best <= self._cmin:
            return self._uniform(rng.random((m, d)))
        r1 = c_best / 2.0
        ri = math.sqrt(max(c_best**2 - self._cmin**2, 0.0)) / 2.0
        T = self._C * np.array([r1] + [ri] * (d - 1))  # rotation times the ellipsoid's radii
        pts = np.empty((0, d))
        cands = np.empty(0, dtype=np.int64)
        carry = 0  # rejected candidates not yet charged to an accepted sample
        while len(pts) < m:
            # uniform in the unit ball, mapped onto the ellipsoid; reject what leaves the box
            x = rng.normal(size=(2 * m, d))
            x *= (rng.random(2 * m) ** (1.0 / d) / np.linalg.norm(x, axis=1))[:, None]
            y = x @ T.T + self._center
            ok = np.flatnonzero(np.all((y >= self.low) & (y < self.high), axis=1))
            if len(ok) == 0:
                carry += 2 * m
                continue
            counts = np.diff(np.concatenate([[-1], ok]))
            counts[0] += carry
            carry = 2 * m - 1 - int(ok[-1])
            pts = np.concatenate([pts, y[ok]])
            cands = np.concatenate([cands, counts])
        # every candidate drawn is charged, those behind surplus samples to the last one returned
        cands[m - 1] += int(cands[m:].sum()) + carry
        return SampleBatch(pts[:m], None, cands[:m])


#: Under a deadline, a pooled draw runs its attempts in compiled calls of about this many seconds, the first of
#: ``FIRST_SLICE_ATTEMPTS`` attempts, and asks the deadline before each.
DRAW_SLICE = 0.005
FIRST_SLICE_ATTEMPTS = 16


def _run_sliced(u, n, m, per, run, out, cand, state, deadline, step):
    """One pool of ``draw_pooled`` in slices of ``step`` attempts (sized to ``DRAW_SLICE``), deadline asked first."""
    from planners.kernels.state import S_POS

    while m < n and int(state[S_POS]) + per <= len(u):
        if deadline():
            raise DrawInterrupted
        end = min(len(u), int(state[S_POS]) + step * per)
        t = time.perf_counter()
        m += run(u[:end], n - m, out[m:], cand[m:], state)
        spent = time.perf_counter() - t
        # the next slice sized from this one's speed, at most doubling (its attempts can be cheaper than the next)
        step = max(1, min(2 * step, int(step * DRAW_SLICE / spent))) if spent > 0 else 2 * step
    return m, step


class PooledDraws(NamedTuple):
    """What ``draw_pooled`` returns.

    Attributes:
        points: (n, dim) rows, the first ``count`` of them samples.
        candidates: (n,) the attempts behind each sample; those of a sample still sought when the
            attempts ran out are charged to the last sample (``pending`` says how many).
        count: Samples made, ``n`` unless ``budget`` ran out.
        pending: Attempts after the last sample that made none.
        checks: The attempts' validity checks.
        rate: The running estimate of attempts per sample after this draw, for the next one.
    """

    points: np.ndarray
    candidates: np.ndarray
    count: int
    pending: int
    checks: int
    rate: float


def draw_pooled(rng: np.random.Generator, n: int, dim: int, per: int, rate: float, run, *,
                attempts: int | None = None, budget: int | None = None, deadline=None) -> PooledDraws:
    """Up to ``n`` samples from a compiled sampler whose samples take attempts of ``per`` uniforms each.

    The Python side of ``planners.kernels.pool.pooled_attempts`` (the Gaussian, bridge-test and obstacle-based
    samplers): pools of uniforms are drawn from ``rng``, each sized for ``1.25 * rate`` attempts a sample still
    wanted (at least 64 attempts), and ``run(u, k, out, cand, state)`` (the sampler's compiled entry) turns a
    pool into at most ``k`` samples, returning how many; its ``state`` (``planners.kernels.state``'s ``S_*``
    slots) carries a sample's attempts from one pool to the next. ``attempts``: no sample takes more (then no
    pool is larger than the samples wanted can use); ``budget``: attempts in all, after which the draw stops.

    ``deadline``: a callable that says whether the draw's time is up (a sampler's ``past_deadline``). Then each
    pool is run in slices of whole attempts, each about ``DRAW_SLICE`` seconds, the deadline asked before each,
    and ``DrawInterrupted`` raised once it has passed. A slice ends where the next begins, so the samples are
    those of one call per pool.
    """
    from planners.kernels.state import N_STATE, S_CHECKS, S_PENDING, S_POS

    out = np.empty((n, dim))
    cand = np.zeros(n, dtype=np.int64)
    state = np.zeros(N_STATE, dtype=np.int64)
    m = used = 0
    step = FIRST_SLICE_ATTEMPTS
    while m < n and (budget is None or used < budget):
        pool = max(64, math.ceil(1.25 * rate * (n - m)))
        if attempts is not None:
            pool = min(attempts * (n - m), pool)
        if budget is not None:
            pool = min(budget - used, pool)
        u = rng.random(int(pool) * per)
        state[S_POS] = 0
        if deadline is None:
            m += run(u, n - m, out[m:], cand[m:], state)
        else:
            m, step = _run_sliced(u, n, m, per, run, out, cand, state, deadline, step)
        used += int(state[S_POS]) // per
    pending = int(state[S_PENDING])
    if m:
        cand[m - 1] += pending  # every attempt is charged to some sample
        rate = 0.5 * rate + 0.5 * used / m
    return PooledDraws(out, cand, m, pending, int(state[S_CHECKS]), rate)


class _NarrowPassageSampler(SamplerBase):
    """Shared by ``GaussianSampler`` and ``BridgeTestSampler``: OMPL's valid state samplers, compiled.

    Both are defined in ``planners.kernels.narrow``; they differ in ``_mode``. The default standard
    deviation is OMPL's: 0.1 of the space's maximum extent (the bounds' diagonal; on the rigid body
    the workspace's diagonal plus pi/2, the extent of SO(3)). On the rigid body OMPL's SE(3) gives the
    position and the rotation half of it each (``pos_sd``, ``rot_sd = 2 * (sd / 2) / sqrt(3)``: its
    ``SO3StateSampler``); above ``ROT_UNIFORM`` the rotation is drawn uniformly.

    Every attempt counts as a candidate (``SampleBatch.candidates``) and the sampler's own validity
    checks accumulate in ``checks`` (a comparison adds them to the planner's). A sample that
    ``attempts`` attempts did not find is the last attempt's uniform state.

    Args:
        stddev: Standard deviation of the Gaussian state; None: OMPL's default.
        attempts: Attempts per sample (OMPL's default 100).
    """

    _mode = 0  # planners.kernels.narrow.GAUSSIAN or BRIDGE

    def __init__(self, stddev: float | None = None, attempts: int = 100) -> None:
        from planners.base.fileio import check_int, check_number

        if stddev is not None:
            check_number(type(self).__name__, "stddev", stddev, low=0, low_open=True)
        self.stddev = None if stddev is None else float(stddev)
        self.attempts = check_int(attempts, f"{type(self).__name__}: attempts", low=1)

    def _setup(self) -> None:
        from planners.kernels import narrow
        from planners.kernels.space import SPACE_RN

        world = self.problem.world
        self._kind = int(world.space_kind)
        rn = self._kind == SPACE_RN
        diag = float(np.linalg.norm((self.high - self.low) if rn else (self.high[:3] - self.low[:3])))
        sd = self.stddev if self.stddev is not None else 0.1 * (diag if rn else diag + 0.5 * math.pi)
        self.pos_sd = sd if rn else 0.5 * sd
        self.rot_sd = 0.0 if rn else 2.0 * (0.5 * sd) / math.sqrt(3.0)
        self._world = world.kernel
        self._per = int(narrow.per_attempt(self.problem.dim))
        self._rate = 4.0  # running estimate of attempts per sample, sizes the uniform pools
        self.checks = 0

    def draw(self, rng, n, view):
        """``n`` samples, with the attempts behind each as candidates."""
        got = draw_pooled(rng, n, self.problem.dim, self._per, self._rate, self._attempts, attempts=self.attempts,
                          deadline=self.deadline_check())
        self.checks += got.checks
        self._rate = got.rate
        return SampleBatch(got.points, None, got.candidates)

    def _attempts(self, u, n, out, cand, state):
        from planners.kernels import narrow

        return narrow.narrow_samples(self._world, self._kind, self._mode, self.low, self.high, u, n, self.attempts,
                                     self.pos_sd, self.rot_sd, out, cand, state)

    def __repr__(self) -> str:
        sd = "default" if self.stddev is None else f"{self.stddev:g}"
        return f"{type(self).__name__}(stddev={sd}, attempts={self.attempts})"


class GaussianSampler(_NarrowPassageSampler):
    """OMPL's Gaussian sampling (Boor et al. 1999): of a uniform state and a Gaussian one near it, the valid one.

    A sample needs exactly one of the two valid. See ``_NarrowPassageSampler`` for the arguments.
    """

    _mode = 0  # planners.kernels.narrow.GAUSSIAN


class BridgeTestSampler(_NarrowPassageSampler):
    """OMPL's bridge test (Hsu et al. 2003): the valid midpoint of two invalid states.

    The two are a uniform state and a Gaussian one near it. See ``_NarrowPassageSampler`` for the arguments.
    """

    _mode = 1  # planners.kernels.narrow.BRIDGE
