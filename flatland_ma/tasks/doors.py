"""Doors: a closed sliding door opens when an agent touches it, a locked one when the
agent holds its key or a key object touches it; a switched door opens while an agent
stands in its zone. Hinged doors
need no rules: agents push them."""

from __future__ import annotations

from flatland_ma.sensors.geometry import Geometry
from flatland_ma.world.entities import Door
from flatland_ma.world.world import World


class DoorRules:
    def __init__(self, world: World, geometry: Geometry, doors: list[Door]):
        self.world = world
        self.geometry = geometry
        self.doors = [d for d in doors if d.spec.kind == "sliding"]
        self.switched = [d for d in self.doors if d.spec.switch is not None]
        for door in self.doors:
            if door.spec.state == "open":
                self._open(door)

    def apply(self, records, occupied: dict[str, bool]) -> None:
        for agent, door in self.world.door_touches:
            spec = door.spec
            if door.is_open or spec.kind != "sliding" or spec.switch is not None:
                continue
            if spec.state == "closed" or spec.key in records[agent.owner].keys:
                self._open(door)
        for thing, door in self.world.key_touches:
            if not door.is_open and door.spec.kind == "sliding" and door.spec.key == thing.key:
                self._open(door)
        for door in self.switched:
            pressed = occupied.get(door.spec.switch, False)
            if pressed and not door.is_open:
                self._open(door)
            elif not pressed and door.is_open and not door.spec.latch and self._doorway_clear(door):
                self._close(door)

    def _open(self, door: Door) -> None:
        door.is_open = True
        self.world.withdraw(door)
        self.geometry.update_entity(door)

    def _close(self, door: Door) -> None:
        door.is_open = False
        self.world.restore(door)
        self.geometry.update_entity(door)

    def _doorway_clear(self, door: Door) -> bool:
        shape = door.shapes[0]
        shape.cache_bb()
        hits = self.world.space.shape_query(shape)
        return not any(not hit.shape.sensor for hit in hits)
