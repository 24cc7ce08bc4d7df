"""Action modes: how an agent's action becomes the planner's next sample.

Each mode is a ``Sampler`` (the planners' one protocol), so the environment drives an unmodified
planner: it stores the action on the planner's bound sampler and calls ``planner.step()``, which
draws exactly one sample. Randomness comes from the planner's generator, itself seeded from the
environment's ``np_random``.

Actions live in ``Box(-1, 1)``; out-of-range values are clipped (documented, as SB3 policies can
emit them) and NaN, non-numeric or wrongly shaped actions raise ``planners.base.fileio.InputError``.
"""

from __future__ import annotations

import math

import numpy as np
from gymnasium import spaces

from planners import SamplerBase
from planners.base.fileio import InputError


class ActionSampler(SamplerBase):
    """Base of the action modes: one sample per ``draw``, computed from the last ``set_action``.

    Args:
        step_size: The planner's step, which sets the scale of Gaussian spreads and offsets.
        uniform_floor: Probability of a uniform sample whatever the action, so probabilistic
            completeness is never lost (``bias``, ``mixture``, ``relative`` and ``guided``; ``point``
            has none: its action is the sample).
    """

    dims = 0  # action dimensions beyond the state dimension
    has_floor = True  # the mode honours uniform_floor (``point`` does not)

    def __init__(self, step_size: float, uniform_floor: float = 0.05) -> None:
        if not 0.0 <= uniform_floor <= 1.0:
            raise InputError(f"uniform_floor must lie in [0, 1], got {uniform_floor}")
        self.step_size = float(step_size)
        self.uniform_floor = float(uniform_floor)
        self.action: np.ndarray | None = None

    @property
    def explores(self) -> bool:
        """Whether every action leaves a positive chance of a uniform sample (a floor above zero).

        Without it, a deterministic policy that answers the same action each time samples one point
        forever and the planner never covers the map.
        """
        return self.has_floor and self.uniform_floor > 0.0

    def action_space(self, dim: int) -> spaces.Box:
        return spaces.Box(-1.0, 1.0, (self.action_size(dim),), np.float32)

    def action_size(self, dim: int) -> int:
        return dim + self.dims

    def set_guide(self, guide) -> None:
        """Hand over the episode's ``GuidedSampling`` (or None); modes that do not sample through it ignore it."""

    def set_action(self, action) -> None:
        n = self.action_size(self.problem.dim)
        expected = f"Box(-1, 1, ({n},), float32) in {type(self).__name__} mode"
        a = np.asarray(action) if action is not None else None
        if a is None or not (a.dtype == bool or np.issubdtype(a.dtype, np.number)):
            raise InputError(f"action must be numbers for {expected}, got {action!r}")
        a = a.astype(np.float64)
        if a.shape != (n,):
            raise InputError(f"action must have shape ({n},) for {expected}, got shape {a.shape}: {action!r}")
        if not np.all(np.isfinite(a)):
            raise InputError(f"action contains NaN or infinity: {a.tolist()}; expected {expected}")
        self.action = np.clip(a, -1.0, 1.0)

    def draw(self, rng, n, view):
        if self.action is None:
            raise RuntimeError("set_action must be called before the planner steps")
        q = self._sample(rng, view)
        return self._clip(q)[None, :]

    def _clip(self, q: np.ndarray) -> np.ndarray:
        hi = np.nextafter(self.high, self.low)
        return np.minimum(np.maximum(q, self.low), hi)

    def _to_state(self, a: np.ndarray) -> np.ndarray:
        return self.low + (a + 1.0) * 0.5 * (self.high - self.low)

    def _spread(self, a: float, lo: float, hi: float) -> float:
        """Log-scale map of a in [-1, 1] to [lo, hi]."""
        return lo * (hi / lo) ** ((a + 1.0) * 0.5)

    def _sample(self, rng, view) -> np.ndarray:
        raise NotImplementedError


class PointAction(ActionSampler):
    """``point``: the action is the sample itself, ``Box(-1, 1, (d,))`` mapped to the map bounds.

    It has no uniform floor: a deterministic policy that has not learned to move its point samples the
    same place every iteration (``EnvSampler`` warns when it is built so).
    """

    has_floor = False

    def _sample(self, rng, view):
        return self._to_state(self.action)


class BiasAction(ActionSampler):
    """``bias``: the action sets this iteration's goal bias p = (a + 1) / 2; ``Box(-1, 1, (1,))``.

    p is capped at ``1 - uniform_floor``, so the sample is uniform at least that often.
    """

    def action_size(self, dim: int) -> int:
        return 1

    def _sample(self, rng, view):
        u = rng.random(self.problem.dim + 1)  # the same stream layout as GoalBiasedSampler
        if u[0] < min((self.action[0] + 1.0) * 0.5, 1.0 - self.uniform_floor):
            return np.array(self.problem.goal, dtype=np.float64)
        return self._uniform(u[1:])


