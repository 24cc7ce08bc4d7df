"""Map sets in the comparison: a user's map set (``--map-set``) and the unseen test-only families.

Queries here stand beside ``protocol.Query`` and answer the runner the same way (``map_set``,
``split``, ``problem(movingai_dir, tolerance, cache)``), so every run, table, plot and OMPL log treats them
alike.

- A user's map set (``planners.maps.mapset.MapSet``): the baselines are tuned on its ``tuning`` part
  and the comparison is its ``test`` part. Workers reopen the set from its spec (once per process).
- The unseen families (``planners.maps.unseen``): generators used for nothing but testing, so they
  have no tuning split of their own. They are tested with the settings tuned on the generated
  families' tuning maps pooled together (:func:`pooled_tuned`): the honest choice for maps unlike any
  one family, where a per-family setting would have to guess which family they resemble.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from planners import Problem
from planners.maps.mapset import MapQuery, MapSet
from planners.maps.unseen import UNSEEN_FAMILIES, UNSEEN_SEED0, generate_unseen
from planners.tools.benchmark import Run

#: The evaluation's parts of a map set, and the split names its runs carry.
PART_SPLITS = {"tuning": "tuning", "test": "test"}

#: The name of the pooled tuning maps behind the unseen families' settings (never a row of the tables).
GENERATED_POOL = "generated families (pooled tuning maps)"


def unseen_name(family: str) -> str:
    """The map-set name of an unseen family's test maps."""
    return f"{family} (unseen)"


@dataclass(frozen=True)
class UnseenQuery:
    """A test map of an unseen family, rebuilt from (family, seed, size) in a worker."""

    family: str
    key: int  # generator seed
    size: int
    split: str = "test"
    shifted: bool = False

    @property
    def map_set(self) -> str:
        return unseen_name(self.family)

    def problem(self, movingai_dir: str | None, tolerance: float,  # noqa: ARG002 - the runner's interface
                cache: dict | None = None) -> Problem:  # noqa: ARG002
        return generate_unseen(self.family, self.key, self.size, goal_tolerance=tolerance)


def unseen_queries(size: int, n_test: int, families: Sequence[str] = UNSEEN_FAMILIES) -> list[UnseenQuery]:
    """``n_test`` test maps of every unseen family, on seeds from ``UNSEEN_SEED0``."""
    return [UnseenQuery(f, UNSEEN_SEED0 + i, size) for f in families for i in range(n_test)]


def pooled_tuned(runs: Sequence[Run], families: Sequence[str], choose: Callable[[Sequence[Run]], dict],
                 targets: Sequence[str]) -> dict[tuple[str, str], float]:
    """Settings for test-only ``targets`` map sets: ``choose`` (e.g. ``best_bias``) on the families' tuning runs pooled.

    Returns ``{(target, planner): value}`` for every planner tuned on the pool.
    """
    keep = set(families)
    pool = [r for r in runs if r.split == "tuning" and r.map in keep]
    from dataclasses import replace

    chosen = choose([replace(r, map=GENERATED_POOL) for r in pool])
    return {(t, planner): v for (_, planner), v in chosen.items() for t in targets}


def open_map_set(spec: str, split_seed: int, cache: dict | None = None) -> MapSet:
    """``MapSet.open(spec, split_seed=...)``, kept in ``cache`` (a worker's context) for the next call."""
    key = ("map set", spec, split_seed)
    cache = {} if cache is None else cache
    if key not in cache:
        cache[key] = MapSet.open(spec, split_seed=split_seed) if _takes_seed(spec) else MapSet.open(spec)
    return cache[key]


def _takes_seed(spec: str) -> bool:
    # the named sets (generated, shifted, movingai) split by their own seed ranges
    return spec.partition(":")[0] not in ("generated", "shifted", "movingai")


@dataclass(frozen=True)
class MapSetQuery:
    """A query of a user's map set; ``size`` is non-zero so the runner never takes it for a MovingAI scenario."""

    spec: str
    split_seed: int
    query: MapQuery
    size: int = 1
    shifted: bool = False

    @property
    def family(self) -> str:
        return self.query.group

    @property
    def map_set(self) -> str:
        return self.query.group

    @property
    def key(self) -> int:
        return self.query.key

    @property
    def split(self) -> str:
        return PART_SPLITS[self.query.part]

    def problem(self, movingai_dir: str | None, tolerance: float,  # noqa: ARG002 - its own tolerance
                cache: dict | None = None) -> Problem:
        return open_map_set(self.spec, self.split_seed, cache).problem(self.query)


def map_set_queries(spec: str, split_seed: int = 0, cache: dict | None = None) -> tuple[list[MapSetQuery], MapSet]:
    """The tuning and test queries of the map set ``spec`` (checked: both parts hold queries), and the set.

    Raises:
        InputError: The spec names no map set, a map or query is bad, or a part is empty.
    """
    ms = open_map_set(spec, split_seed, cache)
    ms.validate(list(PART_SPLITS))
    qs = [MapSetQuery(spec, split_seed, q) for part in PART_SPLITS for q in ms.queries(part)]
    return qs, ms
