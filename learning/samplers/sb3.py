"""Any Stable-Baselines3 model trained on a SamplerGym environment, as a planner ``Sampler``.

    from learning import SB3Sampler
    sampler = SB3Sampler("user_ppo.zip", "SamplerGym/RRT-Forest-v2")
    RRT(problem, step_size=4.0, sampler=sampler, seed=0).solve(20_000)

The model sees what it saw in training and its actions become samples through the environment's own
code (``envs.EnvSampler``): same observation builder, same action mode, same step size. The environment
package is reached as ``samplergym.envs``, so this works also where a project's own ``envs/`` folder
shadows the name ``envs``. A file is read with ``learning.models.checkpoint.read_sb3_zip`` (JSON and
``weights_only`` tensors; nothing is unpickled) and its weights are loaded into the default policy of the
algorithm they belong to (PPO / A2C, DQN, SAC, TD3), built for the environment's spaces; pass
``policy_kwargs`` if the model was trained with others.

Each sample costs a pass of the policy's actor. For PPO and A2C policies ``ActorPass`` runs it module by
module, without SB3's per-call checks, and reuses each observation key's features while that key's
array is unchanged; the actions are the ones ``model.predict`` gives. A policy with no CNN (the
``-v2`` family ids' observations, which SB3 flattens) runs in numpy (``MlpActor``), a few times
faster than a torch call at one decision per iteration.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

import numpy as np
import torch
from gymnasium import spaces

from learning.models.checkpoint import read_sb3_zip
from learning.models.threads import planning_thread_count, planning_threads
from planners.base.fileio import InputError
from samplergym import envs as env_package  # this library's envs, also where a project's own envs/ shadows the name

EnvSampler, SamplerEnv = env_package.EnvSampler, env_package.SamplerEnv


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
    data, state = read_sb3_zip(path)
    recorded = _recorded_space(data)
    if recorded is not None and recorded != _space_summary(env.observation_space):
        raise InputError(f"{path}: the model was trained on observations {recorded}; this environment gives "
                         f"{_space_summary(env.observation_space)}: make the sampler with the env id and env kwargs "
                         "(observation, obs_size, local_size, ...) it was trained with")
    algos = _algorithms()
    name = (algo or _guess_algorithm(state, path)).upper()
    if name not in algos:
        raise InputError(f"algo must be one of {sorted(algos)}, got {algo!r}")
    kind = "MultiInputPolicy" if isinstance(env.observation_space, spaces.Dict) else "MlpPolicy"
    try:
        policy = algos[name].policy_aliases[kind](env.observation_space, env.action_space, lambda _: 0.0,
                                                  **(policy_kwargs or {}))
    except (AssertionError, TypeError, ValueError, RuntimeError) as exc:
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


_BOX = re.compile(r"'([^']+)': Box\([^()]*\(([\d, ]*)\),\s*(\w+)\)")


def _space_summary(space) -> str:
    """A space's shapes and dtypes: ``{'image': (4, 64, 64) uint8, ...}`` for a Dict of Boxes, ``(11,) float32``."""
    if isinstance(space, spaces.Dict):
        return "{" + ", ".join(f"'{k}': {_shape_text(b.shape)} {b.dtype}" for k, b in sorted(space.spaces.items())
                               if isinstance(b, spaces.Box)) + "}"
    if isinstance(space, spaces.Box):
        return f"{_shape_text(space.shape)} {space.dtype}"
    return repr(space)


def _shape_text(shape) -> str:
    return "(" + ", ".join(str(int(n)) for n in shape) + ("," if len(shape) == 1 else "") + ")"


