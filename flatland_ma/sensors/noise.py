"""Noise on a sensor's readings: gaussian, salt-and-pepper and dropout, drawn from the
env's one seeded generator, so a seed gives the same noisy observations every time."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gymnasium import spaces


@dataclass(frozen=True)
class Noise:
    """See ``scenario.spec_sensors.NoiseSpec``: ``gaussian`` is a standard deviation as a
    fraction of each entry's range; ``salt_pepper`` and ``dropout`` are chances per
    reading (an entry of a vector; a row of channels in a camera or an image)."""

    gaussian: float = 0.0
    salt_pepper: float = 0.0
    dropout: float = 0.0

    def apply(self, reading: np.ndarray, space: spaces.Box, rng: np.random.Generator) -> np.ndarray:
        """``reading`` with noise, clipped into ``space`` (changed in place and returned).

        Draws happen in a fixed order (gaussian, salt-and-pepper, dropout), each only when
        its level is above zero: a sensor without noise draws nothing, so it leaves every
        other draw of the episode (respawns, other sensors' noise) as it was."""
        low = np.broadcast_to(space.low, reading.shape)
        high = np.broadcast_to(space.high, reading.shape)
        if self.gaussian > 0:
            spread = np.where(np.isfinite(high - low), high - low, 1.0)
            reading += (rng.standard_normal(reading.shape) * self.gaussian * spread).astype(
                reading.dtype
            )
        cells = reading.shape[:-1] if reading.ndim > 1 else reading.shape
        if self.salt_pepper > 0:
            hit = rng.random(cells) < self.salt_pepper
            salt = rng.random(cells) < 0.5
            if reading.ndim > 1:
                hit, salt = hit[..., None], salt[..., None]
            reading[...] = np.where(hit, np.where(salt, high, low), reading)
        if self.dropout > 0:
            lost = rng.random(cells) < self.dropout
            if reading.ndim > 1:
                lost = lost[..., None]
            reading[...] = np.where(lost, low, reading)
        np.clip(reading, low, high, out=reading)
        return reading
