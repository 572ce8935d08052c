"""The lidar: a ring of range-finding rays all around the body, distances only."""

from __future__ import annotations

import math

import numpy as np
from gymnasium import spaces

from flatland_ma.sensors.kernel import FALLOFF_NONE
from flatland_ma.sensors.sensor import Sensor


class Lidar(Sensor, kind="lidar"):
    """``rays`` rays evenly all around, ray 0 straight ahead and the rest
    counter-clockwise (ray i at ``360 * i / rays`` degrees from the heading).

    Each entry is the distance from the mount's centre to the first thing the ray hits, as
    a fraction of ``range`` (1: nothing within range). It is cast in the same kernel call
    as every camera, so it sees what they see (never its own agent). The observation is
    ``Box(0, 1, (rays,), float32)``.
    """

    def __init__(
        self,
        rays: int = 32,
        range: float = 300.0,  # noqa: A002 - the scenario key
        mount: str = "base",
        name: str = "lidar",
    ):
        self.name = name
        self.mount = mount
        turn = 2 * math.pi * np.arange(rays) / rays
        self.angles = np.where(turn > math.pi, turn - 2 * math.pi, turn)
        self.half_fov = math.pi
        self.view_range = float(range)
        self.falloff = FALLOFF_NONE
        self.space = spaces.Box(0.0, 1.0, (rays,), np.float32)

    def read(self, results, k: int) -> np.ndarray:
        return results.image[results.slices[k], 3].copy()
