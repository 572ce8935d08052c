"""Building an episode from a validated scenario and the env's random generator.

``build`` is the only place where scenario specs become a world. The layout (walls, rooms,
corridors, doors, generated parts) is drawn first: from the env's generator when the
scenario asks for a new layout each episode, otherwise from the layout's own seed (and then
reused). Then agents, then items group by group, are placed at free places the agents can
reach, from the env's generator, in that order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from flatland_ma.agents.body import AgentBody, make_agent_body
from flatland_ma.agents.grasp import Hands
from flatland_ma.agents.parts import attach_parts
from flatland_ma.scenario import layout as layouts
from flatland_ma.scenario.capacity import check_capacity, spawn_group_of, spawn_groups
from flatland_ma.scenario.errors import SpecError, format_path
from flatland_ma.scenario.factory import (
    make_arena_walls,
    make_door,
    make_item,
    make_obstacle,
    make_walls,
)
from flatland_ma.scenario.reach import reachable_region
from flatland_ma.scenario.scatter import scatter_obstacles
from flatland_ma.scenario.schema import ScenarioSpec
from flatland_ma.sensors.camera import Camera
from flatland_ma.sensors.suite import Sensors
from flatland_ma.tasks.task import Task
from flatland_ma.world.entities import Door, Obstacle
from flatland_ma.world.navigation import NavGrid
from flatland_ma.world.placement import PlacementError, Placer
from flatland_ma.world.world import World

LAYOUT_TRIES = 20
"""Fresh draws of a generated layout before giving up on one that cannot be built."""
CHECK_SEEDS = 4
"""How many seeds ``check_layout`` builds a scenario with."""


@dataclass
class Episode:
    """What one episode runs on; rebuilt from scratch at every reset."""

    world: World
    bodies: list[AgentBody]
    sensors: Sensors
    task: Task
    grid: NavGrid
    """Free places for an agent's centre; doors and movable things count as free."""
    placer: Placer
    hands: Hands
    """Every agent's graspers."""
    doors: list[Door] = field(default_factory=list)
    eyes: list = field(default_factory=list)
    """Each agent's camera carrier: its base, or its head."""


@dataclass
class Ground:
    """The static part of an episode: walls, doors and obstacles, and where agents go."""

    world: World
    doors: list[Door]
    grid: NavGrid
    placer: Placer
    """Places agents can reach (through the doors they can open)."""


def build(spec: ScenarioSpec, rng: np.random.Generator, cameras: list[Camera]) -> Episode:
    """A new episode; a scenario that cannot be built (e.g. no room left for an item at
    this seed) raises ``ScenarioError`` naming its file, line and key."""
    try:
        return populate(spec, lay_ground(spec, rng), rng, cameras)
    except SpecError as err:
        raise spec.locate(err) from None


def check_layout(spec: ScenarioSpec) -> None:
    """Build with a few fixed seeds, checking there is room to spare for what is placed at
    random: raise ``SpecError`` if the scenario cannot be built reliably."""
    cameras = [Camera(spec.agent.camera) for _ in range(spec.n_agents)]
    for seed in range(CHECK_SEEDS):
        rng = np.random.default_rng(seed)
        ground = lay_ground(spec, rng)
        check_capacity(spec, ground.placer)
        populate(spec, ground, rng, cameras)


def lay_ground(spec: ScenarioSpec, rng: np.random.Generator) -> Ground:
    """The ground of an episode; a layout generated per episode is drawn again (up to
    ``LAYOUT_TRIES`` times) while it cannot be used."""
    fixed = not spec.layout.per_episode or not spec.layout.generators
    layout_rng = np.random.default_rng(spec.layout.seed) if fixed else rng
    for attempt in range(1 if fixed else LAYOUT_TRIES):
        try:
            return _ground(spec, layout_rng)
        except SpecError:
            if fixed or attempt == LAYOUT_TRIES - 1:
                raise
    raise AssertionError("unreachable")  # pragma: no cover


