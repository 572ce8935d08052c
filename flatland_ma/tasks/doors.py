"""Doors: each door says what opens it (``world.entities.Door``); this rule opens it when
that happens. A touch opens a closed sliding door, or a locked one if the agent holds its
key; a key object opens one whose key it is; a switched door opens while an agent stands
in its switch zone and, unless it latches, closes once the zone is empty and its doorway
clear. Hinged doors need no rule: agents push them."""

from __future__ import annotations

from flatland_ma.tasks.rule import Rule, Step, TaskContext
from flatland_ma.world.entities import Door


class DoorRule(Rule):
    def reset(self, ctx: TaskContext) -> None:
        self.world = ctx.world
        doors = ctx.world.of_type(Door)
        self.switched = [d for d in doors if d.switch is not None]
        for door in doors:
            if door.starts_open:
                self._open(door)

    def apply(self, step: Step) -> None:
        for agent, door in step.log.doors:
            if door.opens_to_touch(step.records[agent.owner].keys):
                self._open(door)
        for thing, door in step.log.keys:
            if thing.key is not None and door.opens_to_key(thing.key):
                self._open(door)
        for door in self.switched:
            pressed = door.switch in step.log.occupied
            if pressed and not door.is_open:
                self._open(door)
            elif not pressed and door.is_open and not door.latch and self.world.is_clear(door):
                self._close(door)

    def _open(self, door: Door) -> None:
        door.is_open = True
        self.world.withdraw(door)

    def _close(self, door: Door) -> None:
        door.is_open = False
        self.world.restore(door)
