"""Turning a policy's wish (walk forward, turn) into an action of the agent's space."""

from __future__ import annotations

import numpy as np

from flatland_ma.agents.actuators import DiscreteAction, continuous_names
from flatland_ma.scenario.schema import AgentSpec


def base_action(agent: AgentSpec, forward: float, turn: float):
    """Discrete: rotate if ``turn`` is non-zero (its sign gives the way), else go forward.
    Continuous: longitudinal ``forward`` and angular ``turn``, every other entry 0."""
    if agent.actions == "discrete":
        if turn > 0:
            return int(DiscreteAction.ROTATE_LEFT)
        if turn < 0:
            return int(DiscreteAction.ROTATE_RIGHT)
        return int(DiscreteAction.FORWARD)
    action = np.zeros(len(continuous_names(agent)), np.float32)
    action[0], action[2] = forward, turn
    return action
