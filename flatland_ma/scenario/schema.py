"""The scenario schema: every field of a scenario file, its type, range and default.

Models are frozen and reject unknown keys. Numbers are strict (a quoted ``"10"`` is an
error, not a number); lengths are in world units, angles in degrees, times in seconds and
rectangles ``[x0, y0, x1, y1]``. ``docs/scenarios.md`` documents each field for authors.
The sections live in ``spec_world`` (layout), ``spec_objects`` (obstacles and items) and
``spec_agent`` (agents); this module ties them together and checks what spans sections.
"""

from __future__ import annotations

import math
from typing import Annotated

from pydantic import Field, model_validator

from flatland_ma.scenario.errors import SpecError
from flatland_ma.scenario.spec_agent import (
    AgentSpec,
    ArmSegmentSpec,
    ArmSpec,
    CameraSpec,
    GrasperSpec,
    HeadSpec,
    SpawnSpec,
    TeamSpec,
)
from flatland_ma.scenario.spec_objects import (
    BoxObstacle,
    CircleObstacle,
    ItemSpec,
    Obstacle,
    ObstacleBase,
    PolygonObstacle,
)
from flatland_ma.scenario.spec_world import (
    ArenaSpec,
    CorridorSpec,
    DoorSpec,
    GridRoomsSpec,
    LayoutSpec,
    MazeSpec,
    OpeningSpec,
    RandomObstaclesSpec,
    RoomSpec,
    WallSpec,
    WallStyle,
    ZoneSpec,
)
from flatland_ma.scenario.types import Flag, Name, Positive, Spec, TextureSpec, int_range

__all__ = [
    "AgentSpec",
    "ArmSegmentSpec",
    "ArmSpec",
    "GrasperSpec",
    "HeadSpec",
    "TeamSpec",
    "ArenaSpec",
    "BoxObstacle",
    "CameraSpec",
    "CircleObstacle",
    "CorridorSpec",
    "DoorSpec",
    "EpisodeSpec",
    "GridRoomsSpec",
    "ItemSpec",
    "LayoutSpec",
    "MazeSpec",
    "ObstacleBase",
    "OpeningSpec",
    "PhysicsSpec",
    "PolygonObstacle",
    "RandomObstaclesSpec",
    "RoomSpec",
    "ScenarioSpec",
    "SpawnSpec",
    "TextureSpec",
    "WallSpec",
    "WallStyle",
    "ZoneSpec",
]

RESERVED_NAMES = ("score", "keys")
"""Keys of ``infos[agent]`` that item groups may not take."""


class PhysicsSpec(Spec):
    dt: Positive = 1.0 / 30.0
    """Simulated seconds per environment step."""
    substeps: int_range(1, 32) = 2
    """pymunk steps per environment step (each of ``dt / substeps`` seconds)."""
    iterations: int_range(1, 100) = 10
    """Constraint-solver iterations per pymunk step."""


class EpisodeSpec(Spec):
    max_steps: int_range(1, 10_000_000) = 500
    """Episode length in environment steps; reaching it is reported as truncation."""
    shared_end: Flag = False
    """When one agent's episode ends (a goal, a terminal zone), everyone's does."""
    end_when_eaten: Name | None = None
    """End everyone's episode once no item of this group is left (with ``respawn: never``)."""


