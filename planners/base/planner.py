"""The steppable planner base class and the result types every planner returns."""

from __future__ import annotations

import abc
import threading
import time
from dataclasses import dataclass
from typing import ClassVar, NamedTuple

import numpy as np
from numba.core import event as _nb_event

from planners.base.fileio import check_int
from planners.base.problem import Problem
from planners.base.samplers import (
    FAMILY_ROADMAP,
    FAMILY_TREE,
    DrawInterrupted,
    SampleBatch,
    Sampler,
    UniformSampler,
    is_sampler,
)
from planners.datastructures.nn import insert as index_insert
from planners.kernels import state as slots
from planners.kernels.cache import announce as announce_compile
from planners.kernels.fused import CHUNK, HAND_BACK, refill_size  # the batch and refill schedule (planners.fused)
from planners.kernels.space import embed, embed_dim, uses_kd
from planners.kernels.state import Tree

#: Under a time limit, one compiled call is sized from the measured time per sample (growing at most
#: twofold) to end by the deadline and to last at most this many seconds, so the deadline is looked
#: at every TIME_SLICE seconds at least, and overrun by about one iteration (an iteration can be slow:
#: long 6-DoF motion checks, a dense roadmap) or one Lazy-PRM search round.
TIME_SLICE = 0.05


class _CompileClock(threading.local):
    depth = 0
    since = 0.0
    total = 0.0


_clock = _CompileClock()


class _CompileTimer(_nb_event.Listener):
    """Adds up, per thread, the time spent holding numba's compiler lock (compiling or loading cached code)."""

    def on_start(self, event) -> None:
        if _clock.depth == 0:
            _clock.since = time.perf_counter()
        _clock.depth += 1

    def on_end(self, event) -> None:
        if _clock.depth == 0:  # a compilation already under way when this module was imported
            return
        _clock.depth -= 1
        if _clock.depth == 0:
            _clock.total += time.perf_counter() - _clock.since


# the lock is taken for every compilation and cache load, nested ones included (it is re-entrant)
_nb_event.register("numba:compiler_lock", _CompileTimer())


def work_clock() -> float:
    """Seconds on this thread's clock that leaves numba compilation out (time limits, and the evaluation's times of
    a run and of a route field, run on it).
    """
    return time.perf_counter() - compile_seconds()


def compile_seconds() -> float:
    """Seconds this thread has spent so far in numba's compiler (compiling or loading cached code).

    Time limits exclude it: the one-off compilation of a kernel says nothing about a planner's speed,
    and it happens whenever a kernel first meets new argument types (a first solve, a first solution,
    a new world kind), so no warm-up could cover every case.
    """
    return _clock.total + (time.perf_counter() - _clock.since if _clock.depth else 0.0)


@dataclass(frozen=True)
class PlanResult:
    """What ``solve()`` returns.

    Attributes:
        solved: A path to the goal region exists.
        path: (k, dim) states from start to a state within tolerance of the goal (every segment
            collision-free); shape (0, dim) when unsolved.
        cost: Path length in the problem's metric (inf when unsolved).
        iterations: Samples consumed so far. For planners that stop at their first solution this
            is the iterations-to-solution.
        first_solution_iteration: The iteration that produced the first solution, or None.
        collision_checks: State and motion validity checks performed.
        candidates: Raw candidates behind the consumed samples (equals ``iterations`` unless the
            sampler rejects candidates).
        num_vertices: Vertices in the tree(s) or roadmap.
        time: Wall-clock seconds spent inside ``step``/``solve`` so far, one-off numba compilation
            included (``Planner.compile_time`` says how much; time limits leave it out).
        stop_reason: "solved", "max_iterations" or "time_limit".
        planner: Planner name.
        seed: The seed that reproduces this run.
        restarts: Attempts begun again before this one (``solve_with_restarts``; 0 for one planner's run).
    """

    solved: bool
    path: np.ndarray
    cost: float
    iterations: int
    first_solution_iteration: int | None
    collision_checks: int
    candidates: int
    num_vertices: int
    time: float
    stop_reason: str
    planner: str
    seed: int
    restarts: int = 0


class StepResult(NamedTuple):
    """What ``step()`` returns: the iteration just run."""

    iterated: bool  # False when a non-anytime planner was already solved
    iteration: int
    sample: np.ndarray  # the state the iteration sampled (anchored samples resolved)
    added: int  # vertex added by this iteration, -1 if none
    solved: bool


