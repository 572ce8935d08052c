"""The ray kernel: every ray of every camera cast in one compiled call.

The world is flat arrays (see ``geometry.py``):

- segments: the edges of convex polygons, counter-clockwise, so each edge's outward
  normal is (ey, -ex); a ray only hits an edge from outside (back faces are skipped);
- circles: centre and radius;
- each segment and circle names its entity; entities carry an owner (the agent they
  belong to, whose own cameras do not see them), a visibility flag and a colour.

Shapes on moving bodies are stored in body coordinates and moved by the body poses at the
start of each call; static shapes are stored in world coordinates. Each camera ("eye")
first culls the shapes that cannot be in its view (range and field of view), then casts
its rays against what is left. Outputs per ray: the colour image (RGB times intensity, and
normalised depth), the distance and the entity hit (-1 for none).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

FALLOFF_LINEAR = 0
FALLOFF_NONE = 1


@nb.njit(cache=True, inline="always")
def _in_view(dx, dy, radius, view_range, hx, hy, half_fov):
    """Can a disc at offset (dx, dy) from the eye be seen within range and field of view?"""
    d2 = dx * dx + dy * dy
    if d2 <= radius * radius:
        return True
    d = math.sqrt(d2)
    if d - radius > view_range:
        return False
    limit = half_fov + math.asin(radius / d)
    if limit >= math.pi:
        return True
    return (dx * hx + dy * hy) >= d * math.cos(limit)


@nb.njit(cache=True)
def observe(
    pose,
    seg_local,
    seg_body,
    seg_entity,
    seg_world,
    circ_local,
    circ_body,
    circ_entity,
    circ_world,
    ent_owner,
    ent_visible,
    ent_color,
    eye_body,
    eye_local,
    eye_owner,
    eye_range,
    eye_half_fov,
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
    static shape. eye_rays (V + 1,): rays of eye v are eye_rays[v]:eye_rays[v + 1].
    ray_dir (N, 2): cosine and sine of each ray's angle relative to its eye's heading.
    Writes image (N, 4), distance (N,) and hit_entity (N,).
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
        view_range = eye_range[v]
        half_fov = eye_half_fov[v]

        n_seg = 0
        for s in range(seg_world.shape[0]):
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
        for s in range(circ_world.shape[0]):
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
            hit = -1
            for k in range(n_seg):
                s = cand_seg[k]
                x1, y1 = seg_world[s, 0], seg_world[s, 1]
                ex, ey = seg_world[s, 2] - x1, seg_world[s, 3] - y1
                denom = dx * ey - dy * ex
                if denom >= 0.0:  # parallel, or the back of the edge
                    continue
                wx, wy = x1 - ox, y1 - oy
                t = (wx * ey - wy * ex) / denom
                if t < 0.0 or t >= best:
                    continue
                u = (wx * dy - wy * dx) / denom
                if u < 0.0 or u > 1.0:
                    continue
                best = t
                hit = seg_entity[s]
            for k in range(n_circ):
                s = cand_circ[k]
                mx, my = ox - circ_world[s, 0], oy - circ_world[s, 1]
                rad = circ_world[s, 2]
                bb = mx * dx + my * dy
                cc = mx * mx + my * my - rad * rad
                if cc > 0.0 and bb > 0.0:  # outside and looking away
                    continue
                disc = bb * bb - cc
                if disc < 0.0:
                    continue
                t = -bb - math.sqrt(disc)
                if t < 0.0:  # the eye is inside the circle
                    t = 0.0
                if t < best:
                    best = t
                    hit = circ_entity[s]
            distance[r] = best
            hit_entity[r] = hit
            depth = best / view_range
            if hit >= 0:
                intensity = 1.0 - depth if eye_falloff[v] == FALLOFF_LINEAR else 1.0
                image[r, 0] = ent_color[hit, 0] * intensity
                image[r, 1] = ent_color[hit, 1] * intensity
                image[r, 2] = ent_color[hit, 2] * intensity
            else:
                image[r, 0] = 0.0
                image[r, 1] = 0.0
                image[r, 2] = 0.0
            image[r, 3] = depth


def empty_work(n_seg: int, n_circ: int) -> tuple[np.ndarray, np.ndarray]:
    """Scratch arrays the kernel fills with the shapes each eye may see."""
    return np.zeros(max(n_seg, 1), np.int32), np.zeros(max(n_circ, 1), np.int32)
