"""A scripted agent that keeps a wall on its left, from its own camera and nothing else.

In a maze whose walls are all connected (a perfect maze: every generated ``maze`` layout
is one), following one wall with the same hand passes every corridor and so every place
in the maze: the left-hand rule. The follower reads, from one observation and no memory,
the depth straight ahead, at the left edge of its view and a little inside it. It turns
right when something is close ahead or it comes too close to the wall on its left, turns
left when the wall on its left falls away (a corridor opens there), and walks on
otherwise. Once an item that pays is in view it turns to it and walks to it.

It is the memoryless baseline of the maze tasks: what a feed-forward policy that reads
only the agent's camera can do there. The planner plans over the whole maze, which the
agent never sees.
"""

from __future__ import annotations

import math

import numpy as np

from flatland_ma.policies.camera_view import CameraView, matches
from flatland_ma.policies.motion import BaseMotion
from flatland_ma.scenario.schema import ScenarioSpec

FRONT_HALF_ANGLE = math.radians(11.0)
"""Rays this close to straight ahead measure what is in front."""
EDGE_SPAN = math.radians(4.0)
"""Rays this close to the view's left edge measure whether the wall falls away."""
INNER_LEFT = (math.radians(33.0), math.radians(48.0))
"""Rays between these angles to the left measure how close the wall on the left is."""
MIN_HALF_FOV = math.radians(50.0)
"""The least half field of view the rule needs: it must see the wall beside it."""
BLOCKED = 18.0
"""Something closer than this straight ahead: turn right."""
TOO_CLOSE = 16.0
"""The wall on the left closer than this: turn right, away from it."""
OPENS = 45.0
"""The view's left edge free this far, and the inner left free ``INNER_FREE``: turn left."""
INNER_FREE = 30.0
AIM = math.radians(7.0)
"""An item seen further than this off straight ahead is turned to before walking."""


class WallFollower:
    """Drives agent number ``agent`` of ``spec`` by the left-hand rule (see the module's
    docstring); ``ValueError`` if its first camera lacks colour and depth or sees less than
    50 degrees either side."""

    def __init__(self, spec: ScenarioSpec, agent: int = 0):
        body = spec.agent_of(agent)
        self.view = view = CameraView(spec, agent, "the wall follower")
        if view.half_fov < MIN_HALF_FOV:
            raise ValueError(
                "the wall follower needs a camera that sees at least 50 degrees either side, "
                f"not {math.degrees(view.half_fov):.0f}"
            )
        angles = np.asarray(view.angles, np.float64)  # positive: to the left
        self.angles = angles
        self.front = np.abs(angles) <= max(FRONT_HALF_ANGLE, np.abs(angles).min())
        self.edge = angles >= angles.max() - EDGE_SPAN
        self.inner = (angles >= INNER_LEFT[0]) & (angles <= INNER_LEFT[1])
        self.range = view.range
        self.good = np.array([i.color for i in spec.items if i.reward > 0], np.float64)
        self.motion = BaseMotion(body, spec.channel)

    def reset(self) -> None:
        """Nothing to forget: the follower keeps no memory."""

    def act(self, observation):
        """The action for one observation: the camera's image (rays, channels), or a
        ``Dict`` holding it."""
        return self.motion.action(*self._decide(self.view.image(observation)))

    def _decide(self, image: np.ndarray) -> tuple[float, float]:
        """(forward, turn): turn > 0 is to the left."""
        depth = image[:, 3]
        seen = self._paying(image)
        if seen.any():
            bearing = float(self.angles[seen].mean())
            return (1.0, 0.0) if abs(bearing) <= AIM else (0.0, math.copysign(1.0, bearing))
        distance = depth * self.range
        if distance[self.front].min() < BLOCKED or distance[self.inner].min() < TOO_CLOSE:
            return 0.0, -1.0
        if distance[self.edge].min() > OPENS and distance[self.inner].min() > INNER_FREE:
            return 0.0, 1.0
        return 1.0, 0.0

    def _paying(self, image: np.ndarray) -> np.ndarray:
        """Which rays see an item that pays, by its colour with the falloff divided out."""
        colour, readable = self.view.colours(image)
        return readable & matches(colour, self.good)
