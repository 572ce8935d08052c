"""Actions: their spaces, their validation, and how they become motor commands."""

from __future__ import annotations

from enum import IntEnum

import numpy as np
from gymnasium import spaces

from flatland_ma.agents.body import AgentBody


class DiscreteAction(IntEnum):
    """The paper's three navigation actions."""

    FORWARD = 0
    ROTATE_LEFT = 1
    ROTATE_RIGHT = 2


# (forward, lateral, turn) as fractions of the top speeds, per discrete action.
DISCRETE_COMMANDS: tuple[tuple[float, float, float], ...] = (
    (1.0, 0.0, 0.0),
    (0.0, 0.0, 1.0),
    (0.0, 0.0, -1.0),
)

CONTINUOUS_DIMENSIONS = ("longitudinal", "lateral", "angular")
"""Meaning of each entry of a continuous action, each in [-1, 1] of its top speed."""


class InvalidActionError(ValueError):
    """An action that does not belong to its agent's action space."""

    def __init__(self, agent: str, action: object, space: spaces.Space, reason: str):
        self.agent, self.action, self.space = agent, action, space
        super().__init__(
            f"invalid action {action!r} for agent {agent!r}: {reason}; "
            f"expected an element of {space}"
        )


class Actuator:
    """Validates one agent's actions and turns them into commands for its body."""

    def __init__(self, mode: str):
        self.mode = mode
        if mode == "discrete":
            self.names = tuple(a.name.lower() for a in DiscreteAction)
            self.space: spaces.Space = spaces.Discrete(len(DiscreteAction))
        else:
            self.names = CONTINUOUS_DIMENSIONS
            self.space = spaces.Box(-1.0, 1.0, (len(CONTINUOUS_DIMENSIONS),), np.float32)

    def check(self, agent: str, action: object):
        """Return the action in canonical form, or raise ``InvalidActionError``."""
        if self.mode == "discrete":
            return self._check_discrete(agent, action)
        return self._check_continuous(agent, action)

    def apply(self, body: AgentBody, action) -> None:
        """Command the body; ``action`` must have passed ``check``."""
        if self.mode == "discrete":
            body.command(*DISCRETE_COMMANDS[action])
        else:
            body.command(float(action[0]), float(action[1]), float(action[2]))

    def _check_discrete(self, agent: str, action: object) -> int:
        if type(action) is int:
            value = action
        elif isinstance(action, np.integer):
            value = int(action)
        elif isinstance(action, np.ndarray) and action.shape == () and action.dtype.kind in "iu":
            value = int(action)
        else:
            raise InvalidActionError(agent, action, self.space, "an integer is required")
        if not 0 <= value < self.space.n:
            raise InvalidActionError(agent, action, self.space, "out of range")
        return value

    def _check_continuous(self, agent: str, action: object) -> np.ndarray:
        try:
            raw = np.asarray(action)
        except (TypeError, ValueError):
            raw = np.asarray(None)
        if raw.dtype.kind not in "fiu":
            raise InvalidActionError(agent, action, self.space, "numbers are required")
        if raw.shape != self.space.shape:
            raise InvalidActionError(
                agent, action, self.space, f"shape {raw.shape} is not {self.space.shape}"
            )
        value = raw.astype(np.float64)
        if not np.isfinite(value).all():
            raise InvalidActionError(agent, action, self.space, "NaN or infinite entries")
        if np.abs(value).max() > 1.0:
            raise InvalidActionError(agent, action, self.space, "entries outside [-1, 1]")
        return value
