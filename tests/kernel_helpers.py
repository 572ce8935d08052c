"""Calling the ray kernel on hand-made geometry, for analytic tests."""

from __future__ import annotations

import math

import numpy as np

from flatland_ma.sensors import kernel


def box(cx, cy, w, h):
    """Counter-clockwise corners of an axis-aligned box."""
    return [
        (cx - w / 2, cy - h / 2),
        (cx + w / 2, cy - h / 2),
        (cx + w / 2, cy + h / 2),
        (cx - w / 2, cy + h / 2),
    ]


def edges(corners):
    return [(*corners[i], *corners[(i + 1) % len(corners)]) for i in range(len(corners))]


def cast(
    angles,
    eye=(0.0, 0.0, 0.0),
    polygons=(),
    circles=(),
    view_range=1000.0,
    owners=None,
    colors=None,
    falloff=kernel.FALLOFF_LINEAR,
    half_fov=None,
    poses=None,
    polygon_bodies=None,
    circle_bodies=None,
    eye_body=-1,
    eye_owner=-1,
    grid=True,
    cells=64,
    textures=None,
):
    """Cast rays at ``angles`` (radians, relative to the eye heading).

    Entities are numbered polygons first, then circles. ``textures``: per entity None or
    (kind, period, duty, seed, second colour). Returns (distance, entity, image).
    """
    segs, seg_entity, seg_body, seg_u0 = [], [], [], []
    for e, corners in enumerate(polygons):
        run = 0.0
        for row in edges(corners):
            segs.append(row)
            seg_entity.append(e)
            seg_body.append(-1 if polygon_bodies is None else polygon_bodies[e])
            seg_u0.append(run)
            run += math.hypot(row[2] - row[0], row[3] - row[1])
    circ, circ_entity, circ_body = [], [], []
    for k, c in enumerate(circles):
        circ.append(c)
        circ_entity.append(len(polygons) + k)
        circ_body.append(-1 if circle_bodies is None else circle_bodies[k])
    n_ent = len(polygons) + len(circles)
    seg_local = np.array(segs, np.float64).reshape(-1, 4)
    circ_local = np.array(circ, np.float64).reshape(-1, 3)
    angles = np.asarray(angles, np.float64)
    n = len(angles)
    image = np.zeros((n, 4), np.float32)
    distance = np.zeros(n)
    hit = np.zeros(n, np.int32)
    work_s, work_c = kernel.empty_work(len(seg_local), len(circ_local))
    if colors is None:
        colors = [(1.0, 1.0, 1.0)] * n_ent
    colors = np.array(colors, np.float32).reshape(-1, 3)
    second = colors.copy()
    tex = np.zeros((n_ent, 3))
    tex_kind = np.zeros(n_ent, np.int32)
    for e, t in enumerate(textures or [None] * n_ent):
        if t is not None:
            tex_kind[e], tex[e], second[e] = t[0], t[1:4], t[4]
    # Shapes on no body are fixed: binned in the grid unless ``grid=False``.
    seg_fixed = (np.array(seg_body) < 0) & grid if len(seg_body) else np.zeros(0, bool)
    circ_fixed = (np.array(circ_body) < 0) & grid if len(circ_body) else np.zeros(0, bool)
    binned = kernel.bin_fixed_shapes(seg_local, seg_fixed, circ_local, circ_fixed, cells)
    kernel.observe(
        np.array(poses if poses is not None else np.zeros((0, 3)), np.float64).reshape(-1, 3),
        seg_local,
        seg_local.copy(),
        np.array(seg_body, np.int32),
        np.array(seg_entity, np.int32),
        np.array(seg_u0, np.float64),
        circ_local,
        circ_local.copy(),
        np.array(circ_body, np.int32),
        np.array(circ_entity, np.int32),
        np.zeros(len(circ_local)),
        np.flatnonzero(~seg_fixed).astype(np.int32),
        np.flatnonzero(~circ_fixed).astype(np.int32),
        *binned,
        np.array(owners if owners is not None else [-1] * n_ent, np.int32),
        np.ones(n_ent, np.bool_),
        np.concatenate([colors, second], axis=1),
        tex,
        tex_kind,
        np.array([eye_body], np.int32),
        np.array([eye], np.float64),
        np.array([eye_owner], np.int32),
        np.array([[view_range, half_fov if half_fov is not None else float(np.abs(angles).max())]]),
        np.array([falloff], np.int32),
        np.array([0, n], np.int32),
        np.stack([np.cos(angles), np.sin(angles)], axis=1),
        image,
        distance,
        hit,
        work_s,
        work_c,
    )
    return distance, hit, image


def deg(*values):
    return [math.radians(v) for v in values]
