"""Any Stable-Baselines3 model trained on a SamplerGym environment, as a planner ``Sampler``.

    from learning import SB3Sampler
    sampler = SB3Sampler("user_ppo.zip", "SamplerGym/RRT-Forest-v0")
    RRT(problem, step_size=4.0, sampler=sampler, seed=0).solve(20_000)

The model sees what it saw in training and its actions become samples through the environment's own
code (``envs.EnvSampler``): same observation builder, same action mode, same step size. A file is read
with ``learning.models.checkpoint.read_sb3_zip`` (JSON and ``weights_only`` tensors; nothing is unpickled) and
its weights are loaded into the default policy of the algorithm they belong to (PPO / A2C, DQN, SAC,
TD3), built for the environment's spaces; pass ``policy_kwargs`` if the model was trained with others.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import torch
from gymnasium import spaces

from envs.env_sampler import EnvSampler
from envs.sampler_env import SamplerEnv
from learning.models.checkpoint import read_sb3_zip
from learning.models.threads import planning_thread_count, planning_threads
from planners.base.fileio import InputError


def _algorithms() -> dict[str, Any]:
    from stable_baselines3 import A2C, DQN, PPO, SAC, TD3

    return {"PPO": PPO, "A2C": A2C, "DQN": DQN, "SAC": SAC, "TD3": TD3}


def _guess_algorithm(state: dict, path: Path) -> str:
    """The algorithm whose default policy has these weight names (PPO and A2C share one policy)."""
    keys = set(state)
    if any(k.startswith("q_net.") for k in keys):
        return "DQN"
    if any(k.startswith("actor.mu") for k in keys):
        return "SAC" if any(k.startswith("actor.log_std") for k in keys) else "TD3"
    if any(k.startswith("action_net.") for k in keys):
        return "PPO"
    raise InputError(f"{path}: its weights ({', '.join(sorted(keys)[:4])}, ...) match no Stable-Baselines3 policy "
                     "this reader knows (PPO, A2C, DQN, SAC, TD3); pass algo=")


def load_sb3_policy(path: str | os.PathLike, env: SamplerEnv, *, algo: str | None = None,
                    policy_kwargs: dict | None = None):
    """The policy in an SB3 ``.zip``, rebuilt for ``env``'s spaces, without unpickling anything."""
    path = Path(path)
    _, state = read_sb3_zip(path)
    algos = _algorithms()
    name = (algo or _guess_algorithm(state, path)).upper()
    if name not in algos:
        raise InputError(f"algo must be one of {sorted(algos)}, got {algo!r}")
    kind = "MultiInputPolicy" if isinstance(env.observation_space, spaces.Dict) else "MlpPolicy"
    try:
        policy = algos[name].policy_aliases[kind](env.observation_space, env.action_space, lambda _: 0.0,
                                                  **(policy_kwargs or {}))
    except (AssertionError, TypeError, ValueError) as exc:
        raise InputError(f"{path}: a {name} {kind} cannot be built for this environment's spaces "
                         f"(observations {env.observation_space}, actions {env.action_space}): {exc}") from None
    try:
        policy.load_state_dict(state)
    except RuntimeError as exc:
        first = str(exc).splitlines()[1:2] or [str(exc)]
        raise InputError(f"{path}: its weights do not fit a default {name} {kind} for this environment "
                         f"({first[0].strip()}); was it trained on another env id or env kwargs, or with "
                         "policy_kwargs (pass the same policy_kwargs=)?") from None
    policy.set_training_mode(False)
    return policy


