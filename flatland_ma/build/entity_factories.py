"""Scenario pieces made physical: pymunk bodies and shapes wrapped in entities, and zones.

The one place where the file format's looks, doors, obstacles, items and zones become the
world's runtime values.
"""

from __future__ import annotations

import math

import pymunk

from flatland_ma.build.layout import DoorPiece, WallPiece
from flatland_ma.scenario.schema import ArenaSpec, ItemSpec, TextureSpec, ZoneSpec
from flatland_ma.world.entities import (
    Category,
    CollisionType,
    Door,
    HingedDoor,
    Item,
    ItemGroup,
    Obstacle,
    Rect,
    SlidingDoor,
    Wall,
    Zone,
    shape_filter,
)
from flatland_ma.world.looks import Texture

FLOOR_GRAVITY = 1000.0
"""Units per second squared: turns ``floor_friction`` into a sliding resistance force."""
WALL_FRICTION = 0.5
HINGE_FRICTION = 2000.0
"""Torque that resists a hinged door's swing (so it stays where it was pushed)."""


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
    shapes = tuple(_wall_shape(pymunk.Poly(body, corners)) for corners in boxes)
    return Wall(body=body, shapes=shapes, color=arena.wall.color, texture=look(arena.wall.texture))


def look(texture: TextureSpec | None) -> Texture | None:
    """A texture spec as the world's runtime texture."""
    if texture is None:
        return None
    return Texture(texture.kind, texture.colors, texture.period, texture.duty, texture.seed)


def _wall_shape(shape: pymunk.Shape) -> pymunk.Shape:
    shape.collision_type = CollisionType.WALL
    shape.filter = shape_filter(Category.WALL)
    shape.friction = WALL_FRICTION
    return shape


def _panel(start, end, thickness) -> tuple[tuple[float, float], float, list]:
    """A box along ``start``-``end``: (position of start, angle, vertices around start)."""
    (x0, y0), (x1, y1) = start, end
    length = math.hypot(x1 - x0, y1 - y0)
    angle = math.atan2(y1 - y0, x1 - x0)
    h = thickness / 2
    return (x0, y0), angle, [(0.0, -h), (length, -h), (length, h), (0.0, h)]


def wall_corners(piece: WallPiece) -> list[tuple[float, float]]:
    """The four corners of a wall piece's box in world coordinates, counter-clockwise."""
    (x0, y0), (x1, y1) = piece.start, piece.end
    length = math.hypot(x1 - x0, y1 - y0)
    ux, uy = (x1 - x0) / length, (y1 - y0) / length
    nx, ny = -uy * piece.thickness / 2, ux * piece.thickness / 2
    return [(x0 - nx, y0 - ny), (x1 - nx, y1 - ny), (x1 + nx, y1 + ny), (x0 + nx, y0 + ny)]


def make_walls(
    pieces: list[WallPiece], static_body: pymunk.Body
) -> tuple[list[Wall], dict[pymunk.Shape, tuple]]:
    """One wall entity per look (colour and texture), its boxes on the space's static body;
    and the key path of the scenario entry each box comes from."""
    looks: dict = {}
    for piece in pieces:
        key = (piece.color, None if piece.texture is None else piece.texture.model_dump_json())
        looks.setdefault(key, []).append(piece)
    walls, paths = [], {}
    for group in looks.values():
        shapes = tuple(_wall_shape(pymunk.Poly(static_body, wall_corners(p))) for p in group)
        paths.update((shape, p.path) for shape, p in zip(shapes, group))
        walls.append(
            Wall(
                body=static_body,
                shapes=shapes,
                color=group[0].color,
                texture=look(group[0].texture),
            )
        )
    return walls, paths


def _hinged(piece: DoorPiece, space: pymunk.Space) -> Door:
    spec = piece.spec
    position, angle, verts = _panel(piece.start, piece.end, piece.thickness)
    # A little short of the gap, so it swings free of the walls at both ends.
    length = verts[1][0] - 1.0
    h = piece.thickness * 0.4
    verts = [(0.5, -h), (length, -h), (length, h), (0.5, h)]
    body = pymunk.Body(spec.mass, pymunk.moment_for_poly(spec.mass, verts))
    body.position, body.angle = position, angle
    hinge = pymunk.PivotJoint(space.static_body, body, position)
    swing = math.radians(spec.swing)
    limit = pymunk.RotaryLimitJoint(space.static_body, body, angle - swing, angle + swing)
    friction = pymunk.GearJoint(space.static_body, body, 0.0, 1.0)
    friction.max_bias = 0.0
    friction.max_force = HINGE_FRICTION
    return HingedDoor(
        **_door_parts(piece, body, verts, angle),
        constraints=(hinge, limit, friction),
        swing=swing,
    )


