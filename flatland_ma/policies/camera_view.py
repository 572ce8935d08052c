"""An agent's camera as the scripted policies that see only it read it: its first camera
with colour and depth, each ray's true colour recovered by dividing out the distance
falloff, and colours matched against items' within a tolerance."""

from __future__ import annotations

import numpy as np

from flatland_ma.build.bodies import make_sensors
from flatland_ma.scenario.schema import CameraSpec, ScenarioSpec

COLOR_TOLERANCE = 0.04
"""Largest distance in RGB space at which a recovered colour matches an item's."""
MIN_INTENSITY = 0.02
"""Rays fainter than this are too far for their colour to be read."""


class CameraView:
    """The first camera with colour and depth of agent number ``agent`` of ``spec``;
    ``ValueError`` naming ``reader`` (the policy) if the agent has none."""

    def __init__(self, spec: ScenarioSpec, agent: int, reader: str):
        body = spec.agent_of(agent)
        found = [
            k
            for k, s in enumerate(body.sensor_specs)
            if isinstance(s, CameraSpec) and {"rgb", "depth"} <= set(s.channels)
        ]
        if not found:
            raise ValueError(f"{reader} reads a camera's colour and depth: the agent has none")
        k = found[0]  # the first camera's image
        camera_spec = body.sensor_specs[k]
        assert isinstance(camera_spec, CameraSpec)
        sensors = make_sensors(body, spec.channel, spec.n_agents)
        camera = sensors[k]
        self.spec = camera_spec
        self.key = camera.name if len(sensors) > 1 else None
        """The camera's entry in a ``Dict`` observation (None: the observation is it)."""
        widths = {"rgb": 3, "depth": 1, "semantic": 6 if camera_spec.semantic == "onehot" else 1}
        starts = dict(
            zip(camera_spec.channels, np.cumsum([0] + [widths[c] for c in camera_spec.channels]))
        )
        self.columns = [starts["rgb"], starts["rgb"] + 1, starts["rgb"] + 2, starts["depth"]]
        """Where red, green, blue and depth are among the camera's channels."""
        self.angles = camera.angles
        """Each ray's angle from the heading (positive: to the left)."""
        self.half_fov = camera.half_fov
        self.range = camera_spec.range
        self.linear = camera_spec.falloff == "linear"

    def image(self, observation) -> np.ndarray:
        """The camera's rays from an observation (its image, or a ``Dict`` holding it) as
        float64 columns red, green, blue, depth."""
        if self.key is not None:
            observation = observation[self.key]
        return np.asarray(observation, np.float64)[:, self.columns]

    def colours(self, image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each ray's true colour (the falloff divided out), and whether it is bright
        enough to be read."""
        depth = image[:, 3]
        intensity = (1.0 - depth) if self.linear else np.ones_like(depth)
        colour = image[:, :3] / np.maximum(intensity, MIN_INTENSITY)[:, None]
        return colour, intensity > MIN_INTENSITY


def matches(colour: np.ndarray, references: np.ndarray) -> np.ndarray:
    """Which of the ``colour`` rows lie within ``COLOR_TOLERANCE`` of one of
    ``references``."""
    if len(references) == 0:
        return np.zeros(len(colour), bool)
    gap = np.linalg.norm(colour[:, None, :] - references[None, :, :], axis=2)
    return gap.min(axis=1) < COLOR_TOLERANCE
