"""Probabilistic roadmaps: PRM (k-nearest or radius) and Lazy-PRM, multi-query."""

from __future__ import annotations

import math
import time

import numpy as np

from planners.algorithms.rrtstar import unit_ball_volume
from planners.base.fileio import check_int
from planners.base.planner import (
    CHUNK,
    TIME_SLICE,
    Planner,
    PlannerData,
    PlanResult,
    VertexStore,
    compile_seconds,
    require_problem,
)
from planners.base.problem import Problem
from planners.base.registry import register_planner
from planners.base.samplers import FAMILY_ROADMAP, Sampler
from planners.kernels import prm as prm_kernels
from planners.kernels import state as slots

#: OMPL's default number of nearest neighbours for PRM (magic::DEFAULT_NEAREST_NEIGHBORS).
DEFAULT_K = 10


#: Searches per lazy resolution call: bounds the work between two looks at the caller's time limit
#: (a huge roadmap with many invalid edges can need thousands of searches). Under a time limit a
#: call makes only as many as fit the call's time slice, by the measured time per search.
LAZY_ROUNDS = 64

@register_planner
class PRM(Planner):
    """Probabilistic roadmap, multi-query.

    Each iteration draws a sample; if it is collision-free it becomes a vertex connected to its
    ``k`` nearest vertices (``connection="knn"``) or to all vertices within a radius
    (``connection="radius"``: ``radius`` if given, else the shrinking PRM* radius), keeping only
    collision-free edges. The query is solved once start and goal share a connected component; the
    path is the shortest roadmap path (A*, or Dijkstra with ``search="dijkstra"``) and ends exactly
    at the goal. ``iterations`` counts the samples drawn until then.

    Multi-query: ``grow(n)`` adds samples regardless of any query, ``query(start, goal)`` answers a
    new query on the existing roadmap (growing it only if needed), ``clear()`` forgets everything.

    L. E. Kavraki, P. Svestka, J.-C. Latombe, M. H. Overmars, "Probabilistic roadmaps for path
    planning in high-dimensional configuration spaces", IEEE T-RA 12(4), 1996,
    doi:10.1109/70.508439.

    Args:
        problem: The planning problem (its start and goal are the first query).
        max_edge_length: Longest edge the roadmap may hold (None: no limit in knn mode). Also caps
            the connection radius. (Not RRT's ``step_size``: a roadmap does not extend toward samples.)
        k: Neighbours per new vertex in knn mode (> 0).
        connection: ``"knn"`` or ``"radius"``.
        radius: Fixed connection radius in radius mode; None uses PRM*'s
            ``gamma (log n / n)^(1/d)``.
        sampler: Where to sample; default uniform.
        seed: Seed of the planner's generator.
        search: Shortest-path search on the roadmap: ``"astar"`` or ``"dijkstra"`` (same path
            length; Lazy-PRM always uses A*).
    """

    name = "PRM"
    step_parameter = "max_edge_length"
    family = FAMILY_ROADMAP
    lazy = False

    def __init__(self, problem: Problem, *, max_edge_length: float | None = None, k: int = DEFAULT_K,
                 connection: str = "knn", radius: float | None = None, sampler: Sampler | None = None,
                 seed: int | None = None, search: str = "astar") -> None:
        require_problem(problem)
        if search not in (("astar",) if self.lazy else ("astar", "dijkstra")):
            allowed = "'astar'" if self.lazy else "'astar' or 'dijkstra'"
            raise ValueError(f"search must be {allowed} for {self.name}, got {search!r}")
        self.search = search
        if connection not in ("knn", "radius"):
            raise ValueError(f"connection must be 'knn' or 'radius', got {connection!r}")
        if connection == "knn":
            check_int(k, "k")
        for label, v in (("max_edge_length", max_edge_length), ("radius", radius)):
            if v is not None and not (isinstance(v, (int, float, np.number)) and math.isfinite(v) and v > 0):
                raise ValueError(f"{label} must be a positive finite number or None, got {v!r}")
        self.connection = connection
        self.k = int(k) if connection == "knn" else 0
        self.max_edge_length = float(max_edge_length) if max_edge_length is not None else None
        self.radius = float(radius) if radius is not None else None
        # the longest edge it adds, as far as known before it runs (PRM*'s radius shrinks as it grows: not counted)
        limits = [v for v in (self.max_edge_length, self.radius if connection == "radius" else None) if v is not None]
        self.edge_limit = min(limits) if limits else None
        d = problem.dim
        mu = problem.world.free_volume()
        # PRM* constant (Karaman & Frazzoli 2011), with OMPL's 1.1 safety factor
        self.gamma = 1.1 * 2.0 * ((1.0 + 1.0 / d) * mu / unit_ball_volume(d)) ** (1.0 / d)
        super().__init__(problem, sampler=sampler, seed=seed)

    # --- state -----------------------------------------------------------------------------

    def _reset(self) -> None:
        self._store = VertexStore(self.problem, 1024, tree=False)
        self._edges = tuple(np.empty(0, dtype=dt) for dt in (np.int64, np.int64, np.float64, np.int8))
        self._uf = (np.empty(0, np.int64), np.empty(0, np.int64), np.empty(0, np.int64), np.empty(0))
        self._vstat = np.empty(0, dtype=np.int8)
        self._grow_vertex_arrays()
        self._grow_edges(4096)
        self._nbr = np.empty(self._store.capacity, dtype=np.int64)
        self._nbr_d = np.empty(self._store.capacity)
        self._qe = np.empty(self._store.edim)
        self._lazy_path: np.ndarray | None = None
        self._csr: tuple | None = None  # the roadmap's adjacency (``_adjacency``) and the (vertices, edges) it holds
        self._csr_size = (-1, -1)
        self._round_s: float | None = None  # measured seconds per lazy search round (timed solves)
        self._rounds = 1
        self._iter0 = 0
        self._growing = False
        self._start_query()

    def _grow_vertex_arrays(self) -> None:
        cap, n = self._store.capacity, len(self._vstat)

        def grown(a, dtype):
            new = np.zeros(cap, dtype=dtype)
            new[:n] = a[:n]
            return new

        self._uf = tuple(grown(a, a.dtype) for a in self._uf)
        self._vstat = grown(self._vstat, np.int8)
        self._nbr = np.empty(cap, dtype=np.int64)
        self._nbr_d = np.empty(cap)

    def _grow_edges(self, need: int) -> None:
        cap = len(self._edges[0])
        if need <= cap:
            return
        new_cap = max(need, 2 * cap)
        e = int(self._istate[slots.I_E])
        self._edges = tuple(np.concatenate([a[:e], np.zeros(new_cap - e, dtype=a.dtype)]) for a in self._edges)

    def _reserve(self, iterations: int) -> None:
        n = int(self._istate[slots.I_N])
        if self._store.reserve(n, 3):
            self._grow_vertex_arrays()
        per = self.k if self.k else n + 3
        self._grow_edges(int(self._istate[slots.I_E]) + 2 * per)

    def _connect_radius(self) -> float:
        if self.k:
            return 0.0
        n = int(self._istate[slots.I_N])
        if self.radius is not None:
            r = self.radius
        else:
            r = self.gamma * (math.log(n + 1.0) / (n + 1.0)) ** (1.0 / self.problem.dim)
        return min(r, self.max_edge_length) if self.max_edge_length else r

    def _insert_query_state(self, q: np.ndarray) -> int:
        self._reserve(1)
        # a writable copy: the argument types roadmap_run's own call compiles insert_vertex for (no second compile)
        return int(prm_kernels.insert_vertex(np.array(q, dtype=np.float64), self._store.as_tree(), self._edges,
                                             self._uf, self._vstat, self._istate, self.problem.world.kernel,
                                             self._space, self._goal, prm_kernels.neighbourhood(self.k),
                                             self._connect_radius(), self.max_edge_length or 0.0, self.lazy, True,
                                             self._nbr, self._nbr_d, self._qe))

    def _start_query(self) -> None:
        """Add the problem's start and goal as vertices and check whether they are already joined."""
        self._istate[slots.I_SOLVED] = 0
        self._istate[slots.I_FIRST] = -1
        self._fstate[slots.F_BEST_COST] = np.inf
        self._lazy_path = None
        self._iter0 = self.iterations
        prm_kernels.rebuild_components(self._store.as_tree(), self._edges, self._uf, self._vstat, self._istate,
                                       self._goal,
                              self._space)
        self._istate[slots.I_QS] = self._insert_query_state(self.problem.start)
        self._istate[slots.I_QG] = self._insert_query_state(self.problem.goal)
        prm_kernels.refresh_anchor(self._uf, self._istate, self._fstate)
        self._after_growth()

    def _joined(self) -> bool:
        qs, qg = int(self._istate[slots.I_QS]), int(self._istate[slots.I_QG])
        return prm_kernels.uf_find(self._uf, qs) == prm_kernels.uf_find(self._uf, qg)

    def _after_growth(self) -> None:
        if self.solved or not self._joined():
            return
        if self.lazy:
            rounds = LAZY_ROUNDS
            if self._call_budget is not None:  # timed: as many rounds as fit the slice, at most doubling
                rounds = 1 if self._round_s is None else int(
                    max(1, min(LAZY_ROUNDS, 2 * self._rounds, self._call_budget / max(self._round_s, 1e-9))))
            t0, c0 = time.perf_counter(), compile_seconds()
            path = prm_kernels.lazy_resolve(self._store.as_tree(), self._edges, self._adjacency(), self._uf,
                                            self._vstat, self._istate, self._fstate, self.problem.world.kernel,
                                            self._space, self._goal, rounds)
            if len(path):
                self._lazy_path = path
            elif self._joined():  # every round was used: an exact time per round
                self._round_s = (time.perf_counter() - t0 - (compile_seconds() - c0)) / rounds
                self._rounds = rounds
        else:
            self._istate[slots.I_SOLVED] = 1
            if self._istate[slots.I_FIRST] < 0:
                self._istate[slots.I_FIRST] = self.iterations

    def _run(self, points, anchored) -> int:
        used = prm_kernels.roadmap_run(points, anchored, self._store.as_tree(), self._edges, self._uf, self._vstat,
                              self._istate, self._fstate, self._last, self.problem.world.kernel, self._space,
                              self._goal, self._low, self._high, prm_kernels.neighbourhood(self.k), self.gamma,
                              self.radius or 0.0, self.max_edge_length or 0.0, float(self.problem.dim), self.lazy,
                              not self._growing, self._nbr, self._nbr_d)
        if not self._growing:
            self._after_growth()
        return used

    def _adjacency(self) -> tuple:
        """The roadmap's adjacency (``build_csr``), built again only once vertices or edges were added.

        Edges are only ever appended and their statuses are read live, so the adjacency of the same vertex and
        edge counts is the same: a Lazy-PRM solve whose roadmap has not grown since the last search (its search
        rounds only, as under a time limit) does not pay for it again (on a roadmap of 100,000 vertices and a
        million edges, 40 to 75 ms of a round's 90 to 125).
        """
        size = (int(self._istate[slots.I_N]), int(self._istate[slots.I_E]))
        if self._csr is None or size != self._csr_size:
            self._csr, self._csr_size = prm_kernels.build_csr(self._edges, *size), size
        return self._csr

    def _shortest(self, only_valid: bool) -> tuple[np.ndarray, np.ndarray]:
        # two calls from here rather than one kernel that makes the adjacency and searches it: such a wrapper
        # compiles its callees' code once more (0.3 s at a first solve); the flags as np.bool_, as
        # Lazy-PRM's kernel passes them, so the search compiles once for both
        csr = self._adjacency()
        return prm_kernels.astar_csr(self._store.X, csr, self._edges[2], self._edges[3], self._vstat,
                                     int(self._istate[slots.I_QS]), int(self._istate[slots.I_QG]), self._space,
                                     np.bool_(only_valid), np.bool_(self.search == "astar"),
                                     np.full(len(csr[0]) - 1, -1.0))

    def _path(self) -> np.ndarray:
        verts = self._lazy_path if self.lazy else self._shortest(only_valid=True)[0]
        return self._store.X[verts].copy()

    def _vertex_store(self) -> VertexStore:
        return self._store

    # --- multi-query API -----------------------------------------------------------------------

    def grow(self, iterations: int) -> None:
        """Add ``iterations`` samples to the roadmap whatever the current query's state."""
        check_int(iterations, "iterations", low=0)
        t0 = time.perf_counter()
        self._growing = True
        try:
            done = 0
            while done < iterations:
                done += self._consume(min(iterations - done, CHUNK))
        finally:
            self._growing = False
        self._after_growth()
        self._time += time.perf_counter() - t0

    def query(self, start, goal, *, max_iterations: int | None = 0, time_limit: float | None = None,
              name: str | None = None) -> PlanResult:
        """Answer a new query on the current roadmap, growing it within the budget if needed.

        ``PlanResult.iterations`` then counts the samples drawn for this query only. ``name`` names the new
        query's problem (``self.problem``; default: the roadmap's first problem's name).
        """
        self.problem = self.problem.with_query(start, goal, **({} if name is None else {"name": str(name)}))
        self._goal = np.array(self.problem.goal, dtype=np.float64)  # writable, as Planner sets it
        self.sampler = self._sampler_spec.bind(self.problem)
        self._buf_pts = self._buf_pts[:0]
        self._pos = 0
        if time_limit is not None:  # the first lazy search rounds run here, before solve's clock
            self._call_budget = min(float(time_limit), TIME_SLICE) if float(time_limit) > 0 else None
        try:
            self._start_query()
        finally:
            self._call_budget = None
        if self.solved or (max_iterations == 0 and time_limit is None):
            return self.result()
        return self.solve(max_iterations=max_iterations, time_limit=time_limit)

    def result(self) -> PlanResult:
        r = super().result()
        first = r.first_solution_iteration
        # the roadmap's shortest path can improve as it grows, so the cost is that of the path returned
        cost = self.problem.path_length(r.path) if r.solved else float("inf")
        return PlanResult(**{**r.__dict__, "cost": cost, "iterations": r.iterations - self._iter0,
                             "first_solution_iteration": None if first is None else first - self._iter0})

    @property
    def num_edges(self) -> int:
        return int(self._istate[slots.I_E])

    def planner_data(self) -> PlannerData:
        n, e = self.num_vertices, self.num_edges
        eu, ev, _, es = self._edges
        keep = es[:e] != slots.EDGE_INVALID
        edges = np.stack([eu[:e][keep], ev[:e][keep]], axis=1)
        return PlannerData(self._store.X[:n].copy(), edges, np.zeros(n, dtype=np.int64))


@register_planner
class LazyPRM(PRM):
    """Lazy PRM: build the roadmap without collision checks, check only candidate paths.

    Samples and connections are stored unchecked. When start and goal share a component of this
    optimistic roadmap, every vertex of the shortest path is checked, then every edge between valid
    ones; what fails is removed and the search repeats, until a valid path is found or the components
    split (then sampling resumes). Collision checks are therefore far fewer than PRM's.

    R. Bohlin, L. E. Kavraki, "Path planning using Lazy PRM", ICRA 2000,
    doi:10.1109/ROBOT.2000.844107.

    Args: as ``PRM``.
    """

    name = "LazyPRM"
    lazy = True
