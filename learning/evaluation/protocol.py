"""What the comparison runs on: the protocol (step, tolerance, cap, seeds, split sizes), queries, map sets, splits."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any, ClassVar

from planners import Problem, make_planner
from planners.base.planner import Planner
from planners.base.registry import planner_class
from planners.maps.generators import SHIFTED_SEED0, SHIFTED_SIZES, TEST_SEED0, TUNING_SEED0, generate
from planners.maps.movingai import benchmark_scenarios, scenario_picks
from planners.tools.benchmark import MAX_ITERATIONS, STEP, TOLERANCE


@dataclass(frozen=True)
class Protocol:
    """How every run of the comparison is made, and on how many queries: the one place of its defaults.

    ``step`` is RRT's extension length (and the step the samplers that take one are built with),
    ``tolerance`` the goal tolerance, ``max_iterations`` the cap; unsolved runs count as the cap.
    ``movingai_dir`` is where MovingAI scenarios are read ("" where none are evaluated).
    """

    step: float = STEP
    tolerance: float = TOLERANCE
    max_iterations: int = MAX_ITERATIONS
    seeds: int = 3  # planner seeds per test query
    size: int = 128  # side of the generated test and tuning maps
    maps: int = 50  # test maps per generated family
    tuning_maps: int = 20  # tuning maps per generated family
    shifted_maps: int = 50  # test maps per family from its shifted generator
    unseen_maps: int = 25  # test maps per unseen family (at most ``maps``)
    scenarios: int = 10  # test scenarios per MovingAI map
    tuning_scenarios: int = 5  # tuning scenarios per MovingAI map
    movingai_dir: str = ""

    def quick(self) -> Protocol:
        """The quick form: fewer test queries and planner seeds, the tuning split unchanged.

        The tuning split is the full run's, so the best goal bias is chosen as carefully as in the full
        comparison (tuned on 6 maps, the "best" bias was worse than uniform on the test maps and flattered
        the policy), and 25 maps x 2 seeds keep the quick ratios near the full ones (10 x 1 put narrow
        passage at 0.12 of the best bias against 0.39 in full).
        """
        return replace(self, **QUICK)

    def problem(self, query, cache: dict | None = None) -> Problem:
        """The problem of ``query`` (any query kind of the comparison) under this protocol's tolerance.

        ``cache`` keeps what is loaded for it (MovingAI scenarios, a user's map set) for the next call.
        """
        return query.problem(self.movingai_dir, self.tolerance, cache)

    def planner(self, name: str, problem: Problem, sampler, seed: int) -> tuple[Planner, int]:
        """The planner a run of ``name`` makes on ``problem`` with ``sampler``, and its iteration cap.

        The registry's planner at this protocol's ``step`` as the extension length (roadmaps keep their own edge
        length), stopping at its first solution where it is anytime, capped at ``max_iterations``. Another kind of
        comparison (the 6-DoF scene sets' seed set-ups) overrides it.
        """
        anytime = {"stop_on_first_solution": True} if planner_class(name).anytime else {}
        planner = make_planner(name, problem, extension_step=self.step, sampler=sampler, seed=seed, **anytime)
        return planner, self.max_iterations

    def solve(self, planner: Planner, cap: int, query=None):
        """A run of ``query``: ``(result, progress)``, ``progress`` being ``Run.progress`` ("" here: one solve).

        Other kinds of run: RRT*'s convergence records how its cost fell (``learning.evaluation.convergence``); a
        roadmap's later queries answer another query on the roadmap built for ``query`` (the run records the
        problem the planner answered last, ``planner.problem``; ``learning.evaluation.later_queries``).
        """
        return planner.solve(max_iterations=cap), ""


@dataclass(frozen=True)
class PartQuery:
    """A test query of the comparison that a part runs under a map set of its own: the query's with ``SUFFIX``.

    So ``runs.csv`` and the OMPL logs (one experiment per map set) keep a part's runs apart from the comparison's
    runs of the same query. The problem is the query's own.
    """

    query: Any
    SUFFIX: ClassVar[str] = ""

    @property
    def map_set(self) -> str:
        return self.query.map_set + self.SUFFIX

    @property
    def split(self) -> str:
        return self.query.split

    @property
    def size(self) -> int:
        return self.query.size

    def problem(self, movingai_dir: str | None, tolerance: float, cache: dict | None = None) -> Problem:
        return self.query.problem(movingai_dir, tolerance, cache)

    @classmethod
    def map_set_of(cls, run) -> str:
        """The comparison's map set a run of this kind was made on (its ``map`` without the suffix)."""
        return run.map.removesuffix(cls.SUFFIX)


#: The MovingAI maps the comparison evaluates by default (``scripts/evaluate.py --movingai-maps``).
MOVINGAI_MAPS = ("arena", "den312d", "lak303d", "Berlin_0_256", "maze512-32-0", "random512-10-0", "32room_000",
                 "maze-32-32-2", "room-32-32-4", "room-64-64-8", "random-32-32-10", "random-64-64-20")
#: What :meth:`Protocol.quick` changes.
QUICK = {"maps": 25, "shifted_maps": 25, "unseen_maps": 8, "scenarios": 4, "seeds": 2}


@dataclass(frozen=True)
class Query:
    """A problem reference that worker processes can rebuild cheaply."""

    family: str  # generated family or MovingAI map name
    key: int  # generator seed, or scenario index
    size: int  # generated size (0 for MovingAI)
    split: str  # "test" or "tuning"
    shifted: bool = False  # the family's shifted generator (test split only)

    @property
    def map_set(self) -> str:
        """The map set this query is reported under: the family, its shifted variant, or the MovingAI map."""
        return shifted_name(self.family) if self.shifted else self.family

    def problem(self, movingai_dir: str | None, tolerance: float, cache: dict | None = None) -> Problem:
        """The problem: a generated map rebuilt, or a MovingAI scenario (loaded into ``cache`` where given)."""
        if self.size:
            return generate(self.family, self.key, self.size, goal_tolerance=tolerance, shifted=self.shifted)
        return scenarios(movingai_dir, self.family, tolerance, cache)[self.key]


def movingai_maps(queries: Sequence) -> list[str]:
    """The MovingAI maps among ``queries`` (the queries of no generated size), sorted."""
    return sorted({q.family for q in queries if not q.size})


def shifted_name(family: str) -> str:
    """The map-set name of ``family``'s shifted test maps."""
    return f"{family} (shifted)"


def scenarios(directory: str, name: str, tolerance: float, cache: dict | None = None) -> list[Problem]:
    """The comparison scenarios of MovingAI map ``name`` in ``directory`` (``benchmark_scenarios``).

    ``cache`` (keyed by ``(directory, name, tolerance)``) keeps what was loaded for the next call.
    """
    key = (directory, name, tolerance)
    cache = {} if cache is None else cache
    if key not in cache:
        cache[key] = benchmark_scenarios(directory, name, tolerance)
    return cache[key]


def generated_queries(families: Sequence[str], size: int, n_test: int, n_tune: int) -> list[Query]:
    """``n_test`` test and ``n_tune`` tuning maps per family, on their disjoint seed ranges."""
    return ([Query(f, TEST_SEED0 + i, size, "test") for f in families for i in range(n_test)]
            + [Query(f, TUNING_SEED0 + i, size, "tuning") for f in families for i in range(n_tune)])


def shifted_queries(families: Sequence[str], n_test: int) -> list[Query]:
    """``n_test`` test maps per family from its shifted generator, sides cycling through ``SHIFTED_SIZES``.

    There is no shifted tuning split: baselines keep the setting tuned on the family's own tuning
    maps (:func:`tuned_for_shifted`), as the policy keeps what it learned on the family's training maps.
    """
    return [Query(f, SHIFTED_SEED0 + i, SHIFTED_SIZES[i % len(SHIFTED_SIZES)], "test", shifted=True)
            for f in families for i in range(n_test)]


def tuned_for_shifted(tuned: dict[tuple[str, str], float], queries: Sequence[Query]) -> dict[tuple[str, str], float]:
    """``tuned`` (per (map set, planner)) with each shifted map set given its family's tuned setting."""
    out = dict(tuned)
    for fam in {q.family for q in queries if q.shifted}:
        for (map_set, planner), value in tuned.items():
            if map_set == fam:
                out[(shifted_name(fam), planner)] = value
    return out


def movingai_queries(directory: str, maps: Sequence[str], n_test: int, n_tune: int, tolerance: float,
                     cache: dict | None = None) -> list[Query]:
    """Each map's test and tuning scenarios (``planners.maps.movingai.scenario_picks``).

    ``n_test`` test and ``n_tune`` tuning scenarios per map (fewer where a map has too few). A run with fewer test
    scenarios (``--quick``) tests on the first of the full run's test scenarios and tunes on the same tuning ones.
    """
    out = []
    for m in maps:
        test, tune = scenario_picks(len(scenarios(directory, m, tolerance, cache)), n_test, n_tune)
        out += [Query(m, i, 0, "test") for i in test]
        out += [Query(m, i, 0, "tuning") for i in tune]
    return out
