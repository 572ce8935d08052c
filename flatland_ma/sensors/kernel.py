"""The ray kernel: every ray of every camera cast in one compiled call.

``observe(pose, shapes, grid, looks, eyes, out, scratch)`` reads the world as named tuples
of flat arrays, built by ``scene.pack_scene`` and ``scene.pack_eyes`` (each field's shape
and meaning is documented there):

- ``pose`` (B, 3) float64: x, y, angle of each moving body, written by the geometry
  snapshot each step;
- ``Shapes``: segments, the edges of convex polygons, counter-clockwise, so each edge's
  outward normal is (ey, -ex) and a ray only hits an edge from outside (back faces are
  skipped), each knowing how far along its polygon's perimeter it starts (for textures);
  and circles (centre, radius, and the angle textures start from). Each names its entity
  and its body's row in ``pose`` (-1: static). Shapes on moving bodies are stored in body
  coordinates and moved to world coordinates at the start of each call; static shapes are
  stored in world coordinates;
- ``Grid``: shapes that never move (walls, fixed obstacles, doors) binned in a uniform
  grid. Each ray walks the cells it crosses, nearest first (a DDA), tests the shapes of
  those that list any, and stops once its nearest hit lies before the cell's far edge;
  an eye inside the grid finds its cell once for all its rays. Everything else ("loose"
  shapes: agents, items, movable things) is culled per eye by range and field of view
  into ``Scratch``, each with the run of the eye's rays it subtends (``cull.py``), and
  tested on the rays of its run only, shape after shape, each ray's nearest hit so far
  kept in ``out`` until the ray walks the grid;
- ``Looks``: per entity an owner (the agent it belongs to, whose own eyes do not see it),
  a visibility flag, two colours and a texture (kind and parameters; see ``textures.py``);
- ``Eyes``: per eye its body row and pose on the body, owner, range, half field of view,
  falloff, its rays' directions and, when they are evenly spaced, their fan (first angle
  and step);
- ``Outputs``, per ray: the colour image (RGB times intensity, and normalised depth), the
  distance and the entity hit (-1 for none).

Every helper is inlined into ``observe`` (``inline="always"``), so the compiler sees one
function. ``observe`` runs without numba's reference counting (``_nrt=False``): it
allocates nothing and only reads and writes arrays its caller keeps alive, while the
counting is not free: each inlined helper that takes the named tuples adds an increment
and decrement per array per call, which numba cannot prune across the helpers' branches
and loops (numba issue #2350), and which made the kernel 2-3 times slower. An array
allocated in the kernel would fail to compile.

Every change for speed keeps the results bit for bit: each ray tests the same shapes in
the same order with the same arithmetic, less those it cannot hit (tests/sensors/test_kernel.py
holds it to a frozen copy of the kernel before them, tests/kernel_reference.py). The
grid walk is most of a ray's time now: benchmarks/rays.py measures the rays per second.
"""

from __future__ import annotations

import math

import numba as nb

from flatland_ma.sensors.cull import cull, unseen
from flatland_ma.sensors.scene import bin_fixed_shapes
from flatland_ma.sensors.textures import shade

__all__ = ["FALLOFF_LINEAR", "FALLOFF_NONE", "bin_fixed_shapes", "observe"]

FALLOFF_LINEAR = 0
FALLOFF_NONE = 1


@nb.njit(cache=True, inline="always")
def _segment_t(seg_world, s, ox, oy, dx, dy, best):
    """Distance along the ray to segment ``s`` if nearer than ``best`` (else -1), and the
    fraction along the segment where it is hit."""
    x1, y1 = seg_world[s, 0], seg_world[s, 1]
    ex, ey = seg_world[s, 2] - x1, seg_world[s, 3] - y1
    denom = dx * ey - dy * ex
    if denom >= 0.0:  # parallel, or the back of the edge
        return -1.0, 0.0
    wx, wy = x1 - ox, y1 - oy
    t = (wx * ey - wy * ex) / denom
    if t < 0.0 or t >= best:
        return -1.0, 0.0
    along = (wx * dy - wy * dx) / denom
    if along < 0.0 or along > 1.0:
        return -1.0, 0.0
    return t, along


@nb.njit(cache=True, inline="always")
def _circle_t(circ_world, s, ox, oy, dx, dy, best):
    """Distance along the ray to circle ``s`` if nearer than ``best``, else -1."""
    mx, my = ox - circ_world[s, 0], oy - circ_world[s, 1]
    rad = circ_world[s, 2]
    bb = mx * dx + my * dy
    cc = mx * mx + my * my - rad * rad
    if cc > 0.0 and bb > 0.0:  # outside and looking away
        return -1.0
    disc = bb * bb - cc
    if disc < 0.0:
        return -1.0
    t = -bb - math.sqrt(disc)
    if t < 0.0:  # the eye is inside the circle
        t = 0.0
    return t if t < best else -1.0


