"""The top-down kernel: one agent's egocentric image drawn from the packed geometry.

``draw(pose, shapes, grid, looks, outline, view)`` reads the same named tuples as the ray
kernel (``scene.py``), after the ray kernel has moved the moving shapes to this step's
poses, plus two of its own: ``Outline`` (per episode: which segments make which polygon,
which entities hide what lies behind them) and ``View`` (per sensor: where its pixels lie
around the mount, its scratch buffers and its output).

Pixels are worked in the mount's frame: ``forward`` along its heading, ``left`` to its
left. Pixel n = row * size + column has its centre at ``view.pixel[n]``; row 0 is the
farthest ahead and column 0 the farthest to the left, so the image shows the world as a
map held with the heading up.

1. Drawing. The fixed shapes near the mount are gathered from the grid's cells (each
   polygon and circle once, by a stamp per call); the loose ones (agents, items, movable
   objects) are all taken. Each visible shape is filled row by row over the rows its
   bounding box spans: on a row of pixel centres, a circle covers the span its chord
   does, and a convex polygon the span its edges all keep on their inner side. Where
   shapes overlap, the entity added to the world last wins (agents over items over
   obstacles over walls), so the picture does not depend on the order of the gathering.
2. Visibility, when asked. A pixel is seen when its centre lies in the field of view and
   no solid shape stands on the line of sight from the mount to it, but the shape the
   centre lies in: so the agent sees the whole of a wall or an obstacle it faces (a map
   shows it filled), and nothing behind it. Each occluding edge that faces the mount,
   and each occluding circle, hides the pixel centres behind it in its angular span;
   those are found by binary search in the pixels sorted by angle (``view.order``), and
   each is tested exactly.
3. Output: the channel values of each pixel's entity (``view.values``, a row per entity
   and a last row for bare floor), with the visibility channel, and zeros where masked.

Every helper is inlined and nothing is allocated, so like the ray kernel it runs without
numba's reference counting (see ``kernel.py``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np

ANGLE_SLACK = 1e-9
"""How much wider than exact an occluder's angular span is searched (its pixels are then
tested exactly)."""


class Outline(NamedTuple):
    """The polygons among the shapes, and what hides what; built once per episode."""

    poly_first: np.ndarray
    """(P + 1,) int32: polygon p's edges are segment rows ``poly_first[p]:poly_first[p + 1]``."""
    seg_poly: np.ndarray
    """(S,) int32: the polygon each segment is an edge of."""
    loose_poly: np.ndarray
    """(Q,) int32: the polygons of loose entities (not in the grid)."""
    blocks: np.ndarray
    """(E,) bool: whether the entity hides what lies behind it (all but items)."""


class View(NamedTuple):
    """One top-down sensor: its pixels around the mount, scratch buffers and output."""

    frame: np.ndarray
    """(4,) float64: pixel side, distance of the image's centre ahead of the mount, the
    farthest pixel centre from the mount, and the pixel count per side."""
    flags: np.ndarray
    """(6,) int64: the mount's row in ``pose``, its agent (-1: none), whether to work out
    visibility, whether to blank unseen pixels, the visibility channel (-1: none), and the
    stamp of the current call."""
    pixel: np.ndarray
    """(N, 2) float64: each pixel centre (forward, left) from the mount."""
    order: np.ndarray
    """(N,) int32: pixels by increasing angle from the heading (counter-clockwise)."""
    angle: np.ndarray
    """(N,) float64: those angles, in (-pi, pi], sorted."""
    in_fov: np.ndarray
    """(N,) bool: whether the pixel centre lies in the field of view."""
    values: np.ndarray
    """(E + 1, C) float32: each entity's channel values; the last row is bare floor."""
    poly_stamp: np.ndarray
    """(P,) int64: the call that last gathered each polygon."""
    circ_stamp: np.ndarray
    """(max(C, 1),) int64: the call that last gathered each circle."""
    ids: np.ndarray
    """(N,) int32: the entity drawn at each pixel, -1 for bare floor."""
    seen: np.ndarray
    """(N,) bool: whether each pixel is seen."""
    out: np.ndarray
    """(N, C) float32: the image, pixel after pixel."""


@nb.njit(cache=True, inline="always")
def _to_mount(x, y, ox, oy, hx, hy):
    """A world point in the mount's frame: (forward, left)."""
    dx, dy = x - ox, y - oy
    return dx * hx + dy * hy, dy * hx - dx * hy