def _recorded_space(data: dict) -> str | None:
    """The observation space a model's ``data`` records, as :func:`_space_summary` writes it; None if it says none.

    Read from the plain fields SB3 writes beside the pickled space (which is never unpickled here):
    a Dict's ``spaces`` text, a Box's ``_shape`` and ``dtype``. Anything else is not judged (None).
    """
    obs = data.get("observation_space") if isinstance(data, dict) else None
    if not isinstance(obs, dict) or not isinstance(obs.get(":type:"), str):
        return None
    kind = obs[":type:"]
    if kind.endswith(".Dict'>") and isinstance(obs.get("spaces"), str):
        boxes = _BOX.findall(obs["spaces"])
        if not boxes or len(boxes) != obs["spaces"].count("':"):
            return None
        return "{" + ", ".join(f"'{k}': {_shape_text([int(n) for n in shape.replace(' ', '').split(',') if n])} "
                               f"{dtype}" for k, shape, dtype in sorted(boxes)) + "}"
    if kind.endswith(".Box'>") and isinstance(obs.get("_shape"), list) and isinstance(obs.get("dtype"), str) \
            and all(isinstance(n, int) for n in obs["_shape"]):
        return f"{_shape_text(obs['_shape'])} {obs['dtype']}"
    return None


def _gaussian_or_categorical(policy) -> bool | None:
    """For an SB3 actor-critic policy (PPO, A2C): True for Gaussian actions, False for categorical; else None."""
    from stable_baselines3.common.distributions import CategoricalDistribution, DiagGaussianDistribution
    from stable_baselines3.common.policies import ActorCriticPolicy

    if not isinstance(policy, ActorCriticPolicy):
        return None
    kind = type(policy.action_dist)
    return {DiagGaussianDistribution: True, CategoricalDistribution: False}.get(kind)


