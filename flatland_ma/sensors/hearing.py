"""Hearing: what an agent hears on the scenario's channel (``flatland_ma.world.channel``).

Every agent of a scenario with a ``channel`` has it, after its own sensors, named
``messages``: so its observation is a ``Dict``. The reading is ``Box(0, 1, (agents, 1 +
tokens x vocabulary))``: per agent in agent order, 1 if heard, then each word one-hot.
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces

from flatland_ma.sensors.sensor import Sensor

MESSAGES = "messages"
"""The observation key of what an agent hears."""


class Hearing(Sensor, kind="hearing"):
    def __init__(self, agents: int, tokens: int, vocabulary: int, name: str = MESSAGES):
        self.name = name
        self.mount = "base"
        self.space = spaces.Box(0.0, 1.0, (agents, 1 + tokens * vocabulary), np.float32)
        self.channel = None
        self.listener = -1

    def attach(self, suite, k: int) -> None:
        self.channel = suite.world.channel
        self.listener = suite.carriers[k].owner

    def read(self, results, k: int) -> np.ndarray:
        assert self.channel is not None, "a scenario with hearing builds a channel"
        return self.channel.heard(self.listener)
