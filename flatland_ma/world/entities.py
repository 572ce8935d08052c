"""What a world is made of: walls, obstacles, doors, items and agents as pymunk bodies,
and zones of floor.

An entity owns one pymunk body and its shapes. The world keeps a dict from each shape to
its entity, so nothing is stored on pymunk objects. Entities answer the questions the
engine asks (``moving``, ``edible``, ``blocks_paths``; a door whether a touch or a key
opens it); the engine never tests what kind an entity is.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from enum import IntEnum, IntFlag

import pymunk

from flatland_ma.world.looks import RGB, Texture

Rect = tuple[float, float, float, float]
"""An axis-aligned rectangle (x0, y0, x1, y1)."""


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


@functools.cache  # a filter is an immutable named tuple: one per kind serves every shape
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
    texture: Texture | None = None
    """How the colour varies along the surface; None: the plain colour."""
    index: int = -1
    """Position in ``World.entities``; set when the entity is added."""
    owner: int = -1
    """Index of the agent this entity belongs to (cameras skip their own agent)."""
    visible: bool = True
    """Whether rays and the renderer see it (an eaten item, an open door are hidden)."""
    touching: int = 0
    """How many solid shapes it touches (the world keeps it for agents' bases)."""

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

    @property
    def key(self) -> str | None:
        """The name of the doors' key this entity is, if it is one."""
        return None

    @property
    def tag(self) -> str | None:
        """The tag zones accept as a delivery, if it has one."""
        return None


@dataclass(eq=False)
class Wall(Entity):
    @property
    def blocks_paths(self) -> bool:
        return True


@dataclass(eq=False)
class Obstacle(Entity):
    delivery_tag: str | None = None
    """Zones that accept this tag take the object as a delivery."""
    graspable: bool = False
    key_name: str | None = None
    """Doors whose key this is open when the object touches them."""
    home: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Where it started (x, y, angle): a delivered object goes back there."""

    @property
    def blocks_paths(self) -> bool:
        return not self.moving

    @property
    def key(self) -> str | None:
        return self.key_name

    @property
    def tag(self) -> str | None:
        return self.delivery_tag


@dataclass(frozen=True)
class ItemGroup:
    """What the items of one group do (the scenario's ``items[index]``)."""

    name: str
    index: int
    reward: float = 0.0
    radius: float = 6.0
    respawn: int | None = 0
    """Steps after being taken until an item comes back; None: never."""
    spawn: Rect | None = None
    """Where items of the group are placed at random; None: anywhere free."""
    terminal: bool = False
    """Taking one ends the taker's episode."""
    shared: bool = False
    """Its reward goes to every agent still playing, the taker included."""
    key: bool = False
    """The taker holds it as a key to doors that name the group."""


@dataclass(eq=False)
class Item(Entity):
    """Taken when an agent touches it."""

    group: ItemGroup = field(default_factory=lambda: ItemGroup("item", 0))
    home: tuple[float, float] | None = None
    """Its fixed place, if the scenario gives one."""
    respawn_at: int = -1
    """Step at which a taken item comes back (-1: not waiting)."""

    @property
    def reward(self) -> float:
        return self.group.reward

    @property
    def radius(self) -> float:
        return self.group.radius

    @property
    def edible(self) -> bool:
        return self.visible

    @property
    def fixed(self) -> bool:
        return False  # it comes back elsewhere


@dataclass(eq=False)
class Door(Entity):
    """A door; ``is_open`` says whether it is open now. Kinds answer how they open."""

    name: str | None = None
    path: tuple = ()
    """Key path of the door in the scenario (for messages)."""
    closed_angle: float = 0.0
    """The panel's angle when shut."""
    is_open: bool = False

    @property
    def starts_open(self) -> bool:
        return False

    @property
    def gate_key(self) -> str | None:
        """The key (item group or key object) that opens it, if any."""
        return None

    @property
    def switch(self) -> str | None:
        """The zone that opens it while an agent stands there, if any."""
        return None

    @property
    def latch(self) -> bool:
        """Whether it stays open once its switch has opened it."""
        return True

    @property
    def needs_opener(self) -> bool:
        """Whether agents can pass only once something opens it (a key or a switch)."""
        return False

    @property
    def swings(self) -> bool:
        """Whether agents push it aside (it opens by physics, not by rules)."""
        return False

    def opens_to_touch(self, keys: set[str]) -> bool:
        """Whether an agent holding ``keys`` opens it by touching it."""
        return False

    def opens_to_key(self, key: str) -> bool:
        """Whether a key object called ``key`` opens it by touching it."""
        return False

    def blocks(self, keys: set[str]) -> bool:
        """Whether it is in the way of an agent holding ``keys``, for planning."""
        return False


@dataclass(eq=False)
class SlidingDoor(Door):
    """A panel that vanishes when opened: by a touch (closed), by a touch from an agent
    holding its key or by a key object (locked), or while an agent stands on its switch."""

    locked: bool = False
    opened: bool = False
    """Whether it starts open."""
    key_name: str | None = None
    switch_zone: str | None = None
    latching: bool = True

    @property
    def starts_open(self) -> bool:
        return self.opened

    @property
    def gate_key(self) -> str | None:
        return self.key_name

    @property
    def switch(self) -> str | None:
        return self.switch_zone

    @property
    def latch(self) -> bool:
        return self.latching

    @property
    def needs_opener(self) -> bool:
        return not self.opened and (self.switch_zone is not None or self.locked)

    def opens_to_touch(self, keys: set[str]) -> bool:
        if self.is_open or self.switch_zone is not None:
            return False
        return not self.locked or self.key_name in keys

    def opens_to_key(self, key: str) -> bool:
        return not self.is_open and self.key_name == key

    def blocks(self, keys: set[str]) -> bool:
        if self.is_open:
            return False
        return self.switch_zone is not None or (self.locked and self.key_name not in keys)


SWUNG = 0.3
"""Radians a hinged door must be turned from shut before it counts as in the way."""


@dataclass(eq=False)
class HingedDoor(Door):
    """A panel on a hinge at its start that agents push open, up to ``swing`` radians
    either way from shut."""

    swing: float = 0.0

    @property
    def swings(self) -> bool:
        return True

    def blocks(self, keys: set[str]) -> bool:
        """Swung aside, it stands in the way; shut, a push opens it."""
        return abs(self.body.angle - self.closed_angle) > SWUNG


@dataclass(eq=False)
class Zone:
    """An area of floor that acts when agents' centres enter it (not seen by rays)."""

    rect: Rect
    index: int = 0
    name: str | None = None
    reward: float = 0.0
    """Reward to an agent each time its centre enters the zone."""
    once: bool = False
    """Reward an agent only on its first entry in an episode."""
    terminal: bool = False
    teleport: bool = False
    color: RGB | None = None
    """Floor paint in pictures; None: not drawn."""
    team: str | None = None
    """The team its rewards go to; None: every agent."""
    accepts: str | None = None
    """Tag of the objects it takes as deliveries."""
    delivery_reward: float = 0.0
    zero_sum: bool = False
    end_on_delivery: bool = False

    def contains(self, x: float, y: float) -> bool:
        x0, y0, x1, y1 = self.rect
        return x0 <= x <= x1 and y0 <= y <= y1

    @property
    def centre(self) -> tuple[float, float]:
        x0, y0, x1, y1 = self.rect
        return ((x0 + x1) / 2, (y0 + y1) / 2)


def darker(color: RGB, factor: float = 0.7) -> RGB:
    """A shade of ``color`` (agents' parts are drawn darker than their base)."""
    r, g, b = color
    return (factor * r, factor * g, factor * b)
