"""Rendering of sampler-environment episodes: rgb frames, a window, and GIF/MP4 recordings."""

from __future__ import annotations

import os
import sys
from collections.abc import Callable

import gymnasium as gym
import numpy as np

from planners import Planner, Problem
from planners.viz.plotting import PlannerAnimator, planner_animator, save_animation


def display_available() -> bool:
    """True when a GUI window can be opened."""
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


class EpisodeRenderer:
    """Frames of map, tree, current sample and path; optionally shown in a window.

    One figure per problem is reused for every frame (only the edges, sample and path change).
    """

    def __init__(self, human: bool = False, fps: int = 15) -> None:
        self.human = human
        self.fps = fps
        self._animator: PlannerAnimator | None = None
        self._window = None
        if human and not display_available():
            gym.logger.warn("render_mode='human' but no display is available; frames are not shown")
            self.human = False

    def reset(self, problem: Problem) -> None:
        self._animator = planner_animator(problem)

    def draw(self, planner: Planner, sample: np.ndarray | None) -> np.ndarray:
        if self._animator is None:
            self.reset(planner.problem)
        frame = self._animator.frame(planner, sample)
        if self.human:
            self._show(frame)
        return frame

    def _show(self, frame: np.ndarray) -> None:
        import matplotlib.pyplot as plt

        if self._window is None:
            plt.ion()
            fig, ax = plt.subplots()
            ax.set_axis_off()
            self._window = (fig, ax.imshow(frame))
        else:
            self._window[1].set_data(frame)
        self._window[0].canvas.draw_idle()
        plt.pause(1.0 / self.fps)

    def close(self) -> None:
        if self._window is not None:
            import matplotlib.pyplot as plt

            plt.close(self._window[0])
            self._window = None


def record_episode(env: gym.Env, policy: Callable[[object], np.ndarray] | None, path: str | os.PathLike, *,
                   seed: int | None = None, every: int = 1, max_frames: int = 300, fps: int = 15) -> dict:
    """Run one episode and save it as an animated GIF (or MP4 when ``path`` ends in ``.mp4``).

    ``env`` must have ``render_mode="rgb_array"``; ``policy`` maps an observation to an action
    (None: random actions from the action space). Returns the final step's ``info``.
    """
    if env.render_mode != "rgb_array":
        raise ValueError("record_episode needs an environment made with render_mode='rgb_array'")
    obs, info = env.reset(seed=seed)
    if seed is not None:
        env.action_space.seed(seed)
    frames = [env.render()]
    t = 0
    done = False
    while not done:
        action = env.action_space.sample() if policy is None else policy(obs)
        obs, _, terminated, truncated, info = env.step(action)
        done = terminated or truncated
        t += 1
        if t % every == 0 or done:
            frames.append(env.render())
            if len(frames) > max_frames:  # keep long episodes bounded: drop every other frame
                frames = frames[::2]
                every *= 2
    save_animation(frames, path, fps)
    return info
