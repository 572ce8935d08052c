"""What kind of thing each ray hit: the camera's ``semantic`` channel."""

from __future__ import annotations

import numpy as np

from flatland_ma.world.entities import Door, Entity, Item, Obstacle, Wall

SEMANTIC_KINDS = ("nothing", "wall", "door", "obstacle", "item", "agent")
"""The kinds, by id: ``nothing`` within range, walls (the arena's and every other),
doors, obstacles (fixed or movable), items, and agents (bases and their parts)."""

SEMANTIC_COLORS = np.array(
    [(0, 0, 0), (150, 150, 150), (165, 105, 45), (70, 110, 210), (240, 200, 40), (215, 60, 160)],
    np.uint8,
)
"""The colour each kind is drawn in, by id, in pictures of the semantic channel: one fixed
colour per kind whatever the scenario's colours (black for nothing, grey walls, brown
doors, blue obstacles, yellow items, magenta agents)."""


def kind_of(entity: Entity) -> int:
    """The id in ``SEMANTIC_KINDS`` of an entity."""
    if entity.actor is not None:
        return SEMANTIC_KINDS.index("agent")
    for kind, name in ((Wall, "wall"), (Door, "door"), (Obstacle, "obstacle"), (Item, "item")):
        if isinstance(entity, kind):
            return SEMANTIC_KINDS.index(name)
    raise TypeError(f"no semantic kind for a {type(entity).__name__}")


def kind_table(entities: list[Entity]) -> np.ndarray:
    """Ids by entity index, with one more entry at the end for ``nothing`` (index -1)."""
    return np.array([kind_of(e) for e in entities] + [0], np.int8)
