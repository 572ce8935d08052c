"""The first-person camera: a fan of rays giving a 1-D image of colour and depth."""

from __future__ import annotations

import math

import numpy as np
from gymnasium import spaces

from flatland_ma.sensors.kernel import FALLOFF_LINEAR, FALLOFF_NONE
from flatland_ma.sensors.sensor import Sensor

CHANNELS = ("red", "green", "blue", "depth")
FALLOFFS = {"linear": FALLOFF_LINEAR, "none": FALLOFF_NONE}
"""How colour intensity falls with distance ``d``: ``1 - d / range``, or not at all."""


class Camera(Sensor, kind="camera"):
    """``rays`` rays spread evenly over ``fov`` degrees, leftmost first.

    Ray i points at ``fov * (1/2 - (i + 1/2) / rays)`` degrees from the heading
    (counter-clockwise positive), so the image reads left to right as the agent sees it.
    Each pixel is the RGB colour of the first thing the ray hits times an intensity
    (``1 - d / range`` for linear falloff), and the depth ``d / range``; a ray that hits
    nothing gives black and depth 1. The observation is ``Box(0, 1, (rays, 4), float32)``.
    """

    def __init__(
        self,
        rays: int = 64,
        fov: float = 120.0,
        range: float = 300.0,  # noqa: A002 - the scenario key
        falloff: str = "linear",
        mount: str = "base",
        name: str = "camera",
    ):
        self.name = name
        self.mount = mount
        fov_rad = math.radians(fov)
        self.angles = fov_rad * (0.5 - (np.arange(rays) + 0.5) / rays)
        self.half_fov = float(np.abs(self.angles).max())
        self.view_range = float(range)
        self.falloff = FALLOFFS[falloff]
        self.space = spaces.Box(0.0, 1.0, (rays, len(CHANNELS)), np.float32)

    def read(self, results, rays: slice) -> np.ndarray:
        return results.image[rays].copy()
