"""What a world is made of: walls, obstacles, doors, items and agents as pymunk bodies.

An entity owns one pymunk body and its shapes. The world keeps a dict from each shape to
its entity, so nothing is stored on pymunk objects. Entities answer the questions the
engine asks (``moving``, ``edible``, ``blocks_paths``); the engine never tests what kind
an entity is.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum, IntFlag

import pymunk

from flatland_ma.scenario.types import TextureSpec

RGB = tuple[float, float, float]


class CollisionType(IntEnum):
    """pymunk collision types; handlers are registered per pair of them."""

    WALL = 1
    OBSTACLE = 2
    ITEM = 3
    AGENT = 4
    DOOR = 5
    GRASPER = 6


class Category(IntFlag):
    """pymunk shape-filter categories: which shapes may collide with which."""

    WALL = 1
    OBSTACLE = 2
    ITEM = 4
    AGENT = 8
    DOOR = 16
    EVERYTHING = 0xFFFFFFFF


def shape_filter(category: Category, ignores: int = 0) -> pymunk.ShapeFilter:
    """Shapes of ``category`` that collide with everything but the ``ignores`` categories."""
    return pymunk.ShapeFilter(categories=category, mask=Category.EVERYTHING & ~ignores)


@dataclass(eq=False)
class Entity:
    """One body with its shapes, as the sensors and the renderer see it."""

    body: pymunk.Body
    shapes: tuple[pymunk.Shape, ...]
    color: RGB
    constraints: tuple[pymunk.Constraint, ...] = ()
    aux_bodies: tuple[pymunk.Body, ...] = ()
    """Bodies without shapes that the constraints need (e.g. a motor's control body)."""
    texture: TextureSpec | None = None
    """How the colour varies along the surface; None: the plain colour."""
    index: int = -1
    """Position in ``World.entities``; set when the entity is added."""
    owner: int = -1
    """Index of the agent this entity belongs to (cameras skip their own agent)."""
    visible: bool = True
    """Whether rays and the renderer see it (an eaten item, an open door are hidden)."""

    @property
    def moving(self) -> bool:
        """True when physics moves the body, so its pose must be read every step."""
        return self.body.body_type == pymunk.Body.DYNAMIC

    @property
    def edible(self) -> bool:
        return False

    @property
    def fixed(self) -> bool:
        """Whether it never moves during an episode (it may still hide, like a door)."""
        return not self.moving

    @property
    def blocks_paths(self) -> bool:
        """Whether it stands in agents' way for good (walls, fixed obstacles)."""
        return False

    @property
    def actor(self) -> Entity | None:
        """The agent's base this entity is (or is a part of); None if no agent's."""
        return None


@dataclass(eq=False)
class Wall(Entity):
    @property
    def blocks_paths(self) -> bool:
        return True


@dataclass(eq=False)
class Obstacle(Entity):
    tag: str | None = None
    """Zones that accept this tag take the object as a delivery."""
    graspable: bool = False
    key: str | None = None
    """Doors whose key this is open when the object touches them."""
    home: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Where it started (x, y, angle): a delivered object goes back there."""

    @property
    def blocks_paths(self) -> bool:
        return not self.moving


@dataclass(eq=False)
class Item(Entity):
    """Taken when an agent touches it; ``group`` indexes the scenario's item list."""

    group: int = 0
    reward: float = 0.0
    radius: float = 0.0
    home: tuple[float, float] | None = None
    """Its fixed place, if the scenario gives one."""
    respawn_at: int = -1
    """Step at which a taken item comes back (-1: not waiting)."""

    @property
    def edible(self) -> bool:
        return self.visible

    @property
    def fixed(self) -> bool:
        return False  # it comes back elsewhere


@dataclass(eq=False)
class Door(Entity):
    """A door; ``spec`` says how it opens, ``is_open`` whether it is open now."""

    spec: object = None
    is_open: bool = False
    closed_angle: float = 0.0
    """The panel's angle when shut (hinged doors swing away from it)."""
    path: tuple = ()
    """Key path of the door in the scenario (for messages)."""