class MixtureAction(ActionSampler):
    """``mixture``: a Gaussian (mean, spread) against uniform sampling, ``Box(-1, 1, (d + 2,))``.

    ``a[:d]`` is the mean (mapped to the bounds), ``a[d]`` the spread (log-scale from half a step to
    a quarter of the map's diagonal), ``a[d + 1]`` the Gaussian's weight w = (a + 1) / 2, capped at
    ``1 - uniform_floor``.
    """

    dims = 2

    def _sample(self, rng, view):
        d = self.problem.dim
        a = self.action
        w = min((a[d + 1] + 1.0) * 0.5, 1.0 - self.uniform_floor)
        u = rng.random()
        z = rng.standard_normal(d)
        if u >= w:
            return self._uniform(rng.random(d))
        diag = float(np.linalg.norm(self.high - self.low))
        sigma = self._spread(a[d], 0.5 * self.step_size, 0.25 * diag)
        return self._to_state(a[:d]) + sigma * z


class RelativeAction(ActionSampler):
    """``relative``: an offset (and spread) from the tree vertex nearest the goal; ``Box(-1, 1, (d + 1,))``.

    ``a[:d]`` scaled by ``reach`` (in units of the step size) is the offset from the anchor vertex,
    ``a[d]`` the Gaussian spread (log-scale from a quarter step to two steps). With probability
    ``uniform_floor`` the sample is uniform instead. Policies can thus sample just ahead of the tree.

    Args:
        reach: Largest offset, in step sizes.
    """

    dims = 1

    def __init__(self, step_size: float, uniform_floor: float = 0.05, reach: float = 3.0) -> None:
        super().__init__(step_size, uniform_floor)
        if not (math.isfinite(reach) and reach > 0):
            raise InputError(f"reach must be positive, got {reach}")
        self.reach = float(reach)

    def _sample(self, rng, view):
        d = self.problem.dim
        a = self.action
        u = rng.random()
        z = rng.standard_normal(d)
        if u < self.uniform_floor:
            return self._uniform(rng.random(d))
        anchor = view.vertices[view.best_vertex]
        sigma = self._spread(a[d], 0.25 * self.step_size, 2.0 * self.step_size)
        q = anchor + a[:d] * self.reach * self.step_size + sigma * z
        if self.problem.world.space_kind != 0:  # wrap angles of rigid-body states
            q[3:] = (q[3:] + np.pi) % (2 * np.pi) - np.pi
        return q


class GuidedAction(ActionSampler):
    """``guided``: ``Discrete(N_ACTIONS)``, a log-polar cell ahead of the progress vertex, or the frontier.

    See ``planners.guidance.guided``. Its samples come from the episode's ``GuidedSampling``, which the
    environment passes with ``set_guide`` after binding.
    """

    guide = None

    def set_guide(self, guide) -> None:
        if guide is None:
            raise ValueError("guided actions sample through the episode's GuidedSampling; got guide=None")
        self.guide = guide

    def action_space(self, dim: int) -> spaces.Discrete:
        from planners.guidance.guided import N_ACTIONS

        return spaces.Discrete(N_ACTIONS)

    def set_action(self, action) -> None:
        from planners.guidance.guided import N_ACTIONS

        expected = f"one integer in [0, {N_ACTIONS}) (Discrete({N_ACTIONS}))"
        a = np.asarray(action) if action is not None else None
        if a is None or a.size != 1 or a.dtype == bool or not np.issubdtype(a.dtype, np.number):
            raise InputError(f"guided action must be {expected}, got {action!r}")
        if not np.issubdtype(a.dtype, np.integer) and not (np.isfinite(a).all() and float(a.reshape(-1)[0]) % 1 == 0):
            raise InputError(f"guided action must be {expected}, got {action!r}")
        a = int(a.reshape(-1)[0])
        if not 0 <= a < N_ACTIONS:
            raise InputError(f"guided action must be {expected}, got {a}")
        self.action = a
        self.classes = np.array([a], dtype=np.int64)

    def set_classes(self, classes) -> None:
        """Several actions at once: the next draw gives one sample per class, in order (a decision batch)."""
        from planners.guidance.guided import N_ACTIONS

        c = np.asarray(classes)
        if c.ndim != 1 or not len(c) or not np.issubdtype(c.dtype, np.integer) or c.min() < 0 or c.max() >= N_ACTIONS:
            raise InputError(f"guided classes must be a non-empty 1-D array of integers in [0, {N_ACTIONS}), "
                             f"got {classes!r}")
        self.action = int(c[0])
        self.classes = c.astype(np.int64)

    def draw(self, rng, n, view):
        if self.action is None or self.guide is None:
            raise RuntimeError("set_action and set_guide must be called before the planner steps")
        self.guide.update(view)
        return self.guide.samples(self.classes[:max(1, n)], rng)


#: Action modes by name; a new mode is an ``ActionSampler`` subclass above and its entry here.
ACTION_MODES: dict[str, type[ActionSampler]] = {"point": PointAction, "bias": BiasAction, "mixture": MixtureAction,
                                                "relative": RelativeAction, "guided": GuidedAction}


def make_action_sampler(mode: str, step_size: float, uniform_floor: float = 0.05, **kwargs) -> ActionSampler:
    """The ``ActionSampler`` for an action-mode name (a key of ``ACTION_MODES``)."""
    if mode not in ACTION_MODES:
        raise InputError(f"action_mode must be one of {tuple(ACTION_MODES)}, got {mode!r}")
    return ACTION_MODES[mode](step_size, uniform_floor, **kwargs)
