"""The compiled kernels of scent (``scent``): spreading distances from the items over the
free cells, and reading them at points.

The kernels work on the grid padded with a border of blocked cells and flattened (cell
(i, j) of the padded grid is entry ``i * width + j``), in cell units: the point (x, y) of
the world is at (x / cell + 1, y / cell + 1), and padded cell (i, j) spans [j, j + 1) x
[i, i + 1). The border spares the kernels every bounds check.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

SQRT2 = math.sqrt(2.0)
CORNER = 0.5 - 1e-6
"""How far from a cell's centre, along each axis, a path bending round one of its corners
turns: at the corner, a hair inside the cell."""
BUCKETS = 4
"""Buckets of the search's queue, each one cell of distance wide, used round in turn: a
step never adds more than the square root of two, so every waiting cell lies in the
bucket being emptied or the next two."""


@nb.njit(cache=True, inline="always")
def _norm(x, y):
    """The length of (x, y) (faster than ``math.hypot``, which guards against overflow)."""
    return math.sqrt(x * x + y * y)


@nb.njit(cache=True, inline="always")
def _blocked_in(table, i0, i1, j0, j1):
    """How many blocked cells rows i0..i1 and columns j0..j1 hold (``table``: the grid's
    summed-area table, see ``summed``)."""
    return table[i1 + 1, j1 + 1] - table[i0, j1 + 1] - table[i1 + 1, j0] + table[i0, j0]


@nb.njit(cache=True)
def _walk(blocked, width, ax, ay, dx, dy, t0, t1):
    """Whether the cells the segment (ax, ay) + t (dx, dy) crosses for t in [t0, t1] are
    all free; through a cell corner, both cells beside it must be free."""
    i, j = int(ay + t0 * dy), int(ax + t0 * dx)
    k = i * width + j
    sj = 1 if dx > 0 else -1
    si = 1 if dy > 0 else -1
    for _ in range(blocked.shape[0]):
        if blocked[k]:
            return False
        tx = ((j + 1 - ax) if dx > 0 else (j - ax)) / dx if dx != 0 else np.inf
        ty = ((i + 1 - ay) if dy > 0 else (i - ay)) / dy if dy != 0 else np.inf
        if min(tx, ty) >= t1:
            return True
        if abs(tx - ty) < 1e-9:
            if blocked[k + sj] or blocked[k + si * width]:
                return False
            i, j = i + si, j + sj
        elif tx < ty:
            j += sj
        else:
            i += si
        k = i * width + j
    return False


@nb.njit(cache=True, inline="always")
def _sees(blocked, table, width, ax, ay, bx, by):
    """Whether the segment from (ax, ay) to (bx, by), both inside the grid, crosses free
    cells only; through a cell corner, both cells beside it must be free. Stretches whose
    bounding box holds no blocked cell (counted in O(1) from the summed-area ``table``)
    pass at once, stretches twice as long are tried next; a stretch that meets one is
    halved, and walked cell by cell once it spans a few cells only."""
    dx, dy = bx - ax, by - ay
    t, h = 0.0, 1.0
    while t < 1.0:
        e = min(1.0, t + h)
        x0, y0, x1, y1 = ax + t * dx, ay + t * dy, ax + e * dx, ay + e * dy
        j0, j1 = int(min(x0, x1)), int(max(x0, x1))
        i0, i1 = int(min(y0, y1)), int(max(y0, y1))
        if _blocked_in(table, i0, i1, j0, j1) == 0:
            t, h = e, 2.0 * h
        elif i1 - i0 + j1 - j0 <= 3:
            if not _walk(blocked, width, ax, ay, dx, dy, t, e):
                return False
            t, h = e, 2.0 * h
        else:
            h = 0.5 * (e - t)
    return True


def summed(blocked: np.ndarray) -> np.ndarray:
    """The summed-area table of a grid: entry (i, j) counts the blocked cells of rows
    below i and columns left of j."""
    table = np.zeros((blocked.shape[0] + 1, blocked.shape[1] + 1), np.int32)
    table[1:, 1:] = blocked.astype(np.int32).cumsum(axis=0).cumsum(axis=1)
    return table


@nb.njit(cache=True)
def _nearest_usable(blocked, dist, width, x, y, reached):
    """The free cell (and, if ``reached``, one the search reached in ``dist``) among the
    cell of (x, y) and its eight neighbours whose centre is nearest to (x, y); -1 if
    none."""
    i, j = int(y), int(x)
    best, found = np.inf, -1
    for a in range(i - 1, i + 2):
        for c in range(j - 1, j + 2):
            k = a * width + c
            if blocked[k] or (reached and dist[k] == np.inf):
                continue
            gap = (c + 0.5 - x) ** 2 + (a + 0.5 - y) ** 2
            if gap < best:
                best, found = gap, k
    return found


@nb.njit(cache=True)
def spread(blocked, table, width, sources, reach, dist, pivot, base, cells, queued_at, after):
    """Fill ``dist`` with the distance of each cell's centre from the nearest of
    ``sources`` ((m, 2) points x, y, inside the grid), around blocked cells; ``pivot``
    (cells, 2) with the point each cell's path last bends at (or its source) and ``base``
    with that pivot's distance; ``table`` as ``_sees`` takes it. Cells farther than
    ``reach`` stay at infinity. A source in a blocked cell starts from the nearest free
    cell beside it. ``cells``, ``queued_at`` and ``after`` (of one length, more than the
    sources) are room for the queue; returns False, the field unfinished, if they are
    too short.

    The sources' cells are queued first, then the search takes cells nearest first
    (``_search``). The helpers are plain compiled functions, not inlined: numba's inlining
    made the search slower."""
    dist[:] = np.inf
    waiting = _queue_sources(
        blocked, width, sources, reach, dist, pivot, base, cells, queued_at, after
    )
    if waiting <= 0:
        return waiting == 0  # no source reaches a free cell (done), or no room for them
    return _search(
        blocked, table, width, reach, dist, pivot, base, cells, queued_at, after, waiting
    )


@nb.njit(cache=True)
def _queue_sources(blocked, width, sources, reach, dist, pivot, base, cells, queued_at, after):
    """Set the distance of the cell of each of ``sources`` (for a source in a blocked cell,
    of the nearest free cell beside it, that cell's centre its pivot) and queue it in entry
    0, 1, ...; returns how many were queued, or -1 if ``after`` is too short for them."""
    room = after.shape[0]
    waiting = 0
    for s in range(sources.shape[0]):
        sx, sy = sources[s, 0], sources[s, 1]
        k = int(sy) * width + int(sx)
        px, py, b = sx, sy, 0.0
        if blocked[k]:
            k = _nearest_usable(blocked, dist, width, sx, sy, False)
            if k < 0:
                continue
            px, py = k % width + 0.5, k // width + 0.5
            b = _norm(px - sx, py - sy)
        new = b + _norm(k % width + 0.5 - px, k // width + 0.5 - py)
        if new < dist[k] and new <= reach:
            if waiting == room:
                return -1
            dist[k], base[k], pivot[k, 0], pivot[k, 1] = new, b, px, py
            cells[waiting], queued_at[waiting], after[waiting] = k, new, waiting + 1
            waiting += 1
    return waiting


@nb.njit(cache=True)
def _search(blocked, table, width, reach, dist, pivot, base, cells, queued_at, after, waiting):
    """Take the ``waiting`` queued cells and those they make shorter, nearest first (see
    ``_start_queue``); each offers its neighbours its pivot if they see it, else a bend in
    it (``_bend``). False if the entries run out."""
    heads = np.full(2 * BUCKETS, -1, np.int64)
    unused = _start_queue(heads, after, waiting)
    level = 0
    while waiting > 0:
        while heads[level % BUCKETS] < 0:
            level += 1
        q = level % BUCKETS
        e = heads[q]  # the first entry of the nearest bucket that holds one
        heads[q] = after[e]
        if heads[q] < 0:
            heads[BUCKETS + q] = -1
        k, when = cells[e], queued_at[e]
        after[e], unused = unused, e
        waiting -= 1
        d = dist[k]
        if when != d:
            continue  # the cell was queued again since, shorter
        i = k // width
        cx, cy = k - i * width + 0.5, i + 0.5
        b, px, py = base[k], pivot[k, 0], pivot[k, 1]
        for di in range(-1, 2):
            for dj in range(-1, 2):
                n = k + di * width + dj
                if n == k or blocked[n]:
                    continue
                if di != 0 and dj != 0 and (blocked[k + di * width] or blocked[k + dj]):
                    continue  # diagonal, past a wall's corner
                ex, ey = cx + dj, cy + di
                gap = dist[n] - 1e-9 - b
                gx, gy = ex - px, ey - py
                if gap <= 0.0 or gx * gx + gy * gy >= gap * gap:
                    continue  # not shorter straight, nor (longer still) round here
                if _sees(blocked, table, width, px, py, ex, ey):
                    new, npx, npy, nb_ = b + _norm(gx, gy), px, py, b
                else:
                    new, npx, npy, nb_ = _bend(blocked, table, width, d, k, di, dj, b, px, py)
                    if new >= dist[n] - 1e-9:
                        continue
                if new > reach:
                    continue
                if unused < 0:
                    return False
                dist[n], base[n], pivot[n, 0], pivot[n, 1] = new, nb_, npx, npy
                e, unused = unused, after[unused]
                cells[e], queued_at[e], after[e] = n, new, -1  # appended to its bucket:
                q = max(int(new), level) % BUCKETS
                if heads[BUCKETS + q] < 0:
                    heads[q] = e
                else:
                    after[heads[BUCKETS + q]] = e
                heads[BUCKETS + q] = e
                waiting += 1
    return True


@nb.njit(cache=True)
def _start_queue(heads, after, waiting):
    """Make the first ``waiting`` entries the first bucket and chain the rest as unused;
    returns the first unused entry, -1 if none.

    The queue: ``BUCKETS`` buckets one cell of distance wide, used round in turn, each a
    chain of entries taken first in first out; entry e holds a cell ``cells[e]``, its
    distance when queued ``queued_at[e]`` and the next entry of its chain ``after[e]``.
    ``heads[q]`` is the first entry of bucket q, ``heads[BUCKETS + q]`` its last (-1: the
    bucket is empty). A cell queued at distance d joins bucket ``int(d)`` (or the one
    being taken, if nearer), modulo ``BUCKETS``."""
    room = after.shape[0]
    heads[0], heads[BUCKETS] = 0, waiting - 1
    after[waiting - 1] = -1
    for e in range(waiting, room):
        after[e] = e + 1
    after[room - 1] = -1
    return waiting if waiting < room else -1


@nb.njit(cache=True)
def _bend(blocked, table, width, d, k, di, dj, b, px, py):
    """Where the path from the pivot (px, py), ``b`` from the sources, to the centre of
    the cell di rows and dj columns from cell k bends in cell k when it does not see the
    pivot: at the corner of cell k that touches blocked cells and sees both the pivot and
    that centre (the shortest such), else at cell k's centre, ``d`` from the sources.
    Returns (length, bend x, bend y, the bend's distance from the sources)."""
    i = k // width
    cx, cy = k - i * width + 0.5, i + 0.5
    ex, ey = cx + dj, cy + di
    new, npx, npy, nb_ = d + (SQRT2 if di != 0 and dj != 0 else 1.0), cx, cy, d
    for oy in (-1, 1):
        for ox in (-1, 1):
            if not (blocked[k + oy * width] or blocked[k + ox] or blocked[k + oy * width + ox]):
                continue  # no blocked cell at this corner of the cell
            vx, vy = cx + ox * CORNER, cy + oy * CORNER
            bv = b + _norm(vx - px, vy - py)
            around = bv + _norm(ex - vx, ey - vy)
            if around >= new:
                continue
            if _sees(blocked, table, width, px, py, vx, vy) and _sees(
                blocked, table, width, vx, vy, ex, ey
            ):
                new, npx, npy, nb_ = around, vx, vy, bv
    return new, npx, npy, nb_


@nb.njit(cache=True)
def read_points(blocked, width, dist, pivot, base, points, fallback, out):
    """``out[k, c]``: the distance of ``points[k]`` from channel c's sources (``dist``,
    ``pivot``, ``base`` stacked by channel), in cell units; infinity if none is in reach.
    A point in a blocked or unreached cell reads the nearest usable cell beside it, else
    ``fallback`` (the agent's centre)."""
    for k in range(points.shape[0]):
        for c in range(dist.shape[0]):
            d = _read_point(blocked, width, dist[c], pivot[c], base[c], points[k, 0], points[k, 1])
            if d == np.inf:
                d = _read_point(
                    blocked, width, dist[c], pivot[c], base[c], fallback[0], fallback[1]
                )
            out[k, c] = d


@nb.njit(cache=True)
def _read_point(blocked, width, dist, pivot, base, x, y):
    """The distance of (x, y) from one channel's sources, through the pivot of its cell
    or of the nearest usable cell beside it; infinity if there is none."""
    k = _nearest_usable(blocked, dist, width, x, y, True)
    if k < 0:
        return np.inf
    return base[k] + _norm(x - pivot[k, 0], y - pivot[k, 1])


@nb.njit(cache=True)
def sniff(
    blocked, width, dist, pivot, base, top, x, y, heading, reach_out, angle, scale, fade, limit, out
):
    """Fill ``out`` (2, channels) with what two nostrils smell: ``exp(-d / fade)`` for a
    distance d below ``limit``, else 0. The nostrils are ``reach_out`` from (x, y) (world
    units, ``scale`` cells per unit), ``angle`` radians left (row 0) and right (row 1) of
    ``heading``; a nostril in a wall reads the free cell beside it, else the centre;
    ``top`` is the highest point of the grid; distances are in cell units."""
    cx = min(max(x * scale + 1.0, 1.0), top[0])
    cy = min(max(y * scale + 1.0, 1.0), top[1])
    for side in range(2):
        a = heading + angle if side == 0 else heading - angle
        nx = min(max((x + reach_out * math.cos(a)) * scale + 1.0, 1.0), top[0])
        ny = min(max((y + reach_out * math.sin(a)) * scale + 1.0, 1.0), top[1])
        for c in range(dist.shape[0]):
            d = _read_point(blocked, width, dist[c], pivot[c], base[c], nx, ny)
            if d == np.inf:
                d = _read_point(blocked, width, dist[c], pivot[c], base[c], cx, cy)
            out[side, c] = math.exp(-d / fade) if d < limit else 0.0
