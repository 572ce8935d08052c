"""Calling the ray kernel on hand-made geometry, for analytic tests."""

from __future__ import annotations

import math

import numpy as np

from flatland_ma.sensors import kernel
from flatland_ma.sensors.scene import Outputs, Scratch, pack_eyes, pack_scene


def box(cx, cy, w, h):
    """Counter-clockwise corners of an axis-aligned box."""
    return [
        (cx - w / 2, cy - h / 2),
        (cx + w / 2, cy - h / 2),
        (cx + w / 2, cy + h / 2),
        (cx - w / 2, cy + h / 2),
    ]


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
    observe=kernel.observe,
):
    """Cast rays at ``angles`` (radians, relative to the eye heading).

    Entities are numbered polygons first, then circles. ``textures``: per entity None or
    (kind, period, duty, seed, second colour). Shapes on no body are fixed: binned in the
    grid unless ``grid=False``. ``observe``: the kernel to call. Returns (distance, entity,
    image).
    """
    poly_body = [-1] * len(polygons) if polygon_bodies is None else list(polygon_bodies)
    circ_body = [-1] * len(circles) if circle_bodies is None else list(circle_bodies)
    n_ent = len(polygons) + len(circles)
    first = np.ones((n_ent, 3)) if colors is None else np.array(colors, np.float64).reshape(-1, 3)
    second = first.copy()
    texture = [(0, 0.0, 0.0, 0.0)] * n_ent
    for e, t in enumerate(textures or []):
        if t is not None:
            texture[e], second[e] = (t[0], *t[1:4]), t[4]
    shapes, fixed_grid, looks = pack_scene(
        [(corners, b, e) for e, (corners, b) in enumerate(zip(polygons, poly_body))],
        [(c, 0.0, b, len(polygons) + k) for k, (c, b) in enumerate(zip(circles, circ_body))],
        fixed=[grid and b < 0 for b in poly_body + circ_body],
        owner=[-1] * n_ent if owners is None else owners,
        visible=[True] * n_ent,
        colors=np.concatenate([first, second], axis=1),
        textures=texture,
        target_cells=cells,
    )
    angles = np.asarray(angles, np.float64)
    eyes = pack_eyes(
        body=[eye_body],
        local=[eye],
        owner=[eye_owner],
        view_range=[view_range],
        half_fov=[float(np.abs(angles).max()) if half_fov is None else half_fov],
        falloff=[falloff],
        angles=[angles],
    )
    out = Outputs.zeros(len(angles))
    pose = np.array(poses if poses is not None else np.zeros((0, 3)), np.float64).reshape(-1, 3)
    observe(pose, shapes, fixed_grid, looks, eyes, out, Scratch.for_shapes(shapes))
    return out.distance, out.hit_entity, out.image


def deg(*values):
    return [math.radians(v) for v in values]
