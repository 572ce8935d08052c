"""The actor-critic network of the batched PPO, for whatever an agent observes and does.

It reads the env's raw observations, exactly as the env gives them (a batch of arrays, or
of dicts of arrays for a ``Dict`` space), so the module a checkpoint holds needs no
preprocessing. Each entry of the observation is encoded by its shape:

- a first-person image, (rays, channels): 1-D convolutions over the rays, on its first
  ``channels`` channels (colour, plus depth when asked);
- a map, (height, width, channels): 2-D convolutions;
- anything else (the heard messages, proprioception, ...): flattened as it is.

The encodings are joined and pass one fully connected layer (``hidden`` units), shared by
the value head and the policy's heads. With ``state_size`` the value comes instead from a
critic of its own that reads the world's global state and which agent the slot is (a
centralised critic, as MAPPO's; Yu et al., "The Surprising Effectiveness of PPO in
Cooperative Multi-Agent Games", 2022): two layers of ``hidden`` units. The policy still
reads only the agent's own observation, so a checkpoint plays without the state.

A ``Discrete`` action space has one categorical head; a ``MultiDiscrete`` one (moves plus
words on the channel) has one per component, independent given the features: an action's
log-probability and entropy are the sums of its components'. The policy's logits come
out joined along the last axis.
"""

from __future__ import annotations

import numpy as np
import torch
from gymnasium import spaces
from torch import nn

from baselines.common import conv_trunk, trunk_length
from flatland_ma.sensors.hearing import MESSAGES

STRIDED = ((32, 8, 4), (64, 4, 2), (64, 3, 1))
"""The strided 1-D trunk's layers: (filters, kernel, stride)."""
MAP = ((16, 8, 4), (32, 4, 2))
"""The 2-D trunk's layers for maps: (filters, kernel, stride); a 64 x 64 map becomes
32 channels of 6 x 6."""


def layer_init(layer: nn.Module, std: float = np.sqrt(2), bias: float = 0.0) -> nn.Module:
    """CleanRL's orthogonal initialisation."""
    nn.init.orthogonal_(layer.weight, std)
    nn.init.constant_(layer.bias, bias)
    return layer


def strided_trunk(channels: int, rays: int) -> tuple[nn.Sequential, int]:
    """The strided conv trunk and the length of its output."""
    layers, length = [], rays
    for filters, kernel, stride in STRIDED:
        layers += [nn.Conv1d(channels, filters, kernel, stride), nn.ReLU()]
        channels, length = filters, (length - kernel) // stride + 1
    return nn.Sequential(*layers), channels * length