@nb.njit(cache=True, inline="always")
def _move_shapes(pose, shapes):
    """Write the world coordinates of every shape on a moving body."""
    for s in range(shapes.seg_local.shape[0]):
        b = shapes.seg_body[s]
        if b >= 0:
            px, py, a = pose[b, 0], pose[b, 1], pose[b, 2]
            c, sn = math.cos(a), math.sin(a)
            for k in range(2):
                lx, ly = shapes.seg_local[s, 2 * k], shapes.seg_local[s, 2 * k + 1]
                shapes.seg_world[s, 2 * k] = px + c * lx - sn * ly
                shapes.seg_world[s, 2 * k + 1] = py + sn * lx + c * ly
    for s in range(shapes.circ_local.shape[0]):
        b = shapes.circ_body[s]
        if b >= 0:
            px, py, a = pose[b, 0], pose[b, 1], pose[b, 2]
            c, sn = math.cos(a), math.sin(a)
            lx, ly = shapes.circ_local[s, 0], shapes.circ_local[s, 1]
            shapes.circ_world[s, 0] = px + c * lx - sn * ly
            shapes.circ_world[s, 1] = py + sn * lx + c * ly
            shapes.circ_world[s, 2] = shapes.circ_local[s, 2]


@nb.njit(cache=True, inline="always")
def _place_eye(pose, eyes, v):
    """Eye v's position (ox, oy) and heading (cosine, sine) in the world."""
    b = eyes.body[v]
    if b >= 0:
        px, py, a = pose[b, 0], pose[b, 1], pose[b, 2]
        c, sn = math.cos(a), math.sin(a)
        ox = px + c * eyes.local[v, 0] - sn * eyes.local[v, 1]
        oy = py + sn * eyes.local[v, 0] + c * eyes.local[v, 1]
        heading = a + eyes.local[v, 2]
    else:
        ox, oy, heading = eyes.local[v, 0], eyes.local[v, 1], eyes.local[v, 2]
    return ox, oy, math.cos(heading), math.sin(heading)


@nb.njit(cache=True, inline="always")
def _ray(eyes, r, hx, hy):
    """The direction of ray r of an eye heading (hx, hy)."""
    lc, ls = eyes.ray_dir[r, 0], eyes.ray_dir[r, 1]
    return hx * lc - hy * ls, hy * lc + hx * ls


@nb.njit(cache=True, inline="always")
def _cast_loose(shapes, eyes, scratch, out, v, n_seg, n_circ, ox, oy, hx, hy):
    """The nearest listed loose shape along each ray of eye v, shape after shape over the
    run of rays each may hit, into ``out``: the distance (the range if none) and the
    shape (-1: none, s >= 0: segment s, -2 - c: circle c). Each ray tests its shapes in
    the listed order, segments first, as if it went through them alone."""
    first = eyes.rays[v]
    for r in range(first, eyes.rays[v + 1]):
        out.distance[r] = eyes.view_range[v]
        out.hit_entity[r] = -1
    for k in range(n_seg):
        s = scratch.cand_seg[k]
        for r in range(first + scratch.seg_rays[k, 0], first + scratch.seg_rays[k, 1] + 1):
            dx, dy = _ray(eyes, r, hx, hy)
            t, _ = _segment_t(shapes.seg_world, s, ox, oy, dx, dy, out.distance[r])
            if t >= 0.0:
                out.distance[r] = t
                out.hit_entity[r] = s
    for k in range(n_circ):
        s = scratch.cand_circ[k]
        for r in range(first + scratch.circ_rays[k, 0], first + scratch.circ_rays[k, 1] + 1):
            dx, dy = _ray(eyes, r, hx, hy)
            t = _circle_t(shapes.circ_world, s, ox, oy, dx, dy, out.distance[r])
            if t >= 0.0:
                out.distance[r] = t
                out.hit_entity[r] = -2 - s


@nb.njit(cache=True, inline="always")
def _loose_hit(shapes, out, r, ox, oy, dx, dy):
    """Ray r's hit among the loose shapes, as ``_cast_loose`` left it: (distance, segment,
    circle, fraction along the segment), -1 for no segment or no circle; the fraction is
    worked again as ``_segment_t`` worked it (the same bits)."""
    best, code = out.distance[r], out.hit_entity[r]
    if code >= 0:
        seg = shapes.seg_world
        x1, y1 = seg[code, 0], seg[code, 1]
        ex, ey = seg[code, 2] - x1, seg[code, 3] - y1
        wx, wy = x1 - ox, y1 - oy
        return best, code, -1, (wx * dy - wy * dx) / (dx * ey - dy * ex)
    return best, -1, (-2 - code if code < -1 else -1), 0.0