@dataclass(frozen=True)
class TreeView:
    """Read-only snapshot of a planner's state, handed to samplers.

    Attributes:
        problem: The problem being solved.
        vertices: (n, dim) states of the start tree (roadmap for PRM), read-only views.
        parents: (n,) parent index (-1 for roots), or None for roadmaps.
        num_vertices: n.
        best_vertex: Index of the vertex nearest the goal: the progress anchor.
        best_distance: Its distance to the goal.
        best_cost: Cost of the best solution so far (inf if none).
        iteration: Iterations run so far.
        tree: Which tree the next sample extends: ``TREE_START`` (0: the start tree, the only tree, or the
            roadmap) or ``TREE_GOAL`` (1: RRT-Connect's goal tree, on its turns).
        goal_tree: RRT-Connect's goal-tree states (read-only, rooted at the goal); None for the other planners.
    """

    problem: Problem
    vertices: np.ndarray
    parents: np.ndarray | None
    num_vertices: int
    best_vertex: int
    best_distance: float
    best_cost: float
    iteration: int
    tree: int = 0
    goal_tree: np.ndarray | None = None


@dataclass(frozen=True)
class PlannerData:
    """A planner's graph for plotting: vertices, directed edges (from, to), a tag per vertex."""

    vertices: np.ndarray
    edges: np.ndarray
    tags: np.ndarray


def require_problem(problem) -> Problem:
    """Raise a clear TypeError unless ``problem`` is a ``Problem`` (planners check this first)."""
    if not isinstance(problem, Problem):
        raise TypeError(f"problem must be a planners.Problem, got {type(problem).__name__}")
    return problem


def _readonly(a: np.ndarray) -> np.ndarray:
    v = a.view()
    v.flags.writeable = False
    return v


class VertexStore:
    """Growable vertex arrays plus their nearest-neighbour index (shared by trees and roadmaps)."""

    def __init__(self, problem: Problem, capacity: int, tree: bool) -> None:
        kind, metric, _ = self.space = problem.space
        self.dim = problem.dim
        # the compiled helpers' Python functions: answering these compiles nothing
        self.edim = int(embed_dim.py_func(kind, metric, self.dim))
        self.same_embedding = kind == 0
        self.kd = bool(uses_kd.py_func(kind, metric))
        self.tree = tree
        self._alloc(max(int(capacity), 64), 0)

    def _alloc(self, cap: int, keep: int) -> None:
        def grown(name, shape, dtype, fill=0):
            new = np.zeros(shape, dtype=dtype) if fill == 0 else np.full(shape, fill, dtype=dtype)
            old = getattr(self, name, None)
            if old is not None and keep:
                new[:keep] = old[:keep]
            return new

        self.X = grown("X", (cap, self.dim), np.float64)
        self.E = self.X if self.same_embedding else grown("E", (cap, self.edim), np.float64)
        self.parent = grown("parent", (cap,), np.int64, -1)
        self.cost = grown("cost", (cap,), np.float64)
        self.perm = grown("perm", (cap,), np.int64)
        self.split = grown("split", (cap,), np.int64)
        self.box = grown("box", (cap, 2 * self.edim), np.float64)

    @property
    def capacity(self) -> int:
        return len(self.X)

    def reserve(self, n_used: int, extra: int) -> bool:
        """Ensure room for ``extra`` more vertices; returns True if the arrays were reallocated."""
        need = n_used + extra
        if need <= self.capacity:
            return False
        self._alloc(max(need, 2 * self.capacity), n_used)
        return True

    def add_root(self, q: np.ndarray) -> int:
        """Make ``q`` vertex 0 of an empty store (no parent, cost 0); returns the vertex count, 1.

        As ``planners.kernels.tree.add_vertex`` would.
        """
        q = np.array(q, dtype=np.float64)  # a writable copy: the argument types the kernels compile for
        self.X[0] = q
        if not self.same_embedding:
            embed(self.space[0], self.space[1], q, self.E[0])
        self.parent[0] = -1
        self.cost[0] = 0.0
        return int(index_insert.py_func(self.E, self.perm, self.split, self.box, 0)) if self.kd else 1

    def as_tree(self) -> Tree:
        """The arrays as the kernels take them (valid until the next ``reserve`` reallocates them)."""
        return Tree(self.X, self.E, self.parent, self.cost, self.perm, self.split, self.box)


