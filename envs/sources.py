"""Where environments get their planning problems: generated families, MovingAI, files, lists, 6-DoF scenes.

A map source is any callable ``source(np_random) -> Problem``; the environment calls it in
``reset`` with its own ``np_random``, so a seeded reset always draws the same problem.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from planners import OccupancyGrid, Problem, load_movingai_scenarios
from planners.generators import FAMILIES, generate
from planners.gridsearch import free_components

MapSource = Callable[[np.random.Generator], Problem]


def default_movingai_dir() -> Path:
    """``$SAMPLERGYM_MOVINGAI_DIR``, else ``../shared/maps/movingai`` beside the repository."""
    env = os.environ.get("SAMPLERGYM_MOVINGAI_DIR")
    return Path(env) if env else Path(__file__).resolve().parents[2] / "shared" / "maps" / "movingai"


def _seeded(seeds: Sequence[int] | None) -> np.ndarray | None:
    """A fixed pool of map seeds (None: any seed)."""
    out = None if seeds is None else np.asarray(seeds, dtype=np.int64)
    if out is not None and len(out) == 0:
        raise ValueError("seeds must not be empty")
    return out


def _draw_seed(pool: np.ndarray | None, np_random: np.random.Generator) -> int:
    return int(np_random.integers(2**31)) if pool is None else int(pool[np_random.integers(len(pool))])


class FamilySource:
    """Problems from one generated family (see ``planners.generators``), a fresh map each reset.

    Args:
        family: One of ``planners.generators.FAMILIES``.
        size: Map side in cells.
        goal_tolerance: Goal radius of every problem.
        seeds: Optional pool of map seeds to draw from (e.g. a training split); default any seed.
    """

    def __init__(self, family: str, size: int = 64, goal_tolerance: float = 4.0,
                 seeds: Sequence[int] | None = None) -> None:
        if family not in FAMILIES:
            raise ValueError(f"unknown family {family!r}; choose from {FAMILIES}")
        self.family, self.size, self.goal_tolerance = family, int(size), float(goal_tolerance)
        self.seeds = _seeded(seeds)

    def __call__(self, np_random: np.random.Generator) -> Problem:
        seed = _draw_seed(self.seeds, np_random)
        return generate(self.family, seed, self.size, goal_tolerance=self.goal_tolerance)

    def __repr__(self) -> str:
        return f"FamilySource({self.family!r}, size={self.size})"


class ProblemListSource:
    """Draws uniformly from a fixed list of problems."""

    def __init__(self, problems: Sequence[Problem]) -> None:
        self.problems = list(problems)
        if not self.problems:
            raise ValueError("ProblemListSource needs at least one problem")

    def __call__(self, np_random: np.random.Generator) -> Problem:
        return self.problems[int(np_random.integers(len(self.problems)))]


class MovingAISource(ProblemListSource):
    """Scenario queries of the MovingAI benchmark maps.

    Args:
        directory: Folder with ``.map`` and ``.scen`` files (default: ``default_movingai_dir()``).
        maps: Map names (stems, e.g. ``"arena"``) to use; default all maps with a scenario file.
        goal_tolerance: Goal radius of every problem.
        per_map: Keep at most this many scenarios per map (the longest ones first).
    """

    def __init__(self, directory: str | os.PathLike | None = None, maps: Sequence[str] | None = None,
                 goal_tolerance: float = 4.0, per_map: int | None = 50) -> None:
        directory = Path(directory) if directory is not None else default_movingai_dir()
        if not directory.is_dir():
            raise FileNotFoundError(
                f"MovingAI maps not found in {directory}; set SAMPLERGYM_MOVINGAI_DIR or pass directory=")
        scens = sorted(directory.glob("*.scen"))
        if maps is not None:
            wanted = set(maps)
            scens = [s for s in scens if s.name.split(".")[0].replace("-random-1", "") in wanted]
            found = {s.name.split(".")[0].replace("-random-1", "") for s in scens}
            if wanted - found:
                raise ValueError(f"no scenario file for maps {sorted(wanted - found)} in {directory}")
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
    """The user's own map files (images, MovingAI ``.map`` or ``.npy``), with random connected queries.

    Args:
        paths: Map files (``OccupancyGrid.from_file``).
        threshold: Gray level below which image pixels are obstacles.
        resolution: World units per cell.
        goal_tolerance: Goal radius.
        min_distance: Minimum straight-line start-goal distance, as a fraction of the map diagonal.
    """

    def __init__(self, paths: Sequence[str | os.PathLike] | str | os.PathLike, threshold: float = 0.5,
                 resolution: float = 1.0, goal_tolerance: float = 4.0, min_distance: float = 0.3) -> None:
        if isinstance(paths, (str, os.PathLike)):
            paths = [paths]
        self.grids: list[OccupancyGrid] = []
        for p in paths:
            self.grids.append(OccupancyGrid.from_file(p, threshold, resolution))
        if not self.grids:
            raise ValueError("FileSource needs at least one map file")
        self.goal_tolerance = float(goal_tolerance)
        self.min_distance = float(min_distance)
        self._labels = [free_components(g.obstacles) for g in self.grids]
        for g, lab in zip(self.grids, self._labels, strict=True):
            if (lab >= 0).sum() < 2:
                raise ValueError(f"map {g.source} has fewer than two free cells")

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


class RigidSceneSource:
    """6-DoF rigid-body problems: a fresh ``planners.rigid3d.random_scene`` each reset.

    Args:
        n_boxes: Boxes per scene.
        seeds: Optional pool of scene seeds to draw from (e.g. a training split); default any seed.
        **scene_kwargs: Further ``random_scene`` arguments (``size``, ``goal_tolerance``, ``delta``,
            ``metric``, ...).
    """

    dim = 6

    def __init__(self, n_boxes: int = 30, seeds: Sequence[int] | None = None, **scene_kwargs) -> None:
        from planners.rigid3d import random_scene

        random_scene(0, n_boxes, **scene_kwargs)  # validates the arguments now, not at the first reset
        self.n_boxes, self.scene_kwargs = int(n_boxes), dict(scene_kwargs)
        self.seeds = _seeded(seeds)

    def __call__(self, np_random: np.random.Generator) -> Problem:
        """A fresh random scene, its seed drawn from ``np_random``."""
        from planners.rigid3d import random_scene

        seed = _draw_seed(self.seeds, np_random)
        return random_scene(seed, self.n_boxes, **self.scene_kwargs)

    def __repr__(self) -> str:
        return f"RigidSceneSource(n_boxes={self.n_boxes})"


def make_source(source: str | MapSource, **kwargs) -> MapSource:
    """Build a map source from a name: a family, ``"movingai"``, ``"files"`` or ``"rigid"``; callables pass.

    ``"rigid"`` is ``RigidSceneSource`` (6-DoF rigid-body scenes).
    """
    if callable(source):
        if kwargs:
            raise ValueError(f"source options {sorted(kwargs)} given with a callable source")
        return source
    if source in FAMILIES:
        return FamilySource(source, **kwargs)
    if source == "movingai":
        return MovingAISource(**kwargs)
    if source == "files":
        if "paths" not in kwargs:
            raise ValueError("map_source='files' needs source_kwargs={'paths': [image or .map files]}")
        return FileSource(**kwargs)
    if source == "rigid":
        return RigidSceneSource(**kwargs)
    raise ValueError(f"map_source must be one of {FAMILIES + ('movingai', 'files', 'rigid')} or a callable, "
                     f"got {source!r}")
