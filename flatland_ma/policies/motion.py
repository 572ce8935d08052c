"""Turning a policy's wish (walk forward, turn) into an action of the agent's space."""

from __future__ import annotations

import numpy as np

from flatland_ma.agents.actuators import DiscreteAction, continuous_names
from flatland_ma.build.bodies import make_parts
from flatland_ma.scenario.schema import AgentSpec, ChannelSpec


class BaseMotion:
    """Actions that move an agent's base only, in its scenario's action space."""

    def __init__(self, agent: AgentSpec, channel: ChannelSpec | None = None):
        """With a scenario's ``channel``, the actions also say ``words`` (word 0 unless
        given)."""
        self.discrete = agent.actions == "discrete"
        self.words = channel.tokens if channel is not None else 0
        self.vocabulary = channel.vocabulary if channel is not None else 2
        self.size = len(continuous_names(make_parts(agent))) + self.words

    def action(self, forward: float, turn: float, words=None):
        """Discrete: rotate if ``turn`` is non-zero (its sign gives the way), else go
        forward. Continuous: longitudinal ``forward`` and angular ``turn``, every other
        entry 0. With a channel, then ``words`` (each in ``range(vocabulary)``)."""
        said = np.zeros(self.words, np.int64) if words is None else np.asarray(words, np.int64)
        if self.discrete:
            move = int(DiscreteAction.FORWARD)
            if turn > 0:
                move = int(DiscreteAction.ROTATE_LEFT)
            elif turn < 0:
                move = int(DiscreteAction.ROTATE_RIGHT)
            return np.concatenate([[move], said]) if self.words else move
        action = np.zeros(self.size, np.float32)
        action[0], action[2] = forward, turn
        if self.words:  # each word at the middle of its bin of [-1, 1]
            action[-self.words :] = (said + 0.5) / self.vocabulary * 2.0 - 1.0
        return action