@nb.njit(cache=True, inline="always")
def _index_span(lo, hi, centre, side, size):
    """The pixel indices (first, last) whose coordinate ``centre - (index + 1/2 - size / 2)
    * side`` lies in [lo, hi], widened by one and clipped; empty when first > last."""
    half = 0.5 * size - 0.5
    a = min(max(half - (hi - centre) / side - 1.0, -1.0), size + 1.0)
    b = min(max(half - (lo - centre) / side + 1.0, -1.0), size + 1.0)
    return max(int(math.floor(a)), 0), min(int(math.ceil(b)), size - 1)


@nb.njit(cache=True, inline="always")
def _fill_row(view, i, lo, hi, e):
    """Draw entity e at the pixels of row i whose centre's ``left`` lies in [lo, hi],
    unless an entity added later is already there."""
    side, size = view.frame[0], int(view.frame[3])
    if not lo <= hi:
        return
    half = 0.5 * size - 0.5
    j0 = max(int(math.ceil(min(max(half - hi / side, -1.0), size + 1.0))), 0)
    j1 = min(int(math.floor(min(max(half - lo / side, -1.0), size + 1.0))), size - 1)
    # Settle the ends on the pixels' own coordinates (column j's is view.pixel[j, 1]).
    left = view.pixel
    while j0 <= j1 and left[j0, 1] > hi:
        j0 += 1
    while 0 < j0 and lo <= left[j0 - 1, 1] <= hi:
        j0 -= 1
    while j1 >= j0 and left[j1, 1] < lo:
        j1 -= 1
    while j1 < size - 1 and lo <= left[j1 + 1, 1] <= hi:
        j1 += 1
    for n in range(i * size + j0, i * size + j1 + 1):
        if e > view.ids[n]:
            view.ids[n] = e


@nb.njit(cache=True, inline="always")
def _draw_polygon(shapes, view, first, last, e, ox, oy, hx, hy):
    """Draw the convex polygon of segment rows first:last (counter-clockwise), row by
    row: on a row, each edge bounds ``left`` from one side."""
    seg = shapes.seg_world
    side, ahead, size = view.frame[0], view.frame[1], int(view.frame[3])
    f_lo, f_hi = math.inf, -math.inf
    for s in range(first, last):
        f, _ = _to_mount(seg[s, 0], seg[s, 1], ox, oy, hx, hy)
        f_lo, f_hi = min(f_lo, f), max(f_hi, f)
    i0, i1 = _index_span(f_lo, f_hi, ahead, side, size)
    for i in range(i0, i1 + 1):
        f = view.pixel[i * size, 0]
        lo, hi = -math.inf, math.inf
        for s in range(first, last):
            af, al = _to_mount(seg[s, 0], seg[s, 1], ox, oy, hx, hy)
            ex, ey = seg[s, 2] - seg[s, 0], seg[s, 3] - seg[s, 1]
            ef, el = ex * hx + ey * hy, ey * hx - ex * hy
            # Inside: ef * (left - al) - el * (f - af) >= 0.
            bound = el * (f - af)
            if ef > 0.0:
                lo = max(lo, al + bound / ef)
            elif ef < 0.0:
                hi = min(hi, al + bound / ef)
            elif bound > 0.0:
                lo = math.inf
        _fill_row(view, i, lo, hi, e)


@nb.njit(cache=True, inline="always")
def _draw_circle(shapes, view, c, e, ox, oy, hx, hy):
    """Draw circle row c, row by row."""
    side, ahead, size = view.frame[0], view.frame[1], int(view.frame[3])
    cf, cl = _to_mount(shapes.circ_world[c, 0], shapes.circ_world[c, 1], ox, oy, hx, hy)
    r = shapes.circ_world[c, 2]
    i0, i1 = _index_span(cf - r, cf + r, ahead, side, size)
    for i in range(i0, i1 + 1):
        df = view.pixel[i * size, 0] - cf
        if df * df <= r * r:
            half_chord = math.sqrt(r * r - df * df)
            _fill_row(view, i, cl - half_chord, cl + half_chord, e)


@nb.njit(cache=True, inline="always")
def _first_at_least(angle, x):
    """The first index k with ``angle[k] >= x`` (len(angle) if none)."""
    lo, hi = 0, angle.shape[0]
    while lo < hi:
        mid = (lo + hi) // 2
        if angle[mid] < x:
            lo = mid + 1
        else:
            hi = mid
    return lo


