"""Actions: their spaces, their names, their validation, and how they become commands.

A plain body keeps the paper's ``Discrete(3)`` (forward, rotate left, rotate right) or
``Box(-1, 1, (3,))`` (longitudinal, lateral, angular). Every control of every part adds
to that (see ``parts.Control``), in the order of the parts:

- discrete: named macro actions, one at a time; the base moves only for ``forward`` and
  the rotations, a part's control is set to +1 or -1 only by its own two macros (e.g.
  ``head_left`` and ``head_right``, ``grasp`` and ``release``), and every other control is
  left alone (joints hold still, hands stay as they are). With parts, ``stay`` (do
  nothing) comes after the base's actions.
- continuous: one Box whose entries are, in order, longitudinal, lateral, angular, then
  one per control (e.g. ``head``, ``arm``, ``arm_grip``). All in [-1, 1], as fractions of
  top speeds (a grip > 0 closes the hand, <= 0 opens it).

``names`` lists what each discrete action or continuous entry means, in order.

With a channel of ``words`` words from a ``vocabulary``, every action also says them: a
discrete agent acts in ``MultiDiscrete([macros, vocabulary, ...])`` (its macro, then
``say_0``, ``say_1``, ...: ``names`` lists the macros, then those), a continuous one has
one more Box entry per word, in [-1, 1], cut into ``vocabulary`` equal bins.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from enum import IntEnum
from typing import Any

import numpy as np
from gymnasium import spaces

from flatland_ma.agents.body import AgentBody
from flatland_ma.agents.parts import Part


class DiscreteAction(IntEnum):
    """The paper's three navigation actions (always the first three)."""

    FORWARD = 0
    ROTATE_LEFT = 1
    ROTATE_RIGHT = 2


CONTINUOUS_DIMENSIONS = ("longitudinal", "lateral", "angular")
"""Meaning of the base's entries of a continuous action, each in [-1, 1] of its top speed."""


@dataclass(frozen=True)
class Macro:
    """One discrete action: a base command and a value for each control (None: left
    alone)."""

    name: str
    base: tuple[float, float, float] = (0.0, 0.0, 0.0)
    values: tuple[float | None, ...] = ()


class InvalidActionError(ValueError):
    """An action that does not belong to its agent's action space."""

    def __init__(self, agent: str, action: object, space: spaces.Space, reason: str):
        self.agent, self.action, self.space = agent, action, space
        super().__init__(
            f"invalid action {action!r} for agent {agent!r}: {reason}; "
            f"expected an element of {space}"
        )


def discrete_macros(parts: Sequence[Part]) -> list[Macro]:
    controls = [c for part in parts for c in part.controls]
    idle = (None,) * len(controls)
    macros = [
        Macro("forward", (1.0, 0.0, 0.0), idle),
        Macro("rotate_left", (0.0, 0.0, 1.0), idle),
        Macro("rotate_right", (0.0, 0.0, -1.0), idle),
    ]
    if not controls:
        return macros
    macros.append(Macro("stay", values=idle))
    for k, control in enumerate(controls):
        for name, value in ((control.plus, 1.0), (control.minus, -1.0)):
            values = idle[:k] + (value,) + idle[k + 1 :]
            macros.append(Macro(name, values=values))
    return macros


def continuous_names(parts: Sequence[Part]) -> tuple[str, ...]:
    return CONTINUOUS_DIMENSIONS + tuple(c.name for part in parts for c in part.controls)


def _numbers_of(agent: str, action: object, space: spaces.Space) -> object:
    """A tensor's numbers as a numpy array (a 0-d one for a scalar); anything else as is."""
    detach = getattr(action, "detach", None)
    if not callable(detach):
        return action
    try:
        tensor: Any = detach()
        tensor = tensor.cpu() if callable(getattr(tensor, "cpu", None)) else tensor
        return np.asarray(tensor.numpy() if callable(getattr(tensor, "numpy", None)) else tensor)
    except Exception as err:  # any failure to read it is a bad action, not a crash
        raise InvalidActionError(agent, action, space, f"cannot read its numbers ({err})") from err


