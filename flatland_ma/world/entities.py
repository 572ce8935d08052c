"""What a world is made of: walls, obstacles, items and agents as pymunk bodies.

An entity owns one pymunk body and its shapes. The world keeps a dict from each shape to
its entity, so nothing is stored on pymunk objects. Entities answer the questions the
engine asks (``moving``, ``edible``); the engine never tests what kind an entity is.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import pymunk

RGB = tuple[float, float, float]


class CollisionType(IntEnum):
    """pymunk collision types; handlers are registered per pair of them."""

    WALL = 1
    OBSTACLE = 2
    ITEM = 3
    AGENT = 4


@dataclass(eq=False)
class Entity:
    """One body with its shapes, as the sensors and the renderer see it."""

    body: pymunk.Body
    shapes: tuple[pymunk.Shape, ...]
    color: RGB
    constraints: tuple[pymunk.Constraint, ...] = ()
    aux_bodies: tuple[pymunk.Body, ...] = ()
    """Bodies without shapes that the constraints need (e.g. a motor's control body)."""
    index: int = -1
    """Position in ``World.entities``; set when the entity is added."""
    owner: int = -1
    """Index of the agent this entity belongs to (cameras skip their own agent)."""
    visible: bool = True
    """Whether rays and the renderer see it (an eaten item is hidden)."""

    @property
    def moving(self) -> bool:
        """True when physics moves the body, so its pose must be read every step."""
        return self.body.body_type == pymunk.Body.DYNAMIC

    @property
    def edible(self) -> bool:
        return False


@dataclass(eq=False)
class Wall(Entity):
    pass


@dataclass(eq=False)
class Obstacle(Entity):
    pass


@dataclass(eq=False)
class Item(Entity):
    """Consumed when an agent touches it; ``group`` indexes the scenario's item list."""

    group: int = 0
    reward: float = 0.0
    radius: float = 0.0

    @property
    def edible(self) -> bool:
        return self.visible
