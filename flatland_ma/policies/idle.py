"""A policy that keeps still: a partner or opponent that does nothing."""

from __future__ import annotations

import numpy as np
from gymnasium import spaces

from flatland_ma.agents.actuators import DiscreteAction


class IdlePolicy:
    """Keeps still: ``stay``, or all zeros; with only the paper's three actions (none of
    which keeps still) it turns left and right in turn, staying where it is. With a
    channel it says word 0."""

    def __init__(self, env, agent: str):
        space, names = env.action_space(agent), env.action_names(agent)
        self.continuous = isinstance(space, spaces.Box)
        self.size = len(names)
        self.words = len(space.nvec) - 1 if isinstance(space, spaces.MultiDiscrete) else 0
        self.stay = names.index("stay") if "stay" in names else None
        self.turns = (int(DiscreteAction.ROTATE_LEFT), int(DiscreteAction.ROTATE_RIGHT))
        self.t = 0

    def reset(self) -> None:
        self.t = 0

    def act(self, observation=None):
        if self.continuous:
            return np.zeros(self.size, np.float32)
        if self.stay is not None:
            move = self.stay
        else:
            self.t += 1
            move = self.turns[self.t % 2]
        return np.array([move] + [0] * self.words) if self.words else move