@nb.njit(cache=True, inline="always")
def _span(view, lo, hi, piece):
    """The positions in ``view.order`` of the pixels with angle in [lo, hi] (radians,
    each in (-pi, pi]; lo > hi wraps past pi): piece 0 is the first range, piece 1 the
    second of a wrapped span (empty otherwise)."""
    angle = view.angle
    n = angle.shape[0]
    if lo <= hi:
        if piece == 1:
            return 0, 0
        return _first_at_least(angle, lo - ANGLE_SLACK), _first_at_least(angle, hi + ANGLE_SLACK)
    if piece == 0:
        return _first_at_least(angle, lo - ANGLE_SLACK), n
    return 0, _first_at_least(angle, hi + ANGLE_SLACK)


@nb.njit(cache=True, inline="always")
def _wrap(a):
    """An angle brought into (-pi, pi]."""
    if a > math.pi:
        return a - 2.0 * math.pi
    if a <= -math.pi:
        return a + 2.0 * math.pi
    return a


@nb.njit(cache=True, inline="always")
def _inside_polygon(seg, first, last, x, y):
    """Whether the world point (x, y) lies in the convex polygon of segments first:last."""
    for s in range(first, last):
        ex, ey = seg[s, 2] - seg[s, 0], seg[s, 3] - seg[s, 1]
        if ex * (y - seg[s, 1]) - ey * (x - seg[s, 0]) < 0.0:
            return False
    return True


@nb.njit(cache=True, inline="always")
def _shadow_segment(shapes, view, s, first, last, ox, oy, hx, hy):
    """Hide the pixels behind edge s of the polygon of segments first:last, if the edge
    faces the mount; the polygon's own pixels stay."""
    seg = shapes.seg_world
    af, al = _to_mount(seg[s, 0], seg[s, 1], ox, oy, hx, hy)
    bf, bl = _to_mount(seg[s, 2], seg[s, 3], ox, oy, hx, hy)
    ef, el = bf - af, bl - al
    if af * el - al * ef >= 0.0:  # its back, or edge-on: the polygon's other edges hide
        return
    length2 = ef * ef + el * el
    along = min(max(-(af * ef + al * el) / length2, 0.0), 1.0) if length2 > 0.0 else 0.0
    nf, nl = af + along * ef, al + along * el
    reach = view.frame[2]
    if nf * nf + nl * nl > reach * reach:
        return
    # Seen from the mount, the edge turns clockwise from a to b: a pixel centre in that
    # wedge and beyond the edge's line has the edge on its line of sight.
    lo, hi = math.atan2(bl, bf), math.atan2(al, af)
    for piece in range(2):
        k0, k1 = _span(view, lo, hi, piece)
        for k in range(k0, k1):
            n = view.order[k]
            if not view.seen[n]:
                continue
            pf, pl = view.pixel[n, 0], view.pixel[n, 1]
            beyond = ef * (pl - al) - el * (pf - af) > 0.0
            if beyond and af * pl - al * pf <= 0.0 and pf * bl - pl * bf <= 0.0:
                x, y = ox + pf * hx - pl * hy, oy + pf * hy + pl * hx
                if not _inside_polygon(seg, first, last, x, y):
                    view.seen[n] = False


@nb.njit(cache=True, inline="always")
def _shadow_circle(shapes, view, c, ox, oy, hx, hy):
    """Hide the pixels behind circle c (unless the mount is inside it); its own pixels
    stay."""
    cf, cl = _to_mount(shapes.circ_world[c, 0], shapes.circ_world[c, 1], ox, oy, hx, hy)
    r = shapes.circ_world[c, 2]
    d = math.sqrt(cf * cf + cl * cl)
    if d <= r or d - r > view.frame[2]:
        return
    centre, half = math.atan2(cl, cf), math.asin(r / d)
    lo, hi = _wrap(centre - half), _wrap(centre + half)
    for piece in range(2):
        k0, k1 = _span(view, lo, hi, piece)
        for k in range(k0, k1):
            n = view.order[k]
            pf, pl = view.pixel[n, 0], view.pixel[n, 1]
            if (pf - cf) ** 2 + (pl - cl) ** 2 <= r * r:
                continue  # in the disc
            p2 = pf * pf + pl * pl
            t = min(max((pf * cf + pl * cl) / p2, 0.0), 1.0) if p2 > 0.0 else 0.0
            df, dl = t * pf - cf, t * pl - cl
            if df * df + dl * dl < r * r:
                view.seen[n] = False


