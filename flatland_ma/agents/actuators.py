"""Actions: their spaces, their names, their validation, and how they become commands.

A plain body keeps the paper's ``Discrete(3)`` (forward, rotate left, rotate right) or
``Box(-1, 1, (3,))`` (longitudinal, lateral, angular). Each part adds its controls:

- discrete: named macro actions, one at a time; the base moves only for ``forward`` and the
  rotations, a part's joint moves only for its own macro, every other joint holds still.
  A head adds ``head_left`` and ``head_right``; each arm joint ``arm<k>_joint<j>_left`` and
  ``..._right`` (``arm_left`` / ``arm_right`` when there is one arm of one joint); each
  grasper ``arm<k>_grasp`` and ``arm<k>_release`` (``grasp`` / ``release`` for one). With
  parts, ``stay`` (do nothing) is added after the base's actions.
- continuous: one Box whose entries are, in order, longitudinal, lateral, angular, then
  ``head`` (turn rate), one ``arm<k>_joint<j>`` per joint (rate), one ``arm<k>_grip`` per
  grasper (> 0 closes the hand, <= 0 opens it). All in [-1, 1], as fractions of top speeds.

``names`` lists what each discrete action or continuous entry means, in order.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import numpy as np
from gymnasium import spaces

from flatland_ma.agents.body import AgentBody
from flatland_ma.scenario.schema import AgentSpec


class DiscreteAction(IntEnum):
    """The paper's three navigation actions (always the first three)."""

    FORWARD = 0
    ROTATE_LEFT = 1
    ROTATE_RIGHT = 2


CONTINUOUS_DIMENSIONS = ("longitudinal", "lateral", "angular")
"""Meaning of the base's entries of a continuous action, each in [-1, 1] of its top speed."""


@dataclass(frozen=True)
class Macro:
    """One discrete action: a base command and at most one part command."""

    name: str
    base: tuple[float, float, float] = (0.0, 0.0, 0.0)
    head: float = 0.0
    joint: int = -1
    rate: float = 0.0
    hand: int = -1
    grip: bool | None = None


class InvalidActionError(ValueError):
    """An action that does not belong to its agent's action space."""

    def __init__(self, agent: str, action: object, space: spaces.Space, reason: str):
        self.agent, self.action, self.space = agent, action, space
        super().__init__(
            f"invalid action {action!r} for agent {agent!r}: {reason}; "
            f"expected an element of {space}"
        )


def part_controls(spec: AgentSpec) -> tuple[list[str], list[str]]:
    """Names of the arm joints and of the graspers, in action order."""
    joints, hands = [], []
    single = len(spec.arms) == 1
    for k, arm in enumerate(spec.arms):
        label = "arm" if single else f"arm{k}"
        for j in range(len(arm.segments)):
            joints.append(label if single and len(arm.segments) == 1 else f"{label}_joint{j}")
        if arm.grasper is not None:
            hands.append(label)
    return joints, hands


def discrete_macros(spec: AgentSpec) -> list[Macro]:
    macros = [
        Macro("forward", base=(1.0, 0.0, 0.0)),
        Macro("rotate_left", base=(0.0, 0.0, 1.0)),
        Macro("rotate_right", base=(0.0, 0.0, -1.0)),
    ]
    joints, hands = part_controls(spec)
    if spec.head is None and not joints:
        return macros
    macros.append(Macro("stay"))
    if spec.head is not None:
        macros += [Macro("head_left", head=1.0), Macro("head_right", head=-1.0)]
    for j, name in enumerate(joints):
        macros += [
            Macro(f"{name}_left", joint=j, rate=1.0),
            Macro(f"{name}_right", joint=j, rate=-1.0),
        ]
    single = len(hands) == 1
    for h, name in enumerate(hands):
        prefix = "" if single else f"{name}_"
        macros += [
            Macro(f"{prefix}grasp", hand=h, grip=True),
            Macro(f"{prefix}release", hand=h, grip=False),
        ]
    return macros


def continuous_names(spec: AgentSpec) -> tuple[str, ...]:
    joints, hands = part_controls(spec)
    head = ("head",) if spec.head is not None else ()
    return CONTINUOUS_DIMENSIONS + head + tuple(joints) + tuple(f"{h}_grip" for h in hands)


class Actuator:
    """Validates one agent's actions and turns them into commands for its body."""

    def __init__(self, spec: AgentSpec):
        self.mode = spec.actions
        joints, hands = part_controls(spec)
        self.n_joints, self.n_hands = len(joints), len(hands)
        self.has_head = spec.head is not None
        if self.mode == "discrete":
            self.macros = discrete_macros(spec)
            self.names = tuple(m.name for m in self.macros)
            self.space: spaces.Space = spaces.Discrete(len(self.macros))
        else:
            self.names = continuous_names(spec)
            self.space = spaces.Box(-1.0, 1.0, (len(self.names),), np.float32)
        self._parts = self.has_head or self.n_joints or self.n_hands

    def index(self, name: str) -> int:
        """The discrete action, or the continuous entry, called ``name``."""
        if name not in self.names:
            raise KeyError(f"no action {name!r}; actions: {', '.join(self.names)}")
        return self.names.index(name)

    def check(self, agent: str, action: object):
        """Return the action in canonical form, or raise ``InvalidActionError``."""
        if self.mode == "discrete":
            return self._check_discrete(agent, action)
        return self._check_continuous(agent, action)

    def apply(self, body: AgentBody, action) -> None:
        """Command the body; ``action`` must have passed ``check``."""
        if self.mode == "discrete":
            macro = self.macros[action]
            body.command(*macro.base)
            if self._parts:
                joints = [0.0] * self.n_joints
                grips = [None] * self.n_hands
                if macro.joint >= 0:
                    joints[macro.joint] = macro.rate
                if macro.hand >= 0:
                    grips[macro.hand] = macro.grip
                body.command_parts(macro.head, joints, grips)
            body.drive()
            return
        body.command(float(action[0]), float(action[1]), float(action[2]))
        if self._parts:
            k = 3
            head = float(action[k]) if self.has_head else 0.0
            k += self.has_head
            joints = [float(a) for a in action[k : k + self.n_joints]]
            k += self.n_joints
            grips = [bool(a > 0.0) for a in action[k : k + self.n_hands]]
            body.command_parts(head, joints, grips)
        body.drive()

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
