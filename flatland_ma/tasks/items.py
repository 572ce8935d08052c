"""Items: taken on touch for their reward; keys go to the taker's hand, goals end its
episode; taken items come back at once, after a delay, or never."""

from __future__ import annotations

import numpy as np

from flatland_ma.scenario.schema import ScenarioSpec
from flatland_ma.sensors.geometry import Geometry
from flatland_ma.world.entities import Item
from flatland_ma.world.placement import PlacementError, Placer
from flatland_ma.world.world import World


class ItemRules:
    def __init__(self, spec: ScenarioSpec, world: World, geometry: Geometry, placer: Placer):
        self.specs = spec.items
        self.world = world
        self.geometry = geometry
        self.placer = placer
        self._waiting: list[Item] = []
        """Taken items due back, in the order they were taken."""

    def apply(self, records, rewards: list[float], terminated: list[bool], rng, step: int) -> None:
        for agent, item in self.world.contacts:
            record = records[agent.owner]
            if not item.edible or record.done:
                continue  # already taken this step, or by an agent whose episode ended
            i = agent.owner
            spec = self.specs[item.group]
            rewards[i] += item.reward
            record.eaten[item.group] += 1
            if spec.key:
                record.keys.add(spec.name)
            if spec.terminal:
                terminated[i] = True
            self.world.withdraw(item)
            self.geometry.update_entity(item)
            if spec.respawn != "never":
                delay = 0 if spec.respawn == "immediate" else spec.respawn
                item.respawn_at = step + delay
                self._waiting.append(item)
        if self._waiting:
            self._respawn(rng, step)

    def _respawn(self, rng: np.random.Generator, step: int) -> None:
        waiting = []
        for item in self._waiting:
            if item.respawn_at > step or not self._put_back(item, rng):
                waiting.append(item)
        self._waiting = waiting

    def _put_back(self, item: Item, rng: np.random.Generator) -> bool:
        if item.home is not None:
            x, y = item.home
            if not self.world.is_free(x, y, item.radius):
                return False  # someone stands there: try again next step
        else:
            try:
                x, y = self.placer.sample(rng, item.radius, self.specs[item.group].spawn)
            except PlacementError:
                return False
        self.world.move_static(item, x, y)
        self.world.restore(item)
        item.respawn_at = -1
        self.geometry.update_entity(item)
        return True

    def none_left(self, group_name: str) -> bool:
        """No item of the group is out, and none is due back."""
        for item in self.world.entities:
            if isinstance(item, Item) and self.specs[item.group].name == group_name:
                if item.visible or item.respawn_at >= 0:
                    return False
        return True
