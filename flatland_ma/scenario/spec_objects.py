"""Things in the world: obstacles of several shapes, and items that agents touch."""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import Field, model_validator

from flatland_ma.scenario.types import (
    MIN_LENGTH,
    Color,
    Flag,
    Friction,
    Length,
    Mass,
    Name,
    Real,
    Rect,
    Reward,
    Size2,
    Spec,
    TextureSpec,
    UnitInterval,
    Vec2,
)


class ObstacleBase(Spec):
    position: Vec2
    """Centre of the obstacle, in arena coordinates (origin at the bottom-left corner)."""
    angle: Real = 0.0
    """Rotation in degrees, counter-clockwise."""
    color: Color = Field(default="darkgray", validate_default=True)
    """Colour of the obstacle."""
    texture: TextureSpec | None = None
    """A texture instead of the plain colour."""
    movable: Flag = False
    """Movable obstacles are dynamic bodies that agents can push."""
    mass: Mass = 10.0
    """Mass of a movable obstacle."""
    friction: Friction = 0.5
    """Surface (Coulomb) friction against agents and other obstacles."""
    elasticity: UnitInterval = 0.0
    """Bounciness of its surface (0: none, 1: perfectly elastic)."""
    floor_friction: Friction = 0.5
    """Resistance to sliding on the floor, for movable obstacles (force = this x mass x g)."""
    tag: Name | None = None
    """A name zones refer to (``accepts``) to take this object as a delivery."""
    graspable: Flag = False
    """Agents' graspers can hold it (it must be movable)."""
    key: Name | None = None
    """A key object: doors whose ``key`` names it open when it touches them."""

    @model_validator(mode="after")
    def _movable_things(self):
        if (self.graspable or self.key is not None) and not self.movable:
            raise ValueError("graspable and key objects must be movable")
        return self

    def local_vertices(self) -> list[tuple[float, float]] | None:
        """Polygon vertices around the centre, counter-clockwise; None for a circle."""
        return None


class CircleObstacle(ObstacleBase):
    shape: Literal["circle"]
    """Selects a circle."""
    radius: Length
    """Its radius."""

    def bounding_radius(self) -> float:
        return self.radius


class BoxObstacle(ObstacleBase):
    shape: Literal["box"]
    """Selects a box."""
    size: Size2
    """Width and height before rotation."""

    def local_vertices(self) -> list[tuple[float, float]]:
        w, h = self.size[0] / 2.0, self.size[1] / 2.0
        return [(-w, -h), (w, -h), (w, h), (-w, h)]

    def bounding_radius(self) -> float:
        return math.hypot(self.size[0], self.size[1]) / 2.0


class PolygonObstacle(ObstacleBase):
    shape: Literal["polygon"]
    """Selects a convex polygon."""
    vertices: Annotated[tuple[Vec2, ...], Field(min_length=3, max_length=32)]
    """Vertices relative to ``position``; the polygon must be convex."""

    @model_validator(mode="after")
    def _convex(self):
        problem = polygon_problem(self.vertices)
        if problem is not None:
            raise ValueError(f"vertices must form a convex polygon: {problem}")
        return self

    def local_vertices(self) -> list[tuple[float, float]]:
        pts = list(self.vertices)
        return pts if polygon_area(pts) > 0 else pts[::-1]

    def bounding_radius(self) -> float:
        return max(math.hypot(x, y) for x, y in self.vertices)


Obstacle = Annotated[CircleObstacle | BoxObstacle | PolygonObstacle, Field(discriminator="shape")]


class ItemSpec(Spec):
    name: Name
    """Name of the group; each agent's ``infos`` count how many of it the agent took."""
    color: Color
    """Colour of the items."""
    texture: TextureSpec | None = None
    """A texture instead of the plain colour."""
    reward: Reward = 0.0
    """Reward to the agent that touches one."""
    count: Annotated[int, Field(strict=True, ge=0, le=10_000)] = 1
    """How many lie in the arena at once (ignored when ``positions`` is given)."""
    radius: Length = 6.0
    """Items are discs of this radius, taken on touch."""
    spawn: Rect | None = None
    """Where they appear, at free places that agents can reach; None: the whole arena."""
    positions: Annotated[tuple[Vec2, ...], Field(max_length=10_000)] | None = None
    """Fixed places instead of random ones (one item at each); items may not overlap."""
    respawn: (
        Literal["immediate", "never"] | Annotated[int, Field(strict=True, ge=1, le=1_000_000)]
    ) = "immediate"
    """After one is taken: ``immediate``ly at a new random place, ``never``, or after this
    many steps. Items with fixed positions reappear where they were."""
    terminal: Flag = False
    """Taking one ends the episode of the agent that took it (a goal)."""
    shared: Flag = False
    """Its reward goes to every agent still playing, not only to the one that took it
    (a reward the agents earn together)."""
    key: Flag = False
    """A key: the agent that takes one holds it (``infos[agent]["keys"]``), and doors
    whose ``key`` names this group open to it."""

    @property
    def n_items(self) -> int:
        return len(self.positions) if self.positions is not None else self.count


def polygon_area(pts) -> float:
    """Signed area: positive when the vertices run counter-clockwise."""
    n = len(pts)
    return 0.5 * sum(
        pts[i][0] * pts[(i + 1) % n][1] - pts[(i + 1) % n][0] * pts[i][1] for i in range(n)
    )


def polygon_problem(pts) -> str | None:
    """What keeps ``pts`` from being a simple convex polygon that pymunk and the rays
    handle well, or None: no two vertices at the same place, every turn the same way and
    once around in all (a star or a shape wound twice turns the same way too), and at
    least ``MIN_LENGTH`` thick across."""
    n = len(pts)
    for i in range(n):
        for j in range(i + 1, n):
            if math.dist(pts[i], pts[j]) < MIN_LENGTH:
                return f"vertices {i} and {j} are at the same place"
    if not is_convex(pts):
        return "the vertices do not all turn the same way"
    turning = 0.0
    for i in range(n):
        (ax, ay), (bx, by), (cx, cy) = pts[i], pts[(i + 1) % n], pts[(i + 2) % n]
        turn = math.atan2(by - ay, bx - ax) - math.atan2(cy - by, cx - bx)
        turning += (turn + math.pi) % (2 * math.pi) - math.pi
    if abs(abs(turning) - 2 * math.pi) > 1e-6:
        return f"the outline winds {abs(turning) / (2 * math.pi):.3g} times around, not once"
    thickness = min(
        max(_distance_to_line(p, pts[i], pts[(i + 1) % n]) for p in pts) for i in range(n)
    )
    if thickness < MIN_LENGTH:
        return f"it is {thickness:.3g} thick at its thinnest, less than {MIN_LENGTH:g}"
    return None


def _distance_to_line(p, a, b) -> float:
    """Distance from ``p`` to the line through ``a`` and ``b`` (distinct points)."""
    (px, py), (ax, ay), (bx, by) = p, a, b
    return abs((bx - ax) * (py - ay) - (by - ay) * (px - ax)) / math.hypot(bx - ax, by - ay)


def is_convex(pts) -> bool:
    n = len(pts)
    signs = set()
    for i in range(n):
        ax, ay = pts[i]
        bx, by = pts[(i + 1) % n]
        cx, cy = pts[(i + 2) % n]
        cross = (bx - ax) * (cy - by) - (by - ay) * (cx - bx)
        if abs(cross) > 1e-9:
            signs.add(cross > 0)
    return len(signs) == 1 and abs(polygon_area(pts)) > 1e-6
