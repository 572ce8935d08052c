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
        items, doors = ItemRule(), DoorRule()
        builtin: list[Rule] = [items, ZoneRule(), doors, DeliveryRule()]
        self.rules: list[Rule] = [
            *builtin,
            *extra,
            EndingRule(items, shared_end, end_when_eaten),
        ]
        for rule in self.rules:
            rule.reset(ctx)
        self._counting = [r for r in self.rules if type(r).info is not Rule.info]
        """The rules that add counters to ``info``."""
        self._items = items
        self._quiet = not extra and not end_when_eaten and not doors.switched
        """Whether a step in which nothing touched an item, door or key, entered a zone
        or was delivered, and no item is due back, leaves every reward, termination and
        record as it was (no rule of the scenario's own, no switched door, no ending on
        items eaten): then ``evaluate`` skips the rules."""
        self._own_counters = any(r not in builtin for r in self._counting)
        self.revision = 0
        """Bumped by every step that may have changed ``info`` (a reward, a termination, an
        item taken, a delivery; every step when a rule of the scenario's own counts): the
        batched env writes a world's counters again only when this moved."""
        self.steps = 0

    def evaluate(self, rng: np.random.Generator) -> tuple[list[float], list[bool]]:
        """Rewards and terminations of every agent for the step just simulated."""
        self.steps += 1
        n = len(self.bodies)
        log = self.world.log
        if self._quiet and not (
            log.items
            or log.entered
            or log.doors
            or log.keys
            or log.deliveries
            or self._items.waiting
        ):
            return [0.0] * n, [False] * n  # what the rules would give: nothing happened
        step = Step(log, self.records, [0.0] * n, [False] * n, rng, self.steps)
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
        if self._own_counters or log.items or log.deliveries or any(rewards) or any(terminated):
            self.revision += 1
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