class ImageInput(nn.Module):
    """A first-person image (batch, rays, channels) through 1-D convolutions."""

    def __init__(self, shape: tuple[int, ...], channels: int, network: str):
        super().__init__()
        rays, self.channels = shape[0], min(channels, shape[1])
        if network == "paper":
            self.trunk = nn.Sequential(conv_trunk(self.channels), nn.MaxPool1d(2))
            self.features = 64 * (trunk_length(rays) // 2)
        else:
            self.trunk, self.features = strided_trunk(self.channels, rays)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.trunk(x[..., : self.channels].transpose(-1, -2)).flatten(1)


class MapInput(nn.Module):
    """A map (batch, height, width, channels) through 2-D convolutions."""

    def __init__(self, shape: tuple[int, ...]):
        super().__init__()
        height, width, channels = shape
        layers = []
        for filters, kernel, stride in MAP:
            layers += [nn.Conv2d(channels, filters, kernel, stride), nn.ReLU()]
            channels = filters
            height, width = (height - kernel) // stride + 1, (width - kernel) // stride + 1
        if height < 1 or width < 1:
            raise ValueError(f"a map of {shape} is too small for the 2-D trunk {MAP}")
        self.trunk = nn.Sequential(*layers)
        self.features = channels * height * width

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.trunk(x.permute(0, 3, 1, 2)).flatten(1)


class FlatInput(nn.Module):
    """Any other entry, flattened."""

    def __init__(self, shape: tuple[int, ...]):
        super().__init__()
        self.features = int(np.prod(shape))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x.flatten(1)


def entry_input(key: str, shape: tuple[int, ...], channels: int, network: str) -> nn.Module:
    """The encoder of one observation entry, chosen by its shape (the heard messages,
    one row per speaker, are not an image)."""
    if len(shape) == 2 and shape[1] >= 3 and key != MESSAGES:
        return ImageInput(shape, channels, network)
    if len(shape) == 3:
        return MapInput(shape)
    return FlatInput(shape)


def action_sizes(space: spaces.Space) -> tuple[int, ...]:
    """The number of choices of each component of a discrete action space."""
    if isinstance(space, spaces.Discrete):
        return (int(space.n),)
    if isinstance(space, spaces.MultiDiscrete) and space.nvec.ndim == 1:
        return tuple(int(n) for n in space.nvec)
    raise ValueError(f"PPO acts in Discrete or MultiDiscrete spaces, not {space}")


class Agent(nn.Module):
    """Encoders per observation entry - Dense(hidden), then the policy's heads and the
    value head; orthogonal initialisation as in CleanRL."""

    def __init__(
        self,
        observation_space: spaces.Space,
        action_space: spaces.Space,
        hidden: int = 128,
        channels: int = 3,
        network: str = "strided",
        state_size: int = 0,
    ):
        super().__init__()
        if isinstance(observation_space, spaces.Dict):
            entries = {key: sub.shape for key, sub in observation_space.spaces.items()}
        else:
            entries = {"": observation_space.shape}
        if any(shape is None for shape in entries.values()):
            raise ValueError(f"PPO reads Box entries, not {observation_space}")
        self.dict_input = isinstance(observation_space, spaces.Dict)
        self.inputs = nn.ModuleDict(
            {
                key or "observation": entry_input(key, shape, channels, network)
                for key, shape in entries.items()
            }
        )
        features = sum(module.features for module in self.inputs.values())
        self.body = nn.Sequential(nn.Linear(features, hidden), nn.ReLU())
        for layer in [*self.inputs.modules(), *self.body.modules()]:
            if isinstance(layer, (nn.Conv1d, nn.Conv2d, nn.Linear)):
                layer_init(layer)
        self.sizes = action_sizes(action_space)
        self.actor = layer_init(nn.Linear(hidden, sum(self.sizes)), std=0.01)
        self.state_size = state_size
        """The length of the centralised critic's input; 0: the value reads the features."""
        if state_size:
            self.critic = nn.Sequential(
                layer_init(nn.Linear(state_size, hidden)),
                nn.ReLU(),
                layer_init(nn.Linear(hidden, hidden)),
                nn.ReLU(),
                layer_init(nn.Linear(hidden, 1), std=1.0),
            )
        else:
            self.critic = layer_init(nn.Linear(hidden, 1), std=1.0)

    def features(self, observation) -> torch.Tensor:
        if self.dict_input:
            parts = [module(observation[key]) for key, module in self.inputs.items()]
        else:
            parts = [self.inputs["observation"](observation)]
        return self.body(torch.cat(parts, dim=1) if len(parts) > 1 else parts[0])

    def forward(self, observation) -> torch.Tensor:
        """The policy's logits, every head's joined along the last axis."""
        return self.actor(self.features(observation))

    def value(self, observation, state: torch.Tensor | None = None) -> torch.Tensor:
        """The value of each row: from ``state`` with a centralised critic, else from the
        observation."""
        if self.state_size:
            assert state is not None, "a centralised critic reads the state"
            return self.critic(state).squeeze(-1)
        return self.critic(self.features(observation)).squeeze(-1)

    def act(self, observation, action: torch.Tensor | None = None, state=None):
        """A sampled action (batch, heads) unless ``action`` is given, its log-probability,
        the policy's entropy and the value (from ``state`` with a centralised critic)."""
        h = self.features(observation)
        heads = [
            torch.distributions.Categorical(logits=logits)
            for logits in self.actor(h).split(self.sizes, dim=-1)
        ]
        if action is None:
            action = torch.stack([head.sample() for head in heads], dim=-1)
        logprob = sum(head.log_prob(action[..., k]) for k, head in enumerate(heads))
        entropy = sum(head.entropy() for head in heads)
        assert isinstance(logprob, torch.Tensor) and isinstance(entropy, torch.Tensor)
        if self.state_size:
            assert state is not None, "a centralised critic reads the state"
            return action, logprob, entropy, self.critic(state).squeeze(-1)
        return action, logprob, entropy, self.critic(h).squeeze(-1)
