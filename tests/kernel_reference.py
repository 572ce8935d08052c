"""The ray kernel as it was before issue 29 made it faster, frozen: the reference that the
new kernel's results must equal bit for bit (image, distance, entity hit), in
tests/sensors/test_kernel.py, and the "before" of benchmarks/rays.py. Used nowhere else; do not
edit it, except to keep it compiling.

It reads the same named tuples as ``flatland_ma.sensors.kernel.observe`` (fields added
since are ignored): loose shapes culled per eye by range and field of view, then tested
against every ray of the eye; fixed shapes in a grid walked cell by cell by every ray.
"""

from __future__ import annotations

import math

import numba as nb

from flatland_ma.sensors.textures import shade

FALLOFF_LINEAR = 0
FALLOFF_NONE = 1


@nb.njit(cache=True, inline="always")
def _in_view(dx, dy, radius, view_range, hx, hy, half_fov):
    """Can a disc at offset (dx, dy) from the eye be seen within range and field of view?"""
    d2 = dx * dx + dy * dy
    if d2 <= radius * radius:
        return True
    reach = view_range + radius
    if d2 > reach * reach:
        return False
    d = math.sqrt(d2)
    limit = half_fov + math.asin(radius / d)
    if limit >= math.pi:
        return True
    return (dx * hx + dy * hy) >= d * math.cos(limit)


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
def _unseen(looks, entity, owner):
    """Is the entity hidden, or part of the agent that owns the eye (owner -1: nobody)?"""
    return not looks.visible[entity] or (owner >= 0 and looks.owner[entity] == owner)


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
def _cull(shapes, looks, scratch, owner, ox, oy, hx, hy, view_range, half_fov):
    """List in ``scratch`` the loose shapes an eye at (ox, oy) heading (hx, hy) may see;
    returns how many segments and circles it listed."""
    seg = shapes.seg_world
    n_seg = 0
    for s in shapes.loose_seg:
        if _unseen(looks, shapes.seg_entity[s], owner):
            continue
        x1, y1, x2, y2 = seg[s, 0], seg[s, 1], seg[s, 2], seg[s, 3]
        half = 0.5 * math.sqrt((x2 - x1) ** 2 + (y2 - y1) ** 2)
        mx, my = 0.5 * (x1 + x2) - ox, 0.5 * (y1 + y2) - oy
        if _in_view(mx, my, half, view_range, hx, hy, half_fov):
            scratch.cand_seg[n_seg] = s
            n_seg += 1
    circ = shapes.circ_world
    n_circ = 0
    for s in shapes.loose_circ:
        if _unseen(looks, shapes.circ_entity[s], owner):
            continue
        dx, dy = circ[s, 0] - ox, circ[s, 1] - oy
        if _in_view(dx, dy, circ[s, 2], view_range, hx, hy, half_fov):
            scratch.cand_circ[n_circ] = s
            n_circ += 1
    return n_seg, n_circ


@nb.njit(cache=True, inline="always")
def _cast_loose(shapes, scratch, n_seg, n_circ, ox, oy, dx, dy, best):
    """The nearest of the listed loose shapes nearer than ``best`` along the ray from
    (ox, oy) in direction (dx, dy): (distance, segment, circle, fraction along the
    segment), -1 for no segment or no circle."""
    hit_seg, hit_circ, hit_along = -1, -1, 0.0
    for k in range(n_seg):
        s = scratch.cand_seg[k]
        t, along = _segment_t(shapes.seg_world, s, ox, oy, dx, dy, best)
        if t >= 0.0:
            best, hit_seg, hit_along = t, s, along
    for k in range(n_circ):
        s = scratch.cand_circ[k]
        t = _circle_t(shapes.circ_world, s, ox, oy, dx, dy, best)
        if t >= 0.0:
            best, hit_seg, hit_circ = t, -1, s
    return best, hit_seg, hit_circ, hit_along


@nb.njit(cache=True, inline="always")
def _cast_cell(shapes, grid, looks, k, owner, ox, oy, dx, dy, hit):
    """``hit`` (as ``_cast_loose`` returns it) updated with the shapes of grid cell k."""
    best, hit_seg, hit_circ, hit_along = hit
    for q in range(grid.cell_seg_start[k], grid.cell_seg_start[k + 1]):
        s = grid.cell_seg[q]
        if _unseen(looks, shapes.seg_entity[s], owner):
            continue
        t, along = _segment_t(shapes.seg_world, s, ox, oy, dx, dy, best)
        if t >= 0.0:
            best, hit_seg, hit_circ, hit_along = t, s, -1, along
    for q in range(grid.cell_circ_start[k], grid.cell_circ_start[k + 1]):
        s = grid.cell_circ[q]
        if _unseen(looks, shapes.circ_entity[s], owner):
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
def _first_cell(o, d, lo, cell, n, t_in):
    """Along one axis (ray origin o, direction d; grid from lo, n cells of side cell): the
    cell the ray enters at t_in, the step to the next cell (+1 or -1), the distance at
    which it crosses into the next cell, and the distance between crossings."""
    i = min(n - 1, max(0, int((o + t_in * d - lo) / cell)))
    step = 1 if d > 0 else -1
    if abs(d) > 1e-12:
        edge = lo + (i + (1 if d > 0 else 0)) * cell
        return i, step, (edge - o) / d, cell / abs(d)
    return i, step, math.inf, math.inf


@nb.njit(cache=True, inline="always")
def _walk_grid(shapes, grid, looks, owner, ox, oy, dx, dy, hit):
    """``hit`` updated with the fixed shapes: the ray walks the grid's cells from the eye
    outwards (Amanatides-Woo) until its nearest hit lies before the cell's far edge."""
    frame = grid.frame
    t_in, t_out = _grid_span(frame, ox, oy, dx, dy, hit[0])
    if t_in > t_out:
        return hit
    gnx, gny = int(frame[3]), int(frame[4])
    i, step_i, t_next_i, t_delta_i = _first_cell(ox, dx, frame[0], frame[2], gnx, t_in)
    j, step_j, t_next_j, t_delta_j = _first_cell(oy, dy, frame[1], frame[2], gny, t_in)
    while True:
        hit = _cast_cell(shapes, grid, looks, j * gnx + i, owner, ox, oy, dx, dy, hit)
        if hit[0] <= min(t_next_i, t_next_j):
            return hit
        if t_next_i < t_next_j:
            i += step_i
            t_next_i += t_delta_i
        else:
            j += step_j
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
        n_seg, n_circ = _cull(shapes, looks, scratch, owner, ox, oy, hx, hy, view_range, half_fov)
        for r in range(eyes.rays[v], eyes.rays[v + 1]):
            lc, ls = eyes.ray_dir[r, 0], eyes.ray_dir[r, 1]
            dx = hx * lc - hy * ls
            dy = hy * lc + hx * ls
            hit = _cast_loose(shapes, scratch, n_seg, n_circ, ox, oy, dx, dy, view_range)
            hit = _walk_grid(shapes, grid, looks, owner, ox, oy, dx, dy, hit)
            _record(pose, shapes, looks, out, r, ox, oy, dx, dy, hit, view_range, linear)
