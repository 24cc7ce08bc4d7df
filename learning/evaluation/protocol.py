"""What the comparison runs on: queries, their map sets and the test and tuning splits."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from planners import Problem
from planners.maps.generators import SHIFTED_SEED0, SHIFTED_SIZES, TEST_SEED0, TUNING_SEED0, generate
from planners.maps.movingai import benchmark_scenarios


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

    def problem(self, movingai_dir: str | None, tolerance: float) -> Problem:
        if self.size:
            return generate(self.family, self.key, self.size, goal_tolerance=tolerance, shifted=self.shifted)
        return scenarios(movingai_dir, self.family, tolerance)[self.key]


def shifted_name(family: str) -> str:
    """The map-set name of ``family``'s shifted test maps."""
    return f"{family} (shifted)"


SCENARIO_CACHE: dict = {}


def scenarios(directory: str, name: str, tolerance: float) -> list[Problem]:
    key = (directory, name, tolerance)
    if key not in SCENARIO_CACHE:
        SCENARIO_CACHE[key] = benchmark_scenarios(directory, name, tolerance)
    return SCENARIO_CACHE[key]


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


def movingai_queries(directory: str, maps: Sequence[str], n_test: int, n_tune: int, tolerance: float) -> list[Query]:
    """The longest half of each map's scenarios, alternately assigned to the test and tuning splits.

    ``n_test`` test and ``n_tune`` tuning scenarios per map (fewer where a map has too few).
    """
    out = []
    for m in maps:
        ps = scenarios(directory, m, tolerance)
        half = max(2, len(ps) // 2)
        stride = max(1, half // (2 * max(n_test, n_tune)))
        picks = list(range(0, half, stride))
        out += [Query(m, i, 0, "test") for i in picks[0::2][:n_test]]
        out += [Query(m, i, 0, "tuning") for i in picks[1::2][:n_tune]]
    return out
