"""The contact log: what happened in the last step that rules may act on.

The world fills it while it steps: pymunk's collision callbacks record touches (never
act on them), and after the physics the world notes which agents' centres entered which
zones, which named zones hold a live agent, and which tagged objects lie in zones that
accept them. Rules read it; so do touch sensors (``pushes``); nobody else writes it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from flatland_ma.world.entities import Door, Entity, Item, Obstacle, Zone


@dataclass
class ContactLog:
    """What happened in the last step, filled by the world as it steps and cleared at
    the next; rules read it (``Step.log``), nothing but the world writes it. An agent in
    it is its base (an ``AgentBody``; its index is ``owner``)."""

    items: list[tuple[Entity, Item]] = field(default_factory=list)
    """(agent base, item) for each item an agent (or its grasper) began touching."""
    doors: list[tuple[Entity, Door]] = field(default_factory=list)
    """(agent base, door) for each door an agent began touching."""
    keys: list[tuple[Entity, Door]] = field(default_factory=list)
    """(key object, door) for each door a key object began touching."""
    entered: list[tuple[Entity, Zone]] = field(default_factory=list)
    """(agent base, zone) for each zone an agent's centre entered, agent by agent."""
    occupied: set[str] = field(default_factory=set)
    """Names of the zones that hold a live agent's centre now."""
    deliveries: list[tuple[Obstacle, Zone]] = field(default_factory=list)
    """(object, zone) for each tagged object whose centre lies in a zone accepting it."""
    pushes: dict[int, list[tuple[float, float]]] = field(default_factory=dict)
    """For each row of felt shapes (``World.feel``) pushed in the step: every push, each
    physics substep, as (bearing, impulse). The bearing is the direction the push comes
    from, in radians from the heading of the felt shape's body, counter-clockwise (the
    contact normal, which for a disc points at the point touched); the impulse is the
    normal impulse the contact solver applied. Empty unless something is felt."""

    def clear(self) -> None:
        self.items.clear()
        self.doors.clear()
        self.keys.clear()
        self.entered.clear()
        self.occupied.clear()
        self.deliveries.clear()
        self.pushes.clear()
