"""The first-person camera: a fan of rays giving a 1-D image of colour and depth."""

from __future__ import annotations

import math

import numpy as np
from gymnasium import spaces

from flatland_ma.scenario.schema import CameraSpec
from flatland_ma.sensors.kernel import FALLOFF_LINEAR, FALLOFF_NONE

CHANNELS = ("red", "green", "blue", "depth")


class Camera:
    """``rays`` rays spread evenly over ``fov`` degrees, leftmost first.

    Ray i points at ``fov * (1/2 - (i + 1/2) / rays)`` degrees from the heading
    (counter-clockwise positive), so the image reads left to right as the agent sees it.
    Each pixel is the RGB colour of the first thing the ray hits times an intensity
    (``1 - d / range`` for linear falloff), and the depth ``d / range``; a ray that hits
    nothing gives black and depth 1.
    """

    def __init__(self, spec: CameraSpec):
        self.spec = spec
        self.n_rays = spec.rays
        fov = math.radians(spec.fov)
        self.angles = fov * (0.5 - (np.arange(spec.rays) + 0.5) / spec.rays)
        self.half_fov = float(np.abs(self.angles).max())
        self.falloff = FALLOFF_LINEAR if spec.falloff == "linear" else FALLOFF_NONE
        self.observation_space = spaces.Box(0.0, 1.0, (spec.rays, len(CHANNELS)), np.float32)
