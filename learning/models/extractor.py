"""Features extractor and policy layout for the egocentric observation.

SB3's NatureCNN needs images of at least 36x36 and is far too heavy for a sampler that must answer in
microseconds, so the image part is a small patchify CNN: a 4x4 stride-4 convolution (each 16x16
window becomes 4x4 patches) and a 2x2 stride-2 convolution, then a linear layer joins it with an
MLP of the vector features. Every width is a parameter: the actor runs once per sampler decision,
so its size is paid in planning time (``scripts/train.py --conv-channels --features-dim --hidden``).
"""

from __future__ import annotations

import gymnasium as gym
import torch
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from torch import nn

from learning.models.fast_policy import KERNELS


class EgocentricExtractor(BaseFeaturesExtractor):
    """CNN for ``local`` (C, 16, 16) windows plus an MLP for ``vector``.

    Args:
        observation_space: ``Dict(local=Box(C, 16, 16) uint8, vector=Box(k,))``.
        features_dim: Output width.
        channels: Output channels of the two convolutions.
        vector_dim: Width of the vector features' layer.
    """

    def __init__(self, observation_space: gym.spaces.Dict, features_dim: int = 128,
                 channels: tuple[int, int] = (16, 32), vector_dim: int = 32) -> None:
        super().__init__(observation_space, features_dim)
        c, h, w = observation_space["local"].shape
        if (h, w) != (16, 16):
            raise ValueError(f"EgocentricExtractor expects 16x16 windows, got {h}x{w}")
        k = observation_space["vector"].shape[0]
        c1, c2 = (int(x) for x in channels)
        k1, k2 = KERNELS
        self.cnn = nn.Sequential(nn.Conv2d(c, c1, k1, k1), nn.ReLU(), nn.Conv2d(c1, c2, k2, k2), nn.ReLU(),
                                 nn.Flatten())
        with torch.no_grad():  # size the head with one pass, as SB3's extractors do
            n = self.cnn(torch.as_tensor(observation_space["local"].sample()[None]).float()).shape[1]
        self.vec = nn.Sequential(nn.Linear(k, vector_dim), nn.ReLU())
        self.head = nn.Sequential(nn.Linear(n + vector_dim, features_dim), nn.ReLU())

    def forward(self, obs: dict[str, torch.Tensor]) -> torch.Tensor:
        return self.head(torch.cat([self.cnn(obs["local"]), self.vec(obs["vector"])], dim=1))


def policy_kwargs(features_dim: int = 128, hidden: int = 128, channels: tuple[int, int] = (16, 32),
                  vector_dim: int = 32) -> dict:
    """``policy_kwargs`` for ``PPO("MultiInputPolicy", ...)``.

    The defaults are the widths used before they were parameters, so runs saved then still load;
    ``TrainConfig`` holds the widths training uses now.

    Actor and critic keep separate extractors, so fitting the critic never disturbs an imitation-trained actor.
    """
    return dict(
        features_extractor_class=EgocentricExtractor,
        features_extractor_kwargs=dict(features_dim=features_dim, channels=tuple(channels), vector_dim=vector_dim),
        net_arch=dict(pi=[hidden], vf=[hidden]),
        activation_fn=nn.ReLU,
        share_features_extractor=False,
    )
