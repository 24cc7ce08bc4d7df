"""The privileged expert: sample just ahead of the tree's progress along the shortest path.

It knows the map's geodesic distance field (a grid search), so it is a reference and a teacher,
never a competitor: at inference the learned policy sees only its observation.

Progress is the tree vertex with the smallest geodesic distance to the goal; the expert's target is
the point ``lookahead`` steps further along the shortest path from that vertex (found by steepest
descent of the distance field), and samples scatter around it with a spread of ``sigma`` steps.
"""

from __future__ import annotations

import numpy as np

from learning.samplers.ablation import ConstantGuidedSampler
from learning.samplers.route import RouteSampler
from planners import OccupancyGrid, Problem, Sampler, SamplerBase
from planners.base.fileio import InputError
from planners.guidance.follow import FieldFollower, frontier_costs
from planners.maps.gridsearch import distance_field


class GeodesicExpert(FieldFollower):
    """Tracks the tree's geodesic progress and proposes targets ahead of it (the grid search's field).

    Args:
        problem: An ``OccupancyGrid`` problem.
        step_size: The planner's step.
        lookahead: How far ahead of the progress vertex the target lies, in steps.
    """

    def __init__(self, problem: Problem, step_size: float, lookahead: float = 1.0) -> None:
        grid = problem.world
        if not isinstance(grid, OccupancyGrid):
            raise TypeError("the geodesic expert needs an OccupancyGrid problem")
        super().__init__(problem, step_size, distance_field(grid.obstacles, grid.cell_of(problem.goal)), lookahead)


class ExpertSampler(SamplerBase):
    """The privileged expert as a ``Sampler`` (reference only: it runs a grid search).

    Args:
        step_size: The planner's step.
        lookahead: Target distance ahead of the progress vertex, in steps (jittered by 0.5-1.5x).
        sigma: Spread around the target, in steps.
    """

    def __init__(self, step_size: float = 4.0, lookahead: float = 1.0, sigma: float = 0.5) -> None:
        self.step_size, self.lookahead, self.sigma = float(step_size), float(lookahead), float(sigma)

    def _setup(self) -> None:
        self._expert = GeodesicExpert(self.problem, self.step_size, self.lookahead)

    def draw(self, rng, n, view):
        self._expert.update(view.vertices, view.num_vertices)
        q = self._expert.target(rng.uniform(0.5, 1.5)) + rng.normal(0.0, self.sigma * self.step_size, 2)
        return np.clip(q, self.low, np.nextafter(self.high, self.low))[None, :]

    def __repr__(self) -> str:
        return f"ExpertSampler(lookahead={self.lookahead:g}, sigma={self.sigma:g})"


class GeodesicFrontierSampler(ConstantGuidedSampler):
    """The ablation with route knowledge in its frontier: a reference, not a competitor (it runs a grid search).

    It draws the constant ablation's classes (``learning.samplers.ablation``), but its frontier prefers cells
    by their geodesic distance to the goal instead of the straight-line one: what the frontier class
    could do if a network knew the cost-to-go of every cell exactly. ``scripts/experiments/imitation_ceiling.py``
    reports it beside the expert.

    Args:
        frontier: Probability of the frontier class; the rest goes to the cell straight ahead.
        step_size: The planner's step.
    """

    def __init__(self, frontier: float = 0.7, *, step_size: float = 4.0) -> None:
        super().__init__(frontier, step_size=step_size)

    def _setup(self) -> None:
        super()._setup()
        grid = self.problem.world
        self._cost = frontier_costs(distance_field(grid.obstacles, grid.cell_of(self.problem.goal)), grid,
                                    self.guide.frontier.cell)

    def draw(self, rng, n, view):
        f = self.guide.frontier
        f.update(view.vertices, view.num_vertices)
        cells = f.front[:len(f)]
        f.dist[cells] = self._cost[cells]  # the frontier draws by these weights from now on
        return super().draw(rng, n, view)

    def __repr__(self) -> str:
        return f"GeodesicFrontierSampler(frontier={self.frontier:g})"