def populate(
    spec: ScenarioSpec, ground: Ground, rng: np.random.Generator, cameras: list[Camera]
) -> Episode:
    """Place the agents, then the items, on the ground; the sensors and the task."""
    world, placer = ground.world, ground.placer
    bodies, eyes, hands = [], [], []
    reach = spec.agent.footprint()
    groups = spawn_groups(spec)
    placed = {g.team: 0 for g in groups}
    for i in range(spec.n_agents):
        spawn, team = spec.spawn_of(i), spec.team_of(i)
        group = spawn_group_of(spec, groups, i)
        k = placed[group.team]
        placed[group.team] += 1
        x, y = _place(placer, rng, reach, spawn.area, group.fault_path(k), "agent")
        angle = (
            float(rng.uniform(-math.pi, math.pi))
            if spawn.heading is None
            else math.radians(spawn.heading)
        )
        color = (
            team.color
            if team is not None and team.color is not None
            else spec.agent.colors[i % len(spec.agent.colors)]
        )
        body = make_agent_body(spec.agent, i, (x, y), angle, color, world.substep_dt, world.dt)
        bodies.append(world.add(body))
        for part in attach_parts(spec.agent, body, i):
            world.add(part)
        for hand in body.hands:
            world.hand_of_shape[hand.shape] = hand
        hands += body.hands
        eyes.append(body.head if spec.agent.camera.mount == "head" else body)

    for g, item_spec in enumerate(spec.items):
        if item_spec.positions is not None:
            for x, y in item_spec.positions:
                world.add(make_item(item_spec, g, x, y, home=(x, y)))
            continue
        for k in range(item_spec.count):
            if item_spec.spawn is not None:
                path = ("items", g, "spawn")
            else:
                path = ("items", g, "radius" if k == 0 else "count")
            x, y = _place(placer, rng, item_spec.radius, item_spec.spawn, path, "item")
            world.add(make_item(item_spec, g, x, y))

    sensors = Sensors(world, eyes, cameras)
    grasps = Hands(world.space, hands)
    task = Task(spec, world, sensors.geometry, bodies, ground.doors, placer, rng, grasps)
    return Episode(world, bodies, sensors, task, ground.grid, placer, grasps, ground.doors, eyes)


def _ground(spec: ScenarioSpec, rng: np.random.Generator) -> Ground:
    """The walls, doors and obstacles of one layout, and where agents fit and can go."""
    world = World(spec.physics, spec.arena.size)
    world.add(make_arena_walls(spec.arena))
    parts = [layouts.explicit_layout(spec)]
    for index, gen in enumerate(spec.layout.generators):
        if gen.generator == "grid_rooms":
            parts.append(layouts.grid_rooms(gen, spec, rng, index))
        elif gen.generator == "maze":
            parts.append(layouts.maze(gen, spec, rng, index))
    walls, owners = make_walls([p for part in parts for p in part.walls], world.space.static_body)
    for wall in walls:
        world.add(wall)
    doors = [world.add(make_door(piece, world.space)) for part in parts for piece in part.doors]
    owners.update((shape, door.path) for door in doors for shape in door.shapes)
    for i, obstacle in enumerate(spec.obstacles):
        entity = make_obstacle(obstacle, world.space)
        _check_clear(world, entity, ("obstacles", i), owners)
        world.add(entity)
        owners.update((shape, ("obstacles", i)) for shape in entity.shapes)

    grid = NavGrid(spec.arena.size, spec.agent.radius)
    for entity in world.entities:
        if entity.blocks_paths:
            for shape in entity.shapes:
                grid.block_shape(shape)
    groups = spawn_groups(spec)
    start = np.zeros_like(grid.blocked)
    for group in groups:
        start |= grid.cells_in(group.spawn.area)
    for index, gen in enumerate(spec.layout.generators):
        if gen.generator == "random_obstacles":
            path = ("layout", "generators", index)
            grid = scatter_obstacles(gen, world, grid, start, rng, path)
    for group in groups:
        if not (grid.cells_in(group.spawn.area) & ~grid.blocked).any():
            where = group.area_path or ("arena", "size")
            raise SpecError(where, "no free place where agents could start")
    region = reachable_region(spec, grid, doors, start)
    return Ground(world, doors, grid, Placer(world, grid, region))


def _check_clear(world: World, entity, path: tuple, owners: dict) -> None:
    """Raise at ``path`` (and at what it overlaps) if the entity overlaps anything."""
    for shape in entity.shapes:
        shape.cache_bb()
        for hit in world.space.shape_query(shape):
            other = owners.get(hit.shape, ())
            thing = world.entity_of_shape[hit.shape]
            what = (
                "a door"
                if isinstance(thing, Door)
                else "another obstacle"
                if isinstance(thing, Obstacle)
                else "a wall"
            )
            where = f" ({format_path(other)})" if other else ""
            also = ((other, f"overlaps {format_path(path)}"),) if other else ()
            raise SpecError(path, f"overlaps {what}{where}", also)


def _place(placer: Placer, rng, radius, area, path, what) -> tuple[float, float]:
    try:
        return placer.sample(rng, radius, area)
    except PlacementError as err:
        raise SpecError(path, f"no room to place every {what}: {err}") from None
