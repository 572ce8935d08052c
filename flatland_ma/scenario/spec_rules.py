"""Rules a scenario adds to its task, beyond what its items, zones and doors do."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Literal

from flatland_ma.scenario.kinds import SpecKinds
from flatland_ma.scenario.types import Reward, Spec


class RuleBaseSpec(Spec):
    """What every rule's spec is: it subclasses this with ``rule: Literal["..."]`` (its
    kind) and the keys its rule takes as keyword arguments."""

    if TYPE_CHECKING:  # each rule's spec declares it, as a ``Literal``
        rule: Any  # (str: pyright holds a Literal override to the base)


class StepRewardSpec(RuleBaseSpec):
    """A reward to every live agent each step (negative: time pressure)."""

    rule: Literal["step_reward"]
    """Selects this rule."""
    reward: Reward
    """Reward per step."""


class ContactRewardSpec(RuleBaseSpec):
    """A reward to an agent for each step in which its body or parts touch something
    solid: a wall, an obstacle, another agent (negative: bumping hurts)."""

    rule: Literal["contact_reward"]
    """Selects this rule."""
    reward: Reward
    """Reward per step of contact."""


RULES = SpecKinds("rule", "rule", RuleBaseSpec)
"""Every rule's spec, by its ``rule``: the shipped ones, and those registered with
``flatland_ma.register`` or an entry point (``flatland_ma.scenario.extensions``)."""
RULES.add(StepRewardSpec)
RULES.add(ContactRewardSpec)

if TYPE_CHECKING:
    RuleSpec = RuleBaseSpec
else:
    RuleSpec = RULES.field
    """A rule in a file: a mapping whose ``rule`` picks its spec in ``RULES``."""
