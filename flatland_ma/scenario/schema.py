"""The scenario schema: every field of a scenario file, its type, range and default.

Models are frozen and reject unknown keys. Numbers are strict (a quoted ``"10"`` is an
error, not a number); lengths are in world units, angles in degrees, times in seconds.
``docs/scenarios.md`` documents each field for authors of scenario files.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, model_validator

from flatland_ma.scenario.colors import parse_color
from flatland_ma.scenario.errors import SpecError

Real = Annotated[float, Field(strict=True, allow_inf_nan=False)]
Positive = Annotated[float, Field(strict=True, gt=0, allow_inf_nan=False)]
NonNegative = Annotated[float, Field(strict=True, ge=0, allow_inf_nan=False)]
UnitInterval = Annotated[float, Field(strict=True, ge=0, le=1, allow_inf_nan=False)]
Vec2 = tuple[Real, Real]
Size2 = tuple[Positive, Positive]
Color = Annotated[tuple[float, float, float], BeforeValidator(parse_color)]
Name = Annotated[str, Field(strict=True, pattern=r"^[a-z][a-z0-9_]*$", max_length=40)]


def _int(lo: int, hi: int):
    return Annotated[int, Field(strict=True, ge=lo, le=hi)]


class Spec(BaseModel):
    """Base of every scenario model: frozen, and unknown keys are errors."""

    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True)


class PhysicsSpec(Spec):
    dt: Positive = 1.0 / 30.0
    """Simulated seconds per environment step."""
    substeps: _int(1, 32) = 2
    """pymunk steps per environment step (each of ``dt / substeps`` seconds)."""
    iterations: _int(1, 100) = 10
    """Constraint-solver iterations per pymunk step."""


class EpisodeSpec(Spec):
    max_steps: _int(1, 10_000_000) = 500
    """Episode length in environment steps; reaching it is reported as truncation."""


class WallSpec(Spec):
    thickness: Positive = 10.0
    """Thickness of the arena's boundary walls, outside the playing area."""
    color: Color = "gray"


class ArenaSpec(Spec):
    size: Size2 = (300.0, 300.0)
    """Width and height of the playing area; walls lie outside it."""
    wall: WallSpec = WallSpec()
    floor_color: Color = "beige"
    """Only drawn by the renderer; rays never see the floor."""


class ObstacleBase(Spec):
    position: Vec2
    """Centre of the obstacle, in arena coordinates (origin at the bottom-left corner)."""
    angle: Real = 0.0
    """Rotation in degrees, counter-clockwise."""
    color: Color = "darkgray"
    movable: Annotated[bool, Field(strict=True)] = False
    """Movable obstacles are dynamic bodies that agents can push."""
    mass: Positive = 10.0
    friction: NonNegative = 0.5
    """Surface (Coulomb) friction against agents and other obstacles."""
    elasticity: UnitInterval = 0.0
    floor_friction: NonNegative = 0.5
    """Resistance to sliding on the floor, for movable obstacles (force = this x mass x g)."""

    def local_vertices(self) -> list[tuple[float, float]] | None:
        """Polygon vertices around the centre, counter-clockwise; None for a circle."""
        return None


class CircleObstacle(ObstacleBase):
    shape: Literal["circle"]
    radius: Positive

    def bounding_radius(self) -> float:
        return self.radius


class BoxObstacle(ObstacleBase):
    shape: Literal["box"]
    size: Size2
    """Width and height before rotation."""

    def local_vertices(self) -> list[tuple[float, float]]:
        w, h = self.size[0] / 2.0, self.size[1] / 2.0
        return [(-w, -h), (w, -h), (w, h), (-w, h)]

    def bounding_radius(self) -> float:
        return math.hypot(self.size[0], self.size[1]) / 2.0


class PolygonObstacle(ObstacleBase):
    shape: Literal["polygon"]
    vertices: Annotated[tuple[Vec2, ...], Field(min_length=3, max_length=32)]
    """Vertices relative to ``position``; the polygon must be convex."""

    @model_validator(mode="after")
    def _convex(self):
        pts = self.vertices
        n = len(pts)
        signs = set()
        for i in range(n):
            ax, ay = pts[i]
            bx, by = pts[(i + 1) % n]
            cx, cy = pts[(i + 2) % n]
            cross = (bx - ax) * (cy - by) - (by - ay) * (cx - bx)
            if abs(cross) > 1e-9:
                signs.add(cross > 0)
        if len(signs) != 1 or _polygon_area(pts) < 1e-6:
            raise ValueError("vertices must form a convex polygon with non-zero area")
        return self

    def local_vertices(self) -> list[tuple[float, float]]:
        pts = list(self.vertices)
        return pts if _polygon_area(pts) > 0 else pts[::-1]

    def bounding_radius(self) -> float:
        return max(math.hypot(x, y) for x, y in self.vertices)


