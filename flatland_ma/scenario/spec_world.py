"""The layout: the arena, walls, rooms, corridors, doors, zones and generated layouts."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import Field, model_validator

from flatland_ma.scenario.kinds import SpecKinds
from flatland_ma.scenario.types import (
    MAX_GROUPS,
    MIN_LENGTH,
    Color,
    Distance,
    Flag,
    Length,
    Mass,
    Name,
    Real,
    Rect,
    Reward,
    Seed,
    Size2,
    Spec,
    TextureSpec,
    UnitInterval,
    Vec2,
)


class WallStyle(Spec):
    """The look of the boundary walls, and the default of every wall."""

    thickness: Length = 10.0
    """Thickness of the boundary walls (outside the playing area) and default of every wall."""
    color: Color = Field(default="gray", validate_default=True)
    """Colour of the walls."""
    texture: TextureSpec | None = None
    """A texture instead of the plain colour."""


class ArenaSpec(Spec):
    size: tuple[Length, Length] = (300.0, 300.0)
    """Width and height of the playing area; its boundary walls lie outside it. At most
    10,000 each: every coordinate lies in the arena, and the grids laid over it (to place
    things and check what agents can reach) grow with its area."""
    wall: WallStyle = WallStyle()
    """Style of the boundary walls; also the default of every other wall."""
    floor_color: Color = Field(default="beige", validate_default=True)
    """Only drawn by the renderer; rays never see the floor."""


class WallSpec(Spec):
    """A straight wall from ``start`` to ``end`` (its centre line), of some thickness."""

    start: Vec2
    """One end of the centre line; the wall reaches half its thickness beyond it."""
    end: Vec2
    """The other end of the centre line."""
    thickness: Length | None = None
    """None: the arena's wall thickness."""
    color: Color | None = None
    """None: the arena's wall colour."""
    texture: TextureSpec | None = None
    """None: the arena's wall texture."""

    @model_validator(mode="after")
    def _has_length(self):
        if math.dist(self.start, self.end) < MIN_LENGTH:
            raise ValueError(f"a wall's start and end must be at least {MIN_LENGTH:g} apart")
        return self


class DoorSpec(Spec):
    """A door. In an opening it fills the gap; on its own it spans ``start`` to ``end``.

    Sliding doors are solid panels that vanish when opened: a ``closed`` one opens when an
    agent touches it, a ``locked`` one when an agent holding its ``key`` touches it; with a
    ``switch`` it opens while an agent stands in that zone (for good, if ``latch``).
    Hinged doors swing on a hinge at their start when pushed, up to ``swing`` degrees
    either way.
    """

    name: Name | None = None
    """A name for the door (for reading the file)."""
    kind: Literal["sliding", "hinged"] = "sliding"
    """``sliding``: a panel that vanishes when opened; ``hinged``: swings when pushed."""
    state: Literal["closed", "locked", "open"] = "closed"
    """How a sliding door starts: closed (opens on touch), locked (needs its key or
    switch), open."""
    key: Name | None = None
    """The item group (with ``key: true``) that opens this door."""
    switch: Name | None = None
    """A zone that opens this door while an agent stands in it."""
    latch: Flag = True
    """A switched door stays open once opened."""
    swing: Annotated[float, Field(strict=True, gt=0, le=180)] = 100.0
    """How far a hinged door turns either way from shut, in degrees."""
    mass: Mass = 4.0
    """Mass of a hinged door's panel."""
    start: Vec2 | None = None
    """For a door on its own: one end of its line (a hinged door's hinge)."""
    end: Vec2 | None = None
    """For a door on its own: the other end of its line."""
    thickness: Length | None = None
    """None: the thickness of the wall it sits in (the arena's for a door on its own)."""
    color: Color = Field(default="brown", validate_default=True)
    """Colour of the panel."""
    texture: TextureSpec | None = None
    """A texture instead of the plain colour."""

    @model_validator(mode="after")
    def _consistent(self):
        if self.state == "locked" and self.key is None and self.switch is None:
            raise ValueError("a locked door needs a 'key' or a 'switch' to open it")
        if self.kind == "hinged" and (self.key or self.switch or self.state != "closed"):
            raise ValueError("a hinged door is pushed open: no key, switch or state")
        if (self.start is None) != (self.end is None):
            raise ValueError("give both 'start' and 'end', or neither")
        if self.start and self.end and math.dist(self.start, self.end) < MIN_LENGTH:
            raise ValueError(f"a door's start and end must be at least {MIN_LENGTH:g} apart")
        return self


