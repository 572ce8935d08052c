"""The task: an ordered list of rules over what each step's contacts and positions mean.

The order is fixed and documented: items, zones, doors, deliveries (the scenario's
entities), then the scenario's own ``rules`` in file order, then the ending rule. Each
agent's ``AgentRecord`` holds its score, its keys, the zones it visited and whether its
episode ended; ``info`` reports the score and every rule's counters (one count per item
group, the keys held, deliveries).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from flatland_ma.tasks.deliveries import DeliveryRule
from flatland_ma.tasks.doors import DoorRule
from flatland_ma.tasks.ending import EndingRule
from flatland_ma.tasks.items import ItemRule
from flatland_ma.tasks.rule import AgentRecord, Rule, Step, TaskContext
from flatland_ma.tasks.zones import ZoneRule


class Task:
    def __init__(
        self,
        ctx: TaskContext,
        extra: Sequence[Rule] = (),
        shared_end: bool = False,
        end_when_eaten: str | None = None,
    ):
        """``extra``: the scenario's own rules; the ending: see ``ending.EndingRule``."""
        self.world, self.bodies, self.hands = ctx.world, ctx.bodies, ctx.hands
        self.records = ctx.records
        items = ItemRule()
        self.rules: list[Rule] = [
            items,
            ZoneRule(),
            DoorRule(),
            DeliveryRule(),
            *extra,
            EndingRule(items, shared_end, end_when_eaten),
        ]
        for rule in self.rules:
            rule.reset(ctx)
        self._counting = [r for r in self.rules if type(r).info is not Rule.info]
        """The rules that add counters to ``info``."""
        self.steps = 0

    def evaluate(self, rng: np.random.Generator) -> tuple[list[float], list[bool]]:
        """Rewards and terminations of every agent for the step just simulated."""
        self.steps += 1
        n = len(self.bodies)
        step = Step(self.world.log, self.records, [0.0] * n, [False] * n, rng, self.steps)
        for rule in self.rules:
            rule.apply(step)
        rewards, terminated = step.rewards, step.terminated
        for i, record in enumerate(self.records):
            if record.done:
                continue
            if step.end_all:
                terminated[i] = True
            if rewards[i]:
                record.score += rewards[i]
            if terminated[i]:
                record.done = True
                self._retire(self.bodies[i])
        return rewards, terminated

    def _retire(self, body) -> None:
        """An agent whose episode ended leaves the world, parts and all."""
        self.hands.drop_all_of(body.hands)
        for entity in (*body.links, body):
            self.world.retire(entity)

    def info(self, agent_index: int) -> dict:
        """The agent's episode counters: ``score``, then each rule's (one count per item
        group; in scenarios with keys, the sorted names of the keys it holds; in scenarios
        with deliveries, how many it was credited with)."""
        info = {"score": float(self.records[agent_index].score)}
        for rule in self.rules:
            rule.info(agent_index, info)
        return info

    def columns(self, agents: list[int]) -> dict[str, list]:
        """``info`` of each of ``agents`` as one list per key (an entry per agent, in
        the order of ``agents``), keys in ``info``'s order."""
        records = self.records
        out = {"score": [float(records[a].score) for a in agents]}
        for rule in self._counting:
            rule.columns(agents, out)
        return out


def new_records(n_agents: int) -> list[AgentRecord]:
    return [AgentRecord() for _ in range(n_agents)]