@nb.njit(cache=True, inline="always")
def _cast_cell(shapes, grid, looks, k, owner, ox, oy, dx, dy, hit):
    """``hit`` (as ``_cast_loose`` returns it) updated with the shapes of grid cell k."""
    best, hit_seg, hit_circ, hit_along = hit
    for q in range(grid.cell_seg_start[k], grid.cell_seg_start[k + 1]):
        s = grid.cell_seg[q]
        if unseen(looks, shapes.seg_entity[s], owner):
            continue
        t, along = _segment_t(shapes.seg_world, s, ox, oy, dx, dy, best)
        if t >= 0.0:
            best, hit_seg, hit_circ, hit_along = t, s, -1, along
    for q in range(grid.cell_circ_start[k], grid.cell_circ_start[k + 1]):
        s = grid.cell_circ[q]
        if unseen(looks, shapes.circ_entity[s], owner):
            continue
        t = _circle_t(shapes.circ_world, s, ox, oy, dx, dy, best)
        if t >= 0.0:
            best, hit_seg, hit_circ = t, -1, s
    return best, hit_seg, hit_circ, hit_along


@nb.njit(cache=True, inline="always")
def _grid_span(frame, ox, oy, dx, dy, best):
    """Where the ray, up to ``best``, is inside the grid: (t_in, t_out); empty if
    t_in > t_out."""
    t_in = 0.0
    t_out = best
    for axis in range(2):
        o = ox if axis == 0 else oy
        d = dx if axis == 0 else dy
        lo = frame[0] if axis == 0 else frame[1]
        hi = lo + frame[2] * (int(frame[3]) if axis == 0 else int(frame[4]))
        if abs(d) < 1e-12:
            if o < lo or o > hi:
                t_in = t_out + 1.0
        else:
            ta, tb = (lo - o) / d, (hi - o) / d
            if ta > tb:
                ta, tb = tb, ta
            t_in = max(t_in, ta)
            t_out = min(t_out, tb)
    return t_in, t_out


@nb.njit(cache=True, inline="always")
def _cell_of(o, lo, cell, n):
    """The cell (along one axis, grid from lo, n cells of side cell) holding o."""
    return min(n - 1, max(0, int((o - lo) / cell)))


@nb.njit(cache=True, inline="always")
def _crossings(o, d, lo, cell, i):
    """Along one axis (ray origin o, direction d) from cell i: the step to the next cell
    (+1 or -1), the distance at which the ray crosses into it, and the distance between
    crossings."""
    step = 1 if d > 0 else -1
    if abs(d) > 1e-12:
        edge = lo + (i + (1 if d > 0 else 0)) * cell
        return step, (edge - o) / d, cell / abs(d)
    return step, math.inf, math.inf


@nb.njit(cache=True, inline="always")
def _eye_cell(frame, ox, oy):
    """The cell (column, row) of an eye strictly inside the grid, where all its rays start
    their walk; (-1, -1) for an eye outside, whose rays each find where they enter."""
    gnx, gny = int(frame[3]), int(frame[4])
    x_in = frame[0] < ox < frame[0] + frame[2] * gnx
    if not (x_in and frame[1] < oy < frame[1] + frame[2] * gny):
        return -1, -1
    return _cell_of(ox, frame[0], frame[2], gnx), _cell_of(oy, frame[1], frame[2], gny)


@nb.njit(cache=True, inline="always")
def _walk_grid(shapes, grid, looks, owner, ox, oy, dx, dy, hit, i, j):
    """``hit`` updated with the fixed shapes: the ray walks the grid's cells from the eye
    outwards (Amanatides-Woo), testing the shapes of the cells that have any, until its
    nearest hit lies before the cell's far edge. (i, j): the eye's cell, from
    ``_eye_cell``."""
    frame = grid.frame
    gnx, gny = int(frame[3]), int(frame[4])
    if i < 0:  # the eye is outside the grid (or on its edge): where does the ray enter?
        t_in, t_out = _grid_span(frame, ox, oy, dx, dy, hit[0])
        if t_in > t_out:
            return hit
        i = _cell_of(ox + t_in * dx, frame[0], frame[2], gnx)
        j = _cell_of(oy + t_in * dy, frame[1], frame[2], gny)
    step_i, t_next_i, t_delta_i = _crossings(ox, dx, frame[0], frame[2], i)
    step_j, t_next_j, t_delta_j = _crossings(oy, dy, frame[1], frame[2], j)
    k = j * gnx + i
    while True:
        if grid.cell_full[k]:
            hit = _cast_cell(shapes, grid, looks, k, owner, ox, oy, dx, dy, hit)
        if hit[0] <= min(t_next_i, t_next_j):
            return hit
        if t_next_i < t_next_j:
            i += step_i
            k += step_i
            t_next_i += t_delta_i
        else:
            j += step_j
            k += step_j * gnx
            t_next_j += t_delta_j
        if i < 0 or j < 0 or i >= gnx or j >= gny:
            return hit