class OpeningSpec(Spec):
    """A gap in one side of a room, optionally filled by a door."""

    side: Literal["north", "south", "east", "west"]
    """Which side of the room."""
    offset: Real | None = None
    """Distance of the gap's centre from the side's west (north and south sides) or south
    (east and west sides) end; None: the middle. The whole gap must lie on the side."""
    width: Length = 40.0
    """Width of the gap."""
    door: DoorSpec | None = None
    """A door filling the gap; none: an open doorway."""


class RoomSpec(Spec):
    """A rectangle of walls whose centre lines run along ``rect``'s edges."""

    name: Name | None = None
    """A name for the room (for reading the file; nothing refers to it)."""
    rect: Rect
    """The centre lines of the room's four walls."""
    openings: tuple[OpeningSpec, ...] = ()
    """Gaps in its sides, each optionally holding a door."""
    thickness: Length | None = None
    """None: the arena's wall thickness."""
    color: Color | None = None
    """None: the arena's wall colour."""
    texture: TextureSpec | None = None
    """None: the arena's wall texture."""


class CorridorSpec(Spec):
    """A straight, axis-parallel passage: a wall on each side of the centre line from
    ``start`` to ``end``; room walls across its ends are opened."""

    start: Vec2
    """One end of the centre line (on a room wall, typically)."""
    end: Vec2
    """The other end; start and end share x or y."""
    width: Length = 40.0
    """Distance between the centre lines of the corridor's two walls."""
    thickness: Length | None = None
    """None: the arena's wall thickness."""
    color: Color | None = None
    """None: the arena's wall colour."""
    texture: TextureSpec | None = None
    """None: the arena's wall texture."""

    @model_validator(mode="after")
    def _axis_parallel(self):
        (x0, y0), (x1, y1) = self.start, self.end
        if (x0 != x1) == (y0 != y1):
            raise ValueError("a corridor runs either horizontally or vertically")
        if math.dist(self.start, self.end) < MIN_LENGTH:
            raise ValueError(f"a corridor's start and end must be at least {MIN_LENGTH:g} apart")
        return self


class ZoneSpec(Spec):
    """An area of floor: rewards, punishes, ends the episode or moves agents on entry,
    and can work a door's switch. Rays do not see zones; the renderer paints them."""

    name: Name | None = None
    """Doors name it as their ``switch``."""
    rect: Rect | None = None
    """Where the zone is. None: a ``size`` rectangle placed at random in ``area`` at each
    reset (on free floor the agents can reach), fixed for the episode."""
    size: Size2 | None = None
    """Width and height of a zone placed at random."""
    area: Rect | None = None
    """Where a randomly placed zone may lie; None: the whole arena."""
    reward: Reward = 0.0
    """Reward to an agent each time its centre enters the zone."""
    once: Flag = False
    """Reward an agent only on its first entry in an episode."""
    terminal: Flag = False
    """Entering ends the agent's episode."""
    teleport: Flag = False
    """Entering moves the agent to a random start place (after the reward)."""
    color: Color | None = None
    """Floor paint in pictures; None: not drawn."""
    accepts: Name | None = None
    """Tag of the objects this zone takes: an object whose centre enters it is delivered
    (it goes back to where it started, and any hold on it is dropped)."""
    team: Name | None = None
    """The team this zone's rewards go to: entering it rewards only agents of this team, and
    deliveries reward this team; none: every agent."""
    delivery_reward: Reward = 0.0
    """Reward to each agent of the zone's team (or to every agent) per delivery."""
    zero_sum: Flag = False
    """On a delivery the agents of the other teams get ``-delivery_reward``."""
    end_on_delivery: Flag = False
    """A delivery ends everyone's episode."""

    @model_validator(mode="after")
    def _placed(self):
        if (self.rect is None) == (self.size is None):
            raise ValueError("give a zone either a 'rect', or a 'size' to place it at random")
        if self.area is not None and self.size is None:
            raise ValueError("'area' is for zones placed at random (with 'size')")
        return self


