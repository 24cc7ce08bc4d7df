"""Map sets: a set of maps with queries, split by map into training, validation, tuning and test parts.

One notion for every source of maps: the user's folder of map files (or a JSON manifest of them)
(``FileMapSet``), the generated families and their shifted variants (``GeneratedMapSet``,
``ShiftedMapSet``) and the MovingAI benchmark folder (``MovingAIMapSet``). Every map set answers the
same questions::

    ms = MapSet.open("tests/data/ros")          # a folder, a manifest .json, or "generated", "movingai", ...
    print(ms.describe())                        # the maps, the query rule and the split rule
    for q in ms.queries("test"):                # MapQuery: small, picklable references
        problem = ms.problem(q)                 # the Problem it stands for
    problem = ms.sample("train", rng)           # a training episode, drawn with rng
    json.dumps(ms.record())                     # what went in, for a run's outputs

Every constructor checks its input before returning (``validate``): an unreadable map, a query
outside a map, inside an obstacle or in another free component than its other end, and an empty
part are refused with the file, the line and the value. ``docs/map-sets.md`` is the user's guide.
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import os
import stat
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from planners.base.fileio import InputError, check_int, check_json_depth, env_limit
from planners.base.problem import Problem
from planners.maps.generators import (
    FAMILIES,
    SHIFTED_SEED0,
    SHIFTED_SIZES,
    TEST_SEED0,
    TRAIN_SEEDS,
    TUNING_SEED0,
    VALIDATION_SEED0,
    check_size,
    generate,
)
from planners.maps.gridsearch import free_components
from planners.maps.movingai import benchmark_scenarios, load_movingai_scenarios, movingai_dir, scenario_picks
from planners.maps.readers import MAP_READERS, MAX_PIXELS_ENV, ROS_SUFFIXES, max_pixels_limit, read_map
from planners.maps.rosmap import read_ros_yaml
from planners.worlds.grid import OccupancyGrid

#: The parts of a map set, in the order a split fills them.
PARTS = ("train", "validation", "tuning", "test")
#: Share of the maps each part gets unless told otherwise.
DEFAULT_FRACTIONS = {"train": 0.6, "validation": 0.1, "tuning": 0.1, "test": 0.2}
#: Name of the queries file a folder map set reads when it has one (see ``read_queries_file``).
QUERIES_FILE = "queries.csv"
#: Columns of a queries file, in world units (ROS maps: metres in the map frame).
QUERY_COLUMNS = ("map", "start_x", "start_y", "goal_x", "goal_y")
#: Files in a map folder that are not maps (documentation, queries, manifests).
NOT_MAPS = (".md", ".txt", ".csv", ".scen", ".json", ".rst")
#: Drawn queries per map unless told otherwise.
DEFAULT_PER_MAP = 10
#: Most drawn queries per map (every one is drawn when the set opens, about a millisecond each on a
#: few hundred cells a side); ``SAMPLERGYM_MAX_PER_MAP`` raises it.
DEFAULT_MAX_PER_MAP = 1000
MAX_PER_MAP_ENV = "SAMPLERGYM_MAX_PER_MAP"
#: Default goal radius, in cells of the map (so in world units it is this times the resolution).
DEFAULT_TOLERANCE_CELLS = 4.0
#: Default least start-goal distance of drawn queries, as a share of the diagonal of the box around the free cells.
DEFAULT_MIN_DISTANCE_SHARE = 0.25
# start cells tried per drawn query before the map is declared too small for the distance
_DRAW_TRIES = 64


@dataclass(frozen=True)
class MapQuery:
    """One query of a map set: a picklable reference that ``MapSet.problem`` turns into a ``Problem``.

    Attributes:
        group: What results are reported under: the map set's name, a generated family (or its
            shifted variant), or a MovingAI map.
        map: The map's name in its set.
        key: The query's number: its index on the map, a generator seed or a scenario index.
        part: ``"train"``, ``"validation"``, ``"tuning"`` or ``"test"``.
        start: Start (x, y) in world units, or None where the map's own generator or scenario gives it.
        goal: Goal (x, y), as ``start``.
        origin: Where the query comes from, for messages: ``"queries.csv, line 4"``, ``"drawn, seed 0"``.
        reference_length: A published shortest-path length, or None.
    """

    group: str
    map: str
    key: int
    part: str
    start: tuple[float, float] | None = None
    goal: tuple[float, float] | None = None
    origin: str = ""
    reference_length: float | None = None


@dataclass(frozen=True)
class Split:
    """Which maps are in which part, and the rule that put them there (``record`` is JSON-able)."""

    parts: dict[str, tuple[str, ...]]
    rule: dict

    def describe(self) -> str:
        """One line per part: its size and the rule."""
        counts = ", ".join(f"{p} {len(self.parts.get(p, ()))}" for p in PARTS)
        return f"split {self.rule.get('rule')}: {counts} maps ({json.dumps(self.rule, sort_keys=True)})"

    def record(self) -> dict:
        """The rule and the parts' map names, for a run's outputs."""
        return {**self.rule, "parts": {p: list(self.parts.get(p, ())) for p in PARTS}}


def split_by_hash(names: Sequence[str], seed: int = 0, fractions: Mapping[str, float] | None = None) -> Split:
    """Split map names into ``PARTS``: ranked by ``sha256(f"{seed}/{name}")``, cut by counts from the fractions.

    Counts are the fractions times the number of maps, rounded by largest remainder; then every part
    with a positive fraction that came out empty takes a map from the largest part while one has
    more than one map. The same names, seed and fractions always give the same split, whatever
    order the names come in; the parts are disjoint and cover every name.

    Raises:
        InputError: Fractions that name an unknown part, are negative, or sum to 0; repeated names.
    """
    fr = _fractions(fractions)
    names = list(names)
    if len(set(names)) != len(names):
        dup = sorted({n for n in names if names.count(n) > 1})
        raise InputError(f"map names must be unique to split by name; repeated: {dup}")
    seed = int(seed)
    ranked = sorted(names, key=lambda n: (hashlib.sha256(f"{seed}/{n}".encode()).hexdigest(), n))
    counts = _counts(len(names), fr)
    parts, i = {}, 0
    for p in PARTS:
        parts[p] = tuple(sorted(ranked[i:i + counts[p]]))
        i += counts[p]
    rule = {"rule": "sha256-rank", "seed": seed, "fractions": fr,
            "how": "maps ranked by sha256('<seed>/<map name>'); the parts take consecutive runs of that order, "
                   "in the order train, validation, tuning, test, sized by the fractions (largest remainder)"}
    return Split(parts, rule)


def _fractions(fractions: Mapping[str, float] | None) -> dict[str, float]:
    if fractions is None:
        return dict(DEFAULT_FRACTIONS)
    if not isinstance(fractions, Mapping):
        raise InputError(f"fractions must map parts {PARTS} to shares, got {fractions!r}")
    unknown = sorted(set(fractions) - set(PARTS))
    if unknown:
        raise InputError(f"fractions name unknown parts {unknown}; the parts are {PARTS}")
    out = {}
    for p in PARTS:
        v = fractions.get(p, 0.0)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
            raise InputError(f"fractions[{p!r}] must be a finite number >= 0, got {v!r}")
        out[p] = float(v)
    total = sum(out.values())
    if total <= 0:
        raise InputError(f"fractions must have a positive sum, got {dict(fractions)!r}")
    return {p: v / total for p, v in out.items()}


def _counts(n: int, fr: dict[str, float]) -> dict[str, int]:
    exact = {p: fr[p] * n for p in PARTS}
    counts = {p: int(math.floor(exact[p])) for p in PARTS}
    for p in sorted(PARTS, key=lambda p: (-(exact[p] - counts[p]), PARTS.index(p)))[:n - sum(counts.values())]:
        counts[p] += 1
    for p in PARTS:
        if fr[p] > 0 and counts[p] == 0:
            donor = max(PARTS, key=lambda q: (counts[q], -PARTS.index(q)))
            if counts[donor] > 1:
                counts[donor] -= 1
                counts[p] += 1
    return counts


class MapSet:
    """A set of maps with queries, split into ``PARTS``; see the module docstring and ``docs/map-sets.md``.

    Subclasses fill ``name``, ``split`` and implement ``queries``, ``problem``, ``sample`` and ``record``.
    """

    name: str
    split: Split

    @staticmethod
    def open(spec: str | os.PathLike, **kwargs) -> MapSet:
        """A map set from a folder, a manifest ``.json``, or a name: ``generated``, ``shifted`` or ``movingai``.

        ``generated``, ``shifted`` and ``movingai`` may be followed by ``:`` and options:
        ``generated:forest,maze@128`` (families and size), ``shifted:maze``, ``movingai:DIR`` (the
        folder). ``kwargs`` go to the constructor (``FileMapSet``, ``GeneratedMapSet``,
        ``ShiftedMapSet`` or ``MovingAIMapSet``).

        Raises:
            InputError: The spec names nothing that exists, or the set fails ``validate``.
        """
        text = os.fspath(spec)
        kind, _, rest = text.partition(":")
        if kind in ("generated", "shifted") and not Path(text).exists():
            families, _, size = rest.partition("@")
            fams = tuple(f for f in families.split(",") if f) or FAMILIES
            if kind == "generated":
                if size:
                    kwargs["size"] = check_size(_int_option(size, "size", text), f"map set {text!r}: size")
                return GeneratedMapSet(fams, **kwargs)
            if size:
                raise InputError(f"map set {text!r}: shifted maps cycle through the sides {SHIFTED_SIZES}; "
                                 f"a size cannot be given")
            return ShiftedMapSet(fams, **kwargs)
        if kind == "movingai" and not Path(text).exists():
            return MovingAIMapSet(rest or None, **kwargs)
        path = Path(text)
        if path.is_dir() or path.suffix.lower() == ".json":
            return FileMapSet(path, **kwargs)
        if not path.exists():
            why = f"; {text!r} does not exist"
        elif path.is_file():
            why = f"; {text!r} is one map file, read by itself (read_map, or plan.py's map argument), not as a map set"
        else:
            why = ""
        raise InputError(f"map set {text!r}: expected a folder of maps, a manifest .json, "
                         f"'generated[:FAMILIES[@SIZE]]', 'shifted[:FAMILIES]' or 'movingai[:DIR]'{why}")

    # --- the interface -------------------------------------------------------------------------

    def maps(self, part: str | None = None) -> tuple[str, ...]:
        """The map names of ``part`` (every map when None)."""
        if part is None:
            return tuple(sorted({m for p in PARTS for m in self.split.parts.get(p, ())}))
        return self.split.parts[_check_part(part)]

    def queries(self, part: str) -> list[MapQuery]:
        """The fixed queries of ``part``, in a fixed order."""
        raise NotImplementedError

    def problem(self, query: MapQuery) -> Problem:
        """The ``Problem`` a query of this set stands for."""
        raise NotImplementedError

    def problems(self, part: str) -> Iterator[Problem]:
        """The problems of ``queries(part)``."""
        return (self.problem(q) for q in self.queries(part))

    def sample(self, part: str, rng: np.random.Generator) -> Problem:
        """A problem of ``part`` drawn with ``rng`` (training episodes): here one of its fixed queries, uniformly."""
        qs = self.queries(part)
        if not qs:
            raise InputError(f"map set {self.name} has no queries in its {part!r} part ({self.split.describe()})")
        return self.problem(qs[int(rng.integers(len(qs)))])

    def record(self) -> dict:
        """A JSON-able record of the set: what it holds, its query rule and its split (with the map names)."""
        raise NotImplementedError

    def files(self) -> list[Path]:
        """The files the set's problems are read from (maps, scenarios, queries, manifest); none where generated."""
        return []

    def describe(self) -> str:
        """The record in a few printable lines."""
        rec = self.record()
        lines = [f"map set {self.name}: {rec.get('kind')}, {len(self.maps())} maps"]
        lines += [f"  {k}: {json.dumps(v, sort_keys=True)}" for k, v in rec.items() if k not in ("kind", "split")]
        lines.append(f"  {self.split.describe()}")
        return "\n".join(lines)

    def validate(self, parts: Sequence[str] | None = None) -> None:
        """Refuse a set whose ``parts`` (default: every part the split means to fill) hold no query."""
        wanted = [p for p in PARTS if self.split.rule.get("fractions", {}).get(p, 1) > 0] if parts is None else parts
        for p in wanted:
            _check_part(p)
            if not self._has_queries(p):
                maps = self.split.parts.get(p, ())
                what = (f"is empty: its maps {list(maps)} have no queries ({getattr(self, 'query_rule', '')})" if maps
                        else "is empty")
                raise InputError(f"map set {self.name}: the {p!r} part {what} ({self.split.describe()}); "
                                 f"add maps or queries, change the fractions, or assign parts in a manifest")

    def _has_queries(self, part: str) -> bool:
        return bool(self.split.parts.get(part)) and bool(self.queries(part))


