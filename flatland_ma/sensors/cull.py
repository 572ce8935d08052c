"""Which loose shapes each ray of an eye may hit: the ray kernel's cull, per eye.

Loose shapes (agents, items, movable things; see ``kernel.py``) are culled once per eye by
range and field of view, as a disc each (a circle, or a segment's bounding disc). Each one
kept also gets the span of the eye's rays it subtends: the rays of a fan are evenly spaced
(``Eyes.fan``), so the rays whose angle lies within the disc's half-width of its centre's
angle are a run of consecutive rays, found by arithmetic, and every other ray skips the
shape. Angles come from a polynomial ``_atan2`` (within 2e-6 radians) and the span is
widened by ``PAD`` on each side, so no ray that could hit a shape skips it.

A shape is kept exactly when ``_in_view`` keeps it (the test the kernel has always used),
so that every ray tests the same shapes it tested before, less those it cannot hit: the
field-of-view decision is taken from the fast angles when they clear its boundary by more
than ``PAD``, and from ``_in_view`` itself when they do not.
"""

from __future__ import annotations

import math

import numba as nb

PAD = 1e-4
"""Radians by which the angles a disc subtends are widened: far above the error of
``_atan2`` (under 2e-6) and the rounding of the hit tests (about 1e-15 radians)."""

BEHIND_FOV = 0.5 * math.pi - 1e-3
"""Eyes whose half field of view is below this see nothing wholly behind them (a disc
whose near side lies behind the line across the eye): ``in_view`` refuses such a disc by
a margin of at least 1e-3 radians when it is less than twice its radius away, far above
its rounding, so the cull refuses it without working its angles."""

_ATAN = (
    0.9999772203139088,
    -0.3326228359852716,
    0.19354037557514298,
    -0.11642641637618123,
    0.052647241655230104,
    -0.011719084003343858,
)
"""atan(z) ~ z * sum(c[k] * z**(2k)) on [0, 1], within 1.7e-6 (weighted least squares)."""


@nb.njit(cache=True, inline="always")
def unseen(looks, entity, owner):
    """Is the entity hidden, or part of the agent that owns the eye (owner -1: nobody)?"""
    return not looks.visible[entity] or (owner >= 0 and looks.owner[entity] == owner)


@nb.njit(cache=True, inline="always")
def in_view(dx, dy, radius, view_range, hx, hy, half_fov):
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
def fast_atan2(y, x):
    """atan2(y, x) within 2e-6 radians: the polynomial on [0, 1], then the octant."""
    ax, ay = abs(x), abs(y)
    big = max(ax, ay)
    z = min(ax, ay) / big if big > 0.0 else 0.0
    z2 = z * z
    c = _ATAN
    a = z * (c[0] + z2 * (c[1] + z2 * (c[2] + z2 * (c[3] + z2 * (c[4] + z2 * c[5])))))
    if ay > ax:
        a = 0.5 * math.pi - a
    if x < 0.0:
        a = math.pi - a
    return -a if y < 0.0 else a


@nb.njit(cache=True, inline="always")
def ray_span(fan, n_rays, theta, width):
    """The first and last of an eye's ``n_rays`` rays (counted from its first) whose angle
    may lie within ``width`` of ``theta`` (radians from the heading); first > last if none.
    All of them when the rays are not evenly spaced, or when the fan and the interval
    together come near a full turn (angles wrap)."""
    a0, step = fan[0], fan[1]
    half_span = 0.5 * abs(step) * (n_rays - 1)
    if step == 0.0 or half_span + width >= math.pi - PAD:
        return 0, n_rays - 1
    mid = a0 + 0.5 * step * (n_rays - 1)
    theta -= 2.0 * math.pi * math.floor((theta - mid) / (2.0 * math.pi) + 0.5)
    u_lo, u_hi = (theta - width - a0) / step, (theta + width - a0) / step
    if step < 0.0:
        u_lo, u_hi = u_hi, u_lo
    if u_hi < 0.0 or u_lo > n_rays - 1.0:
        return 0, -1
    return max(0, int(math.floor(u_lo))), min(n_rays - 1, int(math.ceil(u_hi)))


@nb.njit(cache=True, inline="always")
def disc_rays(dx, dy, radius, view_range, hx, hy, half_fov, fan, n_rays):
    """The first and last ray of an eye heading (hx, hy) that may hit a disc at offset
    (dx, dy) from it (first > last: none): the rays it subtends if ``in_view`` keeps it."""
    d2 = dx * dx + dy * dy
    if d2 <= radius * radius:
        return 0, n_rays - 1
    reach = view_range + radius
    if d2 > reach * reach:
        return 0, -1
    if half_fov < BEHIND_FOV and hx * dx + hy * dy < -radius and 4.0 * radius * radius < d2:
        return 0, -1  # wholly behind the eye, outside any field of view short of a half turn
    alpha = fast_atan2(radius, math.sqrt(d2 - radius * radius))
    theta = fast_atan2(hx * dy - hy * dx, hx * dx + hy * dy)
    limit = half_fov + alpha
    off = abs(theta) - limit  # > 0: outside the field of view
    if limit >= math.pi - PAD or abs(off) <= PAD:
        if not in_view(dx, dy, radius, view_range, hx, hy, half_fov):
            return 0, -1
    elif off > 0.0:
        return 0, -1
    return ray_span(fan, n_rays, theta, alpha + PAD)


@nb.njit(cache=True, inline="always")
def cull(shapes, looks, scratch, fan, n_rays, owner, ox, oy, hx, hy, view_range, half_fov):
    """List in ``scratch`` the loose shapes an eye at (ox, oy) heading (hx, hy) may see,
    with the span of its rays that may hit each; returns how many segments and circles
    it listed."""
    seg = shapes.seg_world
    n_seg = 0
    for s in shapes.loose_seg:
        if unseen(looks, shapes.seg_entity[s], owner):
            continue
        x1, y1, x2, y2 = seg[s, 0], seg[s, 1], seg[s, 2], seg[s, 3]
        half = 0.5 * math.sqrt((x2 - x1) ** 2 + (y2 - y1) ** 2)
        mx, my = 0.5 * (x1 + x2) - ox, 0.5 * (y1 + y2) - oy
        first, last = disc_rays(mx, my, half, view_range, hx, hy, half_fov, fan, n_rays)
        if first <= last:
            scratch.cand_seg[n_seg] = s
            scratch.seg_rays[n_seg, 0] = first
            scratch.seg_rays[n_seg, 1] = last
            n_seg += 1
    circ = shapes.circ_world
    n_circ = 0
    for s in shapes.loose_circ:
        if unseen(looks, shapes.circ_entity[s], owner):
            continue
        dx, dy = circ[s, 0] - ox, circ[s, 1] - oy
        first, last = disc_rays(dx, dy, circ[s, 2], view_range, hx, hy, half_fov, fan, n_rays)
        if first <= last:
            scratch.cand_circ[n_circ] = s
            scratch.circ_rays[n_circ, 0] = first
            scratch.circ_rays[n_circ, 1] = last
            n_circ += 1
    return n_seg, n_circ