class CorridorSampler(SamplerBase):
    """Samples the exact corridor of near-shortest paths: a reference, not a competitor (two grid searches).

    With probability ``q`` a sample is uniform over the free cells through which some path from start
    to goal is at most ``slack`` longer than the shortest; otherwise ``base`` draws it. This is what a
    network that predicts the region a path runs through (NEXT, Neural RRT*, Motion Planning
    Transformers) could give a planner at best. ``scripts/experiments/imitation_ceiling.py`` reports it with uniform
    sampling and with the straight-line follower as ``base``.

    Args:
        q: Share of samples from the corridor.
        base: Sampler of the other samples.
        slack: How much longer than the shortest a path through a corridor cell may be (0.1: 10%).
    """

    def __init__(self, q: float, base: Sampler, slack: float = 0.1) -> None:
        if not (0.0 <= q <= 1.0 and slack >= 0.0):
            raise ValueError(f"need 0 <= q <= 1 and slack >= 0, got q={q}, slack={slack}")
        self.q, self.base, self.slack = float(q), base, float(slack)

    def _setup(self) -> None:
        grid = self.problem.world
        if not isinstance(grid, OccupancyGrid):
            raise TypeError("the corridor reference needs an OccupancyGrid problem")
        start, goal = grid.cell_of(self.problem.start), grid.cell_of(self.problem.goal)
        through = distance_field(grid.obstacles, start) + distance_field(grid.obstacles, goal)
        self._cells = np.flatnonzero(np.isfinite(through) & (through <= through[start] * (1.0 + self.slack)))
        self._bound = self.base.bind(self.problem)

    def draw(self, rng, n, view):
        pts = np.array(self._bound.draw(rng, n, view), dtype=np.float64)
        u = rng.random((len(pts), 4))  # one row per sample, whichever source it takes
        grid = self.problem.world
        pick = (u[:, 0] < self.q) & (len(self._cells) > 0)  # no corridor when the goal is cut off
        cells = self._cells[(u[pick, 1] * len(self._cells)).astype(np.int64)]
        pts[pick, 0] = grid.origin[0] + (cells % grid.width + u[pick, 2]) * grid.resolution
        pts[pick, 1] = grid.origin[1] + (cells // grid.width + u[pick, 3]) * grid.resolution
        return np.clip(pts, self.low, np.nextafter(self.high, self.low))

    def __repr__(self) -> str:
        return f"CorridorSampler(q={self.q:g}, base={self.base!r}, slack={self.slack:g})"


class GeodesicRouteSampler(RouteSampler):
    """The route sampler with the exact cost-to-go in place of an encoder: a reference (a grid search).

    ``uses="both"`` (the default) puts the exact field where ``RouteSampler`` puts the encoder's;
    ``"frontier"`` is the straight-line follower whose frontier prefers cells by their geodesic
    distance to the goal (what a perfect cost-to-go encoder could give the follower's frontier), and
    ``"progress"`` the exact field for the progress only. Other keyword arguments are ``RouteSampler``'s.
    """

    USES = ("progress", "frontier", "both")

    def __init__(self, *, uses: str = "both", **kwargs) -> None:
        if uses not in self.USES:
            raise InputError(f"uses must be one of {self.USES}, got {uses!r}")
        super().__init__(None, **kwargs)
        self.uses = uses

    def _fields(self, grid: OccupancyGrid) -> tuple[np.ndarray, np.ndarray | None]:
        exact = distance_field(grid.obstacles, grid.cell_of(self.problem.goal)) * grid.resolution / self.step_size
        progress = self._straight(grid) if self.uses == "frontier" else exact
        return progress, (None if self.uses == "progress" else exact)

    def __repr__(self) -> str:
        return f"GeodesicRouteSampler(stuck={self.stuck}, tau={self.tau:g}, uses={self.uses!r})"
