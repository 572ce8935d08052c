"""Turning a policy's wish (walk forward, turn) into an action of the agent's space."""

from __future__ import annotations

import numpy as np

from flatland_ma.agents.actuators import DiscreteAction, continuous_names
from flatland_ma.build.bodies import make_parts
from flatland_ma.scenario.schema import AgentSpec


class BaseMotion:
    """Actions that move an agent's base only, in its scenario's action space."""

    def __init__(self, agent: AgentSpec):
        self.discrete = agent.actions == "discrete"
        self.size = len(continuous_names(make_parts(agent)))

    def action(self, forward: float, turn: float):
        """Discrete: rotate if ``turn`` is non-zero (its sign gives the way), else go
        forward. Continuous: longitudinal ``forward`` and angular ``turn``, every other
        entry 0."""
        if self.discrete:
            if turn > 0:
                return int(DiscreteAction.ROTATE_LEFT)
            if turn < 0:
                return int(DiscreteAction.ROTATE_RIGHT)
            return int(DiscreteAction.FORWARD)
        action = np.zeros(self.size, np.float32)
        action[0], action[2] = forward, turn
        return action
