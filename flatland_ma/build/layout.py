"""Layouts as plain geometry: wall pieces and door pieces, before anything is physical.

Explicit walls, rooms and corridors become wall pieces (boxes along a centre line); room
openings and corridor ends carve gaps out of every axis-parallel wall they cross; pieces
that line up are merged. The ``grid_rooms`` and ``maze`` generators (``generators.py``)
add their own pieces, drawn from a random generator; ``ground.py`` makes them physical.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, replace

import numpy as np

from flatland_ma.scenario.schema import DoorSpec, RoomSpec, ScenarioSpec, TextureSpec
from flatland_ma.scenario.types import Spec

Point = tuple[float, float]
RGB = tuple[float, float, float]


@dataclass(frozen=True)
class WallPiece:
    """A solid box whose centre line runs from ``start`` to ``end`` (its full extent):
    ``WallPiece(start, end, thickness, color, texture, path)``, points in arena units,
    ``color`` an (r, g, b) triple of 0..1 floats, ``texture`` None (plain) or a
    ``TextureSpec``. A generator passes its own ``path`` (``Generator.path``)."""

    start: Point
    end: Point
    thickness: float
    color: RGB
    texture: TextureSpec | None
    path: tuple
    """Key path of the scenario entry it comes from, for error messages."""

    @property
    def horizontal(self) -> bool:
        return self.start[1] == self.end[1]

    @property
    def vertical(self) -> bool:
        return self.start[0] == self.end[0]


@dataclass(frozen=True)
class DoorPiece:
    """A door across a gap, from ``start`` to ``end`` (arena units), ``thickness`` wide,
    of the kind its ``spec`` (``scenario.schema.DoorSpec``) says; ``path``: the key path
    of the scenario entry it comes from."""

    start: Point
    """The hinge end, for hinged doors."""
    end: Point
    thickness: float
    spec: DoorSpec
    path: tuple


@dataclass(frozen=True)
class Carve:
    """A rectangle that removes the parts of axis-parallel walls whose centre line
    crosses its inside."""

    x0: float
    y0: float
    x1: float
    y1: float


@dataclass
class Layout:
    """Wall and door pieces for a ``Ground`` (``ground.add(Layout(walls, doors))``)."""

    walls: list[WallPiece]
    doors: list[DoorPiece]


def style(part, spec: ScenarioSpec) -> tuple[float, RGB, TextureSpec | None]:
    wall = spec.arena.wall
    return (
        part.thickness if part.thickness is not None else wall.thickness,
        part.color if part.color is not None else wall.color,
        part.texture if part.texture is not None else wall.texture,
    )


def explicit_layout(spec: ScenarioSpec) -> Layout:
    """Walls, rooms, corridors and doors written in the scenario, carved and merged."""
    walls: list[WallPiece] = []
    doors: list[DoorPiece] = []
    carves: list[Carve] = []
    for i, wall in enumerate(spec.walls):
        t, color, texture = style(wall, spec)
        start, end = _extend(wall.start, wall.end, t / 2)
        walls.append(WallPiece(start, end, t, color, texture, ("walls", i)))
    for r, room in enumerate(spec.rooms):
        t, color, texture = style(room, spec)
        walls += _room_walls(room, t, color, texture, ("rooms", r))
        for o, opening in enumerate(room.openings):
            start, end, gap = _opening(room, opening, t)
            carves.append(gap)
            if opening.door is not None:
                door_t = opening.door.thickness or t
                path = ("rooms", r, "openings", o, "door")
                doors.append(DoorPiece(start, end, door_t, opening.door, path))
    for c, corridor in enumerate(spec.corridors):
        t, color, texture = style(corridor, spec)
        walls += _corridor_walls(corridor, t, color, texture, ("corridors", c))
        carves.append(_corridor_carve(corridor, t))
    for d, door in enumerate(spec.doors):
        t = door.thickness or spec.arena.wall.thickness
        assert door.start is not None and door.end is not None  # checked by the schema
        doors.append(DoorPiece(door.start, door.end, t, door, ("doors", d)))
        carves += _door_carve(door.start, door.end, t)
    return Layout(merge(carve(walls, carves)), doors)


def _door_carve(start: Point, end: Point, t: float) -> list[Carve]:
    """A door set along an axis-parallel line opens the walls it lies in."""
    (x0, y0), (x1, y1) = start, end
    if y0 == y1:
        return [Carve(min(x0, x1), y0 - t, max(x0, x1), y0 + t)]
    if x0 == x1:
        return [Carve(x0 - t, min(y0, y1), x0 + t, max(y0, y1))]
    return []


def _extend(start: Point, end: Point, by: float) -> tuple[Point, Point]:
    (x0, y0), (x1, y1) = start, end
    length = float(np.hypot(x1 - x0, y1 - y0))
    ux, uy = (x1 - x0) / length, (y1 - y0) / length
    return (x0 - ux * by, y0 - uy * by), (x1 + ux * by, y1 + uy * by)


def _room_walls(room: RoomSpec, t, color, texture, path) -> list[WallPiece]:
    x0, y0, x1, y1 = room.rect
    h = t / 2
    sides = [
        ((x0 - h, y0), (x1 + h, y0)),
        ((x0 - h, y1), (x1 + h, y1)),
        ((x0, y0 - h), (x0, y1 + h)),
        ((x1, y0 - h), (x1, y1 + h)),
    ]
    return [WallPiece(a, b, t, color, texture, path) for a, b in sides]


def _opening(room: RoomSpec, opening, t) -> tuple[Point, Point, Carve]:
    """The gap's door line (start, end) and the carve that makes the gap."""
    x0, y0, x1, y1 = room.rect
    w = opening.width
    if opening.side in ("south", "north"):
        y = y0 if opening.side == "south" else y1
        c = x0 + (opening.offset if opening.offset is not None else (x1 - x0) / 2)
        return (c - w / 2, y), (c + w / 2, y), Carve(c - w / 2, y - t, c + w / 2, y + t)
    x = x0 if opening.side == "west" else x1
    c = y0 + (opening.offset if opening.offset is not None else (y1 - y0) / 2)
    return (x, c - w / 2), (x, c + w / 2), Carve(x - t, c - w / 2, x + t, c + w / 2)


