"""The encoders the networks of ``policies.networks`` are built of: each observation entry
through layers chosen by its shape (a first-person image through 1-D convolutions, a map
through 2-D ones, anything else flattened), the paper's and the strided 1-D trunks, and
the initialisations (Keras' and CleanRL's).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TypeVar

import numpy as np
import torch
from torch import nn

from flatland_ma.sensors.hearing import MESSAGES

CONV_CHANNELS = (32, 48, 64)
CONV_KERNELS = (8, 4, 3)
"""The paper's 1-D trunk: filters and kernel of each layer, stride 1."""
STRIDED = ((32, 8, 4), (64, 4, 2), (64, 3, 1))
"""The strided 1-D trunk's layers: (filters, kernel, stride)."""
MAP = ((16, 8, 4), (32, 4, 2))
"""The 2-D trunk's layers for maps: (filters, kernel, stride); a 64 x 64 map becomes
32 channels of 6 x 6."""


def conv_trunk(in_channels: int, activation: type[nn.Module] = nn.ReLU) -> nn.Sequential:
    """The paper's 1-D convolutions: (32 filters, kernel 8) - (48, 4) - (64, 3), stride 1,
    no padding: a 64-ray image becomes 64 channels of length 52."""
    layers, channels = [], in_channels
    for out_channels, kernel in zip(CONV_CHANNELS, CONV_KERNELS):
        layers += [nn.Conv1d(channels, out_channels, kernel), activation()]
        channels = out_channels
    return nn.Sequential(*layers)


def trunk_length(rays: int) -> int:
    """Length of the paper trunk's output for an image of ``rays`` rays."""
    return rays - sum(k - 1 for k in CONV_KERNELS)


def keras_init(module: nn.Module) -> None:
    """Keras' default initialisation (Glorot uniform weights, zero biases), for the
    baselines whose reference implementation is written in Keras."""
    for layer in module.modules():
        if isinstance(layer, (nn.Conv1d, nn.Linear)) and layer.bias is not None:
            nn.init.xavier_uniform_(layer.weight)
            nn.init.zeros_(layer.bias)


Layer = TypeVar("Layer", bound=nn.Conv1d | nn.Conv2d | nn.Linear)


def layer_init(layer: Layer, std: float = np.sqrt(2), bias: float = 0.0) -> Layer:
    """CleanRL's orthogonal initialisation."""
    nn.init.orthogonal_(layer.weight, std)
    if layer.bias is not None:
        nn.init.constant_(layer.bias, bias)
    return layer


def strided_trunk(channels: int, rays: int) -> tuple[nn.Sequential, int]:
    """The strided conv trunk and the length of its output."""
    layers, length = [], rays
    for filters, kernel, stride in STRIDED:
        layers += [nn.Conv1d(channels, filters, kernel, stride), nn.ReLU()]
        channels, length = filters, (length - kernel) // stride + 1
    if length < 1:
        raise ValueError(f"an image of {rays} rays is too short for the strided trunk")
    return nn.Sequential(*layers), channels * length


class ImageInput(nn.Module):
    """A first-person image (batch, rays, channels) through 1-D convolutions; with
    ``frames`` K > 1, K of them (batch, K, rays, channels), their channels joined."""

    def __init__(self, shape: Sequence[int], channels: int, network: str, frames: int = 1):
        super().__init__()
        rays, self.channels, self.frames = shape[0], min(channels, shape[1]), frames
        if network == "paper":
            if trunk_length(rays) // 2 < 1:
                raise ValueError(f"an image of {rays} rays is too short for the paper's trunk")
            self.trunk = nn.Sequential(conv_trunk(frames * self.channels), nn.MaxPool1d(2))
            self.features = 64 * (trunk_length(rays) // 2)
        else:
            self.trunk, self.features = strided_trunk(frames * self.channels, rays)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = x[..., : self.channels].transpose(-1, -2)
        if self.frames > 1:  # (batch, K, channels, rays): frame k's channels k C ... (k + 1) C
            x = x.flatten(1, 2)
        if torch.is_grad_enabled():
            return self.trunk(x).flatten(1)
        for layer in self.trunk:  # acting: no gradient, small batches
            x = unfolded_conv1d(x, layer) if isinstance(layer, nn.Conv1d) else layer(x)
        return x.flatten(1)


def unfolded_conv1d(x: torch.Tensor, conv: nn.Conv1d) -> torch.Tensor:
    """``conv(x)`` (no padding, no dilation) as one matrix product over the input's
    windows. Without gradients it takes 0.4-0.8x the time of oneDNN's convolution at the
    batches of an acting pass (16-512 rows of a 64-ray image, one thread); with them its
    backward pass is slower, so training keeps ``conv``. The same sums in another order:
    equal to about 1e-6."""
    (kernel,), (stride,) = conv.kernel_size, conv.stride
    windows = x.unfold(2, kernel, stride)  # (batch, channels, length, kernel)
    batch, channels, length, _ = windows.shape
    rows = windows.permute(0, 2, 1, 3).reshape(batch, length, channels * kernel)
    out = rows @ conv.weight.reshape(conv.out_channels, -1).t()
    if conv.bias is not None:
        out = out + conv.bias
    return out.transpose(1, 2)


class MapInput(nn.Module):
    """A map (batch, height, width, channels) through 2-D convolutions; with ``frames``
    K > 1, K of them (batch, K, height, width, channels), their channels joined."""

    def __init__(self, shape: Sequence[int], frames: int = 1):
        super().__init__()
        height, width, channels = shape
        self.frames = frames
        channels *= frames
        layers = []
        for filters, kernel, stride in MAP:
            layers += [nn.Conv2d(channels, filters, kernel, stride), nn.ReLU()]
            channels = filters
            height, width = (height - kernel) // stride + 1, (width - kernel) // stride + 1
        if height < 1 or width < 1:
            raise ValueError(f"a map of {tuple(shape)} is too small for the 2-D trunk {MAP}")
        self.trunk = nn.Sequential(*layers)
        self.features = channels * height * width

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if self.frames > 1:
            return self.trunk(x.permute(0, 1, 4, 2, 3).flatten(1, 2)).flatten(1)
        return self.trunk(x.permute(0, 3, 1, 2)).flatten(1)


class FlatInput(nn.Module):
    """Any other entry, flattened (with ``frames`` K > 1, its K frames one after another)."""

    def __init__(self, shape: Sequence[int], frames: int = 1):
        super().__init__()
        self.features = frames * int(np.prod(shape))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x.flatten(1)


def entry_input(
    key: str, shape: Sequence[int], channels: int, network: str, frames: int = 1
) -> nn.Module:
    """The encoder of one observation entry of ``shape`` (read as its last ``frames``
    observations), chosen by its shape (the heard messages, one row per speaker, are not
    an image)."""
    if len(shape) == 2 and shape[1] >= 3 and key != MESSAGES:
        return ImageInput(shape, channels, network, frames)
    if len(shape) == 3:
        return MapInput(shape, frames)
    return FlatInput(shape, frames)
