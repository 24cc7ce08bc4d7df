"""MovingAI grid benchmarks: where their files are, and their ``.scen`` scenarios as ``Problem`` s.

The ``.map`` reader is ``OccupancyGrid.from_movingai``; ``../shared/maps/README.md`` describes the
format and its quirks.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator
from pathlib import Path

from planners.base.fileio import InputError
from planners.base.problem import Problem
from planners.worlds.grid import OccupancyGrid

#: Environment variable naming the folder of MovingAI ``.map`` / ``.scen`` files.
MOVINGAI_ENV = "SAMPLERGYM_MOVINGAI_DIR"


def movingai_dir(directory: str | os.PathLike | None = None, *, required: bool = True) -> Path | None:
    """The folder of MovingAI ``.map`` / ``.scen`` files, the one place the library looks for it.

    ``directory`` if given, else ``$SAMPLERGYM_MOVINGAI_DIR``, else ``../shared/maps/movingai``
    relative to the current working directory. Never derived from where this file sits, so an
    installed (non-editable) package finds the maps too.

    Args:
        directory: The folder, or None to look it up.
        required: If False, a missing *default* folder gives None (callers that skip the MovingAI
            maps then); a folder named by ``directory`` or the variable must still exist.

    Raises:
        InputError: The chosen folder does not exist or holds no ``.map`` file; the message names the
            argument and the environment variable.
    """
    if directory is not None:
        cand, origin = Path(directory), f"directory={str(directory)!r}"
    elif os.environ.get(MOVINGAI_ENV):
        cand, origin = Path(os.environ[MOVINGAI_ENV]), f"{MOVINGAI_ENV}={os.environ[MOVINGAI_ENV]!r}"
    else:
        cand = Path.cwd().parent / "shared" / "maps" / "movingai"
        origin = f"the default ../shared/maps/movingai (from the working directory {Path.cwd()})"
        if not required and not cand.is_dir():
            return None
    if not cand.is_dir() or not any(cand.glob("*.map")):
        raise InputError(f"MovingAI maps not found: {origin} is not a folder of .map files; pass the folder "
                         f"as the directory argument (source_kwargs={{'directory': ...}}, --movingai) or set "
                         f"{MOVINGAI_ENV}")
    return cand


def load_movingai_scenarios(
    path: str | os.PathLike,
    *,
    goal_tolerance: float = 1.0,
    map_path: str | os.PathLike | None = None,
    metric: str = "euclidean",
    limit: int | None = None,
) -> Iterator[Problem]:
    """Yield one ``Problem`` per line of a MovingAI ``.scen`` file.

    Start and goal are the centres of the scenario's cells (``x + 0.5, y + 0.5``); each problem's
    ``reference_length`` is the published octile optimum. The map is found by the basename of the
    scenario's map column next to the ``.scen`` file, unless ``map_path`` is given; then every line's
    map column must name that file (its base name), or the line is refused.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"MovingAI scenario file {path} does not exist")
    raw = path.read_bytes()
    try:
        lines = raw.decode("ascii").splitlines()
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not an ASCII MovingAI scenario file (byte {exc.start} is "
                         f"{raw[exc.start]:#x})") from None
    grids: dict[Path, OccupancyGrid] = {}
    count = 0
    for lineno, line in enumerate(lines, start=1):
        if not line.strip() or (lineno == 1 and line.lower().startswith("version")):
            continue
        fields = line.split("\t")
        if len(fields) != 9:
            raise InputError(f"{path}, line {lineno}: expected 9 tab-separated fields, got {len(fields)}: {line!r}")
        try:
            bucket = int(fields[0])
            w, h, sx, sy, gx, gy = (int(v) for v in fields[2:8])
            optimal = float(fields[8])
        except ValueError:
            raise InputError(f"{path}, line {lineno}: non-numeric field in {line!r}") from None
        if not (math.isfinite(optimal) and optimal >= 0):
            raise InputError(f"{path}, line {lineno}: optimal length must be a finite number >= 0, "
                             f"got {fields[8]!r}")
        named = Path(fields[1].replace("\\", "/")).name
        if map_path is not None and named.casefold() != Path(map_path).name.casefold():
            raise InputError(f"{path}, line {lineno}: its map column names {fields[1]!r}, but the file is read with "
                             f"the map {str(map_path)!r}; a scenario file belongs to the map it names")
        mp = Path(map_path) if map_path is not None else path.parent / named
        if mp not in grids:
            if not mp.is_file():
                raise InputError(f"{path}, line {lineno}: its map {fields[1]!r} is looked up as {str(mp)!r}, "
                                 f"which does not exist; pass map_path=")
            grids[mp] = OccupancyGrid.from_movingai(mp)
        grid = grids[mp]
        if (w, h) != (grid.width, grid.height):
            raise InputError(f"{path}, line {lineno}: scenario size {w}x{h} does not match {mp} "
                             f"({grid.width}x{grid.height})")
        for label, (x, y) in (("start", (sx, sy)), ("goal", (gx, gy))):
            if not (0 <= x < w and 0 <= y < h) or grid.obstacles[y, x]:
                raise InputError(f"{path}, line {lineno}: {label} cell (x={x}, y={y}) is outside the map or blocked")
        yield Problem(
            grid,
            start=grid.cell_center(sy, sx),
            goal=grid.cell_center(gy, gx),
            goal_tolerance=goal_tolerance,
            metric=metric,
            name=f"{mp.stem}#{lineno}",
            reference_length=optimal,
        )
        _ = bucket
        count += 1
        if limit is not None and count >= limit:
            return


def benchmark_scenarios(directory: str | os.PathLike, name: str, goal_tolerance: float) -> list[Problem]:
    """The scenarios of MovingAI map ``name`` in ``directory`` that the comparison uses, longest first.

    The scenario file is ``<name>*.scen`` (``-random-1`` suffixes of the MAPF sets dropped); scenarios
    whose start already lies within ``goal_tolerance`` of the goal are left out; ties in length are
    broken by name, so the order is fixed.

    Raises:
        FileNotFoundError: If the directory holds no scenario file for the map.
    """
    d = Path(directory)
    scen = next((p for p in sorted(d.glob(f"{name}*.scen"))
                 if p.name.split(".")[0].replace("-random-1", "") == name), None)
    if scen is None:
        raise FileNotFoundError(f"no scenario file for MovingAI map {name!r} in {d}")
    ps = [p for p in load_movingai_scenarios(scen, goal_tolerance=goal_tolerance)
          if p.distance(p.start, p.goal) > goal_tolerance]
    return sorted(ps, key=lambda p: (-p.reference_length, p.name))


#: A map's test and tuning scenarios are spaced for at least this many of each (``scenario_picks``), so a run that
#: asks for fewer (the quick comparison) takes the first of the same picks: no scenario is tuned on in one run
#: and tested in another.
PICK_SLOTS = 10


def scenario_picks(count: int, n_test: int, n_tune: int) -> tuple[list[int], list[int]]:
    """The indices of a map's test and tuning scenarios among its ``count`` (``benchmark_scenarios``' order).

    Of the longest half, every stride-th goes alternately to the test and the tuning part, the stride set for
    ``max(n_test, n_tune, PICK_SLOTS)`` of each; ``n_test`` and ``n_tune`` of them (fewer where there are few).
    """
    half = max(2, count // 2)
    stride = max(1, half // (2 * max(n_test, n_tune, PICK_SLOTS)))
    picks = list(range(0, half, stride))
    return picks[0::2][:n_test], picks[1::2][:n_tune]