class Actuator:
    """Validates one agent's actions and turns them into commands for its body.

    ``mode`` is ``discrete`` or ``continuous``; ``parts`` are the agent's parts (their
    controls make the action layout; the body commanded must have parts of that layout).
    """

    def __init__(self, mode: str, parts: Sequence[Part] = (), words: int = 0, vocabulary: int = 2):
        self.mode = mode
        self.n_controls = sum(len(part.controls) for part in parts)
        self.words, self.vocabulary = words, vocabulary
        say = tuple(f"say_{j}" for j in range(words))
        if mode == "discrete":
            self.macros = discrete_macros(parts)
            self._bases = np.array([m.base for m in self.macros], np.float64)
            """Each macro's base command (forward, lateral, turn), one row each."""
            self.names = tuple(m.name for m in self.macros) + say
            self.space: spaces.Space = (
                spaces.MultiDiscrete([len(self.macros)] + [vocabulary] * words)
                if words
                else spaces.Discrete(len(self.macros))
            )
        else:
            self.names = continuous_names(parts) + say
            self.space = spaces.Box(-1.0, 1.0, (len(self.names),), np.float32)

    def index(self, name: str) -> int:
        """The discrete action, or the continuous entry, called ``name``; a word's entry
        of a discrete agent's ``MultiDiscrete`` action for ``say_<j>`` (1 + j)."""
        if name not in self.names:
            raise KeyError(f"no action {name!r}; actions: {', '.join(self.names)}")
        k = self.names.index(name)
        if self.mode == "discrete" and self.words and k >= len(self.macros):
            return 1 + k - len(self.macros)
        return k

    def said(self, action) -> np.ndarray:
        """The words a checked action says (only with a channel)."""
        if self.mode == "discrete":
            return np.asarray(action[1:], np.int64)
        bins = np.floor((np.asarray(action[-self.words :]) + 1.0) / 2.0 * self.vocabulary)
        return np.clip(bins, 0, self.vocabulary - 1).astype(np.int64)

    def check(self, agent: str, action: object):
        """Return the action in canonical form, or raise ``InvalidActionError``.

        Tensors (torch and the like: anything with ``detach``, on any device that has
        ``cpu``) are read as the numbers they hold, with or without a gradient.
        """
        value = _numbers_of(agent, action, self.space)
        if self.mode == "discrete":
            return self._check_discrete(agent, value)
        return self._check_continuous(agent, value)

    def apply(self, body: AgentBody, action) -> None:
        """Command the body; ``action`` must have passed ``check``."""
        if self.mode == "discrete":
            macro = self.macros[action[0] if self.words else action]
            body.command(*macro.base)
            if self.n_controls:
                body.command_parts(macro.values)
        else:
            body.command(float(action[0]), float(action[1]), float(action[2]))
            if self.n_controls:
                body.command_parts([float(a) for a in action[3 : 3 + self.n_controls]])
        body.drive()

    def commands_like(self, other: Actuator) -> bool:
        """Whether every action gives the same base command here as in ``other``."""
        if self.mode != other.mode or self.words != other.words:
            return False
        return self.mode != "discrete" or np.array_equal(self._bases, other._bases)

    def base_commands(self, actions: Sequence) -> np.ndarray:
        """The base's command (forward, lateral, turn) of each checked action, one row
        each, as ``apply`` gives ``AgentBody.command`` (for ``motors.Motors``)."""
        if self.mode == "discrete":
            codes = [a[0] for a in actions] if self.words else actions
            return self._bases.take(codes, axis=0)
        return np.array([a[:3] for a in actions], np.float64).reshape(-1, 3)

    def base_commands_of(self, actions: np.ndarray) -> np.ndarray:
        """``base_commands`` of a batch's array of actions, one per row, each in the space
        (integers of ``Discrete``, or the continuous ``Box``'s numbers in float64)."""
        if self.mode == "discrete":
            return self._bases[actions]
        return actions[:, :3].astype(np.float64)

    def _check_discrete(self, agent: str, action: object):
        if self.words:
            return self._check_words(agent, action)
        if type(action) is int:
            value = action
        elif isinstance(action, np.integer):
            value = int(action)
        elif isinstance(action, np.ndarray) and action.shape == () and action.dtype.kind in "iu":
            value = int(action)
        else:
            raise InvalidActionError(agent, action, self.space, "an integer is required")
        if not 0 <= value < len(self.macros):
            raise InvalidActionError(agent, action, self.space, "out of range")
        return value

    def _check_words(self, agent: str, action: object) -> tuple[int, ...]:
        """A discrete agent's move and words, as a tuple of ints."""
        raw = self._array(agent, action, "iu", "integers")
        assert isinstance(self.space, spaces.MultiDiscrete)
        if (raw < 0).any() or (raw >= self.space.nvec).any():
            raise InvalidActionError(agent, action, self.space, "out of range")
        return tuple(int(v) for v in raw)

    def _array(self, agent: str, action: object, kinds: str, what: str) -> np.ndarray:
        """The action as an array of the space's shape whose dtype is of ``kinds``."""
        try:
            raw = np.asarray(action)
        except (TypeError, ValueError):
            raw = np.asarray(None)
        if raw.dtype.kind not in kinds:
            raise InvalidActionError(agent, action, self.space, f"{what} are required")
        if raw.shape != self.space.shape:
            raise InvalidActionError(
                agent, action, self.space, f"shape {raw.shape} is not {self.space.shape}"
            )
        return raw

    def _check_continuous(self, agent: str, action: object) -> np.ndarray:
        raw = self._array(agent, action, "fiu", "numbers")
        value = raw.astype(np.float64)
        if not np.isfinite(value).all():
            raise InvalidActionError(agent, action, self.space, "NaN or infinite entries")
        if np.abs(value).max() > 1.0:
            raise InvalidActionError(agent, action, self.space, "entries outside [-1, 1]")
        return value
