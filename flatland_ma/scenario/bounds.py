"""Where things lie and whether they fit: everything inside the arena, room openings inside
their sides, agents, items and maze cells big enough for what must pass, fixed items apart.

Solid geometry (walls, corridors, doors) may reach into the arena's boundary walls, which
lie outside the playing area ``[0, width] x [0, height]``, one wall thickness deep; a wall
drawn from one side of the arena to the other ends on them. Nothing may lie beyond them.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from flatland_ma.scenario.budget import maze_size
from flatland_ma.scenario.errors import KeyPath, SpecError, format_path

if TYPE_CHECKING:
    from flatland_ma.scenario.spec_objects import Obstacle
    from flatland_ma.scenario.spec_scenario import ScenarioFields


def check_bounds(spec: ScenarioFields) -> None:
    """Raise ``SpecError`` at the first thing that lies outside the arena or cannot fit."""
    _check_areas(spec)
    _check_geometry(spec)
    _check_openings(spec)
    _check_fit(spec)
    _check_mazes(spec)
    _check_grid_rooms(spec)
    _check_fixed_items(spec)


def _check_areas(spec: ScenarioFields) -> None:
    width, height = spec.arena.size

    def inside(x0: float, y0: float, x1: float, y1: float) -> bool:
        return x0 >= 0 and y0 >= 0 and x1 <= width and y1 <= height

    where = f"outside the {width:g} x {height:g} arena"
    for i, obstacle in enumerate(spec.obstacles):
        if not inside(*obstacle_bounds(obstacle)):
            raise SpecError(("obstacles", i, "position"), f"obstacle reaches {where}")
    for i, zone in enumerate(spec.zones):
        if zone.rect is not None and not inside(*zone.rect):
            raise SpecError(("zones", i, "rect"), f"zone lies {where}")
        if zone.area is not None and not inside(*zone.area):
            raise SpecError(("zones", i, "area"), f"zone area lies {where}")
        if zone.size is not None:
            x0, y0, x1, y1 = zone.area or (0, 0, width, height)
            if zone.size[0] > x1 - x0 or zone.size[1] > y1 - y0:
                raise SpecError(("zones", i, "size"), "zone is larger than its area")
    for i, room in enumerate(spec.rooms):
        if not inside(*room.rect):
            raise SpecError(("rooms", i, "rect"), f"room lies {where}")
    for i, item in enumerate(spec.items):
        if item.spawn is not None and not inside(*item.spawn):
            raise SpecError(("items", i, "spawn"), f"spawn area lies {where}")
        for k, (x, y) in enumerate(item.positions or ()):
            if not inside(x - item.radius, y - item.radius, x + item.radius, y + item.radius):
                raise SpecError(("items", i, "positions", k), f"item lies {where}")
    for path, agent, _ in spec.agent_kinds():
        if agent.spawn.area is not None and not inside(*agent.spawn.area):
            raise SpecError(path + ("spawn", "area"), f"spawn area lies {where}")
    for i, team in enumerate(spec.teams):
        if team.spawn is not None and team.spawn.area is not None and not inside(*team.spawn.area):
            raise SpecError(("teams", i, "spawn", "area"), f"spawn area lies {where}")


def _check_geometry(spec: ScenarioFields) -> None:
    """Walls, corridors and doors lie in the arena (ends may reach into its boundary walls)."""
    width, height = spec.arena.size
    margin = spec.arena.wall.thickness

    def check(path: KeyPath, x: float, y: float, what: str) -> None:
        if not (-margin <= x <= width + margin and -margin <= y <= height + margin):
            raise SpecError(
                path,
                f"{what} ({x:g}, {y:g}) lies outside the {width:g} x {height:g} arena and "
                f"its boundary walls ({margin:g} thick)",
            )

    for i, wall in enumerate(spec.walls):
        check(("walls", i, "start"), *wall.start, "the wall's start")
        check(("walls", i, "end"), *wall.end, "the wall's end")
    for i, door in enumerate(spec.doors):
        if door.start is not None and door.end is not None:  # both or neither
            check(("doors", i, "start"), *door.start, "the door's start")
            check(("doors", i, "end"), *door.end, "the door's end")
    for i, corridor in enumerate(spec.corridors):
        check(("corridors", i, "start"), *corridor.start, "the corridor's start")
        check(("corridors", i, "end"), *corridor.end, "the corridor's end")
        (xa, ya), (_, yb) = corridor.start, corridor.end
        h = corridor.width / 2
        sides = [(xa, ya - h), (xa, ya + h)] if ya == yb else [(xa - h, ya), (xa + h, ya)]
        for x, y in sides:
            check(("corridors", i, "width"), x, y, "the corridor's side wall at")


def _check_openings(spec: ScenarioFields) -> None:
    for r, room in enumerate(spec.rooms):
        x0, y0, x1, y1 = room.rect
        for o, opening in enumerate(room.openings):
            side = x1 - x0 if opening.side in ("north", "south") else y1 - y0
            centre = opening.offset if opening.offset is not None else side / 2
            lo, hi = centre - opening.width / 2, centre + opening.width / 2
            if lo < 0 or hi > side:
                key = "offset" if opening.offset is not None else "width"
                raise SpecError(
                    ("rooms", r, "openings", o, key),
                    f"the gap from {lo:g} to {hi:g} along the {opening.side} side does not "
                    f"fit in the side, {side:g} long",
                )


def _check_fit(spec: ScenarioFields) -> None:
    """An agent's base and every item must fit in the arena (an agent with its parts is
    checked when the parts are known: ``build.feasibility``)."""
    width, height = spec.arena.size
    room = min(width, height)
    for path, agent, _ in spec.agent_kinds():
        if 2 * agent.radius >= room:
            raise SpecError(
                path + ("radius",),
                f"agents of radius {agent.radius:g} do not fit in the {width:g} x {height:g} arena",
            )
    for g, item in enumerate(spec.items):
        if 2 * item.radius >= room:
            raise SpecError(
                ("items", g, "radius"),
                f"items of radius {item.radius:g} do not fit in the {width:g} x {height:g} arena",
            )


def _check_mazes(spec: ScenarioFields) -> None:
    width, height = spec.arena.size
    for index, gen in enumerate(spec.layout.generators):
        if gen.generator != "maze":
            continue
        path = ("layout", "generators", index, "cell")
        cols, rows = maze_size(spec, gen.cell)  # at most MAX_GENERATOR_CELLS (budget)
        if cols * rows == 1:
            continue  # no inner walls
        thickness = gen.thickness if gen.thickness is not None else spec.arena.wall.thickness
        passage = min(width / cols, height / rows) - thickness
        widest = max(2 * agent.radius for _, agent, _ in spec.agent_kinds())
        if passage <= widest:
            raise SpecError(
                path,
                f"maze cells of {gen.cell:g} leave passages {passage:.3g} wide between walls "
                f"{thickness:g} thick: agents {widest:g} across cannot pass",
            )


def _check_grid_rooms(spec: ScenarioFields) -> None:
    """The opening in each shared wall of a grid of rooms fits in the wall, with wall on
    both sides of it."""
    width, height = spec.arena.size
    for index, gen in enumerate(spec.layout.generators):
        if gen.generator != "grid_rooms":
            continue
        thickness = gen.thickness if gen.thickness is not None else spec.arena.wall.thickness
        side = min(width / gen.cols, height / gen.rows)
        if gen.door_width + 2 * thickness > side:
            raise SpecError(
                ("layout", "generators", index, "door_width"),
                f"openings {gen.door_width:g} wide do not fit in walls {side:.3g} long between "
                f"rooms (with {thickness:g} of wall on each side)",
            )


def _check_fixed_items(spec: ScenarioFields) -> None:
    """No two items at fixed places overlap (binned by place, so many items stay fast)."""
    placed = [
        (x, y, item.radius, ("items", g, "positions", k))
        for g, item in enumerate(spec.items)
        for k, (x, y) in enumerate(item.positions or ())
    ]
    if len(placed) < 2:
        return
    cell = 2 * max(r for _, _, r, _ in placed)
    bins: dict[tuple[int, int], list[tuple[float, float, float, KeyPath]]] = {}
    for x, y, r, path in placed:
        bx, by = math.floor(x / cell), math.floor(y / cell)
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for ox, oy, other_r, other in bins.get((bx + dx, by + dy), ()):
                    if math.hypot(x - ox, y - oy) < r + other_r:
                        raise SpecError(path, f"overlaps the item at {format_path(other)}")
        bins.setdefault((bx, by), []).append((x, y, r, path))


def obstacle_bounds(obstacle: Obstacle) -> tuple[float, float, float, float]:
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
