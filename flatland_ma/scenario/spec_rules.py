"""Rules a scenario adds to its task, beyond what its items, zones and doors do."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from flatland_ma.scenario.types import Reward, Spec


class StepRewardSpec(Spec):
    """A reward to every live agent each step (negative: time pressure)."""

    rule: Literal["step_reward"]
    """Selects this rule."""
    reward: Reward
    """Reward per step."""


class ContactRewardSpec(Spec):
    """A reward to an agent for each step in which its body or parts touch something
    solid: a wall, an obstacle, another agent (negative: bumping hurts)."""

    rule: Literal["contact_reward"]
    """Selects this rule."""
    reward: Reward
    """Reward per step of contact."""


RuleSpec = Annotated[StepRewardSpec | ContactRewardSpec, Field(discriminator="rule")]
"""Every rule a file may name; a new rule adds its spec here."""
