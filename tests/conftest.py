"""Shared fixtures: the MovingAI maps, an independent path checker, hypothesis settings."""

from __future__ import annotations

import os
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from hypothesis import settings

import planners.maps.movingai
from planners import GeometricWorld, OccupancyGrid
from planners.base.fileio import InputError
from planners.worlds.shapes import Circle


@pytest.fixture(autouse=True)
def _environment_restored():
    """Each test leaves the process environment as it found it (a training command holds the CPU arithmetic to
    AVX2 through environment variables, ``learning.device.pin_cpu_arithmetic``)."""
    saved = dict(os.environ)
    yield
    if os.environ != saved:
        os.environ.clear()
        os.environ.update(saved)

# derandomized so CI runs are reproducible; examples still cover the strategies broadly
settings.register_profile("samplergym", derandomize=True, deadline=None, max_examples=60, print_blob=True)
settings.load_profile("samplergym")

REPO = Path(__file__).resolve().parents[1]

#: The smoke subset (``pytest -m smoke -n 2``, a minute or two on 2 cores): the files below, their slow
#: tests left out. They cover the grid and problem core, map sets and their hostile inputs, the
#: environments' id prefix, plan.py and evaluate.py's checks before work, its journal, and the layering.
SMOKE = ("test_problem.py", "test_grid.py", "test_layering.py", "test_output_units.py", "test_cli_checks.py",
         "test_mapset.py", "test_plan_mapset.py", "test_samplergym.py", "test_evaluate_io.py")


def pytest_collection_modifyitems(config, items):
    """Mark the tests of the ``SMOKE`` files, slow ones aside, as ``smoke``."""
    for item in items:
        if item.path.name in SMOKE and item.get_closest_marker("slow") is None:
            item.add_marker(pytest.mark.smoke)


