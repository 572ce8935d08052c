"""Items: taken on touch for their reward (to the taker, or to every agent still playing
for a ``shared`` group); keys go to the taker's hand, goals end its
episode; taken items come back at once, after a delay, or never. Each agent's ``infos``
count how many of each group it took (and, with key groups, which keys it holds)."""

from __future__ import annotations

import numpy as np

from flatland_ma.tasks.rule import Rule, Step, TaskContext
from flatland_ma.world.entities import Item
from flatland_ma.world.placement import PlacementError


class ItemRule(Rule):
    def reset(self, ctx: TaskContext) -> None:
        self.world, self.placer = ctx.world, ctx.placer
        self.groups, self.records = ctx.groups, ctx.records
        self.eaten = np.zeros((len(ctx.bodies), len(ctx.groups)), np.int64)
        self.values = np.array([g.reward for g in ctx.groups], np.float64)
        """Each group's reward, the file's at reset; a drifting world changes it."""
        self.has_keys = any(g.key for g in ctx.groups)
        self.items = ctx.world.of_type(Item)
        self.waiting: list[Item] = []
        """Taken items due back, in the order they were taken."""

    def apply(self, step: Step) -> None:
        for agent, item in step.log.items:
            i = agent.owner
            record = step.records[i]
            if not item.edible or record.done:
                continue  # already taken this step, or by an agent whose episode ended
            group = item.group
            value = float(self.values[group.index])
            if group.shared:
                for j, other in enumerate(step.records):
                    if not other.done:
                        step.rewards[j] += value
            else:
                step.rewards[i] += value
            self.eaten[i, group.index] += 1
            if group.key:
                record.keys.add(group.name)
            if group.terminal:
                step.terminated[i] = True
            self.world.withdraw(item)
            if group.respawn is not None:
                item.respawn_at = step.t + group.respawn
                self.waiting.append(item)
        if self.waiting:
            self._respawn(step.rng, step.t)

    def _respawn(self, rng: np.random.Generator, t: int) -> None:
        waiting = []
        for item in self.waiting:
            if item.respawn_at > t or not self._put_back(item, rng):
                waiting.append(item)
        self.waiting = waiting

    def _put_back(self, item: Item, rng: np.random.Generator) -> bool:
        if item.home is not None:
            x, y = item.home
            if not self.world.is_free(x, y, item.radius):
                return False  # someone stands there: try again next step
        else:
            try:
                x, y = self.placer.sample(rng, item.radius, item.group.spawn)
            except PlacementError:
                return False
        self.world.move_static(item, x, y)
        self.world.restore(item)
        item.respawn_at = -1
        return True

    def none_left(self, group_name: str) -> bool:
        """No item of the group is out, and none is due back."""
        for item in self.items:
            if item.group.name == group_name and (item.visible or item.respawn_at >= 0):
                return False
        return True

    def columns(self, agents: list[int], out: dict[str, list]) -> None:
        everyone = agents == list(range(len(self.eaten)))
        counts = self.eaten if everyone else self.eaten[agents]
        for group in self.groups:
            out[group.name] = counts[:, group.index].tolist()
        if self.has_keys:
            out["keys"] = [tuple(sorted(self.records[a].keys)) for a in agents]

    def info(self, agent: int, out: dict) -> None:
        for group in self.groups:
            out[group.name] = int(self.eaten[agent, group.index])
        if self.has_keys:
            out["keys"] = tuple(sorted(self.records[agent].keys))