class Planner(abc.ABC):
    """Base class: a planner that can be stepped one iteration at a time and resumed.

    Subclasses implement ``_reset`` (fresh state), ``_run`` (consume samples in compiled code),
    ``_reserve`` (room for more iterations), ``_path`` and ``planner_data``. This class owns the
    bookkeeping: the seeded generator, the sample buffer (so ``step()`` N times and ``solve(N)``
    consume exactly the same samples), time, budgets and the result.

    Args:
        problem: The planning problem.
        sampler: Any ``Sampler``; default ``UniformSampler()``.
        seed: Seed of the planner's ``np.random.Generator``; None draws one (reported in results).
    """

    #: The planner's name: its label in tables and logs (OMPL's spelling) and its key in
    #: ``planners.base.registry`` (looked up ignoring case, ``-`` and ``_``).
    name: ClassVar[str] = "planner"
    #: The constructor argument that sets the planner's step length: ``"step_size"`` (extension per
    #: iteration, RRT family) or ``"max_edge_length"`` (longest roadmap edge, PRM family).
    step_parameter: ClassVar[str | None] = None
    #: True for planners whose sampler is part of the algorithm (Informed RRT*, OB-PRM): giving them
    #: another sampler makes them a different planner.
    own_sampler: ClassVar[bool] = False
    #: Anytime planners keep improving after the first solution until the budget is spent.
    anytime: ClassVar[bool] = False
    #: The compiled loop a sampler may fuse its draws into (see ``Sampler``); None: draws only.
    fusable_loop: ClassVar[str | None] = None
    #: How the planner uses its samples, told to a sampler's ``for_planner`` hook before binding (``Sampler``):
    #: one of ``planners.base.samplers.PLANNER_FAMILIES``.
    family: ClassVar[str] = FAMILY_TREE
    #: The longest edge a roadmap planner may add (None: no limit), told to a sampler's ``at_edge`` hook (``Sampler``).
    edge_limit: float | None = None

    def __init__(self, problem: Problem, *, sampler: Sampler | None = None, seed: int | None = None) -> None:
        require_problem(problem)
        if sampler is None:
            sampler = UniformSampler()
        if not is_sampler(sampler):
            raise TypeError("sampler must implement bind(problem) and draw(rng, n, view), "
                            f"got {type(sampler).__name__}")
        if seed is None:
            seed = int(np.random.SeedSequence().entropy % (2**63))
        elif isinstance(seed, (bool, float)) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise ValueError(f"seed must be a non-negative integer or None, got {seed!r}")
        at_step = getattr(sampler, "at_step", None)
        if self.step_parameter == "step_size" and callable(at_step):  # the step is the planner's (``Sampler``)
            sampler = at_step(self.step_size)
        for_planner = getattr(sampler, "for_planner", None)
        if callable(for_planner):  # the sampler's rule for this planner family (``Sampler``)
            ruled = for_planner(self.family)
            if not is_sampler(ruled):
                raise TypeError(f"{type(sampler).__name__}.for_planner({self.family!r}) returned a "
                                f"{type(ruled).__name__}, not a Sampler")
            sampler = ruled
        at_edge = getattr(sampler, "at_edge", None)
        if self.family == FAMILY_ROADMAP and callable(at_edge):  # the roadmap's longest edge (``Sampler``)
            sampler = at_edge(self.edge_limit)
        self.problem = problem
        self.seed = int(seed)
        self._sampler_spec = sampler
        self._space = problem.space
        self._low, self._high = (np.ascontiguousarray(b, dtype=np.float64) for b in problem.world.bounds)
        self._goal = np.array(problem.goal, dtype=np.float64)  # writable: the kernels compile one array type
        self._stack = np.empty(2 * 256, dtype=np.int64)
        self._stack_b = np.empty(256)
        announce_compile(self.name, problem.world.kernel, self._space)
        self.clear()

    # --- public API ------------------------------------------------------------------------

    def clear(self) -> None:
        """Forget all progress; the next solve repeats the first one exactly (same seed)."""
        self._rng = np.random.default_rng(self.seed)
        self.sampler = self._sampler_spec.bind(self.problem)
        self._buf_pts = np.empty((0, self.problem.dim))
        self._buf_anch = np.empty(0, dtype=np.int8)
        self._buf_cand: np.ndarray | None = None
        self._pos = 0
        self._refills = 0
        self._time = 0.0
        self._compile = 0.0
        # under a time limit: seconds the current compiled call may take (None: untimed), and the
        # speed measured on the last call, which sizes the next
        self._call_budget: float | None = None
        self._sample_s: float | None = None
        self._last_used = 0
        # whether the sampler's last draw was cut at a timed solve's deadline (and undone: _refill)
        self._draw_cut = False
        self._candidates = 0
        self._stop_reason = "max_iterations"
        self._istate = np.zeros(slots.N_ISTATE, dtype=np.int64)
        self._fstate = np.zeros(slots.N_FSTATE)
        self._fstate[slots.F_BEST_COST] = np.inf
        self._istate[slots.I_ADDED] = -1
        self._istate[slots.I_FIRST] = -1
        self._last = np.zeros(self.problem.dim)
        self._reset()
        fuse = getattr(self.sampler, "fuse", None) if self.fusable_loop is not None else None
        self._fused = fuse(self) if fuse is not None else None

    def step(self) -> StepResult:
        """Run exactly one iteration (one sample drawn); a no-op once a non-anytime planner is solved."""
        t0, c0 = time.perf_counter(), compile_seconds()
        if self._finished():
            return StepResult(False, self.iterations, self._last.copy(), -1, True)
        before = self.iterations
        while self.iterations == before and not self._finished():
            self._consume(1)  # no sample is drawn while a Lazy-PRM resolution is still pending
        self._compile += compile_seconds() - c0
        self._time += time.perf_counter() - t0
        return StepResult(True, self.iterations, self._last.copy(), int(self._istate[slots.I_ADDED]), self.solved)

    def solve(self, max_iterations: int | None = None, time_limit: float | None = None) -> PlanResult:
        """Run until solved (anytime planners: until the budget is spent) or a budget runs out.

        Budgets count from this call, so calling ``solve`` again resumes where it stopped.

        The time limit excludes one-off numba compilation (``compile_time``) and holds within a
        stated margin whatever the input: compiled work is handed out in calls sized by the measured
        speed to end by the deadline and to last at most ``TIME_SLICE`` (0.05 s), so a solve returns
        at most about ``TIME_SLICE`` after ``time_limit`` (measured speed can be off by a factor of
        two), or one iteration or one Lazy-PRM search round after it where that is longer (a
        millisecond or so on 2-D maps), plus the time ``result()`` takes to extract the path. How
        the work is split never changes the result: a timed run ends as the same iterations untimed.
        A world with a ``set_deadline`` hook (``MeshWorld``, whose one motion check can take many
        milliseconds) is told the deadline and answers "blocked" to checks still under way past it,
        so the last iteration ends early; what it had added stays valid. So is a sampler with a
        ``set_deadline`` hook (``SamplerBase``: OB-PRM's, the Gaussian and bridge-test samplers, whose
        draws test states): a draw it cuts at the deadline is undone, the generator put back, and made
        again whole if the planner goes on.

        Args:
            max_iterations: Iterations (samples) this call may use.
            time_limit: Seconds this call may use, compilation excluded.
        """
        if max_iterations is None and time_limit is None:
            raise ValueError("give max_iterations or time_limit (or both)")
        if max_iterations is not None:
            check_int(max_iterations, "max_iterations", low=0)
        if time_limit is not None:
            time_limit = float(time_limit)
            if not np.isfinite(time_limit) or time_limit <= 0:
                raise ValueError(f"time_limit must be a positive number of seconds, got {time_limit}")
        t0, c0 = time.perf_counter(), compile_seconds()
        budget = np.inf if max_iterations is None else int(max_iterations)
        done = 0
        # a world whose single checks can be long (a mesh world) is told the deadline, on the clock that
        # leaves compilation out, and answers "blocked" to the checks still under way past it; so is a sampler
        # whose draws can be long (one that tests states), which stops a draw there
        hooks = () if time_limit is None else tuple(
            h for h in (getattr(self.problem.world, "set_deadline", None), getattr(self.sampler, "set_deadline", None))
            if h is not None)
        for set_deadline in hooks:
            set_deadline(t0 - c0 + time_limit, work_clock)
        self._draw_cut = False
        try:
            while True:
                if self._finished():
                    reason = "solved"
                    break
                if done >= budget:
                    reason = "max_iterations"
                    break
                chunk = CHUNK
                if time_limit is not None:
                    left = time_limit - (time.perf_counter() - t0 - (compile_seconds() - c0))
                    if left <= 0:
                        reason = "time_limit"
                        break
                    self._call_budget = min(left, TIME_SLICE)
                    chunk = self._timed_chunk(self._call_budget)
                t_call, c_call = time.perf_counter(), compile_seconds()
                used = self._consume(int(min(budget - done, chunk)))
                done += used
                if self._draw_cut:  # the sampler's draw met the deadline (and was undone)
                    reason = "time_limit"
                    break
                if time_limit is not None:
                    spent = time.perf_counter() - t_call - (compile_seconds() - c_call)
                    self._sample_s, self._last_used = spent / max(used, 1), used
        finally:
            for set_deadline in hooks:
                set_deadline(None, None)
            self._draw_cut = False
            self._call_budget = None
            self._compile += compile_seconds() - c0
            self._time += time.perf_counter() - t0
        self._stop_reason = reason
        return self.result()

    def _timed_chunk(self, room: float) -> int:
        """Samples for the next compiled call under a time limit: what fits ``room`` seconds at the measured speed."""
        # at most doubling: a few cheap samples say little about the next ones. How the samples are
        # split between calls never changes the result, only when the deadline is looked at
        grow = min(CHUNK, 2 * max(self._last_used, 1))
        if self._sample_s is None:
            return 1
        if self._sample_s <= 0:
            return grow
        return int(min(grow, max(1.0, room / self._sample_s)))

    @property
    def compile_time(self) -> float:
        """Seconds of one-off numba compilation inside ``step``/``solve`` so far (in ``time``, not in time limits)."""
        return self._compile

    def result(self) -> PlanResult:
        """The current result (what the last ``solve`` returned, updated by any later ``step``)."""
        path = self._path() if self.solved else np.empty((0, self.problem.dim))
        path.flags.writeable = False
        first = int(self._istate[slots.I_FIRST])
        return PlanResult(
            solved=self.solved,
            path=path,
            cost=float(self._fstate[slots.F_BEST_COST]) if self.solved else float("inf"),
            iterations=self.iterations,
            first_solution_iteration=first if first >= 0 else None,
            collision_checks=self.collision_checks,
            candidates=int(self._candidates),
            num_vertices=self.num_vertices,
            time=self._time,
            stop_reason="solved" if self._finished() else self._stop_reason,
            planner=self.name,
            seed=self.seed,
        )

    @property
    def iterations(self) -> int:
        return int(self._istate[slots.I_ITER])

    @property
    def collision_checks(self) -> int:
        return int(self._istate[slots.I_CHECKS])

    @property
    def solved(self) -> bool:
        return bool(self._istate[slots.I_SOLVED])

    @property
    def num_vertices(self) -> int:
        return int(self._istate[slots.I_N])

    def vertex_counts(self) -> tuple[int, ...]:
        """Vertices per ``PlannerData`` tag, in tag order (one graph: one count)."""
        return (self.num_vertices,)

    @property
    def rng(self) -> np.random.Generator:
        """The planner's seeded generator, from which every sample is drawn."""
        return self._rng

    def loop_args(self) -> tuple:
        """Arguments of the compiled loop named by ``fusable_loop``, after the sample (arrays grow: re-read)."""
        raise NotImplementedError(f"{type(self).__name__} has no fusable loop")

    def view(self) -> TreeView:
        """Read-only snapshot for samplers and observers."""
        n = int(self._istate[slots.I_N])
        vs = self._vertex_store()
        return TreeView(
            problem=self.problem,
            vertices=_readonly(vs.X[:n]),
            parents=_readonly(vs.parent[:n]) if vs.tree else None,
            num_vertices=n,
            best_vertex=int(self._istate[slots.I_BEST_V]),
            best_distance=float(self._fstate[slots.F_BEST_D]),
            best_cost=float(self._fstate[slots.F_BEST_COST]) if self.solved else float("inf"),
            iteration=self.iterations,
        )

    @abc.abstractmethod
    def planner_data(self) -> PlannerData:
        """Vertices and edges for plotting (read-only copies)."""

    def __repr__(self) -> str:
        return (f"{type(self).__name__}(iterations={self.iterations}, vertices={self.num_vertices}, "
                f"solved={self.solved})")

    # --- subclass interface ------------------------------------------------------------------

    @abc.abstractmethod
    def _reset(self) -> None:
        """Allocate fresh state; the start state is already valid."""

    @abc.abstractmethod
    def _run(self, points: np.ndarray, anchored: np.ndarray) -> int:
        """Consume up to ``len(points)`` samples in compiled code; return how many were used."""

    @abc.abstractmethod
    def _reserve(self, iterations: int) -> None:
        """Make room for at least one more iteration (kernels stop when full; arrays grow by doubling)."""

    @abc.abstractmethod
    def _path(self) -> np.ndarray:
        """The current solution path (only called when solved)."""

    @abc.abstractmethod
    def _vertex_store(self) -> VertexStore:
        """The store whose vertices samplers see."""

    def _finished(self) -> bool:
        return self.solved and not self.anytime

    # --- sample buffer ---------------------------------------------------------------------

    def _refill(self, n: int) -> bool:
        """The next ``n`` samples into the buffer; False (generator restored, buffer kept) if the draw was cut.

        A draw cut at a time limit's deadline (``DrawInterrupted``) leaves the generator where it began, so the
        draw made again on resuming is the one an untimed run makes.
        """
        before = self._rng.bit_generator.state if self._call_budget is not None else None  # timed: can be cut
        try:
            out = self.sampler.draw(self._rng, n, self.view())
        except DrawInterrupted:
            if before is None:
                raise
            self._rng.bit_generator.state = before
            self._draw_cut = True
            return False
        if isinstance(out, SampleBatch):
            pts, anch, cand = out.points, out.anchored, out.candidates
        else:
            pts, anch, cand = out, None, None
        if not (isinstance(pts, np.ndarray) and pts.dtype == np.float64 and pts.flags.c_contiguous):
            pts = np.ascontiguousarray(pts, dtype=np.float64)
        who = type(self.sampler).__name__
        if pts.ndim != 2 or pts.shape[1] != self.problem.dim or not (1 <= len(pts) <= n):
            raise ValueError(f"{who}.draw(n={n}) must return 1..{n} samples of dimension {self.problem.dim}, "
                             f"got shape {pts.shape}")
        if not np.isfinite(pts.sum()):  # one reduction: any NaN or infinity makes the sum non-finite
            raise ValueError(f"{who}.draw returned a NaN or infinite sample")
        m = len(pts)
        if anch is None:
            anch = np.zeros(m, dtype=np.int8)
        else:
            if not (isinstance(anch, np.ndarray) and anch.dtype == np.int8):
                anch = np.ascontiguousarray(anch, dtype=np.int8)
            if anch.shape != (m,) or anch.min() < 0 or anch.max() > 2:
                raise ValueError(f"{who}.draw returned anchored flags that are not {m} codes in 0..2")
        if cand is None:
            self._buf_cand = None
        else:
            cand = np.ascontiguousarray(cand, dtype=np.int64)
            if cand.shape != (m,):
                raise ValueError(f"{who}.draw returned candidate counts that do not match {m} samples")
            self._buf_cand = cand
        self._buf_pts, self._buf_anch, self._pos = pts, anch, 0
        return True

    def _consume(self, n: int) -> int:
        if self._fused is not None:
            self._reserve(n)
            used = self._fused(self, n)
            if used != HAND_BACK:
                self._candidates += used
                return used
            # a loop fused up to the first solution hands the draws back (planners.fused): through draw from here
            self._refills, self._fused = self._fused.refills, None
        # refill sizes follow a fixed schedule: when refills happen (and what a tree-dependent
        # sampler sees) must not depend on how the caller splits its budget, so that
        # step() x N == solve(N) == solve in pieces
        if self._pos >= len(self._buf_pts):
            if not self._refill(refill_size(self._refills)):
                return 0
            self._refills += 1
        end = min(self._pos + n, len(self._buf_pts))
        self._reserve(end - self._pos)
        used = self._run(self._buf_pts[self._pos:end], self._buf_anch[self._pos:end])
        self._candidates += used if self._buf_cand is None else int(self._buf_cand[self._pos:self._pos + used].sum())
        self._pos += used
        return used
