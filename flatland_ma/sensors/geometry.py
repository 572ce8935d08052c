"""The geometry snapshot: the world's visible shapes as flat arrays for the ray kernel.

Packed once per reset from the world's entities by ``scene.pack_scene``. Shapes of moving
bodies are kept in body coordinates with the index of their body's row in ``pose``;
``refresh_poses`` reads the poses from pymunk each step (``body_poses.Poses``, as the
batched env reads every world's at once). Static shapes are kept in world coordinates;
``update_entity`` repacks one when it is moved or hidden.
"""

from __future__ import annotations

import numpy as np
import pymunk

from flatland_ma.sensors.body_poses import ONE, Poses, poses_of_world
from flatland_ma.sensors.scene import Point, pack_scene, polygon_edges
from flatland_ma.sensors.textures import KINDS
from flatland_ma.world.entities import Entity
from flatland_ma.world.world import World


class Geometry:
    """``pose`` (B, 3) float64: x, y, angle of each moving body; ``shapes``, ``grid`` and
    ``looks``: the kernel's named tuples (see ``scene.py``); ``body_row``: entity index to
    its row in ``pose``, for moving entities."""

    def __init__(self, world: World):
        entities = world.entities
        moving = [e for e in entities if e.moving]
        self.bodies = [e.body for e in moving]
        slot = {e.index: i for i, e in enumerate(moving)}
        self.pose = np.zeros((len(moving), 3), np.float64)

        polygons, circles = [], []
        n_seg = 0
        self._rows: dict[int, tuple[range, range]] = {}
        for entity in entities:
            body_row = slot.get(entity.index, -1)
            first_seg, first_circ = n_seg, len(circles)
            for shape in entity.shapes:
                corners, circle, angle = _outline(shape, local=body_row >= 0)
                if corners is not None:
                    polygons.append((corners, body_row, entity.index))
                    n_seg += len(corners)
                elif circle is not None:
                    circles.append((circle, angle, body_row, entity.index))
            self._rows[entity.index] = (range(first_seg, n_seg), range(first_circ, len(circles)))

        colors, textures = zip(*[_look(e) for e in entities]) if entities else ((), ())
        self.shapes, self.grid, self.looks = pack_scene(
            polygons,
            circles,
            fixed=[e.fixed for e in entities],
            owner=[e.owner for e in entities],
            visible=[e.visible for e in entities],
            colors=colors,
            textures=textures,
        )
        self.entities = entities
        self.body_row = slot
        self._poses: Poses | None = None
        """The reader of ``pose``, made at the first ``refresh_poses`` (a batched env reads
        every world's poses with one of its own instead)."""

    def refresh_poses(self) -> None:
        if self._poses is None:
            self._poses = poses_of_world(self.pose, self.bodies)
        self._poses.read(ONE)

    def update_entity(self, entity: Entity) -> None:
        """Repack a static entity after it moved or was shown or hidden."""
        self.looks.visible[entity.index] = entity.visible
        if entity.index in self.body_row:
            return  # a moving body: its pose is read every step anyway
        seg_rows, circ_rows = self._rows[entity.index]
        segs, circs = [], []
        for shape in entity.shapes:
            corners, circle, _ = _outline(shape, local=False)
            if corners is not None:
                segs += polygon_edges(corners)[0]
            elif circle is not None:
                circs.append(circle)
        shapes = self.shapes
        for i, row in zip(seg_rows, segs):
            shapes.seg_local[i] = shapes.seg_world[i] = row
        for i, row in zip(circ_rows, circs):
            shapes.circ_local[i] = shapes.circ_world[i] = row


def _look(entity: Entity) -> tuple[tuple[float, ...], tuple[int, float, float, float]]:
    """An entity's first and second colour (6 values) and its texture (kind, period, duty,
    seed); a plain colour is kind 0 with both colours the same."""
    texture = entity.texture
    if texture is None or texture.kind == "uniform":
        first = entity.color if texture is None else texture.colors[0]
        return (*first, *first), (0, 0.0, 0.0, 0.0)
    colors = (*texture.colors[0], *texture.colors[1])
    return colors, (KINDS[texture.kind], texture.period, texture.duty, texture.seed)


def _outline(shape: pymunk.Shape, local: bool):
    """(polygon corners, circle, texture start angle) of a shape, in its body's frame if
    ``local``, else in the world's.

    A convex polygon gives its corners counter-clockwise (circle None); a circle gives
    (x, y, r) and the angle its texture starts from (corners None).
    """
    body = shape.body
    assert body is not None, "a shape on no body"
    at_origin = body.body_type == pymunk.Body.STATIC and body.position == (0, 0) and body.angle == 0
    to_world = (lambda p: p) if local or at_origin else body.local_to_world
    if isinstance(shape, pymunk.Circle):
        x, y = to_world(shape.offset)
        return None, (x, y, shape.radius), (0.0 if local else body.angle)
    if isinstance(shape, pymunk.Poly):
        corners: list[Point] = [(p[0], p[1]) for p in map(to_world, shape.get_vertices())]
        return corners, None, None
    raise TypeError(f"shape {type(shape).__name__} cannot be seen by cameras")
