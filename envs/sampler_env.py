"""The sampler environment: the agent chooses where the planner samples next."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np

from planners import OccupancyGrid, Planner, Problem, make_planner
from planners.base.fileio import InputError, check_int
from planners.base.registry import planner_class
from planners.base.samplers import FAMILY_BIDIRECTIONAL

from .actions import ACTION_MODES, make_action_sampler
from .observation import OBSERVATIONS, make_observation
from .sources import MapSetSource, MapSource, make_source, map_problem


class SamplerEnv(gym.Env):
    """A sampling-based planner whose sampler is the agent.

    ## Description
    Each episode is one planning query drawn from ``map_source`` with ``self.np_random``. Each step
    turns the action into exactly one sample and runs exactly one iteration of an unmodified
    planner from ``planners`` (RRT by default); the policy thus replaces RRT's fixed goal bias with
    a learned, state-dependent sampling bias.

    ## Action Space
    ``Box(-1, 1, (k,), float32)``, by ``action_mode`` (see ``envs.actions``):
    ``mixture`` (k = d + 2, the default): a Gaussian's mean, spread and weight against uniform
    sampling; ``point`` (k = d): the sample itself, mapped to the map bounds (no uniform floor);
    ``bias`` (k = 1): this iteration's goal-bias probability; ``relative`` (k = d + 1): an offset and
    spread from the tree vertex nearest the goal. Every mode but ``point`` samples uniformly at least a
    ``uniform_floor`` share of the time (default 0.05), so a policy trained briefly with SB3's
    defaults still plans. ``guided``: ``Discrete(177)``, a log-polar cell in the
    frame from the tree's progress vertex towards the goal, or the tree's frontier (``planners.guidance.guided``).
    Out-of-range continuous actions are clipped to [-1, 1]; NaN, non-numeric, wrongly shaped or
    out-of-range discrete actions raise ``planners.base.fileio.InputError`` (a ``ValueError``) naming the
    action and the expected space.

    ## Observation Space
    Occupancy-grid problems: ``Dict(image=(4, 64, 64) uint8, local=(4, 48, 48) uint8, vector=(11,)
    float32)`` by default (channels: obstacles, tree, start, goal; see
    ``envs.observation.GridObservation``). Both images are at least 36x36, the smallest input of
    SB3's default CNN, so ``PPO("MultiInputPolicy", env)`` trains with SB3's defaults; smaller
    ``obs_size`` / ``local_size`` (below 36) need a custom extractor. ``observation="egocentric"``:
    ``Dict(local=(6, 16, 16) uint8, vector=(8,) float32)``, multi-scale windows around the progress
    vertex turned towards the goal (``EgocentricObservation``), for ``learning.models.extractor`` (too
    small for SB3's default CNN); ``observation="egocentric_flat"``: the same with the windows flattened,
    ``local=(1536,) float32`` in [0, 1], which SB3's ``MultiInputPolicy`` feeds to its MLP (the
    family ids' default from ``-v2``). Other worlds (geometric, 6-DoF rigid body): a ``Box`` vector
    (``VectorObservation``), for SB3's ``MlpPolicy``. With a bidirectional planner (``planner="rrtconnect"``)
    the image observation shows both trees (a fifth channel, the goal tree's) and the vector says whose
    turn it is and where the goal tree's vertex nearest the start lies (``envs.observation.TWO_TREE_FEATURES``;
    the rigid body's vector likewise); egocentric observations follow one tree and refuse it.

    ## Rewards
    -1 per iteration, so the return is minus the iterations-to-solution; ``reward="checks"`` adds
    ``-checks_weight`` per collision check. Optional shaping (``shaping=True``, off by default, never
    in the observation): ``F = gamma * Phi(s') - Phi(s)`` with ``Phi = -(geodesic distance from the
    tree's best vertex to the goal) / step_size`` (grid distance transform computed once per map) and
    ``Phi = 0`` at termination. Potential-based shaping leaves optimal policies unchanged (Ng, Harada
    & Russell, ICML 1999) when ``shaping_gamma`` equals the agent's discount.

    ## Episode End
    ``terminated`` when the planner has a solution; ``truncated`` after ``max_iterations`` steps.
    Stepping after either raises ``RuntimeError`` until ``reset()``. ``gym.make`` wraps the env in
    Gymnasium's ``TimeLimit`` at the same ``max_iterations`` (``make_sampler_env``), so
    ``env.spec.max_episode_steps`` is the episode's length whatever ``max_iterations`` is given.

    ## Info
    ``iterations``, ``solved``, ``path_cost``, ``collision_checks``, ``tree_size``, ``sample``,
    ``added``, ``lower_bound`` (ceil((L* - tolerance) / step) when the problem's reference length is
    known), and ``is_success`` at the end of an episode.

    ## Arguments
    ``map_source``: family name (``forest``, ``narrow_passage``, ``bugtrap``, ``maze``, ``rooms``),
    ``"movingai"``, ``"files"`` (default: the sample maps shipped in ``envs/data/maps``), a map
    (array, ``OccupancyGrid`` or path) or a callable ``np_random -> Problem``; ``source_kwargs``
    configure it. ``map`` (a map file, a 2-D boolean obstacle array or an ``OccupancyGrid``) with
    optional ``start`` and ``goal`` (world units) plans on the user's own map (random queries
    without ``start`` / ``goal``); it replaces ``map_source``. ``map_set`` (a folder of maps, a
    manifest, ``"generated"``, ``"movingai"`` or a ``planners.maps.mapset.MapSet``) draws episodes
    from its ``split`` part (default ``"train"``; ``source_kwargs`` go to ``MapSet.open``); it
    replaces ``map_source`` too.
    ``planner``: any registered planner (``planners.planner_names()``; default ``"rrt"``).
    ``step_size`` is the extension length of the RRT family; roadmap planners keep their own edge
    length. ``step_size``,
    ``max_iterations``, ``action_mode``, ``uniform_floor``, ``reach`` (relative mode),
    ``observation`` (``image`` or ``egocentric``), ``obs_size``, ``local_size``, ``local_scale``,
    ``reward``, ``checks_weight``, ``shaping``,
    ``shaping_gamma``, ``render_mode`` (``rgb_array`` or ``human``).

    ## Version History
    * v0: initial version (``point`` actions).
    * v1: ``mixture`` actions (a uniform floor).
    * v1, ``planner="rrtconnect"``: the goal tree joined the observation (it showed the start tree only).
    * v2 (the generated-family, ``MovingAI`` and ``Files`` ids): ``guided`` actions,
      ``egocentric_flat`` observations, ``shaping=True`` at ``shaping_gamma=0.99``
      (``envs.V2_DEFAULTS``); ``SamplerEnv``'s own defaults, and ``Planning-v1``'s, are version 1's.
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 15}

    def __init__(
        self,
        map_source: str | MapSource = "forest",
        source_kwargs: dict[str, Any] | None = None,
        planner: str = "rrt",
        step_size: float = 4.0,
        max_iterations: int = 2000,
        action_mode: str = "mixture",
        uniform_floor: float = 0.05,
        reach: float = 3.0,
        observation: str = "image",
        obs_size: int = 64,
        local_size: int = 48,
        local_scale: int = 1,
        reward: str = "iterations",
        checks_weight: float = 0.1,
        shaping: bool = False,
        shaping_gamma: float = 1.0,
        dim: int | None = None,
        render_mode: str | None = None,
        map: Any = None,  # noqa: A002 (the Gymnasium-style keyword users expect)
        start: Any = None,
        goal: Any = None,
        map_set: Any = None,
        split: str = "train",
    ) -> None:
        super().__init__()
        try:
            cls = planner_class(planner)
        except ValueError as exc:
            raise InputError(f"planner: {exc}") from None
        if cls.own_sampler:  # the agent is the sampler: a planner whose sampler is its algorithm cannot host it
            raise InputError(f"planner {cls.name} brings its own sampler; the env's agent samples for RRT, RRTConnect, "
                             "RRTstar, PRM or LazyPRM")
        planner = cls.name
        self.two_trees = cls.family == FAMILY_BIDIRECTIONAL
        if action_mode not in ACTION_MODES:
            raise InputError(f"action_mode must be one of {tuple(ACTION_MODES)}, got {action_mode!r}")
        if observation not in OBSERVATIONS:
            raise InputError(f"observation must be one of {tuple(OBSERVATIONS)}, got {observation!r}")
        if reward not in ("iterations", "checks"):
            raise InputError(f"reward must be 'iterations' or 'checks', got {reward!r}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise InputError(f"render_mode must be one of {self.metadata['render_modes']}, got {render_mode!r}")
        check_int(max_iterations, "max_iterations")
        step_size = _number("step_size", step_size, low=0.0, low_open=True)
        uniform_floor = _number("uniform_floor", uniform_floor, low=0.0, high=1.0)
        reach = _number("reach", reach, low=0.0, low_open=True)
        checks_weight = _number("checks_weight", checks_weight, low=0.0)
        shaping_gamma = _number("shaping_gamma", shaping_gamma, low=0.0, high=1.0)
        if map is not None and map_set is not None:
            raise InputError("give map= (one map) or map_set= (a set of maps), not both")
        if map is not None:
            if source_kwargs:
                raise InputError(f"source_kwargs {sorted(source_kwargs)} given with map=; pass map options "
                                 "(goal_tolerance, threshold, resolution) through source_kwargs only without map=")
            self.source = map_problem(map, start, goal)
        elif start is not None or goal is not None:
            raise InputError("start and goal need map= (the map they are points of)")
        elif map_set is not None:
            self.source = MapSetSource(map_set, split, **(source_kwargs or {}))
        else:
            self.source = make_source(map_source, **(source_kwargs or {}))
        self.planner_name = planner
        self.step_size = float(step_size)
        self.max_iterations = int(max_iterations)
        self.action_mode = action_mode
        self.reward_mode, self.checks_weight = reward, float(checks_weight)
        self.shaping, self.shaping_gamma = bool(shaping), float(shaping_gamma)
        self.render_mode = render_mode
        self.reach = float(reach)
        self.uniform_floor = float(uniform_floor)
        self._action_sampler = self.new_action_sampler()
        self.dim = int(dim if dim is not None else getattr(self.source, "dim", 2))
        self.observation = observation
        self.obs_size, self.local_size, self.local_scale = obs_size, local_size, local_scale
        self._guide = None
        if (observation.startswith("egocentric") or action_mode == "guided") and self.dim != 2:
            raise InputError("egocentric observations and guided actions are defined for 2-D grid problems")
        self._obs = self.new_observation()
        self.observation_space = self._obs.space
        self.action_space = self._action_sampler.action_space(self.dim)
        self.problem: Problem | None = None
        self.planner: Planner | None = None
        self._renderer = None
        self._last_sample = None
        self._ended = None

    # --- Gymnasium API -------------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        problem = (options or {}).get("problem") or self.source(self.np_random)
        if problem.dim != self.dim:
            raise ValueError(f"map source returned a {problem.dim}-D problem for a {self.dim}-D environment")
        self.problem = problem
        self.planner = make_planner(self.planner_name, problem, extension_step=self.step_size,
                                    sampler=self._action_sampler, seed=int(self.np_random.integers(2**63)))
        self._guide = self.new_guide(problem)
        self.planner.sampler.set_guide(self._guide)
        self._obs.reset(problem, self.max_iterations, self._guide)
        self._obs.update(self.planner)
        self._potential = self._geodesic_potential_init() if self.shaping else 0.0
        self._last_sample = None
        self._added = False
        self._ended = None  # "terminated" / "been truncated": further steps are refused until reset
        if self._renderer is not None:
            self._renderer.reset(problem)
        if self.render_mode == "human":
            self.render()
        return self._obs.build(self.planner), self._info()

    def step(self, action):
        if self.planner is None:
            raise RuntimeError("call reset() before step()")
        if self._ended is not None:
            raise RuntimeError(f"the episode has {self._ended}; call reset()")
        checks = self.planner.collision_checks
        self.planner.sampler.set_action(action)
        s = self.planner.step()
        self._last_sample = s.sample
        self._added = s.added >= 0
        self._obs.update(self.planner)
        terminated = s.solved
        truncated = not terminated and self.planner.iterations >= self.max_iterations
        reward = -1.0
        if self.reward_mode == "checks":
            reward -= self.checks_weight * (self.planner.collision_checks - checks)
        if self.shaping:
            phi = 0.0 if terminated else self._geodesic_potential(s.added)
            reward += self.shaping_gamma * phi - self._potential
            self._potential = phi
        info = self._info()
        if terminated or truncated:
            info["is_success"] = terminated
            self._ended = "terminated" if terminated else "been truncated"
        if self.render_mode == "human":
            self.render()
        return self._obs.build(self.planner), reward, terminated, truncated, info

    def sample_problem(self, seed: int | np.random.Generator | None = None) -> Problem:
        """A planning query (a ``Problem``) drawn from this environment's maps, as an episode draws it.

        ``seed``: an int (``reset(seed=seed)`` plans the same query), a ``np.random.Generator`` to
        draw with, or None (the environment's own ``np_random``, as the next episode would). For
        planning a query with a sampler of your own outside the environment::

            problem = gym.make("samplergym:SamplerGym/RRT-Forest-v2").unwrapped.sample_problem(7)
        """
        if seed is None:
            rng = self.np_random
        elif isinstance(seed, np.random.Generator):
            rng = seed
        else:
            rng = np.random.default_rng(check_int(seed, "seed", low=0))
        problem = self.source(rng)
        if problem.dim != self.dim:
            raise ValueError(f"map source returned a {problem.dim}-D problem for a {self.dim}-D environment")
        return problem

    def render(self):
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' or 'human'")
            return None
        if self._renderer is None:
            from .render import EpisodeRenderer

            self._renderer = EpisodeRenderer(human=self.render_mode == "human", fps=self.metadata["render_fps"])
            if self.problem is not None:
                self._renderer.reset(self.problem)
        if self.planner is None:
            raise RuntimeError("call reset() before render()")
        frame = self._renderer.draw(self.planner, self._last_sample)
        return frame if self.render_mode == "rgb_array" else None

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    # --- the parts a sampler outside the env is built from (``envs.EnvSampler``) -----------------

    def new_action_sampler(self):
        """A fresh, unbound sampler of this env's action mode: it turns an action into one sample."""
        return make_action_sampler(self.action_mode, self.step_size, self.uniform_floor,
                                   **({"reach": self.reach} if self.action_mode == "relative" else {}))

    def new_observation(self):
        """A fresh observation builder of this env's kind (``envs.observation.make_observation``)."""
        return make_observation(self.observation, self.dim, obs_size=self.obs_size, local_size=self.local_size,
                                local_scale=self.local_scale, two_trees=self.two_trees)

    def new_guide(self, problem: Problem):
        """The per-query ``GuidedSampling`` that egocentric observations and guided actions share, or None."""
        if not self.observation.startswith("egocentric") and self.action_mode != "guided":
            return None
        from planners.guidance.guided import GuidedSampling

        return GuidedSampling(problem, self.step_size, max_iterations=self.max_iterations,
                              uniform_floor=self.uniform_floor)

    def as_sampler(self, act, *, deterministic: bool = True):
        """This env's observation and action code as a planner ``Sampler`` driven by ``act(obs, rng)``.

        ``deterministic``: whether ``act`` ignores ``rng`` (see ``EnvSampler``, which warns about a
        deterministic ``act`` in an action mode without a uniform floor).
        """
        from .env_sampler import EnvSampler

        return EnvSampler(self, act, deterministic=deterministic)

    # --- helpers ---------------------------------------------------------------------------

    def _info(self) -> dict[str, Any]:
        r = self.planner.result()
        info = {
            "iterations": r.iterations,
            "solved": r.solved,
            "path_cost": r.cost,
            "collision_checks": r.collision_checks,
            "tree_size": r.num_vertices,
            "sample": None if self._last_sample is None else self._last_sample.copy(),
            "added": self._added,
        }
        bound = self.problem.iteration_lower_bound(self.step_size)
        if bound is not None:
            info["lower_bound"] = bound
        return info

    def _geodesic_potential_init(self) -> float:
        from planners.maps.gridsearch import distance_field

        grid = self.problem.world
        if not isinstance(grid, OccupancyGrid):
            raise ValueError("shaping needs an OccupancyGrid problem (geodesic distances on the grid)")
        self._field = distance_field(grid.obstacles, grid.cell_of(self.problem.goal)) * grid.resolution
        self._best_geo = self._field_at(self.problem.start)
        return -self._best_geo / self.step_size

    def _field_at(self, q: np.ndarray) -> float:
        r, c = self.problem.world.cell_of(q)
        d = self._field[r, c]
        return float(d) if np.isfinite(d) else float(np.nanmax(self._field[np.isfinite(self._field)]))

    def _geodesic_potential(self, added: int) -> float:
        if added >= 0:
            self._best_geo = min(self._best_geo, self._field_at(self.planner.view().vertices[added]))
        return -self._best_geo / self.step_size

    @property
    def guide(self):
        """The episode's ``GuidedSampling`` (egocentric observation and guided actions), or None."""
        return self._guide

    def __getstate__(self):
        state = self.__dict__.copy()
        state["_renderer"] = None  # matplotlib figures do not pickle
        return state


def make_sampler_env(**kwargs) -> gym.Env:
    """What ``gym.make`` builds for every ``SamplerGym/`` id: a ``SamplerEnv`` in ``TimeLimit(max_iterations)``.

    The limit follows the env's own ``max_iterations`` (a registered ``max_episode_steps`` could not:
    ``gym.make(id, max_iterations=5000)`` would be cut at the registered number), so both truncate at
    the same step and ``env.spec.max_episode_steps`` reports it.
    """
    env = SamplerEnv(**kwargs)
    return gym.wrappers.TimeLimit(env, env.max_iterations)


make_sampler_env.metadata = SamplerEnv.metadata  # gym.make reads the render modes from the entry point


def _number(name: str, value, low: float | None = None, high: float | None = None, low_open: bool = False) -> float:
    """``value`` as a finite float in [low, high] (``(low, high]`` with ``low_open``), else ``InputError``."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InputError(f"{name} must be a number, got {value!r}")
    v = float(value)
    lo_ok = low is None or (v > low if low_open else v >= low)
    if not (math.isfinite(v) and lo_ok and (high is None or v <= high)):
        lo = "-inf" if low is None else f"{low:g}"
        rng = f"{'(' if low_open else '['}{lo}, {'inf)' if high is None else f'{high:g}]'}"
        raise InputError(f"{name} must be a finite number in {rng}, got {value!r}")
    return v