class SB3Sampler(EnvSampler):
    """A trained SB3 model (or a path to its ``.zip``) as a ``Sampler`` every planner accepts.

    Args:
        model: An SB3 model or policy, or the path of a model saved with ``model.save``.
        env_id: The SamplerGym id it was trained on; ``env_kwargs`` are the kwargs it was made with.
            They fix the observation and action code; the maps come from the planner's problem.
        deterministic: Take the policy's most likely action (the default). Otherwise draw the action
            from the policy's distribution with the planner's generator, so runs stay seeded
            (actor-critic policies: PPO, A2C). Deterministic in an action mode with no uniform floor
            (``point``, or ``uniform_floor=0``) warns (``envs.NoExplorationWarning``): such a
            sampler may sample one place forever.
        algo: For a path: the algorithm (``PPO``, ``A2C``, ``DQN``, ``SAC``, ``TD3``), guessed from the
            weight names if omitted. ``policy_kwargs``: those the model was trained with, if any.
        threads: torch threads for the policy's passes while planning (``learning.models.threads``):
            default ``SAMPLERGYM_TORCH_THREADS`` or 1; the caller's setting is restored after each pass.
    """

    def __init__(self, model: Any, env_id: str, *, deterministic: bool = True, algo: str | None = None,
                 policy_kwargs: dict | None = None, threads: int | None = None, **env_kwargs) -> None:
        import gymnasium as gym

        import envs

        gym.register_envs(envs)
        try:
            env = gym.make(env_id, **env_kwargs).unwrapped
        except gym.error.Error as exc:
            raise InputError(f"env_id {env_id!r}: {exc}") from None
        if not isinstance(env, SamplerEnv):
            raise InputError(f"env_id {env_id!r} is not a SamplerGym environment ({type(env).__name__})")
        if isinstance(model, (str, os.PathLike)):
            policy = load_sb3_policy(model, env, algo=algo, policy_kwargs=policy_kwargs)
            self.source = str(model)
        else:
            policy = getattr(model, "policy", model)
            if not hasattr(policy, "predict") or not hasattr(policy, "observation_space"):
                raise InputError("model must be a Stable-Baselines3 model, policy or .zip path, "
                                 f"got {type(model).__name__}")
            if policy.observation_space != env.observation_space or policy.action_space != env.action_space:
                raise InputError(f"the model was trained on observations {policy.observation_space} and actions "
                                 f"{policy.action_space}; {env_id} with {env_kwargs or 'no kwargs'} has "
                                 f"{env.observation_space} and {env.action_space}")
            self.source = type(model).__name__
        if not deterministic and not hasattr(policy, "get_distribution"):
            raise InputError(f"deterministic=False needs an actor-critic policy (PPO, A2C) whose action distribution "
                             f"can be drawn from; {type(policy).__name__} acts deterministically only")
        # eval mode once, here: SB3's predict() switches every module's mode on every call, which cost
        # about a third of a small CNN policy's time per decision (no module here trains)
        if hasattr(policy, "set_training_mode"):
            policy.set_training_mode(False)
        if threads is not None:
            planning_thread_count(threads)  # refused now, by name, rather than at the first draw
        self.threads = threads
        self.policy = policy
        self.deterministic = bool(deterministic)
        self.env_id = env_id
        super().__init__(env, self._act, deterministic=self.deterministic)

    def _act(self, obs, rng: np.random.Generator):
        with planning_threads(self.threads):
            return self._act_now(obs, rng)

    def _act_now(self, obs, rng: np.random.Generator):
        if self.deterministic:
            return self._predict(obs)
        with torch.no_grad():
            obs_t, _ = self.policy.obs_to_tensor(obs)
            dist = self.policy.get_distribution(obs_t).distribution
        if isinstance(dist, torch.distributions.Categorical):
            cdf = np.cumsum(dist.probs[0].double().numpy())
            return min(int(np.searchsorted(cdf, rng.random() * cdf[-1], side="right")), len(cdf) - 1)
        if isinstance(dist, torch.distributions.Normal):
            mean, std = dist.mean[0].double().numpy(), dist.stddev[0].double().numpy()
            a = mean + std * rng.standard_normal(mean.shape)
            space = self.policy.action_space
            return np.clip(a, space.low, space.high).astype(np.float32)
        raise InputError(f"deterministic=False: {type(dist).__name__} action distributions are not supported")

    def _predict(self, obs):
        """``policy.predict(obs, deterministic=True)[0]`` without its per-call mode switch and checks (same action)."""
        policy = self.policy
        if not hasattr(policy, "_predict") or not hasattr(policy, "obs_to_tensor"):
            return policy.predict(obs, deterministic=True)[0]
        with torch.inference_mode():
            obs_t, _ = policy.obs_to_tensor(obs)
            actions = policy._predict(obs_t, deterministic=True)
        space = policy.action_space
        actions = actions.cpu().numpy().reshape((-1, *space.shape))
        if isinstance(space, spaces.Box):
            actions = (policy.unscale_action(actions) if getattr(policy, "squash_output", False)
                       else np.clip(actions, space.low, space.high))
        return actions.squeeze(axis=0)

    def __repr__(self) -> str:
        mode = "deterministic" if self.deterministic else "stochastic"
        return f"SB3Sampler({self.source!r}, {self.env_id!r}, {mode})"
