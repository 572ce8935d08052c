"""Building an episode from a validated scenario and the env's random generator.

``build`` is the only place where scenario specs become pymunk objects. Everything random
(spawn positions and headings) is drawn from the generator it is given, in a fixed order:
agents first, then items group by group.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pymunk

from flatland_ma.agents.body import AgentBody, make_agent_body
from flatland_ma.scenario.errors import SpecError
from flatland_ma.scenario.schema import ArenaSpec, ItemSpec, ScenarioSpec
from flatland_ma.sensors.camera import Camera
from flatland_ma.sensors.suite import Sensors
from flatland_ma.tasks.foraging import ForagingTask
from flatland_ma.world.entities import CollisionType, Item, Obstacle, Wall
from flatland_ma.world.placement import PlacementError, sample_free_position
from flatland_ma.world.world import World

FLOOR_GRAVITY = 1000.0
"""Units per second squared: turns ``floor_friction`` into a sliding resistance force."""


@dataclass
class Episode:
    """What one episode runs on; rebuilt from scratch at every reset."""

    world: World
    bodies: list[AgentBody]
    sensors: Sensors
    task: ForagingTask


def build(spec: ScenarioSpec, rng: np.random.Generator, cameras: list[Camera]) -> Episode:
    world = World(spec.physics, spec.arena.size)
    world.add(make_arena_walls(spec.arena))
    for i, obstacle in enumerate(spec.obstacles):
        entity = make_obstacle(obstacle, world.space)
        for shape in entity.shapes:
            for hit in world.space.shape_query(shape):
                other = world.entity_of_shape[hit.shape]
                what = "the arena wall" if isinstance(other, Wall) else "another obstacle"
                raise SpecError(("obstacles", i), f"overlaps {what}")
        world.add(entity)

    bodies = []
    for i in range(spec.n_agents):
        x, y = _place(world, rng, spec.agent.radius, ("n_agents",), "agent")
        angle = float(rng.uniform(-math.pi, math.pi))
        color = spec.agent.colors[i % len(spec.agent.colors)]
        body = make_agent_body(spec.agent, i, (x, y), angle, color, world.substep_dt)
        bodies.append(world.add(body))

    for g, item_spec in enumerate(spec.items):
        for _ in range(item_spec.count):
            x, y = _place(world, rng, item_spec.radius, ("items", g, "count"), "item")
            world.add(make_item(item_spec, g, x, y))

    sensors = Sensors(world, bodies, cameras)
    task = ForagingTask(spec, world, sensors.geometry)
    return Episode(world, bodies, sensors, task)


def check_layout(spec: ScenarioSpec) -> None:
    """Build once with a fixed seed: raise ``SpecError`` if the layout is impossible."""
    cameras = [Camera(spec.agent.camera) for _ in range(spec.n_agents)]
    build(spec, np.random.default_rng(0), cameras)


def _place(world, rng, radius, path, what) -> tuple[float, float]:
    try:
        return sample_free_position(world, rng, radius)
    except PlacementError as err:
        raise SpecError(path, f"no room to place every {what}: {err}") from None


def make_arena_walls(arena: ArenaSpec) -> Wall:
    """Four boxes around the playing area [0, width] x [0, height], outside it."""
    w, h = arena.size
    t = arena.wall.thickness
    body = pymunk.Body(body_type=pymunk.Body.STATIC)
    boxes = [
        [(-t, -t), (w + t, -t), (w + t, 0), (-t, 0)],
        [(-t, h), (w + t, h), (w + t, h + t), (-t, h + t)],
        [(-t, 0), (0, 0), (0, h), (-t, h)],
        [(w, 0), (w + t, 0), (w + t, h), (w, h)],
    ]
    shapes = []
    for corners in boxes:
        shape = pymunk.Poly(body, corners)
        shape.collision_type = CollisionType.WALL
        shape.friction = 0.5
        shapes.append(shape)
    return Wall(body=body, shapes=tuple(shapes), color=arena.wall.color)


def make_obstacle(spec, space: pymunk.Space) -> Obstacle:
    vertices = spec.local_vertices()
    if spec.movable:
        if vertices is None:
            moment = pymunk.moment_for_circle(spec.mass, 0.0, spec.radius)
        else:
            moment = pymunk.moment_for_poly(spec.mass, vertices)
        body = pymunk.Body(spec.mass, moment)
    else:
        body = pymunk.Body(body_type=pymunk.Body.STATIC)
    body.position = spec.position
    body.angle = math.radians(spec.angle)
    if vertices is None:
        shape = pymunk.Circle(body, spec.radius)
    else:
        shape = pymunk.Poly(body, vertices)
    shape.collision_type = CollisionType.OBSTACLE
    shape.friction = spec.friction
    shape.elasticity = spec.elasticity
    constraints = ()
    if spec.movable and spec.floor_friction > 0:
        force = spec.floor_friction * spec.mass * FLOOR_GRAVITY
        slide = pymunk.PivotJoint(space.static_body, body, (0.0, 0.0), (0.0, 0.0))
        spin = pymunk.GearJoint(space.static_body, body, 0.0, 1.0)
        slide.max_bias = spin.max_bias = 0.0
        slide.max_force = force
        spin.max_force = force * spec.bounding_radius() * 0.5
        constraints = (slide, spin)
    return Obstacle(body=body, shapes=(shape,), color=spec.color, constraints=constraints)


def make_item(spec: ItemSpec, group: int, x: float, y: float) -> Item:
    body = pymunk.Body(body_type=pymunk.Body.STATIC)
    body.position = (x, y)
    shape = pymunk.Circle(body, spec.radius)
    shape.sensor = True
    shape.collision_type = CollisionType.ITEM
    return Item(
        body=body,
        shapes=(shape,),
        color=spec.color,
        group=group,
        reward=spec.reward,
        radius=spec.radius,
    )
