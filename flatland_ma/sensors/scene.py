"""The scene the ray kernel reads: named tuples of flat arrays, and their constructors.

``pack_scene`` is the one place where shapes and entities become arrays: the world's
geometry snapshot (``geometry.py``) and the kernel's analytic tests both call it. How the
kernel reads each structure is told in ``kernel.py``'s docstring. Lengths are in world
units, angles in radians.
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import numpy as np

Point = tuple[float, float]


class Shapes(NamedTuple):
    """Every shape the eyes can see: polygon edges ("segments") and circles, a row each."""

    seg_local: np.ndarray
    """(S, 4) float64: x1, y1, x2, y2 in the body's frame (the world's for a static shape)."""
    seg_world: np.ndarray
    """(S, 4) float64: the same in the world's frame; the kernel moves the moving ones."""
    seg_body: np.ndarray
    """(S,) int32: the row of the segment's body in ``pose``, or -1 for a static shape."""
    seg_entity: np.ndarray
    """(S,) int32: the entity the segment belongs to."""
    seg_u0: np.ndarray
    """(S,) float64: distance along its polygon's perimeter at which the edge starts."""
    circ_local: np.ndarray
    """(C, 3) float64: centre x, y and radius in the body's (or the world's) frame."""
    circ_world: np.ndarray
    """(C, 3) float64: the same in the world's frame."""
    circ_body: np.ndarray
    """(C,) int32: the row of the circle's body in ``pose``, or -1."""
    circ_entity: np.ndarray
    """(C,) int32: the entity the circle belongs to."""
    circ_angle: np.ndarray
    """(C,) float64: the angle a static circle's texture starts from (moving circles use
    their body's angle)."""
    loose_seg: np.ndarray
    """(L,) int32: the segments not binned in the grid, culled per eye instead."""
    loose_circ: np.ndarray
    """(M,) int32: the circles not binned in the grid."""


class Grid(NamedTuple):
    """The fixed shapes binned in a uniform grid of square cells.

    Cell k = row * columns + column lists the segments ``cell_seg[cell_seg_start[k]:
    cell_seg_start[k + 1]]`` and likewise the circles.
    """

    frame: np.ndarray
    """(5,) float64: x0, y0 of the lower-left corner, cell side, columns, rows."""
    cell_seg_start: np.ndarray
    """(K + 1,) int32: where each cell's segments start in ``cell_seg``."""
    cell_seg: np.ndarray
    """int32: segment rows, cell after cell."""
    cell_circ_start: np.ndarray
    """(K + 1,) int32: where each cell's circles start in ``cell_circ``."""
    cell_circ: np.ndarray
    """int32: circle rows, cell after cell."""
    cell_full: np.ndarray
    """(K,) bool: whether cell k lists any shape (a ray crosses empty cells on this alone)."""


class Looks(NamedTuple):
    """What each entity looks like, a row per entity."""

    owner: np.ndarray
    """(E,) int32: the agent the entity belongs to (its own eyes do not see it), or -1."""
    visible: np.ndarray
    """(E,) bool: whether rays see the entity at all."""
    colors: np.ndarray
    """(E, 6) float32: first and second RGB colour, channels in [0, 1]."""
    texture: np.ndarray
    """(E, 3) float64: texture period (world units), duty and seed."""
    texture_kind: np.ndarray
    """(E,) int32: texture kind (``textures.KINDS``; 0 is a uniform colour)."""


class Eyes(NamedTuple):
    """The cameras' eyes and their rays: eye v casts rays ``rays[v]:rays[v + 1]``."""

    body: np.ndarray
    """(V,) int32: the row of the eye's body in ``pose``, or -1 for an eye fixed in the world."""
    local: np.ndarray
    """(V, 3) float64: x, y and heading of the eye in its body's (or the world's) frame."""
    owner: np.ndarray
    """(V,) int32: the agent the eye belongs to, or -1."""
    view_range: np.ndarray
    """(V,) float64: how far the eye sees (world units)."""
    half_fov: np.ndarray
    """(V,) float64: half the field of view (radians)."""
    falloff: np.ndarray
    """(V,) int32: ``kernel.FALLOFF_LINEAR`` or ``kernel.FALLOFF_NONE``."""
    rays: np.ndarray
    """(V + 1,) int32: where each eye's rays start."""
    ray_dir: np.ndarray
    """(N, 2) float64: cosine and sine of each ray's angle from its eye's heading."""
    fan: np.ndarray
    """(V, 2) float64: the angle of the eye's first ray and the step from each ray to the
    next, when its rays are evenly spaced (step 0 when they are not, or when there is only
    one): the kernel tests a loose shape only on the rays whose angles it subtends."""