class ActorPass:
    """An SB3 actor-critic policy's actor (PPO, A2C), module by module, reusing a part's output while its input holds.

    SB3's ``predict`` copies the observation, checks and preprocesses it and runs every module on every
    call. Here the same modules run on the same tensors (so the outputs are the same numbers), with
    three savings: the preprocessing of each key is decided once; with SB3's ``CombinedExtractor``
    (the ``MultiInputPolicy`` default) each key's extractor is a part of its own, and a part whose
    input array equals the one it saw last returns its last output instead of running again. A planner
    iteration that adds no vertex (a sample in collision, or one the tree already covers) leaves the
    image observations unchanged, so most iterations skip most of the CNN.

    ``ActorPass.of(policy)`` builds one for the policies it reproduces exactly (an ``ActorCriticPolicy``
    with Gaussian or categorical actions and ``Box`` observations), else None.
    """

    def __init__(self, policy, gaussian: bool, parts: list[tuple[str | None, Any]], scales: dict) -> None:
        self.policy = policy
        self.gaussian = gaussian
        self.parts = parts  # (observation key, or None for the whole observation; its extractor)
        self.scales = scales  # observation key (None for a Box observation) -> (shape, divide by 255)
        self.device = policy.device  # SB3's property walks the parameters on every read
        self._last: dict = {}

    @classmethod
    def of(cls, policy) -> ActorPass | None:
        from stable_baselines3.common.preprocessing import is_image_space
        from stable_baselines3.common.torch_layers import CombinedExtractor

        gaussian = _gaussian_or_categorical(policy)
        if gaussian is None:
            return None
        space = policy.observation_space
        boxes = dict(space.spaces) if isinstance(space, spaces.Dict) else {None: space}
        if not all(type(box) is spaces.Box for box in boxes.values()):
            return None
        scales = {key: (box.shape, bool(policy.normalize_images and is_image_space(box))) for key, box in boxes.items()}
        extractor = policy.pi_features_extractor
        if isinstance(space, spaces.Dict) and type(extractor) is CombinedExtractor:
            parts = list(extractor.extractors.items())
        else:
            parts = [(None, extractor)]
        return cls(policy, gaussian, parts, scales)

    def __getstate__(self) -> dict:
        return {**self.__dict__, "_last": {}}

    def _tensor(self, key: str | None, array: np.ndarray) -> torch.Tensor:
        shape, image = self.scales[key]
        t = torch.from_numpy(array.reshape((1, *shape)))  # ``array`` is this pass's own copy
        if t.device != self.device:
            t = t.to(self.device)
        return t.float() / 255.0 if image else t.float()

    def _inputs(self, obs, key: str | None) -> tuple[np.ndarray, ...] | None:
        """The arrays a part reads (``key``'s, or all for the whole extractor); None if one has another shape."""
        keys = list(self.scales) if key is None else [key]
        arrays = tuple(np.asarray(obs if k is None else obs[k]) for k in keys)
        if any(a.shape != self.scales[k][0] for k, a in zip(keys, arrays, strict=True)):
            return None
        return arrays

    def _part(self, key: str | None, arrays: tuple[np.ndarray, ...]):
        """A part's input tensors, preprocessed as SB3's ``preprocess_obs`` does."""
        if key is not None or None in self.scales:
            return self._tensor(key, arrays[0])
        return {k: self._tensor(k, a) for k, a in zip(self.scales, arrays, strict=True)}

    def features(self, obs) -> torch.Tensor | None:
        """``policy.extract_features(obs_to_tensor(obs), pi_features_extractor)``; None if ``obs`` does not fit."""
        encoded = []
        for key, extractor in self.parts:
            arrays = self._inputs(obs, key)
            if arrays is None:
                return None
            last = self._last.get(key)
            if last is None or not all(np.array_equal(a, b) for a, b in zip(last[0], arrays, strict=True)):
                arrays = tuple(a.copy() for a in arrays)  # copies: a caller may reuse its arrays
                last = self._last[key] = (arrays, extractor(self._part(key, arrays)))
            encoded.append(last[1])
        return torch.cat(encoded, dim=1)

    def head(self, obs) -> torch.Tensor | None:
        """The action net's output for one observation (Gaussian means or categorical logits), or None."""
        with torch.inference_mode():
            features = self.features(obs)
            if features is None:
                return None
            return self.policy.action_net(self.policy.mlp_extractor.forward_actor(features))

    def distribution(self, head: torch.Tensor) -> torch.distributions.Distribution:
        """The torch distribution SB3 builds from ``head``."""
        dist = self.policy.action_dist
        with torch.inference_mode():
            if self.gaussian:
                return dist.proba_distribution(head, self.policy.log_std).distribution
            return dist.proba_distribution(action_logits=head).distribution

    def mode(self, head: torch.Tensor) -> torch.Tensor:
        """The deterministic action SB3 takes: the Gaussian's mean (``head`` itself), or the most probable class."""
        if self.gaussian:
            return head
        with torch.inference_mode():
            return torch.argmax(self.distribution(head).probs, dim=1)


#: Samples per decision of a sampler drawing guided classes (``SB3Sampler(batch=None)``): chosen on the
#: forest tuning maps by ``learning.sb3_defaults.choose_batch`` (docs/first-steps.md), the largest batch
#: whose median iterations stay within 10% of deciding every sample.
GUIDED_BATCH = 32


