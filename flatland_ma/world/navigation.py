"""Where an agent's centre can be, and what it can reach: an occupancy grid of the world.

A cell is blocked when its centre lies within ``clearance`` (an agent's radius) of a solid
static shape. Reachability is a flood fill over free cells (8-connected, no squeezing
between two blocked cells). The grid serves placement (spawns and items only at reachable
places), validation (items nobody could reach) and planning (shortest paths for the
search-based policies). Rasterising and filling are compiled (numba).

Cells are half an agent's radius wide (at least one unit), and coarser when that would
make more than ``MAX_CELLS`` cells, so a grid never takes more than a few tens of MB.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
import pymunk

UNREACHED = np.iinfo(np.int32).max
MAX_CELLS = 4_000_000
"""The most cells a grid has (2,000 x 2,000): a 10,000-unit arena gets 5-unit cells."""


@nb.njit(cache=True)
def _block_polygon(blocked, verts, clearance, cell, x0, y0):
    """Mark cells whose centre is inside the convex CCW polygon or within ``clearance``."""
    ny, nx = blocked.shape
    n = verts.shape[0]
    lo_x, hi_x = verts[:, 0].min() - clearance, verts[:, 0].max() + clearance
    lo_y, hi_y = verts[:, 1].min() - clearance, verts[:, 1].max() + clearance
    i0, i1 = max(0, int((lo_y - y0) / cell)), min(ny - 1, int((hi_y - y0) / cell) + 1)
    j0, j1 = max(0, int((lo_x - x0) / cell)), min(nx - 1, int((hi_x - x0) / cell) + 1)
    c2 = clearance * clearance
    for i in range(i0, i1 + 1):
        py = y0 + (i + 0.5) * cell
        for j in range(j0, j1 + 1):
            if blocked[i, j]:
                continue
            px = x0 + (j + 0.5) * cell
            inside = True
            best = np.inf
            for k in range(n):
                ax, ay = verts[k, 0], verts[k, 1]
                bx, by = verts[(k + 1) % n, 0], verts[(k + 1) % n, 1]
                ex, ey = bx - ax, by - ay
                if ex * (py - ay) - ey * (px - ax) < 0.0:
                    inside = False
                length2 = ex * ex + ey * ey
                t = ((px - ax) * ex + (py - ay) * ey) / length2 if length2 > 0 else 0.0
                t = min(1.0, max(0.0, t))
                dx, dy = px - (ax + t * ex), py - (ay + t * ey)
                best = min(best, dx * dx + dy * dy)
            if inside or best < c2:
                blocked[i, j] = True


@nb.njit(cache=True)
def _block_circle(blocked, cx, cy, radius, clearance, cell, x0, y0):
    ny, nx = blocked.shape
    reach = radius + clearance
    i0, i1 = max(0, int((cy - reach - y0) / cell)), min(ny - 1, int((cy + reach - y0) / cell) + 1)
    j0, j1 = max(0, int((cx - reach - x0) / cell)), min(nx - 1, int((cx + reach - x0) / cell) + 1)
    for i in range(i0, i1 + 1):
        py = y0 + (i + 0.5) * cell
        for j in range(j0, j1 + 1):
            px = x0 + (j + 0.5) * cell
            if (px - cx) ** 2 + (py - cy) ** 2 < reach * reach:
                blocked[i, j] = True


@nb.njit(cache=True)
def _visit(blocked, dist, code, out, n):
    """Give the unreached free neighbours of cell ``code`` (8-connected, no corner
    cutting) its steps plus one and append them to ``out`` from ``n``; the new ``n``."""
    ny, nx = blocked.shape
    i, j = code // nx, code % nx
    for di in range(-1, 2):
        for dj in range(-1, 2):
            if di == 0 and dj == 0:
                continue
            a, b = i + di, j + dj
            if a < 0 or b < 0 or a >= ny or b >= nx or blocked[a, b]:
                continue
            if di != 0 and dj != 0 and (blocked[i + di, j] or blocked[i, j + dj]):
                continue
            if dist[a, b] == UNREACHED:
                dist[a, b] = dist[i, j] + 1
                out[n] = a * nx + b
                n += 1
    return n


@nb.njit(cache=True)
def grid_steps(blocked, starts):
    """Steps (8-connected, no corner cutting) from the nearest start cell; UNREACHED if none."""
    ny, nx = blocked.shape
    dist = np.full((ny, nx), UNREACHED, np.int32)
    queue = np.empty(ny * nx, np.int64)
    head, tail = 0, 0
    for k in range(starts.shape[0]):
        i, j = starts[k, 0], starts[k, 1]
        if not blocked[i, j] and dist[i, j] == UNREACHED:
            dist[i, j] = 0
            queue[tail] = i * nx + j
            tail += 1
    while head < tail:
        tail = _visit(blocked, dist, queue[head], queue, tail)
        head += 1
    return dist


@nb.njit(cache=True)
def grid_steps_from(blocked, start):
    """Steps as ``grid_steps``, where each free cell with ``start`` below UNREACHED is a
    start that begins at that many steps: the least of start plus steps over the starts
    (a breadth-first search level by level, each start joining at its own level)."""
    ny, nx = blocked.shape
    dist = np.full((ny, nx), UNREACHED, np.int32)
    flat = start.ravel()
    order = np.argsort(flat, kind="mergesort")
    seeds = 0
    while seeds < order.shape[0] and flat[order[seeds]] < UNREACHED:
        seeds += 1
    level_cells = np.empty(ny * nx, np.int64)
    next_cells = np.empty(ny * nx, np.int64)
    n_level, k = 0, 0
    level = flat[order[0]] if seeds > 0 else 0
    while n_level > 0 or k < seeds:
        if n_level == 0 and flat[order[k]] > level:
            level = flat[order[k]]
        while k < seeds and flat[order[k]] == level:
            code = order[k]
            k += 1
            i, j = code // nx, code % nx
            if not blocked[i, j] and dist[i, j] == UNREACHED:
                dist[i, j] = level
                level_cells[n_level] = code
                n_level += 1
        n_next = 0
        for q in range(n_level):
            n_next = _visit(blocked, dist, level_cells[q], next_cells, n_next)
        level_cells, next_cells = next_cells, level_cells
        n_level = n_next
        level += 1
    return dist


class NavGrid:
    """Free and reachable places for an agent's centre over the arena."""

    def __init__(self, size: tuple[float, float], clearance: float, cell: float | None = None):
        self.size = size
        self.clearance = clearance
        if cell is None:
            cell = max(clearance / 2.0, 1.0, math.sqrt(size[0] * size[1] / MAX_CELLS))
        self.cell = cell
        self.nx = max(1, math.ceil(size[0] / self.cell))
        self.ny = max(1, math.ceil(size[1] / self.cell))
        self.blocked = np.zeros((self.ny, self.nx), np.bool_)
        # The arena's own walls: centres closer than ``clearance`` to its edges.
        self.xs = xs = (np.arange(self.nx) + 0.5) * self.cell
        self.ys = ys = (np.arange(self.ny) + 0.5) * self.cell
        """The cells' centres along x and along y."""
        self.blocked[:, (xs < clearance) | (xs > size[0] - clearance)] = True
        self.blocked[(ys < clearance) | (ys > size[1] - clearance), :] = True

    def copy(self) -> NavGrid:
        other = NavGrid.__new__(NavGrid)
        other.__dict__.update(self.__dict__)
        other.blocked = self.blocked.copy()
        return other

    def block_entities(self, entities) -> None:
        """Block every shape of the entities that stand in agents' way for good."""
        for entity in entities:
            if entity.blocks_paths:
                for shape in entity.shapes:
                    self.block_shape(shape)

    def block_shape(self, shape: pymunk.Shape, extra: float = 0.0) -> None:
        """Mark what ``shape`` (at its body's current pose) keeps agents' centres out of."""
        self._rasterise(self.blocked, shape, extra)

    def shape_mask(self, shape: pymunk.Shape, extra: float = 0.0) -> np.ndarray:
        """The cells ``shape`` (at its body's current pose) keeps agents' centres out of."""
        mask = np.zeros_like(self.blocked)
        self._rasterise(mask, shape, extra)
        return mask

    def window(self, shape: pymunk.Shape, pad: int) -> tuple[tuple[slice, slice], np.ndarray]:
        """The cells ``shape`` keeps agents' centres out of, within a window of the grid
        around it (``pad`` cells wider on every side): ``(window, mask)``, the window as
        an index into the grid and the mask of its cells. Costs the window's area only."""
        shape.cache_bb()
        bb, reach = shape.bb, self.clearance
        i0 = max(0, int((bb.bottom - reach) / self.cell) - pad)
        j0 = max(0, int((bb.left - reach) / self.cell) - pad)
        i1 = min(self.ny, int((bb.top + reach) / self.cell) + pad + 2)
        j1 = min(self.nx, int((bb.right + reach) / self.cell) + pad + 2)
        mask = np.zeros((max(0, i1 - i0), max(0, j1 - j0)), np.bool_)
        self._rasterise(mask, shape, 0.0, (j0 * self.cell, i0 * self.cell))
        return (slice(i0, i1), slice(j0, j1)), mask

    def _rasterise(
        self, mask: np.ndarray, shape: pymunk.Shape, extra: float, origin=(0.0, 0.0)
    ) -> None:
        """Mark the cells of ``mask`` (whose cell (0, 0) has its corner at ``origin``)."""
        body = shape.body
        assert body is not None, "a shape on no body"
        at_origin = body.position == (0, 0) and body.angle == 0
        x0, y0 = float(origin[0]), float(origin[1])
        if isinstance(shape, pymunk.Circle):
            cx, cy = body.local_to_world(shape.offset)
            _block_circle(mask, cx, cy, shape.radius, self.clearance + extra, self.cell, x0, y0)
        elif isinstance(shape, pymunk.Poly):
            verts = shape.get_vertices()
            if not at_origin:
                verts = [body.local_to_world(v) for v in verts]
            verts = np.array([tuple(v) for v in verts])
            _block_polygon(mask, verts, self.clearance + extra, self.cell, x0, y0)
        else:  # pragma: no cover - the builder makes only circles and polygons
            raise TypeError(f"cannot rasterise {type(shape).__name__}")

    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        i = min(self.ny - 1, max(0, int(y / self.cell)))
        j = min(self.nx - 1, max(0, int(x / self.cell)))
        return i, j

    def centre(self, i: int, j: int) -> tuple[float, float]:
        return ((j + 0.5) * self.cell, (i + 0.5) * self.cell)

    def cells_in(
        self, rect: tuple[float, float, float, float] | None, grow: float = 0.0
    ) -> np.ndarray:
        """Boolean mask of the cells whose centre lies in ``rect`` grown by ``grow`` on
        every side (None: everywhere)."""
        mask = np.ones((self.ny, self.nx), np.bool_)
        if rect is not None:
            x0, y0, x1, y1 = rect[0] - grow, rect[1] - grow, rect[2] + grow, rect[3] + grow
            xs, ys = self.xs, self.ys
            mask &= ((ys >= y0) & (ys <= y1))[:, None] & ((xs >= x0) & (xs <= x1))[None, :]
        return mask

    def distances(self, start_mask: np.ndarray) -> np.ndarray:
        """BFS steps from the free cells of ``start_mask`` to every cell."""
        starts = np.argwhere(start_mask & ~self.blocked).astype(np.int64).reshape(-1, 2)
        return grid_steps(self.blocked, starts)

    def distances_from(self, start_steps: np.ndarray) -> np.ndarray:
        """BFS steps where every free cell with ``start_steps`` below UNREACHED is a start
        that begins at that many steps (the rest of a way that goes on from there)."""
        return grid_steps_from(self.blocked, np.ascontiguousarray(start_steps, np.int32))

    def reachable(self, start_mask: np.ndarray) -> np.ndarray:
        return self.distances(start_mask) != UNREACHED
