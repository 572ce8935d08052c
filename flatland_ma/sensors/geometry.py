"""The geometry snapshot: the world's visible shapes as flat arrays for the ray kernel.

Packed once per reset from the world's entities. Shapes of moving bodies are kept in body
coordinates with the index of their body's row in ``pose``; ``refresh_poses`` reads the
poses from pymunk each step (the one Python loop over moving bodies). Static shapes are
kept in world coordinates; ``update_entity`` repacks one when it is moved or hidden.
"""

from __future__ import annotations

import numpy as np
import pymunk

from flatland_ma.world.entities import Entity
from flatland_ma.world.world import World


class Geometry:
    def __init__(self, world: World):
        entities = world.entities
        moving = [e for e in entities if e.moving]
        self.bodies = [e.body for e in moving]
        slot = {e.index: i for i, e in enumerate(moving)}
        self.pose = np.zeros((len(moving), 3), np.float64)

        segs, seg_body, seg_entity = [], [], []
        circs, circ_body, circ_entity = [], [], []
        self._rows: dict[int, tuple[list[int], list[int]]] = {}
        for entity in entities:
            body_row = slot.get(entity.index, -1)
            seg_rows, circ_rows = [], []
            for shape in entity.shapes:
                for row in _shape_rows(shape, entity, local=body_row >= 0):
                    if len(row) == 4:
                        seg_rows.append(len(segs))
                        segs.append(row)
                        seg_body.append(body_row)
                        seg_entity.append(entity.index)
                    else:
                        circ_rows.append(len(circs))
                        circs.append(row)
                        circ_body.append(body_row)
                        circ_entity.append(entity.index)
            self._rows[entity.index] = (seg_rows, circ_rows)

        self.seg_local = np.array(segs, np.float64).reshape(-1, 4)
        self.seg_world = self.seg_local.copy()
        self.seg_body = np.array(seg_body, np.int32)
        self.seg_entity = np.array(seg_entity, np.int32)
        self.circ_local = np.array(circs, np.float64).reshape(-1, 3)
        self.circ_world = self.circ_local.copy()
        self.circ_body = np.array(circ_body, np.int32)
        self.circ_entity = np.array(circ_entity, np.int32)
        self.ent_owner = np.array([e.owner for e in entities], np.int32)
        self.ent_visible = np.array([e.visible for e in entities], np.bool_)
        self.ent_color = np.array([e.color for e in entities], np.float32).reshape(-1, 3)
        self.entities = entities
        self.body_row = slot

    def refresh_poses(self) -> None:
        pose = self.pose
        for i, body in enumerate(self.bodies):
            x, y = body.position
            pose[i, 0] = x
            pose[i, 1] = y
            pose[i, 2] = body.angle

    def update_entity(self, entity: Entity) -> None:
        """Repack a static entity after it moved, and its visibility."""
        self.ent_visible[entity.index] = entity.visible
        seg_rows, circ_rows = self._rows[entity.index]
        rows = [r for shape in entity.shapes for r in _shape_rows(shape, entity, local=False)]
        segs = [r for r in rows if len(r) == 4]
        circs = [r for r in rows if len(r) == 3]
        for i, row in zip(seg_rows, segs):
            self.seg_local[i] = self.seg_world[i] = row
        for i, row in zip(circ_rows, circs):
            self.circ_local[i] = self.circ_world[i] = row


def _shape_rows(shape: pymunk.Shape, entity: Entity, local: bool) -> list[tuple]:
    """A circle gives one (x, y, r) row; a convex polygon one (x1, y1, x2, y2) per edge."""
    body = entity.body
    to_world = (lambda p: p) if local else body.local_to_world
    if isinstance(shape, pymunk.Circle):
        x, y = to_world(shape.offset)
        return [(x, y, shape.radius)]
    if isinstance(shape, pymunk.Poly):
        pts = [to_world(v) for v in shape.get_vertices()]
        return [(*pts[i], *pts[(i + 1) % len(pts)]) for i in range(len(pts))]
    raise TypeError(f"shape {type(shape).__name__} cannot be seen by cameras")