class GeneratorBaseSpec(Spec):
    """What every generator's spec is: it subclasses this with ``generator:
    Literal["..."]`` (its kind) and its own keys."""

    if TYPE_CHECKING:  # each generator's spec declares it, as a ``Literal``
        generator: Any  # (str: pyright holds a Literal override to the base)


class GridRoomsSpec(GeneratorBaseSpec):
    """``rows`` x ``cols`` equal rooms filling the arena, with one opening at a random place
    in every wall two rooms share (so every room is reachable)."""

    generator: Literal["grid_rooms"]
    """Selects this generator."""
    rows: Annotated[int, Field(strict=True, ge=1, le=30)] = 2
    """Rooms along y."""
    cols: Annotated[int, Field(strict=True, ge=1, le=30)] = 2
    """Rooms along x."""
    door_width: Length = 40.0
    """Width of the opening in each shared wall."""
    doors: Literal["none", "closed", "hinged"] = "none"
    """What fills the openings: nothing, sliding doors that open on touch, hinged doors."""
    thickness: Length | None = None
    """None: the arena's wall thickness."""
    color: Color | None = None
    """None: the arena's wall colour."""
    texture: TextureSpec | None = None
    """None: the arena's wall texture."""


class MazeSpec(GeneratorBaseSpec):
    """A perfect maze (one path between any two cells) of square cells over the arena;
    ``loops`` > 0 removes that fraction of the remaining inner walls at random."""

    generator: Literal["maze"]
    """Selects this generator."""
    cell: Length = 50.0
    """Side of a maze cell (adjusted so that whole cells fill the arena). An agent must
    fit between the walls of a cell, and a maze has at most 10,000 cells."""
    loops: UnitInterval = 0.0
    """Fraction of the inner walls left by the perfect maze that are removed."""
    thickness: Length | None = None
    """None: the arena's wall thickness."""
    color: Color | None = None
    """None: the arena's wall colour."""
    texture: TextureSpec | None = None
    """None: the arena's wall texture."""


class RandomObstaclesSpec(GeneratorBaseSpec):
    """Obstacles scattered at random, never overlapping anything, never cutting off a
    part of the arena from the agents."""

    generator: Literal["random_obstacles"]
    """Selects this generator."""
    count: Annotated[int, Field(strict=True, ge=1, le=500)] = 10
    """How many obstacles."""
    shapes: Annotated[
        tuple[Literal["circle", "box", "triangle", "pentagon"], ...], Field(min_length=1)
    ] = ("circle", "box", "triangle", "pentagon")
    """Shapes to draw from, uniformly."""
    size: tuple[Length, Length] = (15.0, 40.0)
    """Smallest and largest diameter."""
    colors: Annotated[tuple[Color, ...], Field(min_length=1)] = Field(
        default=("green", "cyan", "yellow", "white"), validate_default=True
    )
    """Colours to draw from, uniformly."""
    gap: Distance = 25.0
    """Least clearance around each obstacle, so that agents can pass between them."""


GENERATORS = SpecKinds("generator", "generator", GeneratorBaseSpec)
"""Every generator's spec, by its ``generator``: the shipped ones, and those registered
with ``flatland_ma.register`` or an entry point (``flatland_ma.scenario.extensions``)."""
for _spec in (GridRoomsSpec, MazeSpec, RandomObstaclesSpec):
    GENERATORS.add(_spec)

if TYPE_CHECKING:  # the shipped ones, which the checks here look into by their tag
    Generator = GridRoomsSpec | MazeSpec | RandomObstaclesSpec
else:
    Generator = GENERATORS.field
    """A generator in a file: a mapping whose ``generator`` picks its spec."""


class LayoutSpec(Spec):
    generators: Annotated[tuple[Generator, ...], Field(max_length=MAX_GROUPS)] = ()
    """Applied in order over the explicit walls, rooms and obstacles."""
    per_episode: Flag = True
    """True: a new layout at every reset, drawn from the env's generator. False: one layout
    for every episode, drawn from ``seed``."""
    seed: Seed = 0
    """The seed of the one layout drawn when ``per_episode`` is false."""