class Outputs(NamedTuple):
    """What the kernel writes, a row per ray."""

    image: np.ndarray
    """(N, 4) float32: RGB times the intensity, and the depth (distance / range)."""
    distance: np.ndarray
    """(N,) float64: distance to the first hit, or the range."""
    hit_entity: np.ndarray
    """(N,) int32: the entity hit, or -1."""

    @classmethod
    def zeros(cls, n_rays: int) -> Outputs:
        return cls(
            np.zeros((n_rays, 4), np.float32), np.zeros(n_rays), np.full(n_rays, -1, np.int32)
        )

    def with_image(self, image: np.ndarray) -> Outputs:
        """The same outputs, but the RGB and depth written to ``image`` instead."""
        return self._replace(image=image)


class Scratch(NamedTuple):
    """The loose shapes one eye may see, refilled for each eye."""

    cand_seg: np.ndarray
    """(max(S, 1),) int32: segment rows; the kernel uses as many as it found."""
    cand_circ: np.ndarray
    """(max(C, 1),) int32: circle rows."""
    seg_rays: np.ndarray
    """(max(S, 1), 2) int32: the first and last ray of the eye (counted from its first)
    that may hit each listed segment."""
    circ_rays: np.ndarray
    """(max(C, 1), 2) int32: likewise for each listed circle."""

    @classmethod
    def for_shapes(cls, shapes: Shapes) -> Scratch:
        n_seg, n_circ = max(len(shapes.seg_local), 1), max(len(shapes.circ_local), 1)
        return cls(
            np.zeros(n_seg, np.int32),
            np.zeros(n_circ, np.int32),
            np.zeros((n_seg, 2), np.int32),
            np.zeros((n_circ, 2), np.int32),
        )


def polygon_edges(corners: Sequence[Point]) -> tuple[list[tuple[float, ...]], list[float]]:
    """The (x1, y1, x2, y2) row of each edge of a polygon, and the distance along the
    perimeter at which each edge starts."""
    rows, u0, run = [], [], 0.0
    for i in range(len(corners)):
        a, b = corners[i], corners[(i + 1) % len(corners)]
        rows.append((*a, *b))
        u0.append(run)
        run += math.hypot(b[0] - a[0], b[1] - a[1])
    return rows, u0


def pack_scene(
    polygons: Sequence[tuple[Sequence[Point], int, int]],
    circles: Sequence[tuple[tuple[float, float, float], float, int, int]],
    fixed: Sequence[bool],
    owner: Sequence[int],
    visible: Sequence[bool],
    colors: Sequence[Sequence[float]],
    textures: Sequence[tuple[int, float, float, float]],
    target_cells: int = 1024,
) -> tuple[Shapes, Grid, Looks]:
    """The shapes, the grid of fixed shapes and the entities' looks, as arrays.

    polygons: (corners, body, entity) for each convex polygon, corners counter-clockwise in
    the body's frame (the world's if body is -1). circles: ((x, y, radius), texture start
    angle, body, entity) for each circle. Per entity: ``fixed`` (it never moves: its shapes
    go in the grid), ``owner``, ``visible``, ``colors`` (first and second RGB, 6 values) and
    ``textures`` (kind, period, duty, seed).
    """
    segs, seg_body, seg_entity, seg_u0 = [], [], [], []
    for corners, body, entity in polygons:
        rows, u0 = polygon_edges(corners)
        segs += rows
        seg_u0 += u0
        seg_body += [body] * len(rows)
        seg_entity += [entity] * len(rows)
    seg_local = np.array(segs, np.float64).reshape(-1, 4)
    circ_local = np.array([c[0] for c in circles], np.float64).reshape(-1, 3)
    seg_entity = np.array(seg_entity, np.int32)
    circ_entity = np.array([c[3] for c in circles], np.int32)
    is_fixed = np.array(fixed, np.bool_)
    seg_fixed, circ_fixed = is_fixed[seg_entity], is_fixed[circ_entity]
    shapes = Shapes(
        seg_local=seg_local,
        seg_world=seg_local.copy(),
        seg_body=np.array(seg_body, np.int32),
        seg_entity=seg_entity,
        seg_u0=np.array(seg_u0, np.float64),
        circ_local=circ_local,
        circ_world=circ_local.copy(),
        circ_body=np.array([c[2] for c in circles], np.int32),
        circ_entity=circ_entity,
        circ_angle=np.array([c[1] for c in circles], np.float64),
        loose_seg=np.flatnonzero(~seg_fixed).astype(np.int32),
        loose_circ=np.flatnonzero(~circ_fixed).astype(np.int32),
    )
    grid = fixed_grid(seg_local, seg_fixed, circ_local, circ_fixed, target_cells)
    texture_rows = np.array(textures, np.float64).reshape(-1, 4)
    looks = Looks(
        owner=np.array(owner, np.int32),
        visible=np.array(visible, np.bool_),
        colors=np.array(colors, np.float32).reshape(-1, 6),
        texture=texture_rows[:, 1:].copy(),
        texture_kind=texture_rows[:, 0].astype(np.int32),
    )
    return shapes, grid, looks


