"""A SamplerGym environment's observation and action code as a planner ``Sampler``.

An agent trained in a ``SamplerEnv`` sees an observation and answers an action, which the env's action
mode turns into one sample. ``EnvSampler`` runs that same code inside any planner: at each draw it
brings a fresh observation builder up to date from the planner's tree view, asks ``act(obs, rng)`` for
an action and hands it to a fresh action sampler of the env's mode. With a deterministic ``act``, a
planner using it and a rollout of the env on the same query and planner seed are the same run.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from planners import SamplerBase

if TYPE_CHECKING:
    from planners import Problem

    from .sampler_env import SamplerEnv


class NoExplorationWarning(UserWarning):
    """A sampler that may never sample outside its policy's choices: deterministic, with no uniform floor."""


def no_exploration_message(env: SamplerEnv, who: str) -> str:
    """Why a deterministic sampler on ``env``'s action mode cannot explore, and what to change."""
    why = ("has no uniform floor" if env.action_mode == "point"
           else f"has uniform_floor={env.uniform_floor:g}")
    return (f"{who} with action_mode={env.action_mode!r}, which {why}: a policy that answers the same action "
            "for similar observations samples the same place every iteration and the planner may never reach the "
            "goal. Train with an action mode that keeps a uniform floor (action_mode='mixture', the default, or "
            "'bias', 'relative', 'guided', with uniform_floor > 0), or draw actions from the policy "
            "(deterministic=False)")


class _ViewHolder:
    """What an observation builder reads from a planner (``view()``), for a sampler that has only a view."""

    __slots__ = ("_view",)

    def __init__(self, view) -> None:
        self._view = view

    def view(self):
        return self._view


class EnvSampler(SamplerBase):
    """Samples where ``act`` says, through ``env``'s observation and action mode.

    Args:
        env: The (unwrapped) ``SamplerEnv`` whose observation kind, action mode, step size, uniform
            floor and ``max_iterations`` (which scales the iteration feature) define the sampler.
        act: ``act(obs, rng) -> action``; ``rng`` is the planner's generator, for stochastic choices.
        deterministic: Whether ``act`` answers the same action for the same observation. A
            deterministic ``act`` in an action mode without a uniform floor (``point``, or
            ``uniform_floor=0``) may sample one place forever; that combination warns when the
            sampler is built, naming what to change.
        act_batch: ``act_batch(obs, rng, k) -> k guided classes`` (the ``guided`` action mode only): with
            ``batch`` above 1, each observation decides the next ``batch`` samples, drawn from one
            answer (a decision batch: a guided sample is an offset from the progress vertex current when
            the planner uses it, so a batch keeps following the tree). ``batch``: samples per decision.

    Warns:
        NoExplorationWarning: ``deterministic`` and the env's action mode has no uniform floor.
    """

    def __init__(self, env: SamplerEnv, act: Callable[[Any, np.random.Generator], Any], *,
                 deterministic: bool = True, act_batch: Callable | None = None, batch: int = 1) -> None:
        from planners.base.fileio import InputError, check_int

        check_int(batch, "batch")
        if batch > 1 and (env.action_mode != "guided" or act_batch is None):
            raise InputError(f"batch={batch} needs the guided action mode and an act_batch; this sampler has "
                             f"action_mode={env.action_mode!r}" + ("" if act_batch else " and no act_batch"))
        self.env = env
        self.act = act
        self.act_batch, self.batch = act_batch, int(batch)
        if deterministic and not env.new_action_sampler().explores:
            warnings.warn(no_exploration_message(env, f"{type(self).__name__} (deterministic)"),
                          NoExplorationWarning, stacklevel=2)

    def bind(self, problem: Problem) -> EnvSampler:
        if problem.dim != self.env.dim:
            raise ValueError(f"{self!r} is for {self.env.dim}-D problems, got a {problem.dim}-D one")
        bound = super().bind(problem)
        guide = self.env.new_guide(problem)  # shared by the observation and the action mode, as in the env
        bound.actions = self.env.new_action_sampler().bind(problem)
        bound.actions.set_guide(guide)
        bound.observer = self.env.new_observation()
        bound.observer.reset(problem, self.env.max_iterations, guide)
        return bound

    def draw(self, rng, n, view):
        holder = _ViewHolder(view)
        self.observer.update(holder)
        obs = self.observer.build(holder)
        if self.batch > 1:
            k = min(n, self.batch)
            self.actions.set_classes(self.act_batch(obs, rng, k))
            return self.actions.draw(rng, k, view)
        self.actions.set_action(self.act(obs, rng))
        return self.actions.draw(rng, 1, view)

    def __repr__(self) -> str:
        return f"EnvSampler({self.env.action_mode} actions, {self.env.observation} observations)"