def _sliding(piece: DoorPiece, space: pymunk.Space) -> Door:
    spec = piece.spec
    position, angle, verts = _panel(piece.start, piece.end, piece.thickness)
    body = pymunk.Body(body_type=pymunk.Body.STATIC)
    body.position, body.angle = position, angle
    return SlidingDoor(
        **_door_parts(piece, body, verts, angle),
        locked=spec.state == "locked",
        opened=spec.state == "open",
        key_name=spec.key,
        switch_zone=spec.switch,
        latching=spec.latch,
    )


def _door_parts(piece: DoorPiece, body: pymunk.Body, verts, angle: float) -> dict:
    shape = pymunk.Poly(body, verts)
    shape.collision_type = CollisionType.DOOR
    # Doors pass through walls: a hinged panel must swing free of the wall it sits in.
    shape.filter = shape_filter(Category.DOOR, ignores=Category.WALL)
    shape.friction = WALL_FRICTION
    spec = piece.spec
    return dict(
        body=body,
        shapes=(shape,),
        color=spec.color,
        texture=look(spec.texture),
        name=spec.name,
        path=piece.path,
        closed_angle=angle,
    )


DOOR_KINDS = {"sliding": _sliding, "hinged": _hinged}
"""How each kind of door (``DoorSpec.kind``) is made."""


def make_door(piece: DoorPiece, space: pymunk.Space) -> Door:
    return DOOR_KINDS[piece.spec.kind](piece, space)


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
    shape = pymunk.Circle(body, spec.radius) if vertices is None else pymunk.Poly(body, vertices)
    shape.collision_type = CollisionType.OBSTACLE
    shape.filter = shape_filter(Category.OBSTACLE)
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
    return Obstacle(
        body=body,
        shapes=(shape,),
        color=spec.color,
        texture=look(spec.texture),
        constraints=constraints,
        delivery_tag=spec.tag,
        graspable=spec.graspable,
        key_name=spec.key,
        home=(*spec.position, math.radians(spec.angle)),
    )


def item_group(spec: ItemSpec, index: int) -> ItemGroup:
    """What the items of ``spec`` (the scenario's ``items[index]``) do."""
    respawn = {"immediate": 0, "never": None}.get(spec.respawn, spec.respawn)  # type: ignore[arg-type]
    return ItemGroup(
        name=spec.name,
        index=index,
        reward=spec.reward,
        radius=spec.radius,
        respawn=respawn,
        spawn=spec.spawn,
        terminal=spec.terminal,
        shared=spec.shared,
        key=spec.key,
    )


def make_item(
    spec: ItemSpec, group: ItemGroup, x: float, y: float, home=None, reuse: Item | None = None
) -> Item:
    """An item of ``spec`` at (x, y); ``reuse`` made again when given (an item of the same
    spec from the last episode, out of the space: a reset in place makes no new objects
    for items, so leaves none to the garbage collector)."""
    if reuse is None:
        body = pymunk.Body(body_type=pymunk.Body.STATIC)
        body.position = (x, y)
        shape = pymunk.Circle(body, spec.radius)
        shape.sensor = True
        shape.collision_type = CollisionType.ITEM
        shape.filter = shape_filter(Category.ITEM)
        return Item(
            body=body,
            shapes=(shape,),
            color=spec.color,
            texture=look(spec.texture),
            group=group,
            home=home,
        )
    reuse.body.position = (x, y)
    # Made again in place: every field as a new item's, no new object for the collector.
    Item.__init__(
        reuse,
        body=reuse.body,
        shapes=reuse.shapes,
        color=spec.color,
        texture=look(spec.texture),
        group=group,
        home=home,
    )
    return reuse


def make_zone(spec: ZoneSpec, rect: Rect) -> Zone:
    """A zone of ``spec`` over ``rect`` (its own, or one drawn at random)."""
    return Zone(
        rect=tuple(float(v) for v in rect),  # type: ignore[arg-type]
        name=spec.name,
        reward=spec.reward,
        once=spec.once,
        terminal=spec.terminal,
        teleport=spec.teleport,
        color=spec.color,
        team=spec.team,
        accepts=spec.accepts,
        delivery_reward=spec.delivery_reward,
        zero_sum=spec.zero_sum,
        end_on_delivery=spec.end_on_delivery,
    )
