"""The collision interface every planner plans against (OMPL's SpaceInformation, in small).

A ``World`` bundles the configuration space (dimension, sampling bounds, supported metrics) with
exact collision checking. Planners only ever call it through its ``kernel`` (a
``planners.kernels.state.WorldKernel``), which the compiled checks dispatch on by ``kind``;
``is_valid`` / ``check_motion`` are the same checks for Python callers (tests, smoothing, plotting).

Adding a world kind touches two places and no planner: a ``WorldBase`` subclass in
``planners/worlds/`` whose ``kernel`` carries a new kind code and its arrays, and that code's branch
in ``planners.kernels.geometry.motion_free`` (plus ``space_kind`` in ``planners.kernels.space`` if
its states are not real vectors). A kind the dispatch does not know is an error, never another
kind's check.
"""

from __future__ import annotations

import math
from typing import Protocol, runtime_checkable

import numpy as np

from planners.kernels import geometry
from planners.kernels.state import WorldKernel


@runtime_checkable
class World(Protocol):
    """What a planner needs from the space it plans in."""

    dim: int
    space_kind: int
    metrics: tuple[str, ...]

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Sampling box ``(low, high)``; samples are drawn from ``[low, high)``."""
        ...

    @property
    def kernel(self) -> WorldKernel:
        """The world as the compiled checks in ``planners.kernels.geometry`` take it."""
        ...

    def free_volume(self) -> float:
        """Lebesgue measure of the free space (used by RRT*/PRM* connection radii)."""
        ...

    def is_valid(self, q: np.ndarray) -> bool: ...

    def check_motion(self, a: np.ndarray, b: np.ndarray) -> bool: ...

    def explain_invalid(self, q: np.ndarray) -> str:
        """Human-readable reason why ``q`` is not a valid state ('' if it is)."""
        ...


def _finite(q: np.ndarray) -> bool:
    """Whether every entry of the state ``q`` (a float64 vector) is finite: ``np.isfinite(q).all()``'s answer, in a
    fifth of its time on a state's few entries (planners and samplers ask it once per query, a user once per call).
    """
    return all(map(math.isfinite, q.tolist()))


#: OMPL's default range: this fraction of the sampling box's diagonal (MAX_MOTION_DISTANCE_FRACTION), the RRT
#: family's default step on a world that does not set its own (``WorldBase.range_fraction``).
DEFAULT_RANGE_FRACTION = 0.2


class WorldBase:
    """Python-facing checks shared by all worlds, via the compiled dispatch."""

    dim: int
    #: The RRT family's default step (OMPL's ``range``) on this world, as a fraction of the sampling box's diagonal.
    range_fraction: float = DEFAULT_RANGE_FRACTION

    @property
    def kernel(self) -> WorldKernel:
        return self._kernel

    def _state(self, q, name: str = "state") -> np.ndarray:
        q = np.asarray(q, dtype=np.float64)
        if q.shape != (self.dim,):
            raise ValueError(f"{name} must have shape ({self.dim},), got {q.shape}")
        return q

    def is_valid(self, q) -> bool:
        """True if state ``q`` is collision-free and inside the bounds."""
        q = self._state(q)
        return _finite(q) and geometry.state_free_of(self._kernel, q)

    def check_motion(self, a, b) -> bool:
        """True if the straight motion ``a -> b`` is collision-free (exact; see the world's docs)."""
        a = self._state(a, "a")
        b = self._state(b, "b")
        if not (_finite(a) and _finite(b)):
            return False
        return bool(geometry.motion_free(self._kernel, a, b))

    def check_motions(self, A, B) -> np.ndarray:
        """Vectorised ``check_motion`` over rows of ``A`` and ``B``."""
        A = np.ascontiguousarray(A, dtype=np.float64).reshape(-1, self.dim)
        B = np.ascontiguousarray(B, dtype=np.float64).reshape(-1, self.dim)
        if A.shape != B.shape:
            raise ValueError(f"A and B must have the same shape, got {A.shape} and {B.shape}")
        out = np.zeros(len(A), dtype=np.bool_)
        geometry.motions_free(self._kernel, A, B, out)
        out &= np.isfinite(A).all(axis=1) & np.isfinite(B).all(axis=1)
        return out

    def path_valid(self, path) -> bool:
        """True if every state and every segment of ``path`` is valid."""
        path = np.asarray(path, dtype=np.float64).reshape(-1, self.dim)
        if len(path) == 0:
            return False
        if len(path) == 1:
            return self.is_valid(path[0])
        return bool(self.check_motions(path[:-1], path[1:]).all())
