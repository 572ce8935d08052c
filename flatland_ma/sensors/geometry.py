"""The geometry snapshot: the world's visible shapes as flat arrays for the ray kernel.

Packed once per reset from the world's entities. Shapes of moving bodies are kept in body
coordinates with the index of their body's row in ``pose``; ``refresh_poses`` reads the
poses from pymunk each step (the one Python loop over moving bodies). Static shapes are
kept in world coordinates; ``update_entity`` repacks one when it is moved or hidden.
"""

from __future__ import annotations

import math

import numpy as np
import pymunk

from flatland_ma.sensors import kernel
from flatland_ma.sensors.textures import KINDS
from flatland_ma.world.entities import Entity
from flatland_ma.world.world import World


class Geometry:
    def __init__(self, world: World):
        entities = world.entities
        moving = [e for e in entities if e.moving]
        self.bodies = [e.body for e in moving]
        slot = {e.index: i for i, e in enumerate(moving)}
        self.pose = np.zeros((len(moving), 3), np.float64)

        segs, seg_body, seg_entity, seg_u0 = [], [], [], []
        circs, circ_body, circ_entity, circ_angle = [], [], [], []
        self._rows: dict[int, tuple[list[int], list[int]]] = {}
        for entity in entities:
            body_row = slot.get(entity.index, -1)
            seg_rows, circ_rows = [], []
            for shape in entity.shapes:
                rows, u0, angle = _shape_rows(shape, local=body_row >= 0)
                if angle is None:
                    seg_rows += range(len(segs), len(segs) + len(rows))
                    segs += rows
                    seg_u0 += u0
                    seg_body += [body_row] * len(rows)
                    seg_entity += [entity.index] * len(rows)
                else:
                    circ_rows.append(len(circs))
                    circs += rows
                    circ_angle.append(angle)
                    circ_body.append(body_row)
                    circ_entity.append(entity.index)
            self._rows[entity.index] = (seg_rows, circ_rows)

        self.seg_local = np.array(segs, np.float64).reshape(-1, 4)
        self.seg_world = self.seg_local.copy()
        self.seg_body = np.array(seg_body, np.int32)
        self.seg_entity = np.array(seg_entity, np.int32)
        self.seg_u0 = np.array(seg_u0, np.float64)
        self.circ_local = np.array(circs, np.float64).reshape(-1, 3)
        self.circ_world = self.circ_local.copy()
        self.circ_body = np.array(circ_body, np.int32)
        self.circ_entity = np.array(circ_entity, np.int32)
        self.circ_angle = np.array(circ_angle, np.float64)
        fixed = np.array([e.fixed for e in entities], np.bool_)
        seg_fixed = fixed[self.seg_entity] if len(self.seg_entity) else np.zeros(0, np.bool_)
        circ_fixed = fixed[self.circ_entity] if len(self.circ_entity) else np.zeros(0, np.bool_)
        self.loose_seg = np.flatnonzero(~seg_fixed).astype(np.int32)
        self.loose_circ = np.flatnonzero(~circ_fixed).astype(np.int32)
        (
            self.grid,
            self.cell_seg_start,
            self.cell_seg,
            self.cell_circ_start,
            self.cell_circ,
        ) = kernel.bin_fixed_shapes(self.seg_world, seg_fixed, self.circ_world, circ_fixed)
        self.ent_owner = np.array([e.owner for e in entities], np.int32)
        self.ent_visible = np.array([e.visible for e in entities], np.bool_)
        self.ent_colors = np.zeros((len(entities), 6), np.float32)
        self.ent_texture = np.zeros((len(entities), 3), np.float64)
        self.ent_texture_kind = np.zeros(len(entities), np.int32)
        for entity in entities:
            self._pack_look(entity)
        self.entities = entities
        self.body_row = slot

    def _pack_look(self, entity: Entity) -> None:
        i, texture = entity.index, entity.texture
        if texture is None or texture.kind == "uniform":
            first = entity.color if texture is None else texture.colors[0]
            self.ent_colors[i] = (*first, *first)
            return
        self.ent_colors[i] = (*texture.colors[0], *texture.colors[1])
        self.ent_texture[i] = (texture.period, texture.duty, texture.seed)
        self.ent_texture_kind[i] = KINDS[texture.kind]

    def refresh_poses(self) -> None:
        if self.bodies:  # one assignment: numpy's per-element writes cost more than the reads
            self.pose[:] = [(*body.position, body.angle) for body in self.bodies]

    def update_visibility(self, entity: Entity) -> None:
        self.ent_visible[entity.index] = entity.visible

    def update_entity(self, entity: Entity) -> None:
        """Repack a static entity after it moved or was shown or hidden."""
        self.ent_visible[entity.index] = entity.visible
        if entity.index in self.body_row:
            return  # a moving body: its pose is read every step anyway
        seg_rows, circ_rows = self._rows[entity.index]
        segs, circs = [], []
        for shape in entity.shapes:
            rows, _, angle = _shape_rows(shape, local=False)
            (segs if angle is None else circs).extend(rows)
        for i, row in zip(seg_rows, segs):
            self.seg_local[i] = self.seg_world[i] = row
        for i, row in zip(circ_rows, circs):
            self.circ_local[i] = self.circ_world[i] = row


def _shape_rows(shape: pymunk.Shape, local: bool):
    """(rows, perimeter offsets, texture start angle).

    A circle gives one (x, y, r) row and the angle its texture starts from (None marks a
    polygon); a convex polygon one (x1, y1, x2, y2) row per edge, each with the distance
    along the perimeter at which it starts.
    """
    body = shape.body
    at_origin = body.body_type == pymunk.Body.STATIC and body.position == (0, 0) and body.angle == 0
    to_world = (lambda p: p) if local or at_origin else body.local_to_world
    if isinstance(shape, pymunk.Circle):
        x, y = to_world(shape.offset)
        return [(x, y, shape.radius)], [], (0.0 if local else body.angle)
    if isinstance(shape, pymunk.Poly):
        pts = [tuple(to_world(v)) for v in shape.get_vertices()]
        rows, u0, run = [], [], 0.0
        for i in range(len(pts)):
            a, b = pts[i], pts[(i + 1) % len(pts)]
            rows.append((*a, *b))
            u0.append(run)
            run += math.hypot(b[0] - a[0], b[1] - a[1])
        return rows, u0, None
    raise TypeError(f"shape {type(shape).__name__} cannot be seen by cameras")