@nb.njit(cache=True, inline="always")
def _hides(looks, outline, e, owner):
    """Whether entity e hides what lies behind it from the mount of agent ``owner``."""
    return looks.visible[e] and outline.blocks[e] and not (owner >= 0 and looks.owner[e] == owner)


@nb.njit(cache=True, inline="always")
def _polygon(shapes, looks, outline, view, p, ox, oy, hx, hy, shadows, owner):
    """Draw polygon p and, if asked, let its edges cast their shadows."""
    first, last = outline.poly_first[p], outline.poly_first[p + 1]
    e = shapes.seg_entity[first]
    if not looks.visible[e]:
        return
    _draw_polygon(shapes, view, first, last, e, ox, oy, hx, hy)
    if shadows and _hides(looks, outline, e, owner):
        for s in range(first, last):
            _shadow_segment(shapes, view, s, first, last, ox, oy, hx, hy)


@nb.njit(cache=True, inline="always")
def _circle(shapes, looks, outline, view, c, ox, oy, hx, hy, shadows, owner):
    """Draw circle c and, if asked, let it cast its shadow."""
    e = shapes.circ_entity[c]
    if not looks.visible[e]:
        return
    _draw_circle(shapes, view, c, e, ox, oy, hx, hy)
    if shadows and _hides(looks, outline, e, owner):
        _shadow_circle(shapes, view, c, ox, oy, hx, hy)


@nb.njit(cache=True, _nrt=False)  # type: ignore[call-overload]  # no refcounts: see the docstring
def draw(pose, shapes, grid, looks, outline, view):
    """Fill ``view.out`` with this step's image (see the module's docstring)."""
    flags = view.flags
    row, owner, shadows = flags[0], flags[1], flags[2] != 0
    masked, visibility = flags[3] != 0, flags[4]
    flags[5] += 1
    stamp = flags[5]
    ox, oy = pose[row, 0], pose[row, 1]
    a = pose[row, 2] if flags[6] != 0 else 0.5 * math.pi  # held north up unless turned
    hx, hy = math.cos(a), math.sin(a)
    n_pixels = view.ids.shape[0]
    for n in range(n_pixels):
        view.ids[n] = -1
        view.seen[n] = view.in_fov[n]

    # The fixed shapes in the grid's cells within reach of the mount, each once.
    frame = grid.frame
    x0, y0, cell = frame[0], frame[1], frame[2]
    columns, rows = int(frame[3]), int(frame[4])
    reach = view.frame[2] + view.frame[0]
    i0 = min(max(int(math.floor((ox - reach - x0) / cell)), 0), columns - 1)
    i1 = min(max(int(math.floor((ox + reach - x0) / cell)), 0), columns - 1)
    j0 = min(max(int(math.floor((oy - reach - y0) / cell)), 0), rows - 1)
    j1 = min(max(int(math.floor((oy + reach - y0) / cell)), 0), rows - 1)
    for j in range(j0, j1 + 1):
        for i in range(i0, i1 + 1):
            k = j * columns + i
            for q in range(grid.cell_seg_start[k], grid.cell_seg_start[k + 1]):
                p = outline.seg_poly[grid.cell_seg[q]]
                if view.poly_stamp[p] != stamp:
                    view.poly_stamp[p] = stamp
                    _polygon(shapes, looks, outline, view, p, ox, oy, hx, hy, shadows, owner)
            for q in range(grid.cell_circ_start[k], grid.cell_circ_start[k + 1]):
                c = grid.cell_circ[q]
                if view.circ_stamp[c] != stamp:
                    view.circ_stamp[c] = stamp
                    _circle(shapes, looks, outline, view, c, ox, oy, hx, hy, shadows, owner)

    # The loose shapes: agents, items, movable objects.
    for p in outline.loose_poly:
        _polygon(shapes, looks, outline, view, p, ox, oy, hx, hy, shadows, owner)
    for c in shapes.loose_circ:
        _circle(shapes, looks, outline, view, c, ox, oy, hx, hy, shadows, owner)

    floor = view.values.shape[0] - 1
    values, out = view.values, view.out
    width = out.shape[1]
    for n in range(n_pixels):
        e = view.ids[n]
        entry = e if e >= 0 else floor
        if masked and not view.seen[n]:
            for ch in range(width):
                out[n, ch] = 0.0
        else:
            for ch in range(width):
                out[n, ch] = values[entry, ch]
        if visibility >= 0:
            out[n, visibility] = 1.0 if view.seen[n] or not shadows else 0.0