class MlpActor:
    """An SB3 actor-critic policy whose extractor only flattens, evaluated in numpy.

    An ``MlpPolicy``, or a ``MultiInputPolicy`` on non-image keys (the ``-v2`` family ids). Such a policy
    is a few small matrix products; torch's per-call overhead is several times their cost, so at one
    decision per planner iteration numpy runs the same layers on the same float32 weights (the outputs
    agree with torch's to rounding). ``MlpActor.of(policy)`` builds one for the policies it reproduces
    (flattening extractor, ``Linear`` and ``Tanh`` / ``ReLU`` policy layers, Gaussian or categorical
    actions), else None.
    """

    def __init__(self, keys: list[str | None], shapes: dict, layers: list, gaussian: bool, std: np.ndarray | None,
                 space) -> None:
        self.keys, self.shapes, self.layers = keys, shapes, layers
        self.gaussian, self.std, self.space = gaussian, std, space

    @classmethod
    def of(cls, policy) -> MlpActor | None:
        from stable_baselines3.common.preprocessing import is_image_space
        from stable_baselines3.common.torch_layers import CombinedExtractor, FlattenExtractor
        from torch import nn

        gaussian = _gaussian_or_categorical(policy)
        if gaussian is None:
            return None
        space = policy.observation_space
        extractor = policy.pi_features_extractor
        if isinstance(space, spaces.Dict) and type(extractor) is CombinedExtractor:
            keys = list(extractor.extractors)
            if not all(type(m) is nn.Flatten for m in extractor.extractors.values()):
                return None
            boxes = {k: space.spaces[k] for k in keys}
        elif type(space) is spaces.Box and type(extractor) is FlattenExtractor:
            keys, boxes = [None], {None: space}
        else:
            return None
        if not all(type(b) is spaces.Box and not is_image_space(b) for b in boxes.values()):
            return None
        layers = []
        for module in [*policy.mlp_extractor.policy_net, policy.action_net]:
            if type(module) is nn.Linear:
                layers.append((module.weight.detach().cpu().numpy().astype(np.float32),
                               module.bias.detach().cpu().numpy().astype(np.float32)))
            elif type(module) in (nn.Tanh, nn.ReLU):
                layers.append(np.tanh if type(module) is nn.Tanh else _relu)
            else:
                return None
        std = np.exp(policy.log_std.detach().cpu().numpy().astype(np.float64)) if gaussian else None
        return cls(keys, {k: b.shape for k, b in boxes.items()}, layers, gaussian, std, policy.action_space)

    def head(self, obs) -> np.ndarray | None:
        """The action net's output (Gaussian means or categorical logits) for one observation, or None."""
        parts = []
        for k in self.keys:
            a = np.asarray(obs if k is None else obs[k])
            if a.shape != self.shapes[k]:
                return None
            parts.append(a.reshape(-1))
        x = np.concatenate(parts).astype(np.float32, copy=False)
        for layer in self.layers:
            x = layer(x) if callable(layer) else layer[0] @ x + layer[1]
        return x

    def act(self, obs, rng: np.random.Generator, deterministic: bool):
        """SB3's action (``deterministic``) or one drawn from its distribution with ``rng``; None if ``obs`` misfits."""
        head = self.head(obs)
        if head is None:
            return None
        if self.gaussian:
            a = head.astype(np.float64) if deterministic else head + self.std * rng.standard_normal(head.shape)
            return np.clip(a, self.space.low, self.space.high).astype(np.float32)
        if deterministic:
            return np.int64(np.argmax(head))
        return int(_draw_classes(np.exp(head.astype(np.float64) - float(head.max())), rng, 1)[0])


def _draw_classes(weights: np.ndarray, rng: np.random.Generator, k: int) -> np.ndarray:
    """``k`` classes drawn with probabilities proportional to ``weights`` (one uniform each, as ``_act_now``)."""
    cdf = np.cumsum(weights)
    return np.minimum(np.searchsorted(cdf, rng.random(k) * cdf[-1], side="right"), len(cdf) - 1).astype(np.int64)


def _relu(x: np.ndarray) -> np.ndarray:
    return np.maximum(x, 0.0)


