"""Rules a scenario may add in its ``rules`` list to shape rewards."""

from __future__ import annotations

from flatland_ma.tasks.rule import Rule, Step, TaskContext


class StepReward(Rule, kind="step_reward"):
    """``reward`` to every live agent each step (negative: hurry)."""

    def __init__(self, reward: float):
        self.reward = reward

    def apply(self, step: Step) -> None:
        for i in step.live:
            step.rewards[i] += self.reward


class ContactReward(Rule, kind="contact_reward"):
    """``reward`` to a live agent for each step in which its body or parts touch
    something solid (a wall, an obstacle, another agent; negative: bumping hurts)."""

    def __init__(self, reward: float):
        self.reward = reward

    def reset(self, ctx: TaskContext) -> None:
        self.bodies = ctx.bodies

    def apply(self, step: Step) -> None:
        for i in step.live:
            if self.bodies[i].touching:
                step.rewards[i] += self.reward
