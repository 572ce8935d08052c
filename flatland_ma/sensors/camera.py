"""The first-person camera: a fan of rays giving a 1-D image of colour and depth."""

from __future__ import annotations

import math

import numpy as np
from gymnasium import spaces

from flatland_ma.sensors.kernel import FALLOFF_LINEAR, FALLOFF_NONE
from flatland_ma.sensors.semantic import SEMANTIC_COLORS, SEMANTIC_KINDS
from flatland_ma.sensors.sensor import Sensor

CHANNELS = ("red", "green", "blue", "depth")
FALLOFFS = {"linear": FALLOFF_LINEAR, "exponential": FALLOFF_NONE, "none": FALLOFF_NONE}
"""The kernel's law for each falloff: ``1 - d / range`` there, or full colour (exponential
falloff is applied to the full colour when the camera reads its rays)."""


class Camera(Sensor, kind="camera"):
    """``rays`` rays spread evenly over ``fov`` degrees, leftmost first.

    Ray i points at ``fov * (1/2 - (i + 1/2) / rays)`` degrees from the heading
    (counter-clockwise positive), so the image reads left to right as the agent sees it.
    Per ray, the ``channels`` in order: ``rgb``, the colour of the first thing the ray
    hits times an intensity (``1 - d / range`` for linear falloff, ``exp(-d / decay)``
    for exponential, 1 for none); ``depth``, ``d /
    range``; ``semantic``, the kind of thing hit (``SEMANTIC_KINDS``), as its id or
    one-hot. A ray that hits nothing gives black, depth 1 and kind 0. The observation is
    ``Box(rays, width)`` float32; the default channels (rgb, depth) give width 4.
    """

    def __init__(
        self,
        rays: int = 64,
        fov: float = 120.0,
        range: float = 300.0,  # noqa: A002 - the scenario key
        falloff: str = "linear",
        mount: str = "base",
        name: str = "camera",
        channels: tuple[str, ...] = ("rgb", "depth"),
        semantic: str = "id",
        decay: float | None = None,
    ):
        self.name = name
        self.mount = mount
        fov_rad = math.radians(fov)
        self.angles = fov_rad * (0.5 - (np.arange(rays) + 0.5) / rays)
        self.half_fov = float(np.abs(self.angles).max())
        self.view_range = float(range)
        self.falloff = FALLOFFS[falloff]
        self.decay = (decay or range / 3.0) if falloff == "exponential" else None
        self.channels, self.onehot = tuple(channels), semantic == "onehot"
        kinds = len(SEMANTIC_KINDS)
        high = {
            "rgb": [1.0] * 3,
            "depth": [1.0],
            "semantic": [1.0] * kinds if self.onehot else [kinds - 1.0],
        }
        top = np.array([h for c in self.channels for h in high[c]], np.float32)
        self.space = spaces.Box(np.zeros((rays, len(top)), np.float32), np.tile(top, (rays, 1)))
        self._plain = self.channels == ("rgb", "depth")
        self._onehot_rows = np.eye(kinds, dtype=np.float32)

    def picture(self, reading: np.ndarray) -> np.ndarray:
        """One row of pixels per channel group, as in the paper's figure: the colour as
        seen, the depth in grey (near is bright), the kind of thing hit in its fixed colour
        (``SEMANTIC_COLORS``)."""
        rows, column = [], 0
        for channel in self.channels:
            if channel == "rgb":
                rows.append(np.clip(reading[:, column : column + 3], 0.0, 1.0) * 255.0)
                column += 3
            elif channel == "depth":
                near = (1.0 - np.clip(reading[:, column], 0.0, 1.0)) * 255.0
                rows.append(np.repeat(near[:, None], 3, axis=1))
                column += 1
            else:
                width = len(SEMANTIC_KINDS) if self.onehot else 1
                block = reading[:, column : column + width]
                kind = block.argmax(axis=1) if self.onehot else np.rint(block[:, 0])
                kind = np.clip(kind, 0, len(SEMANTIC_KINDS) - 1).astype(np.intp)
                rows.append(SEMANTIC_COLORS[kind])
                column += width
        return np.rint(np.stack(rows)).astype(np.uint8)

    def read(self, results, k: int) -> np.ndarray:
        rays = results.slices[k]
        image = results.image[rays]
        if self.decay is not None:
            image = image.copy()
            fade = np.exp(-results.distance[rays] / self.decay).astype(np.float32)
            image[:, :3] *= fade[:, None]
        if self._plain:
            return image.copy() if self.decay is None else image
        parts = []
        for channel in self.channels:
            if channel == "rgb":
                parts.append(image[:, :3])
            elif channel == "depth":
                parts.append(image[:, 3:4])
            else:
                kind = results.kinds[results.hit_entity[rays]]
                if self.onehot:
                    parts.append(self._onehot_rows[kind])
                else:
                    parts.append(kind[:, None].astype(np.float32))
        return np.concatenate(parts, axis=1).astype(np.float32, copy=False)