def _corridor_walls(corridor, t, color, texture, path) -> list[WallPiece]:
    (xa, ya), (xb, yb) = corridor.start, corridor.end
    h = corridor.width / 2
    if ya == yb:
        lo, hi = min(xa, xb), max(xa, xb)
        sides = [((lo, ya - h), (hi, ya - h)), ((lo, ya + h), (hi, ya + h))]
    else:
        lo, hi = min(ya, yb), max(ya, yb)
        sides = [((xa - h, lo), (xa - h, hi)), ((xa + h, lo), (xa + h, hi))]
    return [WallPiece(a, b, t, color, texture, path) for a, b in sides]


def _corridor_carve(corridor, t) -> Carve:
    (xa, ya), (xb, yb) = corridor.start, corridor.end
    h = corridor.width / 2
    if ya == yb:
        return Carve(min(xa, xb) - t, ya - h, max(xa, xb) + t, ya + h)
    return Carve(xa - h, min(ya, yb) - t, xa + h, max(ya, yb) + t)


def carve(walls: list[WallPiece], carves: list[Carve]) -> list[WallPiece]:
    """Cut every carve out of the axis-parallel walls whose centre line crosses it.

    Walls are filed by their line, so a carve visits only the lines it crosses (thousands
    of rooms' openings cost what they cut, not every wall each); pieces keep their walls'
    order."""
    lines: dict[tuple[int, float], list[tuple[int, WallPiece]]] = {}
    others = []
    for k, w in enumerate(walls):
        if w.horizontal:
            lines.setdefault((0, w.start[1]), []).append((k, w))
        elif w.vertical:
            lines.setdefault((1, w.start[0]), []).append((k, w))
        else:
            others.append((k, w))
    at = {axis: sorted(c for a, c in lines if a == axis) for axis in (0, 1)}
    for c in carves:
        for axis, lo, hi, cut_lo, cut_hi in (
            (0, c.y0, c.y1, c.x0, c.x1),
            (1, c.x0, c.x1, c.y0, c.y1),
        ):
            coords = at[axis]
            for coord in coords[bisect.bisect_right(coords, lo) : bisect.bisect_left(coords, hi)]:
                line = lines[(axis, coord)]
                lines[(axis, coord)] = [
                    (k, piece) for k, w in line for piece in _cut(w, axis, cut_lo, cut_hi)
                ]
    pieces = others + [kw for line in lines.values() for kw in line]
    pieces.sort(key=lambda kw: kw[0])
    return [w for _, w in pieces]


def _cut(w: WallPiece, axis: int, lo: float, hi: float) -> list[WallPiece]:
    a, b = sorted((w.start[axis], w.end[axis]))
    pieces = []
    for p, q in ((a, min(b, lo)), (max(a, hi), b)):
        if q - p > 1e-9:
            start, end = list(w.start), list(w.end)
            start[axis], end[axis] = p, q
            pieces.append(replace(w, start=tuple(start), end=tuple(end)))
    return pieces


def merge(walls: list[WallPiece]) -> list[WallPiece]:
    """Join axis-parallel pieces of one style that lie on one line and touch or overlap."""
    groups: dict[tuple, list[WallPiece]] = {}
    others = []
    for w in walls:
        if w.horizontal or w.vertical:
            axis = 0 if w.horizontal else 1
            line = w.start[1 - axis]
            key = (axis, line, w.thickness, w.color, _texture_key(w.texture))
            groups.setdefault(key, []).append(w)
        else:
            others.append(w)
    merged = []
    for (axis, line, *_), pieces in groups.items():
        spans = sorted(
            ((*sorted((w.start[axis], w.end[axis])), w) for w in pieces), key=lambda s: s[:2]
        )
        current: list | None = None
        for lo, hi, w in spans:
            if current is not None and lo <= current[1] + 1e-9:
                current[1] = max(current[1], hi)
                continue
            if current is not None:
                merged.append(_span(current, axis, line))
            current = [lo, hi, w]
        merged.append(_span(current, axis, line))
    return merged + others


def _span(current, axis, line) -> WallPiece:
    lo, hi, w = current
    if axis == 0:
        return replace(w, start=(lo, line), end=(hi, line))
    return replace(w, start=(line, lo), end=(line, hi))


def _texture_key(texture: Spec | None):
    return None if texture is None else texture.model_dump_json()


def axis_point(axis: int, line: float, along: float) -> Point:
    """A point on an axis-parallel line: ``axis`` 0 runs along x at y = line."""
    return (along, line) if axis == 0 else (line, along)


def axis_piece(axis, line, a, b, t, color, texture, path) -> WallPiece:
    return WallPiece(axis_point(axis, line, a), axis_point(axis, line, b), t, color, texture, path)