@nb.njit(cache=True, inline="always")
def _surface_u(pose, shapes, hit_seg, hit_circ, along, px, py):
    """Distance along the surface hit at (px, py) from where its texture starts."""
    if hit_circ >= 0:
        circ = shapes.circ_world[hit_circ]
        body = shapes.circ_body[hit_circ]
        ref = pose[body, 2] if body >= 0 else shapes.circ_angle[hit_circ]
        ang = math.atan2(py - circ[1], px - circ[0]) - ref
        ang = ang - 2.0 * math.pi * math.floor(ang / (2.0 * math.pi))
        return circ[2] * ang
    seg = shapes.seg_world[hit_seg]
    ex, ey = seg[2] - seg[0], seg[3] - seg[1]
    return shapes.seg_u0[hit_seg] + along * math.sqrt(ex * ex + ey * ey)


@nb.njit(cache=True, inline="always")
def _record(pose, shapes, looks, out, r, ox, oy, dx, dy, hit, view_range, linear):
    """Write ray r's distance, entity and pixel: the hit's colour (textured) times the
    intensity, which falls linearly with depth if ``linear``."""
    best, hit_seg, hit_circ, along = hit
    out.distance[r] = best
    depth = best / view_range
    out.image[r, 3] = depth
    if hit_seg < 0 and hit_circ < 0:
        out.hit_entity[r] = -1
        out.image[r, 0] = 0.0
        out.image[r, 1] = 0.0
        out.image[r, 2] = 0.0
        return
    e = shapes.seg_entity[hit_seg] if hit_seg >= 0 else shapes.circ_entity[hit_circ]
    out.hit_entity[r] = e
    w = 0.0
    kind = looks.texture_kind[e]
    if kind != 0:
        px, py = ox + best * dx, oy + best * dy
        u = _surface_u(pose, shapes, hit_seg, hit_circ, along, px, py)
        tex = looks.texture[e]
        w = shade(kind, tex[0], tex[1], tex[2], u, px, py)
    intensity = 1.0 - depth if linear else 1.0
    for ch in range(3):
        colour = looks.colors[e, ch] * (1.0 - w) + looks.colors[e, 3 + ch] * w
        out.image[r, ch] = min(colour, 1.0) * intensity


@nb.njit(cache=True, _nrt=False)  # type: ignore[call-overload]  # no refcounts: see the docstring
def observe(pose, shapes, grid, looks, eyes, out, scratch):
    """Move the moving shapes to their bodies' poses, then cast every ray of every eye
    into ``out`` (the structures are described in the module's docstring)."""
    _move_shapes(pose, shapes)
    for v in range(eyes.body.shape[0]):
        ox, oy, hx, hy = _place_eye(pose, eyes, v)
        owner = eyes.owner[v]
        view_range, half_fov = eyes.view_range[v], eyes.half_fov[v]
        linear = eyes.falloff[v] == FALLOFF_LINEAR
        n_rays = eyes.rays[v + 1] - eyes.rays[v]
        n_seg, n_circ = cull(
            shapes, looks, scratch, eyes.fan[v], n_rays, owner, ox, oy, hx, hy, view_range, half_fov
        )
        cell_i, cell_j = _eye_cell(grid.frame, ox, oy)
        _cast_loose(shapes, eyes, scratch, out, v, n_seg, n_circ, ox, oy, hx, hy)
        for r in range(eyes.rays[v], eyes.rays[v + 1]):
            dx, dy = _ray(eyes, r, hx, hy)
            hit = _loose_hit(shapes, out, r, ox, oy, dx, dy)
            hit = _walk_grid(shapes, grid, looks, owner, ox, oy, dx, dy, hit, cell_i, cell_j)
            _record(pose, shapes, looks, out, r, ox, oy, dx, dy, hit, view_range, linear)