def pack_eyes(
    body: Sequence[int],
    local: Sequence[tuple[float, float, float]],
    owner: Sequence[int],
    view_range: Sequence[float],
    half_fov: Sequence[float],
    falloff: Sequence[int],
    angles: Sequence[np.ndarray],
) -> Eyes:
    """The eyes as arrays: per eye its body row, pose in the body's frame, owner, range,
    half field of view, falloff and its rays' angles from its heading (radians)."""
    starts = np.cumsum([0] + [len(a) for a in angles]).astype(np.int32)
    all_angles = np.concatenate([np.asarray(a, np.float64) for a in angles] or [np.zeros(0)])
    fan = np.zeros((len(angles), 2), np.float64)
    for v, a in enumerate(angles):
        a = np.asarray(a, np.float64)
        if len(a) > 1:
            step = (a[-1] - a[0]) / (len(a) - 1)
            even = np.abs(a - (a[0] + step * np.arange(len(a)))).max() <= 1e-9 * abs(step)
            fan[v] = (a[0], step if even and step != 0.0 else 0.0)
        elif len(a) == 1:
            fan[v, 0] = a[0]
    return Eyes(
        body=np.array(body, np.int32),
        local=np.array(local, np.float64).reshape(-1, 3),
        owner=np.array(owner, np.int32),
        view_range=np.array(view_range, np.float64),
        half_fov=np.array(half_fov, np.float64),
        falloff=np.array(falloff, np.int32),
        rays=starts,
        ray_dir=np.stack([np.cos(all_angles), np.sin(all_angles)], axis=1),
        fan=fan,
    )


KEPT = 64
"""Packed arrays kept for reuse (grids of fixed shapes, eyes): those a process met last."""
_KEPT: OrderedDict[tuple, Any] = OrderedDict()
_KEPT_LOCK = threading.Lock()


def _kept(key: tuple, make: Callable[[], Any]) -> Any:
    """``make()``, or the same object again for the same ``key``: a world's arrays that
    every episode of a fixed layout, or every world of a batch, has alike are made once and
    read from one copy in the cache by every world's rays. Nobody writes them (the kernel
    only reads them)."""
    with _KEPT_LOCK:  # envs in several threads share the cache
        value = _KEPT.get(key)
        if value is not None:
            _KEPT.move_to_end(key)
            return value
    value = make()
    with _KEPT_LOCK:
        value = _KEPT.setdefault(key, value)
        while len(_KEPT) > KEPT:
            _KEPT.popitem(last=False)
    return value