class ScenarioSpec(Spec):
    description: Annotated[str, Field(strict=True, max_length=200)] = ""
    """One line shown by ``flatland-ma list``."""
    n_agents: int_range(1, 64) = 1
    """How many agents share the world (named agent_0, agent_1, ...)."""
    episode: EpisodeSpec = EpisodeSpec()
    """Episode length and how episodes end."""
    physics: PhysicsSpec = PhysicsSpec()
    """Time step and solver settings."""
    arena: ArenaSpec = ArenaSpec()
    """The playing area and its boundary walls."""
    walls: tuple[WallSpec, ...] = ()
    """Straight walls anywhere in the arena."""
    rooms: tuple[RoomSpec, ...] = ()
    """Rectangles of walls, with openings."""
    corridors: tuple[CorridorSpec, ...] = ()
    """Passages between walls; they open the room walls they run through."""
    doors: tuple[DoorSpec, ...] = ()
    """Doors on their own (doors in room openings are given there)."""
    zones: tuple[ZoneSpec, ...] = ()
    """Areas of floor that act when agents enter them."""
    layout: LayoutSpec = LayoutSpec()
    """Generated walls and obstacles, drawn per episode or once."""
    obstacles: tuple[Obstacle, ...] = ()
    """Obstacles at fixed places: circles, boxes, convex polygons."""
    items: tuple[ItemSpec, ...] = ()
    """Groups of items that agents take by touching them."""
    agent: AgentSpec = AgentSpec()
    """What every agent is: body, motor, camera, actions, start."""
    teams: tuple[TeamSpec, ...] = ()
    """Teams of agents, in agent order; their sizes add up to ``n_agents``."""

    @model_validator(mode="after")
    def _cross_checks(self):
        self._check_inside_arena()
        self._check_names()
        self._check_teams()
        self._check_speed_against_walls()
        return self

    def team_of(self, agent_index: int) -> TeamSpec | None:
        """The team of an agent (teams take agents in order), or None without teams."""
        first = 0
        for team in self.teams:
            if agent_index < first + team.size:
                return team
            first += team.size
        return None

    def spawn_of(self, agent_index: int) -> SpawnSpec:
        team = self.team_of(agent_index)
        return team.spawn if team is not None and team.spawn is not None else self.agent.spawn

    def _check_teams(self) -> None:
        if not self.teams:
            for i, zone in enumerate(self.zones):
                if zone.team is not None:
                    raise SpecError(("zones", i, "team"), f"no team {zone.team!r}: no teams")
            return
        names = [t.name for t in self.teams]
        for i, name in enumerate(names):
            if name in names[:i]:
                raise SpecError(("teams", i, "name"), f"team name {name!r} used twice")
        total = sum(t.size for t in self.teams)
        if total != self.n_agents:
            raise SpecError(("n_agents",), f"the teams have {total} agents, not {self.n_agents}")
        for i, zone in enumerate(self.zones):
            if zone.team is not None and zone.team not in names:
                raise SpecError(("zones", i, "team"), f"no team {zone.team!r}; teams: {names}")

    def all_doors(self) -> list[tuple[tuple, DoorSpec]]:
        """Every door with its key path: standalone ones and those in room openings."""
        doors = [(("doors", i), d) for i, d in enumerate(self.doors)]
        for r, room in enumerate(self.rooms):
            for o, opening in enumerate(room.openings):
                if opening.door is not None:
                    doors.append((("rooms", r, "openings", o, "door"), opening.door))
        return doors

    def _check_inside_arena(self) -> None:
        width, height = self.arena.size

        def inside(x0, y0, x1, y1) -> bool:
            return x0 >= 0 and y0 >= 0 and x1 <= width and y1 <= height

        where = f"outside the {width:g} x {height:g} arena"
        for i, obstacle in enumerate(self.obstacles):
            if not inside(*_obstacle_bounds(obstacle)):
                raise SpecError(("obstacles", i, "position"), f"obstacle reaches {where}")
        for i, zone in enumerate(self.zones):
            if zone.rect is not None and not inside(*zone.rect):
                raise SpecError(("zones", i, "rect"), f"zone lies {where}")
            if zone.area is not None and not inside(*zone.area):
                raise SpecError(("zones", i, "area"), f"zone area lies {where}")
            if zone.size is not None:
                x0, y0, x1, y1 = zone.area or (0, 0, width, height)
                if zone.size[0] > x1 - x0 or zone.size[1] > y1 - y0:
                    raise SpecError(("zones", i, "size"), "zone is larger than its area")
        for i, room in enumerate(self.rooms):
            if not inside(*room.rect):
                raise SpecError(("rooms", i, "rect"), f"room lies {where}")
        for i, item in enumerate(self.items):
            if item.spawn is not None and not inside(*item.spawn):
                raise SpecError(("items", i, "spawn"), f"spawn area lies {where}")
            for k, (x, y) in enumerate(item.positions or ()):
                if not inside(x - item.radius, y - item.radius, x + item.radius, y + item.radius):
                    raise SpecError(("items", i, "positions", k), f"item lies {where}")
        spawn = self.agent.spawn.area
        if spawn is not None and not inside(*spawn):
            raise SpecError(("agent", "spawn", "area"), f"spawn area lies {where}")
        for i, team in enumerate(self.teams):
            if (
                team.spawn is not None
                and team.spawn.area is not None
                and not inside(*team.spawn.area)
            ):
                raise SpecError(("teams", i, "spawn", "area"), f"spawn area lies {where}")

    def _check_names(self) -> None:
        groups = [item.name for item in self.items]
        for i, name in enumerate(groups):
            if name in groups[:i]:
                raise SpecError(("items", i, "name"), f"item name {name!r} used twice")
            if name in RESERVED_NAMES:
                raise SpecError(("items", i, "name"), f"{name!r} is reserved for infos")
        zones = [z.name for z in self.zones if z.name is not None]
        for i, zone in enumerate(self.zones):
            if zone.name is not None and zones.count(zone.name) > 1:
                raise SpecError(("zones", i, "name"), f"zone name {zone.name!r} used twice")
        keys = {item.name for item in self.items if item.key}
        keys |= {o.key for o in self.obstacles if o.key is not None}
        door_names = []
        for path, door in self.all_doors():
            if door.key is not None and door.key not in keys:
                raise SpecError(
                    path + ("key",),
                    f"no key item group or key object {door.key!r}; keys: {sorted(keys)}",
                )
            if door.switch is not None and door.switch not in zones:
                raise SpecError(
                    path + ("switch",), f"no zone named {door.switch!r}; zones: {zones}"
                )
            if door.name is not None:
                if door.name in door_names:
                    raise SpecError(path + ("name",), f"door name {door.name!r} used twice")
                door_names.append(door.name)
        for path, door in self.all_doors():
            if path[0] == "doors" and door.start is None:
                raise SpecError(path, "a door outside a room opening needs 'start' and 'end'")
        tags = {o.tag for o in self.obstacles if o.tag is not None}
        for i, zone in enumerate(self.zones):
            if zone.accepts is not None and zone.accepts not in tags:
                raise SpecError(
                    ("zones", i, "accepts"),
                    f"no object with tag {zone.accepts!r}; tags: {sorted(tags)}",
                )
        eaten = self.episode.end_when_eaten
        if eaten is not None and eaten not in groups:
            raise SpecError(
                ("episode", "end_when_eaten"),
                f"no item group {self.episode.end_when_eaten!r}; groups: {groups}",
            )

    def _check_speed_against_walls(self) -> None:
        """Between two contact checks a body moves one substep's travel: a part that can
        travel farther than the wall's half thickness plus its own could pass through."""
        substep = self.physics.dt / self.physics.substeps
        walls = [(("arena", "wall", "thickness"), self.arena.wall.thickness)]
        for key in ("walls", "rooms", "corridors"):
            for i, piece in enumerate(getattr(self, key)):
                if piece.thickness is not None:
                    walls.append(((key, i, "thickness"), piece.thickness))
        for gen_index, gen in enumerate(self.layout.generators):
            if getattr(gen, "thickness", None) is not None:
                walls.append((("layout", "generators", gen_index, "thickness"), gen.thickness))
        for path, thickness in walls:
            for part, speed, half in self.agent.fastest_parts():
                travel = speed * substep
                if thickness / 2 + half <= travel:
                    raise SpecError(
                        path,
                        f"walls {thickness:g} thick can be crossed by an agent's {part}, which "
                        f"can move {travel:.3g} units per substep; use thicker walls, more "
                        "physics substeps, or slower motors",
                    )


def _obstacle_bounds(obstacle) -> tuple[float, float, float, float]:
    x, y = obstacle.position
    verts = obstacle.local_vertices()
    if verts is None:
        r = obstacle.bounding_radius()
        return x - r, y - r, x + r, y + r
    a = math.radians(obstacle.angle)
    c, s = math.cos(a), math.sin(a)
    xs = [x + c * vx - s * vy for vx, vy in verts]
    ys = [y + s * vx + c * vy for vx, vy in verts]
    return min(xs), min(ys), max(xs), max(ys)
