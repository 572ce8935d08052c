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
from flatland_ma.scenario.errors import SpecError
from flatland_ma.scenario.factory import (
    make_arena_walls,
    make_door,
    make_item,
    make_obstacle,
    make_walls,
)
from flatland_ma.scenario.scatter import scatter_obstacles
from flatland_ma.scenario.schema import ScenarioSpec
from flatland_ma.sensors.camera import Camera
from flatland_ma.sensors.suite import Sensors
from flatland_ma.tasks.task import Task
from flatland_ma.world.entities import Door, Wall
from flatland_ma.world.navigation import NavGrid
from flatland_ma.world.placement import PlacementError, Placer
from flatland_ma.world.world import World

LAYOUT_TRIES = 20
"""Fresh draws of a generated layout before giving up on one that cannot be built."""


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
class LayoutCache:
    """The static layout of a scenario whose layout does not change between episodes."""

    seeds: dict = field(default_factory=dict)


def build(
    spec: ScenarioSpec,
    rng: np.random.Generator,
    cameras: list[Camera],
    cache: LayoutCache | None = None,
) -> Episode:
    fixed = not spec.layout.per_episode or not spec.layout.generators
    layout_rng = np.random.default_rng(spec.layout.seed) if fixed else rng
    for attempt in range(1 if fixed else LAYOUT_TRIES):
        try:
            world, doors, grid = _static_world(spec, layout_rng)
            break
        except SpecError:
            if fixed or attempt == LAYOUT_TRIES - 1:
                raise
    start = np.zeros_like(grid.blocked)
    for i in range(spec.n_agents):
        start |= grid.cells_in(spec.spawn_of(i).area)
    reachable = grid.reachable(start)
    placer = Placer(world, grid, reachable)

    bodies, eyes, hands = [], [], []
    reach = footprint(spec.agent)
    for i in range(spec.n_agents):
        spawn, team = spec.spawn_of(i), spec.team_of(i)
        x, y = _place(placer, rng, reach, spawn.area, ("n_agents",), "agent")
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
            for k, (x, y) in enumerate(item_spec.positions):
                if not reachable[grid.cell_of(x, y)]:
                    raise SpecError(("items", g, "positions", k), "agents cannot reach this place")
                world.add(make_item(item_spec, g, x, y, home=(x, y)))
            continue
        for _ in range(item_spec.count):
            path = ("items", g, "spawn" if item_spec.spawn is not None else "count")
            x, y = _place(placer, rng, item_spec.radius, item_spec.spawn, path, "item")
            world.add(make_item(item_spec, g, x, y))

    sensors = Sensors(world, eyes, cameras)
    grasps = Hands(world.space, hands)
    task = Task(spec, world, sensors.geometry, bodies, doors, placer, rng, grasps)
    return Episode(world, bodies, sensors, task, grid, placer, grasps, doors, eyes)


def footprint(agent) -> float:
    """Radius of the disc an agent with its parts needs to start in."""
    reach = agent.radius
    if agent.head is not None:
        reach = max(reach, agent.head.offset + agent.head.radius)
    for arm in agent.arms:
        tip = sum(s.length for s in arm.segments) + (arm.grasper.radius if arm.grasper else 0.0)
        reach = max(reach, agent.radius + tip)
    return reach


def _static_world(
    spec: ScenarioSpec, rng: np.random.Generator
) -> tuple[World, list[Door], NavGrid]:
    """The walls, doors and obstacles of one layout, with the grid of where agents fit."""
    world = World(spec.physics, spec.arena.size)
    world.add(make_arena_walls(spec.arena))
    parts = [layouts.explicit_layout(spec)]
    for index, gen in enumerate(spec.layout.generators):
        if gen.generator == "grid_rooms":
            parts.append(layouts.grid_rooms(gen, spec, rng, index))
        elif gen.generator == "maze":
            parts.append(layouts.maze(gen, spec, rng, index))
    for wall in make_walls([p for part in parts for p in part.walls], world.space.static_body):
        world.add(wall)
    doors = [world.add(make_door(piece, world.space)) for part in parts for piece in part.doors]
    for i, obstacle in enumerate(spec.obstacles):
        entity = make_obstacle(obstacle, world.space)
        for shape in entity.shapes:
            shape.cache_bb()
            for hit in world.space.shape_query(shape):
                other = world.entity_of_shape[hit.shape]
                what = (
                    "a wall"
                    if isinstance(other, Wall)
                    else "a door"
                    if isinstance(other, Door)
                    else "another obstacle"
                )
                raise SpecError(("obstacles", i), f"overlaps {what}")
        world.add(entity)

    grid = NavGrid(spec.arena.size, spec.agent.radius)
    for entity in world.entities:
        if entity.blocks_paths:
            for shape in entity.shapes:
                grid.block_shape(shape)
    start = grid.cells_in(spec.agent.spawn.area)
    for index, gen in enumerate(spec.layout.generators):
        if gen.generator == "random_obstacles":
            path = ("layout", "generators", index)
            grid = scatter_obstacles(gen, world, grid, start, rng, path)
    if not (start & ~grid.blocked).any():
        where = ("agent", "spawn", "area") if spec.agent.spawn.area else ("arena", "size")
        raise SpecError(where, "no free place where agents could start")
    return world, doors, grid


def check_layout(spec: ScenarioSpec) -> None:
    """Build once with a fixed seed: raise ``SpecError`` if the layout is impossible."""
    cameras = [Camera(spec.agent.camera) for _ in range(spec.n_agents)]
    build(spec, np.random.default_rng(0), cameras)


def _place(placer: Placer, rng, radius, area, path, what) -> tuple[float, float]:
    try:
        return placer.sample(rng, radius, area)
    except PlacementError as err:
        raise SpecError(path, f"no room to place every {what}: {err}") from None
