"""The ray kernel: every ray of every camera cast in one compiled call.

The world is flat arrays (see ``geometry.py``):

- segments: the edges of convex polygons, counter-clockwise, so each edge's outward
  normal is (ey, -ex); a ray only hits an edge from outside (back faces are skipped).
  Each edge also knows how far along its polygon's perimeter it starts (for textures);
- circles: centre and radius, and the angle textures start from;
- each segment and circle names its entity; entities carry an owner (the agent they
  belong to, whose own cameras do not see them), a visibility flag, two colours and a
  texture (kind and parameters; see ``textures.py``).

Shapes on moving bodies are stored in body coordinates and moved by the body poses at the
start of each call; static shapes are stored in world coordinates. Shapes that never move
(walls, fixed obstacles, doors) are also binned in a uniform grid: each ray walks the grid
cells it crosses, nearest first (a DDA), and stops once its nearest hit lies before the
cell's far edge. Everything else ("loose" shapes: agents, items, movable things) is culled
per camera ("eye") by range and field of view, then tested against every ray of that eye.
Outputs per ray: the colour image (RGB times intensity, and normalised depth), the
distance and the entity hit (-1 for none).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

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


@nb.njit(cache=True)
def observe(
    pose,
    seg_local,
    seg_world,
    seg_body,
    seg_entity,
    seg_u0,
    circ_local,
    circ_world,
    circ_body,
    circ_entity,
    circ_angle,
    loose_seg,
    loose_circ,
    grid,
    cell_seg_start,
    cell_seg,
    cell_circ_start,
    cell_circ,
    ent_owner,
    ent_visible,
    ent_colors,
    ent_texture,
    ent_texture_kind,
    eye_body,
    eye_local,
    eye_owner,
    eye_view,
    eye_falloff,
    eye_rays,
    ray_dir,
    image,
    distance,
    hit_entity,
    cand_seg,
    cand_circ,
):
    """Move the moving shapes to their bodies' poses, then cast every ray.

    pose (B, 3): x, y, angle of each moving body. *_body: index into pose, or -1 for a
    static shape. loose_seg, loose_circ: indices of the shapes not in the grid. grid:
    x0, y0, cell size, columns, rows; cell k lists cell_seg[cell_seg_start[k]:
    cell_seg_start[k + 1]] (likewise circles). ent_colors (E, 6): first and second
    colour. ent_texture (E, 3): period, duty, seed. eye_view (V, 2): range and half field
    of view. eye_rays (V + 1,): rays of eye v are eye_rays[v]:eye_rays[v + 1]. ray_dir
    (N, 2): cosine and sine of each ray's angle relative to its eye's heading.
    Writes image (N, 4), distance (N,), hit_entity (N,).
    """
    for s in range(seg_local.shape[0]):
        b = seg_body[s]
        if b >= 0:
            px, py, a = pose[b, 0], pose[b, 1], pose[b, 2]
            c, sn = math.cos(a), math.sin(a)
            for k in range(2):
                lx, ly = seg_local[s, 2 * k], seg_local[s, 2 * k + 1]
                seg_world[s, 2 * k] = px + c * lx - sn * ly
                seg_world[s, 2 * k + 1] = py + sn * lx + c * ly
    for s in range(circ_local.shape[0]):
        b = circ_body[s]
        if b >= 0:
            px, py, a = pose[b, 0], pose[b, 1], pose[b, 2]
            c, sn = math.cos(a), math.sin(a)
            lx, ly = circ_local[s, 0], circ_local[s, 1]
            circ_world[s, 0] = px + c * lx - sn * ly
            circ_world[s, 1] = py + sn * lx + c * ly
            circ_world[s, 2] = circ_local[s, 2]

    gx0, gy0, cell = grid[0], grid[1], grid[2]
    gnx, gny = int(grid[3]), int(grid[4])
    for v in range(eye_body.shape[0]):
        b = eye_body[v]
        if b >= 0:
            px, py, a = pose[b, 0], pose[b, 1], pose[b, 2]
            c, sn = math.cos(a), math.sin(a)
            ox = px + c * eye_local[v, 0] - sn * eye_local[v, 1]
            oy = py + sn * eye_local[v, 0] + c * eye_local[v, 1]
            heading = a + eye_local[v, 2]
        else:
            ox, oy, heading = eye_local[v, 0], eye_local[v, 1], eye_local[v, 2]
        hx, hy = math.cos(heading), math.sin(heading)
        owner = eye_owner[v]
        view_range = eye_view[v, 0]
        half_fov = eye_view[v, 1]

        n_seg = 0
        for k in range(loose_seg.shape[0]):
            s = loose_seg[k]
            e = seg_entity[s]
            if not ent_visible[e] or (owner >= 0 and ent_owner[e] == owner):
                continue
            x1, y1, x2, y2 = seg_world[s, 0], seg_world[s, 1], seg_world[s, 2], seg_world[s, 3]
            half = 0.5 * math.sqrt((x2 - x1) ** 2 + (y2 - y1) ** 2)
            mx, my = 0.5 * (x1 + x2) - ox, 0.5 * (y1 + y2) - oy
            if _in_view(mx, my, half, view_range, hx, hy, half_fov):
                cand_seg[n_seg] = s
                n_seg += 1
        n_circ = 0
        for k in range(loose_circ.shape[0]):
            s = loose_circ[k]
            e = circ_entity[s]
            if not ent_visible[e] or (owner >= 0 and ent_owner[e] == owner):
                continue
            dx, dy = circ_world[s, 0] - ox, circ_world[s, 1] - oy
            if _in_view(dx, dy, circ_world[s, 2], view_range, hx, hy, half_fov):
                cand_circ[n_circ] = s
                n_circ += 1

        for r in range(eye_rays[v], eye_rays[v + 1]):
            lc, ls = ray_dir[r, 0], ray_dir[r, 1]
            dx = hx * lc - hy * ls
            dy = hy * lc + hx * ls
            best = view_range
            hit_seg = -1
            hit_circ = -1
            hit_along = 0.0
            for k in range(n_seg):
                s = cand_seg[k]
                t, along = _segment_t(seg_world, s, ox, oy, dx, dy, best)
                if t >= 0.0:
                    best, hit_seg, hit_along = t, s, along
            for k in range(n_circ):
                s = cand_circ[k]
                t = _circle_t(circ_world, s, ox, oy, dx, dy, best)
                if t >= 0.0:
                    best, hit_seg, hit_circ = t, -1, s

            # Walk the grid of fixed shapes from the eye outwards (Amanatides-Woo).
            t_in = 0.0
            t_out = best
            for axis in range(2):
                o = ox if axis == 0 else oy
                d = dx if axis == 0 else dy
                lo = gx0 if axis == 0 else gy0
                hi = lo + cell * (gnx if axis == 0 else gny)
                if abs(d) < 1e-12:
                    if o < lo or o > hi:
                        t_in = t_out + 1.0
                else:
                    ta, tb = (lo - o) / d, (hi - o) / d
                    if ta > tb:
                        ta, tb = tb, ta
                    t_in = max(t_in, ta)
                    t_out = min(t_out, tb)
            if t_in <= t_out:
                cx = ox + t_in * dx
                cy = oy + t_in * dy
                i = min(gnx - 1, max(0, int((cx - gx0) / cell)))
                j = min(gny - 1, max(0, int((cy - gy0) / cell)))
                step_i = 1 if dx > 0 else -1
                step_j = 1 if dy > 0 else -1
                if abs(dx) > 1e-12:
                    edge = gx0 + (i + (1 if dx > 0 else 0)) * cell
                    t_next_i = (edge - ox) / dx
                    t_delta_i = cell / abs(dx)
                else:
                    t_next_i = np.inf
                    t_delta_i = np.inf
                if abs(dy) > 1e-12:
                    edge = gy0 + (j + (1 if dy > 0 else 0)) * cell
                    t_next_j = (edge - oy) / dy
                    t_delta_j = cell / abs(dy)
                else:
                    t_next_j = np.inf
                    t_delta_j = np.inf
                while True:
                    k = j * gnx + i
                    for q in range(cell_seg_start[k], cell_seg_start[k + 1]):
                        s = cell_seg[q]
                        e = seg_entity[s]
                        if not ent_visible[e] or (owner >= 0 and ent_owner[e] == owner):
                            continue
                        t, along = _segment_t(seg_world, s, ox, oy, dx, dy, best)
                        if t >= 0.0:
                            best, hit_seg, hit_circ, hit_along = t, s, -1, along
                    for q in range(cell_circ_start[k], cell_circ_start[k + 1]):
                        s = cell_circ[q]
                        e = circ_entity[s]
                        if not ent_visible[e] or (owner >= 0 and ent_owner[e] == owner):
                            continue
                        t = _circle_t(circ_world, s, ox, oy, dx, dy, best)
                        if t >= 0.0:
                            best, hit_seg, hit_circ = t, -1, s
                    t_exit = min(t_next_i, t_next_j)
                    if best <= t_exit:
                        break
                    if t_next_i < t_next_j:
                        i += step_i
                        t_next_i += t_delta_i
                    else:
                        j += step_j
                        t_next_j += t_delta_j
                    if i < 0 or j < 0 or i >= gnx or j >= gny:
                        break

            distance[r] = best
            depth = best / view_range
            image[r, 3] = depth
            if hit_seg >= 0:
                hit = seg_entity[hit_seg]
            elif hit_circ >= 0:
                hit = circ_entity[hit_circ]
            else:
                hit_entity[r] = -1
                image[r, 0] = 0.0
                image[r, 1] = 0.0
                image[r, 2] = 0.0
                continue
            hit_entity[r] = hit
            w = 0.0
            kind = ent_texture_kind[hit]
            if kind != 0:
                px, py = ox + best * dx, oy + best * dy
                if hit_circ >= 0:
                    cb = circ_body[hit_circ]
                    ref = pose[cb, 2] if cb >= 0 else circ_angle[hit_circ]
                    ang = (
                        math.atan2(py - circ_world[hit_circ, 1], px - circ_world[hit_circ, 0]) - ref
                    )
                    ang = ang - 2.0 * math.pi * math.floor(ang / (2.0 * math.pi))
                    u = circ_world[hit_circ, 2] * ang
                else:
                    ex = seg_world[hit_seg, 2] - seg_world[hit_seg, 0]
                    ey = seg_world[hit_seg, 3] - seg_world[hit_seg, 1]
                    u = seg_u0[hit_seg] + hit_along * math.sqrt(ex * ex + ey * ey)
                tex = ent_texture[hit]
                w = shade(kind, tex[0], tex[1], tex[2], u, px, py)
            intensity = 1.0 - depth if eye_falloff[v] == FALLOFF_LINEAR else 1.0
            for ch in range(3):
                colour = ent_colors[hit, ch] * (1.0 - w) + ent_colors[hit, 3 + ch] * w
                image[r, ch] = min(colour, 1.0) * intensity


def empty_work(n_seg: int, n_circ: int) -> tuple[np.ndarray, np.ndarray]:
    """Scratch arrays the kernel fills with the shapes each eye may see."""
    return np.zeros(max(n_seg, 1), np.int32), np.zeros(max(n_circ, 1), np.int32)


def bin_fixed_shapes(seg_world, seg_fixed, circ_world, circ_fixed, target_cells: int = 1024):
    """A uniform grid over the fixed shapes: (grid, cell_seg_start, cell_seg,
    cell_circ_start, cell_circ), each shape listed in every cell its bounding box meets."""
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
        return np.array([0.0, 0.0, 1.0, 1.0, 1.0]), empty, empty[:0], empty, empty[:0]
    all_boxes = np.concatenate(boxes)
    x0, y0 = all_boxes[:, 0].min() - 1.0, all_boxes[:, 1].min() - 1.0
    x1, y1 = all_boxes[:, 2].max() + 1.0, all_boxes[:, 3].max() + 1.0
    cell = max(math.sqrt((x1 - x0) * (y1 - y0) / target_cells), 1.0)
    nx, ny = max(1, math.ceil((x1 - x0) / cell)), max(1, math.ceil((y1 - y0) / cell))
    grid = np.array([x0, y0, cell, nx, ny], np.float64)

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
    return grid, seg_start, segs, circ_start, circs