def _check_part(part: str) -> str:
    if part not in PARTS:
        raise InputError(f"part must be one of {PARTS}, got {part!r}")
    return part


def _int_option(text: str, what: str, spec: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise InputError(f"map set {spec!r}: {what} must be an integer, got {text!r}") from None


# --- the user's maps ---------------------------------------------------------------------------

@dataclass
class _Map:
    name: str
    path: Path
    grid: OccupancyGrid  # inflated by the robot radius: the space the planner sees
    labels: np.ndarray  # free_components of grid.obstacles
    tolerance: float
    part: str | None = None


class FileMapSet(MapSet):
    """The user's maps: a folder of map files, or a JSON manifest naming them.

    A folder: every file under it (sub-folders included) with a suffix a reader knows
    (``planners.maps.readers.MAP_READERS``) is a map, named by its path relative to the folder
    without the suffix (``<folder>/map.yaml``, map_saver's name, is named ``<folder>``); images a
    ROS ``.yaml`` names are part of that map. ``.md``, ``.txt``,
    ``.csv``, ``.scen``, ``.json`` files and hidden files are skipped; any other file is refused.
    Queries: ``queries.csv`` in the folder if there is one, else the ``.scen`` files if there are
    any, else drawn.

    A manifest (JSON: parsed by the standard library without running anything, and the format the
    project keeps its metadata in) is an object with ``"maps"``, a list of ``{"path": ..., "name":
    ..., "resolution": ..., "origin": [x, y], "part": ...}`` (only ``path`` required; paths are
    relative to the manifest's folder), and optionally any keyword argument below as a key.
    Keyword arguments given here win over the manifest's.

    Args:
        source: The folder or the manifest file.
        queries: ``"drawn"``, ``"scen"`` (each map's MovingAI scenario file ``<stem>*.scen`` next to
            it), or a queries file (``read_queries_file``); default as described above.
        resolution: Cell size in world units of images, ``.map`` and ``.npy`` files (a ROS yaml
            brings its own), default 1.
        origin: World (x, y) of those maps' cell (0, 0) corner, default (0, 0).
        robot_radius: Obstacles grow by this radius (world units) before anything else, default 0.
        threshold: Gray level below which image pixels are obstacles, default 0.5.
        goal_tolerance: Goal radius in world units, default 4 cells of each map.
        per_map: Drawn queries per map, default 10, at most ``DEFAULT_MAX_PER_MAP`` (1,000; raised by
            ``SAMPLERGYM_MAX_PER_MAP``).
        min_distance: Least straight-line start-goal distance of drawn queries in world units,
            default a quarter of the diagonal of the box around each map's free cells.
        seed: Seed of the drawn queries (each map's queries depend on it and the map's name only).
        split_seed: Seed of the split (``split_by_hash``).
        fractions: Share of the maps per part, default ``DEFAULT_FRACTIONS``.
        name: The set's name in outputs, default the folder's or manifest's name.
        max_pixels: Largest map accepted, in cells (``planners.maps.readers.max_pixels_limit``). Given
            here it may raise the limit; a manifest's may only lower it (one above is refused).

    Raises:
        InputError: Anything ``validate`` refuses, before any query is planned.
    """

    _OPTIONS = ("queries", "resolution", "origin", "robot_radius", "threshold", "goal_tolerance", "per_map",
                "min_distance", "seed", "split_seed", "fractions", "name", "max_pixels")

    def __init__(self, source: str | os.PathLike, *, queries: str | os.PathLike | None = None,
                 resolution: float | None = None, origin: Sequence[float] | None = None,
                 robot_radius: float | None = None, threshold: float | None = None,
                 goal_tolerance: float | None = None, per_map: int | None = None, min_distance: float | None = None,
                 seed: int | None = None, split_seed: int | None = None,
                 fractions: Mapping[str, float] | None = None, name: str | None = None,
                 max_pixels: int | None = None) -> None:
        source = Path(source)
        given = {k: v for k, v in dict(queries=queries, resolution=resolution, origin=origin,
                                       robot_radius=robot_radius, threshold=threshold,
                                       goal_tolerance=goal_tolerance, per_map=per_map, min_distance=min_distance,
                                       seed=seed, split_seed=split_seed, fractions=fractions, name=name,
                                       max_pixels=max_pixels).items() if v is not None}
        if source.is_dir():
            entries, opts, root = _folder_entries(source), {}, source
        elif source.is_file():
            entries, opts = _manifest(source)
            root = source.parent
        else:
            raise InputError(f"map set {str(source)!r} does not exist; expected a folder of maps or a manifest .json")
        if "max_pixels" in opts and "max_pixels" not in given:  # a file may lower the limit in force, never raise it
            limit, mp = max_pixels_limit(), opts["max_pixels"]
            check_int(mp, f"manifest {source}: max_pixels")
            if mp > limit:
                raise InputError(f"manifest {source}: max_pixels = {mp:,} is above the limit in force ({limit:,}); a "
                                 f"manifest may only lower it. To raise it, set {MAX_PIXELS_ENV} or pass max_pixels= "
                                 "in code")
        opts.update(given)
        self.source = source
        self.name = str(opts.get("name", source.stem if source.is_file() else source.name))
        self.options = {k: opts[k] for k in self._OPTIONS if k in opts and k != "name"}
        self.seed = check_int(opts.get("seed", 0), f"map set {source}: seed", low=0)
        self.per_map = check_int(opts.get("per_map", DEFAULT_PER_MAP), f"map set {source}: per_map", low=1)
        most = env_limit(MAX_PER_MAP_ENV, DEFAULT_MAX_PER_MAP)
        if self.per_map > most:
            raise InputError(f"map set {source}: per_map = {self.per_map:,} drawn queries per map, more than the limit "
                             f"of {most:,} (each is drawn when the set opens); set {MAX_PER_MAP_ENV} to raise it")
        self.min_distance = _positive(opts.get("min_distance"), "min_distance", source)
        robot_radius = _positive(opts.get("robot_radius", 0.0), "robot_radius", source, zero=True)
        tolerance = _positive(opts.get("goal_tolerance"), "goal_tolerance", source)
        self.maps_by_name: dict[str, _Map] = {}
        for entry in entries:
            m = _load_entry(entry, root, opts, robot_radius, tolerance)
            if m.name in self.maps_by_name:
                raise InputError(f"map set {source}: two maps are named {m.name!r} "
                                 f"({self.maps_by_name[m.name].path} and {m.path}); rename one")
            self.maps_by_name[m.name] = m
        if not self.maps_by_name:
            raise InputError(f"map set {source}: no maps found; readable kinds are {sorted(MAP_READERS)}")
        assigned = [m for m in self.maps_by_name.values() if m.part is not None]
        if assigned:
            if len(assigned) != len(self.maps_by_name):
                loose = sorted(m.name for m in self.maps_by_name.values() if m.part is None)
                raise InputError(f"manifest {source}: some maps give a 'part' and others do not ({loose}); give "
                                 f"every map a part, or none (then the seeded split assigns them)")
            parts = {p: tuple(sorted(m.name for m in assigned if m.part == p)) for p in PARTS}
            self.split = Split(parts, {"rule": "manifest", "fractions": {p: float(bool(parts[p])) for p in PARTS},
                                       "how": f"each map's 'part' in {source.name}"})
        else:
            split_seed = check_int(opts.get("split_seed", 0), f"map set {source}: split_seed", low=0)
            self.split = split_by_hash(list(self.maps_by_name), split_seed, opts.get("fractions"))
        self._drawn_queries: dict[str, list[MapQuery]] = {}
        self._query_files: list[Path] = []
        self._queries = self._read_queries(opts.get("queries"), root if "queries" not in given else Path.cwd())
        self.validate()

    # --- queries -------------------------------------------------------------------------------

    def _read_queries(self, rule, root: Path) -> dict[str, list[MapQuery]] | None:
        """Fixed queries by map (from a file or scenarios), or None for drawn queries."""
        if rule is None:
            if self.source.is_dir() and os.path.lexists(self.source / QUERIES_FILE):  # a folder or FIFO is refused
                rule = self.source / QUERIES_FILE
            elif self.source.is_dir() and any(self.source.rglob("*.scen")):
                rule = "scen"
            else:
                rule = "drawn"
        self.query_rule = str(rule)
        if rule == "drawn":
            return None
        if rule == "scen":
            return self._scen_queries()
        return self._file_queries(root / Path(rule))  # relative to the manifest, or as given

    def _part_of(self, name: str) -> str:
        return next(p for p in PARTS if name in self.split.parts[p])

    def _file_queries(self, path: Path) -> dict[str, list[MapQuery]]:
        out: dict[str, list[MapQuery]] = {n: [] for n in self.maps_by_name}
        self._query_files.append(path)
        for lineno, name, start, goal in read_queries_file(path):
            where = f"{path}, line {lineno}"
            if name not in self.maps_by_name:
                raise InputError(f"{where}: map {name!r} is not in map set {self.name} "
                                 f"(its maps: {', '.join(sorted(self.maps_by_name))})")
            m = self.maps_by_name[name]
            _check_query(m, start, goal, where)
            out[name].append(MapQuery(self.name, name, len(out[name]), self._part_of(name), start, goal, where))
        return out

    def _scen_queries(self) -> dict[str, list[MapQuery]]:
        out: dict[str, list[MapQuery]] = {n: [] for n in self.maps_by_name}
        for name, m in self.maps_by_name.items():
            if m.path.suffix.lower() != ".map":
                continue
            scens = sorted(p for p in m.path.parent.glob(f"{m.path.stem}*.scen")
                           if p.name.split(".")[0].replace("-random-1", "") == m.path.stem)
            for scen in scens:
                self._query_files.append(scen)
                for p in load_movingai_scenarios(scen, map_path=m.path):
                    # the scenario counts cells; the set's map may have a resolution and an origin
                    where = f"{scen}, line {p.name.rpartition('#')[2]}"
                    start, goal = (tuple(float(v) for v in m.grid.origin + q * m.grid.resolution)
                                   for q in (p.start, p.goal))
                    _check_query(m, start, goal, where)
                    ref = p.reference_length * m.grid.resolution
                    out[name].append(MapQuery(self.name, name, len(out[name]), self._part_of(name), start, goal,
                                              where, ref))
        return out

    def _drawn(self, m: _Map) -> list[MapQuery]:
        """The map's ``per_map`` drawn queries: from ``seed`` and the map's name only, drawn once."""
        if m.name not in self._drawn_queries:
            rng = np.random.default_rng([self.seed, _name_key(m.name)])
            part = self._part_of(m.name)
            out = []
            for i in range(self.per_map):
                start, goal = draw_query(m.grid, m.labels, rng, self._min_distance(m), m.tolerance)
                out.append(MapQuery(self.name, m.name, i, part, start, goal, f"drawn, seed {self.seed}"))
            self._drawn_queries[m.name] = out
        return self._drawn_queries[m.name]

    def _min_distance(self, m: _Map) -> float:
        if self.min_distance is not None:
            return self.min_distance
        rows, cols = np.nonzero(m.labels >= 0)  # the free cells' bounding box: ROS maps are mostly unknown
        extent = np.hypot(rows.max() - rows.min() + 1, cols.max() - cols.min() + 1)
        return DEFAULT_MIN_DISTANCE_SHARE * float(extent) * m.grid.resolution

    def queries(self, part: str) -> list[MapQuery]:
        out = []
        for name in self.maps(part):
            out += self._queries[name] if self._queries is not None else self._drawn(self.maps_by_name[name])
        return out

    def problem(self, query: MapQuery) -> Problem:
        m = self.maps_by_name[query.map]
        return Problem(m.grid, query.start, query.goal, goal_tolerance=m.tolerance, name=f"{m.name}#{query.key}",
                       reference_length=query.reference_length)

    def sample(self, part: str, rng: np.random.Generator) -> Problem:
        """A query of ``part`` drawn with ``rng``: a fresh drawn query on a random map, or a random fixed query."""
        names = self.maps(part)
        if self._queries is not None or not names:
            return super().sample(part, rng)
        m = self.maps_by_name[names[int(rng.integers(len(names)))]]
        start, goal = draw_query(m.grid, m.labels, rng, self._min_distance(m), m.tolerance)
        return Problem(m.grid, start, goal, goal_tolerance=m.tolerance, name=m.name)

    def files(self) -> list[Path]:
        out = [self.source] if self.source.is_file() else []
        for m in sorted(self.maps_by_name.values(), key=lambda m: m.name):
            out.append(m.path)
            if m.path.suffix.lower() in ROS_SUFFIXES:
                out.append(read_ros_yaml(m.path)["image"])
        return out + self._query_files

    def record(self) -> dict:
        maps = {n: {"path": str(m.path), "shape": list(m.grid.shape), "resolution": m.grid.resolution,
                    "origin": [float(v) for v in m.grid.origin], "goal_tolerance": m.tolerance}
                for n, m in sorted(self.maps_by_name.items())}
        return {"kind": "files", "name": self.name, "source": str(self.source), "queries": self.query_rule,
                "options": {k: (str(v) if isinstance(v, os.PathLike) else list(v) if isinstance(v, tuple) else v)
                            for k, v in self.options.items() if k != "fractions"},
                "maps": maps, "split": self.split.record()}

    def _has_queries(self, part: str) -> bool:
        if self._queries is None:
            return bool(self.maps(part))
        return any(self._queries[n] for n in self.maps(part))

    def validate(self, parts: Sequence[str] | None = None) -> None:
        """Refuse an empty part; for drawn queries, a map where the queries of the least distance do not fit."""
        super().validate(parts)
        if self._queries is None:
            for m in self.maps_by_name.values():
                self._drawn(m)


def _name_key(name: str) -> int:
    """A stable 63-bit integer of a map name (seeds its drawn queries)."""
    return int.from_bytes(hashlib.sha256(name.encode()).digest()[:8], "little") >> 1


def _positive(value, what: str, source: Path, zero: bool = False) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or value < 0 or (value == 0 and not zero):
        raise InputError(f"map set {source}: {what} must be a {'non-negative' if zero else 'positive'} number of "
                         f"world units, got {value!r}")
    return float(value)


def _folder_entries(folder: Path) -> list[dict]:
    files = sorted(p for p in folder.rglob("*") if p.is_file()
                   and not any(part.startswith(".") for part in p.relative_to(folder).parts))
    images = set()
    for p in files:
        if p.suffix.lower() in ROS_SUFFIXES:
            images.add(read_ros_yaml(p)["image"].resolve())
    entries = []
    for p in files:
        suffix = p.suffix.lower()
        if suffix in NOT_MAPS or p.name.lower().startswith("readme") or p.resolve() in images:
            continue
        if suffix not in MAP_READERS:
            raise InputError(f"map set {folder}: {p} is not a map file a reader knows (suffix {suffix or '(none)'!r}; "
                             f"known: {', '.join(sorted(MAP_READERS))}); move it out of the folder")
        entries.append({"path": str(p.relative_to(folder)), "name": _default_name(p.relative_to(folder))})
    return entries


def _default_name(relative: Path) -> str:
    """A map's name from its relative path: without the suffix, and ``<folder>/map.yaml`` is ``<folder>``."""
    stem = relative.with_suffix("")
    if stem.name == "map" and stem.parent != Path("."):
        stem = stem.parent
    return stem.as_posix()


def _manifest(path: Path) -> tuple[list[dict], dict]:
    try:
        text = path.read_text(encoding="utf-8")
        check_json_depth(text, f"manifest {path}")
        data = json.loads(text)
    except UnicodeDecodeError as exc:
        raise InputError(f"manifest {path}: not UTF-8 text ({exc})") from None
    except json.JSONDecodeError as exc:
        raise InputError(f"manifest {path}, line {exc.lineno}: not valid JSON: {exc.msg}") from None
    if not isinstance(data, dict) or not isinstance(data.get("maps"), list):
        raise InputError(f"manifest {path}: expected a JSON object with a list \"maps\"")
    unknown = sorted(set(data) - {"maps", *FileMapSet._OPTIONS})
    if unknown:
        raise InputError(f"manifest {path}: unknown keys {unknown}; known: maps, {', '.join(FileMapSet._OPTIONS)}")
    entries = []
    for i, e in enumerate(data["maps"]):
        if isinstance(e, str):
            e = {"path": e}
        if not isinstance(e, dict) or not isinstance(e.get("path"), str):
            raise InputError(f"manifest {path}: maps[{i}] must be a path or an object with a \"path\", got {e!r}")
        bad = sorted(set(e) - {"path", "name", "resolution", "origin", "part"})
        if bad:
            raise InputError(f"manifest {path}: maps[{i}] has unknown keys {bad}; known: path, name, resolution, "
                             f"origin, part")
        if "part" in e and e["part"] not in PARTS:
            raise InputError(f"manifest {path}: maps[{i}] part {e['part']!r} is not one of {PARTS}")
        entries.append(dict(e, where=f"manifest {path}: maps[{i}]"))
    return entries, {k: v for k, v in data.items() if k != "maps"}


def _load_entry(entry: dict, root: Path, opts: dict, robot_radius: float, tolerance: float | None) -> _Map:
    path = Path(entry["path"])
    if not path.is_absolute():
        path = root / path
    where = entry.get("where", f"map set {root}")
    if path.is_dir() or not Path(entry["path"]).name:
        raise InputError(f"{where}: path {entry['path']!r} is {'a folder' if path.is_dir() else 'empty'}, expected "
                         "a map file (list the maps of a folder one by one, or open the folder as the map set)")
    name = str(entry.get("name") or _default_name(Path(entry["path"])))
    ros = path.suffix.lower() in ROS_SUFFIXES
    if ros and ("resolution" in entry or "origin" in entry):
        raise InputError(f"{where}: {path} is a ROS map.yaml, which sets its own resolution and origin; "
                         f"remove them from its entry")
    # a ROS yaml brings its own resolution, origin and thresholds; the set's apply to the other kinds
    resolution = None if ros else entry.get("resolution", opts.get("resolution"))
    origin = None if ros else entry.get("origin", opts.get("origin"))
    kwargs = {"max_pixels": opts.get("max_pixels")}
    if not ros:
        kwargs["threshold"] = opts.get("threshold", 0.5)
        if resolution is not None:
            kwargs["resolution"] = resolution
    try:
        grid = read_map(path, **kwargs)
    except FileNotFoundError as exc:
        raise InputError(f"{where}: {exc}") from None
    except InputError as exc:
        raise InputError(f"{where}: unreadable map {path}: {exc}") from None
    if origin is not None:
        grid = OccupancyGrid(grid.obstacles, grid.resolution, origin=origin, y_up=grid.y_up, source=grid.source)
    if robot_radius:
        grid = grid.inflate(robot_radius)
    labels = free_components(grid.obstacles)
    if not (labels >= 0).any():
        raise InputError(f"{where}: map {path} has no free cell"
                         + (f" once inflated by robot_radius {robot_radius:g}" if robot_radius else ""))
    tol = tolerance if tolerance is not None else DEFAULT_TOLERANCE_CELLS * grid.resolution
    return _Map(name, path, grid, labels, tol, entry.get("part"))


def read_queries_file(path: str | os.PathLike) -> Iterator[tuple[int, str, tuple[float, float], tuple[float, float]]]:
    """Rows of a queries file: ``(line, map name, (start x, start y), (goal x, goal y))`` in world units.

    The format: CSV with the header ``map,start_x,start_y,goal_x,goal_y`` (``QUERY_COLUMNS``), one
    query a line; blank lines and lines starting with ``#`` are skipped. ``map`` is a map's name in
    the set (its path relative to the folder, without the suffix).

    Raises:
        InputError: A missing file, one that is not a regular file (a folder, a FIFO, a device), a
            wrong header, a short row or a value that is not a finite number; the message names the
            file, the line and the value.
    """
    path = Path(path)
    try:
        mode = path.stat().st_mode
    except OSError:
        raise InputError(f"queries file {str(path)!r} does not exist") from None
    if not stat.S_ISREG(mode):
        kind = ("a folder" if stat.S_ISDIR(mode) else "a FIFO" if stat.S_ISFIFO(mode) else
                "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else "not a regular file")
        raise InputError(f"queries file {str(path)!r} is {kind}; expected a regular file")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(f"queries file {path}: not UTF-8 text ({exc})") from None
    header = None
    for lineno, row in _csv_rows(path, text):
        if not row or not "".join(row).strip() or row[0].lstrip().startswith("#"):
            continue
        row = [v.strip() for v in row]
        if header is None:
            if tuple(row) != QUERY_COLUMNS:
                raise InputError(f"{path}, line {lineno}: expected the header {','.join(QUERY_COLUMNS)}, got "
                                 f"{','.join(row)!r}")
            header = row
            continue
        if len(row) != len(QUERY_COLUMNS):
            raise InputError(f"{path}, line {lineno}: expected {len(QUERY_COLUMNS)} values "
                             f"({','.join(QUERY_COLUMNS)}), got {len(row)}: {','.join(row)!r}")
        values = []
        for col, v in zip(QUERY_COLUMNS[1:], row[1:], strict=True):
            try:
                x = float(v)
            except ValueError:
                x = math.nan
            if not math.isfinite(x):
                raise InputError(f"{path}, line {lineno}: {col} must be a finite number, got {v!r}")
            values.append(x)
        yield lineno, row[0], (values[0], values[1]), (values[2], values[3])
    if header is None:
        raise InputError(f"queries file {path} is empty; expected the header {','.join(QUERY_COLUMNS)}")


def _csv_rows(path: Path, text: str) -> Iterator[tuple[int, list[str]]]:
    """The CSV rows of ``text`` with their line numbers; a malformed row is an ``InputError`` naming the line."""
    reader = csv.reader(text.splitlines())
    while True:
        try:
            row = next(reader)
        except StopIteration:
            return
        except csv.Error as exc:
            why = (f"a value longer than the {csv.field_size_limit() // 1024} KiB a field may hold"
                   if "field larger than field limit" in str(exc) else str(exc))
            raise InputError(f"{path}, line {reader.line_num}: {why}") from None
        yield reader.line_num, row


def _check_query(m: _Map, start, goal, where: str) -> None:
    """Refuse a query end outside the map or in an obstacle (of the inflated map), or ends in two components."""
    grid = m.grid
    cells = []
    for label, q in (("start", start), ("goal", goal)):
        why = grid.explain_invalid(np.asarray(q, dtype=float))
        if why:
            raise InputError(f"{where}: {label} ({q[0]:g}, {q[1]:g}) on map {m.name!r} {why}")
        cells.append(grid.cell_of(q))
    (ra, ca), (rb, cb) = cells
    if m.labels[ra, ca] != m.labels[rb, cb]:
        raise InputError(f"{where}: start ({start[0]:g}, {start[1]:g}) and goal ({goal[0]:g}, {goal[1]:g}) on map "
                         f"{m.name!r} lie in two free regions that no path joins")


def draw_query(grid: OccupancyGrid, labels: np.ndarray, rng: np.random.Generator, min_distance: float,
               goal_tolerance: float = 0.0) -> tuple[tuple[float, float], tuple[float, float]]:
    """A start and goal at free cell centres of one free component, at least ``min_distance`` apart.

    The start is a uniform free cell (so larger components are likelier); the goal is uniform among
    the cells of the start's component at least ``min_distance`` (and more than ``goal_tolerance``)
    away in a straight line. ``labels`` is ``free_components(grid.obstacles)``.

    Raises:
        InputError: No such pair found from ``_DRAW_TRIES`` starts: the map is too small or too
            broken up for the distance (the message names the map and the distance).
    """
    flat = labels.ravel()
    free = np.flatnonzero(flat >= 0)
    free_labels = flat[free]
    width, res = grid.width, grid.resolution
    need = max(float(min_distance), float(goal_tolerance) + 1e-9)
    for _ in range(_DRAW_TRIES):
        a = int(free[rng.integers(len(free))])
        comp = free[free_labels == flat[a]]
        ra, ca = divmod(a, width)
        rows, cols = np.divmod(comp, width)
        far = comp[np.hypot(rows - ra, cols - ca) * res >= need]
        if far.size:
            b = int(far[rng.integers(far.size)])
            s, g = grid.cell_center(ra, ca), grid.cell_center(*divmod(b, width))
            return (float(s[0]), float(s[1])), (float(g[0]), float(g[1]))
    raise InputError(f"map {grid.source or grid}: found no start and goal in one free region at least {need:g} world "
                     f"units apart in {_DRAW_TRIES} tries; give a smaller min_distance")


# --- the generated families and the MovingAI folder ---------------------------------------------

class GeneratedMapSet(MapSet):
    """The generated families as a map set: the seed ranges of ``planners.maps.generators`` are its parts.

    Test maps take seeds ``TEST_SEED0 + i``, tuning maps ``TUNING_SEED0 + i`` and validation maps
    ``VALIDATION_SEED0 + i`` (sides cycling through ``validation_sizes``), family by family; the
    training part is the whole ``TRAIN_SEEDS`` range, drawn by ``sample``. One query per map: the
    generator's own.

    Args:
        families: Families, default all of ``FAMILIES``.
        size: Side of the test and tuning maps.
        n_test: Test maps per family.
        n_tune: Tuning maps per family.
        n_validation: Validation maps per family.
        validation_sizes: Sides of the validation maps, in turn.
        train_sizes: Sides ``sample("train", ...)`` draws from.
        goal_tolerance: Goal radius (cells).
    """

    def __init__(self, families: Sequence[str] = FAMILIES, size: int = 128, n_test: int = 25, n_tune: int = 10,
                 n_validation: int = 10, validation_sizes: Sequence[int] = (64, 128),
                 train_sizes: Sequence[int] = (64, 128), goal_tolerance: float = 4.0) -> None:
        self.families = _families(families)
        self.size, self.goal_tolerance = check_size(size, "size"), float(goal_tolerance)
        for what, sides in (("validation_sizes", validation_sizes), ("train_sizes", train_sizes)):
            for side in sides:
                check_size(side, what)
        self.n = {"test": check_int(n_test, "n_test", low=0), "tuning": check_int(n_tune, "n_tune", low=0),
                  "validation": check_int(n_validation, "n_validation", low=0)}
        self.validation_sizes, self.train_sizes = tuple(validation_sizes), tuple(train_sizes)
        self.name = "generated"
        seeds = {"test": TEST_SEED0, "tuning": TUNING_SEED0, "validation": VALIDATION_SEED0}
        self._queries = {p: [MapQuery(f, f"{f}-{self._side(p, i)}-{seeds[p] + i}", seeds[p] + i, p)
                             for f in self.families for i in range(self.n[p])] for p in seeds}
        self._queries["train"] = []
        parts = {p: tuple(q.map for q in self._queries[p]) for p in PARTS}
        self.split = Split(parts, {"rule": "seed-ranges", "fractions": {p: float(p == "train" or self.n[p] > 0)
                                                                         for p in PARTS},
                                   "train_seeds": list(TRAIN_SEEDS), "validation_seed0": VALIDATION_SEED0,
                                   "tuning_seed0": TUNING_SEED0, "test_seed0": TEST_SEED0,
                                   "how": "each part its own generator seed range (planners.maps.generators)"})
        self.validate()

    def _side(self, part: str, i: int) -> int:
        return self.validation_sizes[i % len(self.validation_sizes)] if part == "validation" else self.size

    def queries(self, part: str) -> list[MapQuery]:
        return list(self._queries[_check_part(part)])

    def problem(self, query: MapQuery) -> Problem:
        size = int(query.map.rsplit("-", 2)[1])
        return generate(query.group, query.key, size, goal_tolerance=self.goal_tolerance)

    def sample(self, part: str, rng: np.random.Generator) -> Problem:
        if part != "train":
            return super().sample(part, rng)
        choices = [(f, s) for f in self.families for s in self.train_sizes]
        family, size = choices[int(rng.integers(len(choices)))]
        return generate(family, int(rng.integers(*TRAIN_SEEDS)), size, goal_tolerance=self.goal_tolerance)

    def _has_queries(self, part: str) -> bool:
        return part == "train" or bool(self._queries[part])

    def record(self) -> dict:
        return {"kind": "generated", "name": self.name, "families": list(self.families), "size": self.size,
                "per_family": dict(self.n), "validation_sizes": list(self.validation_sizes),
                "train_sizes": list(self.train_sizes), "goal_tolerance": self.goal_tolerance,
                "split": {k: v for k, v in self.split.rule.items()}}


class ShiftedMapSet(MapSet):
    """The families' shifted variants (``generate(..., shifted=True)``): a test-only map set.

    ``n_test`` maps per family, seeds ``SHIFTED_SEED0 + i``, sides cycling through ``SHIFTED_SIZES``;
    each query's group is ``"<family> (shifted)"``.
    """

    def __init__(self, families: Sequence[str] = FAMILIES, n_test: int = 25, goal_tolerance: float = 4.0) -> None:
        self.families = _families(families)
        self.n_test, self.goal_tolerance = check_int(n_test, "n_test"), float(goal_tolerance)
        self.name = "shifted"
        self._test = [MapQuery(f"{f} (shifted)", f"{f}-shifted-{SHIFTED_SIZES[i % len(SHIFTED_SIZES)]}-"
                               f"{SHIFTED_SEED0 + i}", SHIFTED_SEED0 + i, "test")
                      for f in self.families for i in range(self.n_test)]
        parts = {p: (tuple(q.map for q in self._test) if p == "test" else ()) for p in PARTS}
        self.split = Split(parts, {"rule": "test-only", "fractions": {p: float(p == "test") for p in PARTS},
                                   "shifted_seed0": SHIFTED_SEED0, "sizes": list(SHIFTED_SIZES),
                                   "how": "every shifted map is a test map"})
        self.validate()

    def queries(self, part: str) -> list[MapQuery]:
        return list(self._test) if _check_part(part) == "test" else []

    def problem(self, query: MapQuery) -> Problem:
        family = query.group.removesuffix(" (shifted)")
        size = int(query.map.rsplit("-", 2)[1])
        return generate(family, query.key, size, goal_tolerance=self.goal_tolerance, shifted=True)

    def record(self) -> dict:
        return {"kind": "shifted", "name": self.name, "families": list(self.families), "per_family": self.n_test,
                "goal_tolerance": self.goal_tolerance, "split": dict(self.split.rule)}


class MovingAIMapSet(MapSet):
    """The MovingAI benchmark folder as a map set: scenarios of each map split into test and tuning queries.

    Each map's scenarios farther apart than the goal tolerance, longest first: of the longest half,
    every stride-th goes alternately to the test and the tuning part (``n_test`` and ``n_tune`` per map, fewer
    where a map has too few; ``planners.maps.movingai.scenario_picks``, as the comparison picks them).
    Unlike a user's set, this splits the queries of one map, not the maps: the maps are a test
    collection, never trained on.

    Args:
        directory: The folder (``planners.maps.movingai.movingai_dir``).
        maps: Map names (stems); default every map with a scenario file.
        n_test: Test scenarios per map.
        n_tune: Tuning scenarios per map.
        goal_tolerance: Goal radius (cells).
    """

    def __init__(self, directory: str | os.PathLike | None = None, maps: Sequence[str] | None = None,
                 n_test: int = 10, n_tune: int = 4, goal_tolerance: float = 4.0) -> None:
        self.directory = movingai_dir(directory)
        scen_maps = sorted({p.name.split(".")[0].replace("-random-1", "") for p in self.directory.glob("*.scen")})
        self.names = tuple(scen_maps if maps is None else maps)
        missing = sorted(set(self.names) - set(scen_maps))
        if missing:
            raise InputError(f"MovingAI map set: no scenario file for maps {missing} in {self.directory}")
        self.n_test, self.n_tune = check_int(n_test, "n_test", low=0), check_int(n_tune, "n_tune", low=0)
        self.goal_tolerance = float(goal_tolerance)
        self.name = "movingai"
        self._problems = {m: self._scenarios(m) for m in self.names}
        self._queries: dict[str, list[MapQuery]] = {p: [] for p in PARTS}
        for m in self.names:
            test, tune = scenario_picks(len(self._problems[m]), self.n_test, self.n_tune)
            self._queries["test"] += [MapQuery(m, m, i, "test") for i in test]
            self._queries["tuning"] += [MapQuery(m, m, i, "tuning") for i in tune]
        parts = {p: tuple(dict.fromkeys(q.map for q in self._queries[p])) for p in PARTS}
        fr = {"train": 0.0, "validation": 0.0, "tuning": float(self.n_tune > 0), "test": float(self.n_test > 0)}
        self.split = Split(parts, {"rule": "movingai-scenarios", "fractions": fr, "n_test": self.n_test,
                                   "n_tune": self.n_tune,
                                   "how": "each map's longest half of scenarios, every stride-th alternately to "
                                          "test and tuning"})
        self.validate()

    def _scenarios(self, name: str) -> list[Problem]:
        return benchmark_scenarios(self.directory, name, self.goal_tolerance)

    def queries(self, part: str) -> list[MapQuery]:
        return list(self._queries[_check_part(part)])

    def problem(self, query: MapQuery) -> Problem:
        return self._problems[query.map][query.key]

    def files(self) -> list[Path]:
        out = []
        for m in self.names:
            out += [p for p in sorted(self.directory.glob(f"{m}*.scen"))
                    if p.name.split(".")[0].replace("-random-1", "") == m]
            out += [p for p in (self.directory / f"{m}.map",) if p.is_file()]
        return out

    def record(self) -> dict:
        return {"kind": "movingai", "name": self.name, "directory": str(self.directory), "maps": list(self.names),
                "goal_tolerance": self.goal_tolerance, "split": dict(self.split.rule)}


def _families(families: Sequence[str]) -> tuple[str, ...]:
    fams = tuple(families)
    bad = [f for f in fams if f not in FAMILIES]
    if bad or not fams:
        raise InputError(f"unknown map families {bad}; choose from {', '.join(FAMILIES)}" if bad
                         else "families must not be empty")
    return fams


class MixedMapSet:
    """Several map sets drawn with weights: training on a mixture.

    ``sample(part, rng)`` picks a set with probability proportional to its weight (with ``rng``),
    then a problem of that set's ``part``.

    Args:
        sets: The map sets.
        weights: One positive weight per set, default equal.

    Raises:
        InputError: No sets, a weight count that differs, a weight that is not positive, or a set
            whose part is empty (checked by ``validate(parts)``).
    """

    def __init__(self, sets: Sequence[MapSet], weights: Sequence[float] | None = None) -> None:
        self.sets = list(sets)
        if not self.sets:
            raise InputError("MixedMapSet needs at least one map set")
        w = [1.0] * len(self.sets) if weights is None else list(weights)
        if len(w) != len(self.sets):
            raise InputError(f"MixedMapSet: {len(self.sets)} map sets but {len(w)} weights")
        for s, x in zip(self.sets, w, strict=True):
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x) or x <= 0:
                raise InputError(f"MixedMapSet: the weight of map set {s.name} must be a positive number, got {x!r}")
        self.weights = np.asarray(w, dtype=float) / float(sum(w))
        self.name = "+".join(s.name for s in self.sets)

    def validate(self, parts: Sequence[str] | None = None) -> None:
        """Refuse a mixture where a set has nothing in one of ``parts`` (default: the train part)."""
        for s in self.sets:
            s.validate(["train"] if parts is None else parts)

    def sample(self, part: str, rng: np.random.Generator) -> Problem:
        i = int(rng.choice(len(self.sets), p=self.weights))
        return self.sets[i].sample(part, rng)

    def record(self) -> dict:
        return {"kind": "mixed", "sets": [s.record() for s in self.sets], "weights": self.weights.tolist()}

    def describe(self) -> str:
        return "\n".join(f"weight {w:.3g}: {s.describe()}" for s, w in zip(self.sets, self.weights, strict=True))