def load_script(name: str):
    """``scripts/<name>.py`` imported as a module (scripts are not a package), registered in ``sys.modules``.

    ``name`` may name a subfolder, e.g. ``"experiments/route_variants"``.
    """
    import importlib.util
    import sys

    spec = importlib.util.spec_from_file_location(f"_script_{name.replace('/', '_')}",
                                                  Path(__file__).resolve().parents[1] / "scripts" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


def npy_map_folder(folder: Path, count: int, side: int = 32, family: str = "forest") -> Path:
    """``folder`` filled with ``count`` generated maps (seeds 0, 1, ...) as ``m0.npy``, ``m1.npy``, ...: a map set."""
    from planners.maps.generators import generate

    folder.mkdir(parents=True, exist_ok=True)
    for i in range(count):
        np.save(folder / f"m{i}.npy", generate(family, i, side).world.obstacles)
    return folder


def random_walled_problem(data, size: int, *, wall: int, gap: int, tolerance: float):
    """A hypothesis-drawn map: 1 to 3 vertical walls ``wall`` cells thick, each with a ``gap`` cells tall, and a
    query between two free cells (``data``: ``st.data()``)."""
    from hypothesis import strategies as st

    from planners import OccupancyGrid, Problem

    obs = np.zeros((size, size), dtype=bool)
    for _ in range(data.draw(st.integers(1, 3))):
        col = data.draw(st.integers(6 + wall, size - 7 - wall))
        row = data.draw(st.integers(1, size - 1 - gap))
        obs[:, col:col + wall] = True
        obs[row:row + gap, col:col + wall] = False
    free = np.argwhere(~obs)
    a, b = (free[data.draw(st.integers(0, len(free) - 1))] for _ in range(2))
    return Problem(OccupancyGrid(obs), (a[1] + 0.5, a[0] + 0.5), (b[1] + 0.5, b[0] + 0.5), goal_tolerance=tolerance)


def movingai_dir() -> Path | None:
    """The shared MovingAI maps (the library's lookup, anchored at the repo rather than the working directory)."""
    try:
        return planners.movingai_dir(os.environ.get(planners.maps.movingai.MOVINGAI_ENV)
                                     or REPO.parent / "shared" / "maps" / "movingai")
    except InputError:
        return None


@pytest.fixture(scope="session")
def movingai() -> Path:
    d = movingai_dir()
    if d is None:
        pytest.skip("MovingAI maps not found: set SAMPLERGYM_MOVINGAI_DIR or place them in ../shared/maps/movingai")
    return d


def _closed_cells_at(grid: OccupancyGrid, p: np.ndarray):
    """Cells whose closure contains point p (1, 2 or 4 cells)."""
    x, y = p[0] / grid.resolution, p[1] / grid.resolution
    cols = {int(np.floor(x))} | ({int(x) - 1} if x == int(x) else set())
    rows = {int(np.floor(y))} | ({int(y) - 1} if y == int(y) else set())
    return [(r, c) for r in rows for c in cols]


def fine_check_path(world, path, spacing: float = 0.01) -> bool:
    """Independent validity check: dense points along every segment, tested one by one.

    Shares no code with the planners' compiled checks.
    """
    path = np.asarray(path, dtype=float)
    if isinstance(world, OccupancyGrid):
        H, W = world.shape

        def ok(p):
            for r, c in _closed_cells_at(world, p):
                if not (0 <= r < H and 0 <= c < W) or world.obstacles[r, c]:
                    return False
            return True
    elif isinstance(world, GeometricWorld):
        def ok(p):
            if not (0 < p[0] < world.width and 0 < p[1] < world.height):
                return False
            for ob in world.obstacles:
                if isinstance(ob, Circle):
                    if (p[0] - ob.x) ** 2 + (p[1] - ob.y) ** 2 <= ob.r**2:
                        return False
                elif ob.x0 <= p[0] <= ob.x1 and ob.y0 <= p[1] <= ob.y1:
                    return False
            return True
    else:
        raise TypeError(type(world))
    if len(path) == 1:
        return ok(path[0])
    for a, b in zip(path[:-1], path[1:], strict=True):
        n = max(2, int(np.ceil(np.linalg.norm(b - a) / spacing)) + 1)
        for t in np.linspace(0.0, 1.0, n):
            if not ok(a + t * (b - a)):
                return False
    return True


def exact_segment_free(grid: OccupancyGrid, a, b) -> bool:
    """Exact oracle in rational arithmetic: does segment a-b avoid every closed blocked/outside cell?"""
    ax, ay, bx, by = (Fraction(float(v)) / Fraction(grid.resolution) for v in (a[0], a[1], b[0], b[1]))
    H, W = grid.shape
    x_lo, x_hi = min(ax, bx), max(ax, bx)
    y_lo, y_hi = min(ay, by), max(ay, by)
    for r in range(int(np.floor(float(y_lo))) - 1, int(np.floor(float(y_hi))) + 2):
        for c in range(int(np.floor(float(x_lo))) - 1, int(np.floor(float(x_hi))) + 2):
            blocked = not (0 <= r < H and 0 <= c < W) or grid.obstacles[r, c]
            if blocked and _segment_meets_box(ax, ay, bx, by, Fraction(c), Fraction(r), Fraction(c + 1),
                                              Fraction(r + 1)):
                return False
    return True


def _segment_meets_box(ax, ay, bx, by, x0, y0, x1, y1) -> bool:
    t0, t1 = Fraction(0), Fraction(1)
    for p, d, lo, hi in ((ax, bx - ax, x0, x1), (ay, by - ay, y0, y1)):
        if d == 0:
            if p < lo or p > hi:
                return False
        else:
            ta, tb = (lo - p) / d, (hi - p) / d
            if ta > tb:
                ta, tb = tb, ta
            t0, t1 = max(t0, ta), min(t1, tb)
            if t0 > t1:
                return False
    return True


@pytest.fixture(scope="session")
def ray_backend():
    """One local Ray instance (loopback, 2 CPUs) for every test in this process that runs on Ray.

    Without Ray (the ``test`` extra alone) the tests that use it skip, saying which extra brings it.
    """
    pytest.importorskip("ray", reason="Ray is not installed: pip install -e '.[test-ray]' runs these tests")
    from learning.evaluation import worker_init
    from planners.tools.parallel import make_backend

    backend = make_backend("ray", processes=2, worker_init=worker_init)
    yield backend
    backend.close()
