"""Proprioception: what an agent feels of its own body, without looking."""

from __future__ import annotations

import math

import numpy as np
from gymnasium import spaces

from flatland_ma.sensors.sensor import Sensor


class Proprioception(Sensor, kind="proprioception"):
    """The agent's own motion and posture, each in [-1, 1]:

    - its velocity ahead and to its left, as fractions of its top speed, and its turn
      rate as a fraction of its top turn rate (counter-clockwise positive);
    - per joint (the head's, then each arm's segments, in action order), where the joint
      stands between its limits: -1 at the lowest, 1 at the highest;
    - per grasper, 1 while it holds something, else 0.

    ``labels`` names the entries. The observation is ``Box(-1, 1, (3 + joints + hands,))``.
    """

    def __init__(self, joints: int = 0, hands: int = 0, name: str = "proprioception"):
        self.name = name
        self.mount = "base"
        self.labels = ("ahead", "left", "turn")
        self.labels += tuple(f"joint_{i}" for i in range(joints))
        self.labels += tuple(f"hand_{i}" for i in range(hands))
        self.space = spaces.Box(-1.0, 1.0, (len(self.labels),), np.float32)

    @classmethod
    def from_spec(cls, values: dict, parts: list) -> Proprioception:
        """Sized from the parts it is given, whatever their kinds: one entry per part
        that is ``jointed`` (the agent's ``links``, in build order), one per hand."""
        joints = sum(1 for p in parts if p.jointed)
        hands = sum(1 for p in parts if p.holds)
        return cls(joints=joints, hands=hands, **values)

    def read(self, results, k: int) -> np.ndarray:
        agent = results.carriers[k].actor
        body = agent.body
        vx, vy = body.velocity
        c, s = math.cos(body.angle), math.sin(body.angle)
        out = [
            (c * vx + s * vy) / agent.max_speed,
            (c * vy - s * vx) / agent.max_speed,
            body.angular_velocity / agent.max_turn_rate,
        ]
        for link in agent.links:
            lo, hi = link.limits
            out.append(2.0 * (link.angle_to_parent - lo) / (hi - lo) - 1.0)
        out += [0.0 if part.held is None else 1.0 for part in agent.parts if part.holds]
        return np.clip(np.asarray(out, np.float32), -1.0, 1.0)
