"""Where environments get their planning problems: generated families, MovingAI, files, map sets, lists, 6-DoF scenes.

A map source is any callable ``source(np_random) -> Problem``; the environment calls it in
``reset`` with its own ``np_random``, so a seeded reset always draws the same problem.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from planners import OccupancyGrid, Problem, load_movingai_scenarios, movingai_dir
from planners.base.fileio import InputError, short_repr
from planners.maps.generators import FAMILIES, TRAIN_SEEDS, generate
from planners.maps.gridsearch import free_components
from planners.maps.mapset import PARTS, MapSet, MixedMapSet
from planners.maps.readers import SCENE_SUFFIXES

MapSource = Callable[[np.random.Generator], Problem]


def sample_map_paths() -> list[Path]:
    """The small sample maps shipped with the package (``envs/data/maps/*.png``), used by ``RRT-Files-v2``."""
    from importlib import resources

    root = resources.files("envs") / "data" / "maps"
    paths = sorted(Path(str(p)) for p in root.iterdir() if p.name.endswith(".png"))
    if not paths:
        raise InputError(f"no sample maps found in {root}; the package data is missing, pass source_kwargs="
                         "{'paths': [...]}")
    return paths


def _seeded(seeds: Sequence[int] | None) -> np.ndarray | None:
    """A fixed pool of map seeds (None: any seed)."""
    out = None if seeds is None else np.asarray(seeds, dtype=np.int64)
    if out is not None and len(out) == 0:
        raise InputError("seeds must not be empty")
    return out


def _draw_seed(pool: np.ndarray | None, np_random: np.random.Generator, low: int = 0, high: int = 2**31) -> int:
    """A seed from ``pool``, or from ``[low, high)`` when there is none."""
    return int(np_random.integers(low, high)) if pool is None else int(pool[np_random.integers(len(pool))])


class FamilySource:
    """Problems from one generated family (see ``planners.maps.generators``), a fresh map each reset.

    Args:
        family: One of ``planners.maps.generators.FAMILIES``.
        size: Map side in cells.
        goal_tolerance: Goal radius of every problem.
        seeds: Optional pool of map seeds to draw from; default the training split's seeds
            (``planners.maps.generators.TRAIN_SEEDS``), so an environment never serves a validation, tuning
            or test map unless asked to.
    """

    def __init__(self, family: str, size: int = 64, goal_tolerance: float = 4.0,
                 seeds: Sequence[int] | None = None) -> None:
        if family not in FAMILIES:
            raise InputError(f"unknown family {family!r}; choose from {FAMILIES}")
        self.family, self.size, self.goal_tolerance = family, int(size), float(goal_tolerance)
        self.seeds = _seeded(seeds)

    def __call__(self, np_random: np.random.Generator) -> Problem:
        seed = _draw_seed(self.seeds, np_random, *TRAIN_SEEDS)
        return generate(self.family, seed, self.size, goal_tolerance=self.goal_tolerance)

    def __repr__(self) -> str:
        return f"FamilySource({self.family!r}, size={self.size})"


class ProblemListSource:
    """Draws uniformly from a fixed list of problems."""

    def __init__(self, problems: Sequence[Problem]) -> None:
        self.problems = list(problems)
        if not self.problems:
            raise InputError("ProblemListSource needs at least one problem")

    def __call__(self, np_random: np.random.Generator) -> Problem:
        return self.problems[int(np_random.integers(len(self.problems)))]


class MovingAISource(ProblemListSource):
    """Scenario queries of the MovingAI benchmark maps.

    Args:
        directory: Folder with ``.map`` and ``.scen`` files (default: ``movingai_dir()``: the
            ``SAMPLERGYM_MOVINGAI_DIR`` variable, else ``../shared/maps/movingai`` from the working directory).
        maps: Map names (stems, e.g. ``"arena"``) to use; default all maps with a scenario file.
        goal_tolerance: Goal radius of every problem.
        per_map: Keep at most this many scenarios per map (the longest ones first).
    """

    def __init__(self, directory: str | os.PathLike | None = None, maps: Sequence[str] | None = None,
                 goal_tolerance: float = 4.0, per_map: int | None = 50) -> None:
        directory = movingai_dir(directory)
        scens = sorted(directory.glob("*.scen"))
        if maps is not None:
            wanted = set(maps)
            scens = [s for s in scens if s.name.split(".")[0].replace("-random-1", "") in wanted]
            found = {s.name.split(".")[0].replace("-random-1", "") for s in scens}
            if wanted - found:
                raise InputError(f"no scenario file for maps {sorted(wanted - found)} in {directory}")
        problems = []
        for scen in scens:
            ps = sorted(load_movingai_scenarios(scen, goal_tolerance=goal_tolerance),
                        key=lambda p: -p.reference_length)
            # skip queries the goal region already covers
            ps = [p for p in ps if p.distance(p.start, p.goal) > goal_tolerance]
            problems += ps[:per_map] if per_map else ps
        super().__init__(problems)
        self.directory = directory


class FileSource:
    """The user's own maps (image, MovingAI ``.map`` or ``.npy`` files, or arrays), with random connected queries.

    Args:
        paths: Map files (``OccupancyGrid.from_file``), boolean obstacle arrays or ``OccupancyGrid``s;
            default the sample maps shipped with the package (``sample_map_paths()``).
        threshold: Gray level below which image pixels are obstacles.
        resolution: World units per cell.
        goal_tolerance: Goal radius.
        min_distance: Minimum straight-line start-goal distance, as a fraction of the map diagonal.
    """

    def __init__(self, paths=None, threshold: float = 0.5, resolution: float = 1.0, goal_tolerance: float = 4.0,
                 min_distance: float = 0.3) -> None:
        if paths is None:
            paths = sample_map_paths()
        if isinstance(paths, (str, os.PathLike, np.ndarray, OccupancyGrid)):
            paths = [paths]
        self.grids = [_as_grid(p, threshold, resolution) for p in paths]
        if not self.grids:
            raise InputError("FileSource needs at least one map (paths=[])")
        self.goal_tolerance = float(goal_tolerance)
        self.min_distance = float(min_distance)
        self._labels = [free_components(g.obstacles) for g in self.grids]
        for g, lab in zip(self.grids, self._labels, strict=True):
            if (lab >= 0).sum() < 2:
                raise InputError(f"map {g.source} has fewer than two free cells")

    def __call__(self, np_random: np.random.Generator) -> Problem:
        i = int(np_random.integers(len(self.grids)))
        grid, labels = self.grids[i], self._labels[i]
        # start and goal in the largest free component, far enough apart
        sizes = np.bincount(labels[labels >= 0])
        cells = np.argwhere(labels == int(np.argmax(sizes)))
        diag = float(np.hypot(*grid.shape)) * grid.resolution
        best = None
        for _ in range(200):
            a, b = cells[np_random.integers(len(cells), size=2)]
            s, g = grid.cell_center(*a), grid.cell_center(*b)
            d = float(np.linalg.norm(s - g))
            if best is None or d > best[0]:
                best = (d, s, g)
            if d >= self.min_distance * diag and d > self.goal_tolerance:
                break
        _, s, g = best
        return Problem(grid, s, g, goal_tolerance=self.goal_tolerance, name=f"{Path(str(grid.source)).name}")


def _as_grid(m, threshold: float, resolution: float) -> OccupancyGrid:
    """An ``OccupancyGrid`` from a grid, a 2-D obstacle array (True or nonzero = blocked) or a map file."""
    if isinstance(m, OccupancyGrid):
        return m
    if isinstance(m, np.ndarray):
        if m.ndim != 2 or m.size == 0 or not (m.dtype == bool or np.issubdtype(m.dtype, np.number)):
            raise InputError(f"map array must be a non-empty 2-D boolean obstacle array, got shape {m.shape}, "
                             f"dtype {m.dtype}")
        if not np.isfinite(m).all():
            raise InputError("map array holds NaN or infinity; expected a boolean obstacle array")
        return OccupancyGrid(m.astype(bool), resolution=resolution)
    if isinstance(m, (str, os.PathLike)):
        return OccupancyGrid.from_file(m, threshold, resolution)
    raise InputError(f"map must be a file path, a 2-D obstacle array or an OccupancyGrid, got {type(m).__name__}")


def map_problem(map, start=None, goal=None, goal_tolerance: float = 4.0, threshold: float = 0.5,
                resolution: float = 1.0, **kwargs) -> MapSource:
    """A source for the user's own map: a fixed query when ``start`` and ``goal`` are given, else random ones.

    A path ending in ``.cfg`` (an OMPL.app problem) or ``.scene`` (a box scene) is that one 6-DoF problem, with the
    start and goal the file gives (``scene_file_source``).

    Args:
        map: A map file, a 2-D obstacle array (True = blocked) or an ``OccupancyGrid``.
        start: Start point (x, y) in world units, or None (random queries, as ``FileSource``).
        goal: Goal point (x, y), given with ``start``.
        goal_tolerance: Goal radius.
        threshold: Gray level below which image pixels are obstacles.
        resolution: World units per cell.
        **kwargs: Further ``FileSource`` options (random queries only).
    """
    if isinstance(map, (str, os.PathLike)) and str(map).lower().endswith(SCENE_SUFFIXES):
        if start is not None or goal is not None:
            raise InputError(f"map {str(map)!r}: a {Path(map).suffix} file holds its own start and goal; give "
                             f"neither start nor goal with it")
        return scene_file_source(map)
    grid = _as_grid(map, threshold, resolution)
    if (start is None) != (goal is None):
        raise InputError(f"give both start and goal, or neither (random queries); got start={start!r}, "
                         f"goal={goal!r}")
    if start is None:
        return FileSource([grid], goal_tolerance=goal_tolerance, **kwargs)
    if kwargs:
        raise InputError(f"options {sorted(kwargs)} apply to random queries only, not with start and goal")
    return ProblemListSource([Problem(grid, start, goal, goal_tolerance=goal_tolerance)])


class MapSetSource:
    """Problems from one part of a map set (``planners.maps.mapset``), drawn with the env's ``np_random``.

    Args:
        map_set: A ``MapSet`` or ``MixedMapSet``, or what ``MapSet.open`` takes: a folder of maps, a
            manifest ``.json``, ``"generated"``, ``"shifted"`` or ``"movingai"`` (with options).
        split: The part episodes come from: ``"train"`` (default), ``"validation"``, ``"tuning"`` or ``"test"``.
        **kwargs: ``MapSet.open`` options (``split_seed``, ``fractions``, ``robot_radius``, ...) when
            ``map_set`` is not yet a map set.

    Raises:
        InputError: The set fails its checks, or ``split`` is not a part or is empty in it.
    """

    def __init__(self, map_set, split: str = "train", **kwargs) -> None:
        if split not in PARTS:
            raise InputError(f"split must be one of {PARTS}, got {split!r}")
        if isinstance(map_set, (MapSet, MixedMapSet)):
            if kwargs:
                raise InputError(f"map set options {sorted(kwargs)} given with a map set that is already open")
        elif isinstance(map_set, (str, os.PathLike)):
            map_set = MapSet.open(map_set, **kwargs)
        else:
            raise InputError(f"map_set must be a folder, a manifest .json, a map set name or a MapSet, "
                             f"got {type(map_set).__name__}")
        map_set.validate([split])
        self.map_set, self.split = map_set, split

    def __call__(self, np_random: np.random.Generator) -> Problem:
        return self.map_set.sample(self.split, np_random)

    def __repr__(self) -> str:
        return f"MapSetSource({self.map_set.name!r}, split={self.split!r})"


class RigidSceneSource:
    """6-DoF rigid-body problems: a fresh ``planners.worlds.rigid3d.random_scene`` each reset.

    Args:
        n_boxes: Boxes per scene.
        seeds: Optional pool of scene seeds to draw from (e.g. a training split); default any seed.
        **scene_kwargs: Further ``random_scene`` arguments (``size``, ``goal_tolerance``, ``delta``,
            ``metric``, ...).
    """

    dim = 6

    def __init__(self, n_boxes: int = 30, seeds: Sequence[int] | None = None, **scene_kwargs) -> None:
        from planners.worlds.rigid3d import random_scene

        random_scene(0, n_boxes, **scene_kwargs)  # validates the arguments now, not at the first reset
        self.n_boxes, self.scene_kwargs = int(n_boxes), dict(scene_kwargs)
        self.seeds = _seeded(seeds)

    def __call__(self, np_random: np.random.Generator) -> Problem:
        """A fresh random scene, its seed drawn from ``np_random``."""
        from planners.worlds.rigid3d import random_scene

        seed = _draw_seed(self.seeds, np_random)
        return random_scene(seed, self.n_boxes, **self.scene_kwargs)

    def __repr__(self) -> str:
        return f"RigidSceneSource(n_boxes={self.n_boxes})"


class SceneSetSource:
    """6-DoF rigid-body problems from one part of the generated scene sets (``planners.worlds.rigid_scenes``).

    Each reset draws a scene of ``part`` with the env's ``np_random`` (``RigidSceneSet.sample``): ``train``
    draws a family and a seed from the training seeds; ``validation``, ``tuning`` and ``test`` draw among that
    part's fixed scenes (``test`` includes the test-only families unless ``test_only=()``).

    Args:
        part: ``train`` (default), ``validation``, ``tuning`` or ``test``.
        families: Training families (default all); ``test_only``: test-only families (default all).
        counts: Scenes per family in the fixed parts (``RigidSceneSet``'s default otherwise).
    """

    dim = 6

    def __init__(self, part: str = "train", families: Sequence[str] | None = None,
                 test_only: Sequence[str] | None = None, counts: dict | None = None) -> None:
        from planners.worlds.rigid_scenes import TEST_ONLY_FAMILIES, TRAINING_FAMILIES, RigidSceneSet

        if part not in ("train", "validation", "tuning", "test"):
            raise InputError(f"part must be train, validation, tuning or test, got {short_repr(part)}")
        self.part = part
        self.scenes = RigidSceneSet(TRAINING_FAMILIES if families is None else families,
                                    TEST_ONLY_FAMILIES if test_only is None else test_only, counts)
        if part != "train" and not self.scenes.queries(part):
            raise InputError(f"the {part!r} part of the scene set holds no scene (counts: {self.scenes.counts})")

    def __call__(self, np_random: np.random.Generator) -> Problem:
        return self.scenes.sample(self.part, np_random)

    def __repr__(self) -> str:
        return f"SceneSetSource(part={self.part!r}, families={list(self.scenes.families)})"


def scene_file_source(path: str | os.PathLike) -> ProblemListSource:
    """One 6-DoF problem from a file, every episode.

    An OMPL.app ``.cfg`` (its meshes; the ``mesh`` extra) or a box scene (``planners.worlds.rigid3d.load_scene``).
    """
    path = Path(path)
    if path.suffix.lower() == ".cfg":
        from planners.worlds.omplapp import load_omplapp_cfg

        source = ProblemListSource([load_omplapp_cfg(path)])
    else:
        from planners.worlds.rigid3d import load_scene

        source = ProblemListSource([load_scene(path)])
    source.dim = source.problems[0].dim  # the environment's dimension follows its source
    return source


def make_source(source: str | MapSource, **kwargs) -> MapSource:
    """Build a map source from a name: a family, ``"movingai"``, ``"files"``, ``"rigid"`` or ``"rigid_scenes"``.

    ``"rigid"`` is ``RigidSceneSource`` (random 6-DoF box scenes), ``"rigid_scenes"`` ``SceneSetSource`` (a part
    of the generated scene sets). A path ending in ``.cfg`` (an OMPL.app problem) or ``.scene`` (a box scene) is
    that one 6-DoF problem; other paths, arrays and grids are 2-D maps; callables pass.
    """
    if callable(source):
        if kwargs:
            raise InputError(f"source options {sorted(kwargs)} given with a callable source")
        return source
    if isinstance(source, (str, os.PathLike)) and str(source).lower().endswith(SCENE_SUFFIXES):
        if kwargs:
            raise InputError(f"source options {sorted(kwargs)} given with the problem file {source}")
        return scene_file_source(source)
    if isinstance(source, (np.ndarray, OccupancyGrid, os.PathLike)):
        return map_problem(source, **kwargs)  # the user's own map, e.g. map_source=array
    if not isinstance(source, str):
        raise InputError(f"map_source must be a family name, 'movingai', 'files', 'rigid', a map (array, "
                         f"OccupancyGrid or path) or a callable, got {type(source).__name__}")
    if source in FAMILIES:
        return FamilySource(source, **kwargs)
    if source == "movingai":
        return MovingAISource(**kwargs)
    if source == "files":
        return FileSource(**kwargs)  # no paths: the shipped sample maps
    if source == "rigid":
        return RigidSceneSource(**kwargs)
    if source == "rigid_scenes":
        return SceneSetSource(**kwargs)
    raise InputError(f"map_source must be one of {FAMILIES + ('movingai', 'files', 'rigid', 'rigid_scenes')}, a "
                     f"map, a .cfg or .scene file or a callable, got {source!r}")