class SB3Sampler(EnvSampler):
    """A trained SB3 model (or a path to its ``.zip``) as a ``Sampler`` every planner accepts.

    Args:
        model: An SB3 model or policy, or the path of a model saved with ``model.save``.
        env_id: The SamplerGym id it was trained on; ``env_kwargs`` are the kwargs it was made with.
            They fix the observation and action code; the maps come from the planner's problem.
        deterministic: Take the policy's most likely action (the default, except in the ``guided``
            action mode, whose classes are cells to sample in: there the default draws). Otherwise
            draw the action from the policy's distribution with the planner's generator, so runs
            stay seeded (actor-critic policies: PPO, A2C). Deterministic in an action mode with no uniform floor
            (``point``, or ``uniform_floor=0``) warns (``envs.NoExplorationWarning``): such a
            sampler may sample one place forever.
        algo: For a path: the algorithm (``PPO``, ``A2C``, ``DQN``, ``SAC``, ``TD3``), guessed from the
            weight names if omitted. ``policy_kwargs``: those the model was trained with, if any.
        batch: Samples per decision in the ``guided`` action mode (``envs.EnvSampler``): each
            observation answers ``batch`` classes, drawn from the policy's distribution (its mode,
            deterministically), and the planner uses their samples in turn. Default
            ``GUIDED_BATCH`` where the sampler draws guided classes, else 1 (which decides every
            sample, so a deterministic sampler's run is the env's rollout, draw for draw).
        threads: torch threads for the policy's passes while planning (``learning.models.threads``):
            default ``SAMPLERGYM_TORCH_THREADS`` or 1; the caller's setting is restored after each pass.
    """

    def __init__(self, model: Any, env_id: str, *, deterministic: bool | None = None, algo: str | None = None,
                 policy_kwargs: dict | None = None, threads: int | None = None, batch: int | None = None,
                 **env_kwargs) -> None:
        import gymnasium as gym

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
        if deterministic is None:  # a guided class is a distribution over cells: its draws are the sampler
            deterministic = env.action_mode != "guided" or not hasattr(policy, "get_distribution")
        if batch is None:
            batch = GUIDED_BATCH if env.action_mode == "guided" and not deterministic else 1
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
        self._actor = ActorPass.of(policy)
        self._mlp = MlpActor.of(policy)
        super().__init__(env, self._act, deterministic=self.deterministic, act_batch=self._act_batch, batch=batch)

    def _act(self, obs, rng: np.random.Generator):
        with planning_threads(self.threads):
            return self._act_now(obs, rng)

    def _act_batch(self, obs, rng: np.random.Generator, k: int) -> np.ndarray:
        """``k`` guided classes for one observation: the policy's mode ``k`` times, or ``k`` draws from it."""
        with planning_threads(self.threads):
            if self.deterministic:
                return np.full(k, int(self._act_now(obs, rng)), dtype=np.int64)
            head = self._mlp.head(obs) if self._mlp is not None else None
            if head is not None:
                return _draw_classes(np.exp(head.astype(np.float64) - float(head.max())), rng, k)
            head = self._actor.head(obs) if self._actor is not None else None
            if head is not None:
                dist = self._actor.distribution(head)
            else:
                with torch.no_grad():
                    dist = self.policy.get_distribution(self.policy.obs_to_tensor(obs)[0]).distribution
            return _draw_classes(dist.probs[0].double().numpy(), rng, k)

    def _act_now(self, obs, rng: np.random.Generator):
        if self._mlp is not None:
            action = self._mlp.act(obs, rng, self.deterministic)
            if action is not None:
                return action
        head = self._actor.head(obs) if self._actor is not None else None
        if self.deterministic:
            return self._predict(obs) if head is None else self._actions(self._actor.mode(head))
        if head is not None:
            dist = self._actor.distribution(head)
        else:
            with torch.no_grad():
                obs_t, _ = self.policy.obs_to_tensor(obs)
                dist = self.policy.get_distribution(obs_t).distribution
        if isinstance(dist, torch.distributions.Categorical):
            return int(_draw_classes(dist.probs[0].double().numpy(), rng, 1)[0])
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
            return self._actions(policy._predict(obs_t, deterministic=True))

    def _actions(self, actions: torch.Tensor):
        """A batch of one action as ``policy.predict`` returns it: an array of the space's shape, clipped to a Box."""
        policy = self.policy
        space = policy.action_space
        actions = actions.cpu().numpy().reshape((-1, *space.shape))
        if isinstance(space, spaces.Box):
            actions = (policy.unscale_action(actions) if getattr(policy, "squash_output", False)
                       else np.clip(actions, space.low, space.high))
        return actions.squeeze(axis=0)

    def __repr__(self) -> str:
        mode = "deterministic" if self.deterministic else "stochastic"
        return f"SB3Sampler({self.source!r}, {self.env_id!r}, {mode})"