def fixed_grid(seg_world, seg_fixed, circ_world, circ_fixed, target_cells: int = 1024) -> Grid:
    """``bin_fixed_shapes``, the same ``Grid`` object again for the same fixed shapes."""
    key = (
        "grid",
        seg_world[seg_fixed].tobytes(),
        np.flatnonzero(seg_fixed).tobytes(),
        circ_world[circ_fixed].tobytes(),
        np.flatnonzero(circ_fixed).tobytes(),
        target_cells,
    )
    return _kept(
        key, lambda: bin_fixed_shapes(seg_world, seg_fixed, circ_world, circ_fixed, target_cells)
    )


def shared_eyes(body, local, owner, view_range, half_fov, falloff, angles) -> Eyes:
    """``pack_eyes``, the same ``Eyes`` object again for the same eyes."""
    key = (
        "eyes",
        tuple(body),
        tuple(local),
        tuple(owner),
        tuple(view_range),
        tuple(half_fov),
        tuple(falloff),
        tuple(np.asarray(a, np.float64).tobytes() for a in angles),
    )
    return _kept(key, lambda: pack_eyes(body, local, owner, view_range, half_fov, falloff, angles))


def bin_fixed_shapes(seg_world, seg_fixed, circ_world, circ_fixed, target_cells: int = 1024):
    """A uniform grid over the fixed shapes (a ``Grid``), each shape listed in every cell
    its bounding box meets; about ``target_cells`` cells of side at least 1."""
    boxes = []
    if seg_fixed.any():
        s = seg_world[seg_fixed]
        lo = np.minimum(s[:, :2], s[:, 2:])
        hi = np.maximum(s[:, :2], s[:, 2:])
        boxes.append(np.concatenate([lo, hi], axis=1))
    if circ_fixed.any():
        c = circ_world[circ_fixed]
        boxes.append(np.concatenate([c[:, :2] - c[:, 2:3], c[:, :2] + c[:, 2:3]], axis=1))
    if not boxes:
        empty = np.zeros(2, np.int32)
        frame = np.array([0.0, 0.0, 1.0, 1.0, 1.0])
        return Grid(frame, empty, empty[:0], empty, empty[:0], np.zeros(1, np.bool_))
    all_boxes = np.concatenate(boxes)
    x0, y0 = all_boxes[:, 0].min() - 1.0, all_boxes[:, 1].min() - 1.0
    x1, y1 = all_boxes[:, 2].max() + 1.0, all_boxes[:, 3].max() + 1.0
    cell = max(math.sqrt((x1 - x0) * (y1 - y0) / target_cells), 1.0)
    nx, ny = max(1, math.ceil((x1 - x0) / cell)), max(1, math.ceil((y1 - y0) / cell))
    frame = np.array([x0, y0, cell, nx, ny], np.float64)

    def cells_of(indices, index_boxes):
        """CSR lists of the shapes whose bounding box meets each cell."""
        n_cells = nx * ny
        if len(indices) == 0:
            return np.zeros(n_cells + 1, np.int32), np.zeros(0, np.int32)
        i0 = np.clip(((index_boxes[:, 0] - x0) / cell).astype(np.int64), 0, nx - 1)
        i1 = np.clip(((index_boxes[:, 2] - x0) / cell).astype(np.int64), 0, nx - 1)
        j0 = np.clip(((index_boxes[:, 1] - y0) / cell).astype(np.int64), 0, ny - 1)
        j1 = np.clip(((index_boxes[:, 3] - y0) / cell).astype(np.int64), 0, ny - 1)
        width = i1 - i0 + 1
        counts = width * (j1 - j0 + 1)
        owner = np.repeat(np.arange(len(indices)), counts)
        local = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
        cells = (j0[owner] + local // width[owner]) * nx + i0[owner] + local % width[owner]
        order = np.argsort(cells, kind="stable")
        start = np.zeros(n_cells + 1, np.int32)
        start[1:] = np.cumsum(np.bincount(cells, minlength=n_cells))
        return start, np.asarray(indices, np.int32)[owner[order]]

    seg_start, segs = cells_of(np.flatnonzero(seg_fixed), boxes[0] if seg_fixed.any() else None)
    circ_start, circs = cells_of(
        np.flatnonzero(circ_fixed), boxes[-1] if circ_fixed.any() else None
    )
    full = (np.diff(seg_start) > 0) | (np.diff(circ_start) > 0)
    return Grid(frame, seg_start, segs, circ_start, circs, full)