def _polygon_area(pts) -> float:
    """Signed area: positive when the vertices run counter-clockwise."""
    n = len(pts)
    return 0.5 * sum(
        pts[i][0] * pts[(i + 1) % n][1] - pts[(i + 1) % n][0] * pts[i][1] for i in range(n)
    )


Obstacle = Annotated[CircleObstacle | BoxObstacle | PolygonObstacle, Field(discriminator="shape")]


class ItemSpec(Spec):
    name: Name
    """Name of the group; the agents' ``infos`` count how many of it each has eaten."""
    color: Color
    reward: Real
    """Reward to the agent that touches one."""
    count: _int(0, 10_000)
    """How many lie in the arena at once."""
    radius: Positive = 6.0
    respawn: Literal["immediate", "never"] = "immediate"
    """``immediate``: an eaten item reappears at once at a random free position."""


class CameraSpec(Spec):
    rays: _int(1, 4096) = 64
    """Number of rays, i.e. the width of the 1-D image."""
    fov: Annotated[float, Field(strict=True, gt=0, le=360, allow_inf_nan=False)] = 120.0
    """Field of view in degrees, centred on the heading."""
    range: Positive = 300.0
    """Farthest distance a ray sees; depth is normalised by it."""
    falloff: Literal["linear", "none"] = "linear"
    """How colour intensity falls with distance: ``linear`` is ``1 - d / range``."""


class AgentSpec(Spec):
    radius: Positive = 10.0
    mass: Positive = 1.0
    colors: Annotated[tuple[Color, ...], Field(min_length=1)] = (
        "blue",
        "red",
        "green",
        "yellow",
        "cyan",
        "magenta",
        "teal",
        "brown",
    )
    """Agent i is drawn (and seen by other agents) in ``colors[i % len(colors)]``."""
    actions: Literal["discrete", "continuous"] = "discrete"
    max_speed: Positive = 200.0
    """Top linear speed, units per second."""
    max_turn_rate: Positive = 300.0
    """Top angular speed, degrees per second."""
    max_force: Positive = 15_000.0
    """Largest force the agent's motor applies to reach its commanded velocity."""
    max_torque: Positive = 100_000.0
    """Largest torque the agent's motor applies to reach its commanded turn rate."""
    camera: CameraSpec = CameraSpec()


class ScenarioSpec(Spec):
    description: Annotated[str, Field(strict=True, max_length=200)] = ""
    """One line shown by ``flatland-ma list``."""
    n_agents: _int(1, 64) = 1
    episode: EpisodeSpec = EpisodeSpec()
    physics: PhysicsSpec = PhysicsSpec()
    arena: ArenaSpec = ArenaSpec()
    obstacles: tuple[Obstacle, ...] = ()
    items: tuple[ItemSpec, ...] = ()
    agent: AgentSpec = AgentSpec()

    @model_validator(mode="after")
    def _obstacles_inside_arena(self):
        width, height = self.arena.size
        for i, obstacle in enumerate(self.obstacles):
            x, y = obstacle.position
            r = obstacle.bounding_radius()
            verts = obstacle.local_vertices()
            if verts is None:
                xs, ys = (x - r, x + r), (y - r, y + r)
            else:
                a = math.radians(obstacle.angle)
                c, s = math.cos(a), math.sin(a)
                xs = [x + c * vx - s * vy for vx, vy in verts]
                ys = [y + s * vx + c * vy for vx, vy in verts]
            if min(xs) < 0 or min(ys) < 0 or max(xs) > width or max(ys) > height:
                raise SpecError(
                    ("obstacles", i, "position"),
                    f"obstacle reaches outside the {width:g} x {height:g} arena",
                )
        names = [item.name for item in self.items]
        for i, name in enumerate(names):
            if name in names[:i]:
                raise SpecError(("items", i, "name"), f"item name {name!r} used twice")
        return self
