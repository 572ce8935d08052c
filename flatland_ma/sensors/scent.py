"""Scent: how far each point of the arena is from the nearest live item of a kind, going
around walls rather than through them.

The field lives on a grid of its own (``cell`` wide cells) with the cells under walls and
fixed obstacles blocked: those whose centre lies inside one, and around a wall thinner
than a cell a band just over a cell wide, so that no wall leaves a gap (see ``COVER``).
Unlike the navigation grid there is no clearance for an agent's body: scent reaches right
up to a wall. Agents, items, doors (closed or open: scent seeps under them) and movable
things let scent through.

Distances spread from the items over the free cells, nearest first (a shortest-path
search, 8-connected, never squeezing diagonally between two blocked cells), but each cell
keeps a *pivot*: the farthest point back along its path that it sees in a straight line,
the item itself in the open, else the last corner the path bends around. A cell's distance
is its pivot's plus the straight line to the pivot. So distances are Euclidean in the open
and bend only at corners, taken at the corner of the blocked cells: exact where walls lie
on cell edges, else off by less than a cell per corner (as far as the blocked cells stray
from the walls). Counting grid steps instead (as ``navigation.grid_steps`` does) is up to
29% short, and weighting diagonals by the square root of two up to 8% long. A point
between cell centres is read from its cell's pivot the same way, so readings vary
smoothly as an agent moves. Searching and reading are compiled (numba, ``scent_kernel``);
the search stops at ``reach``, beyond which a point smells of nothing.
"""

from __future__ import annotations

import math

import numpy as np
import pymunk

from flatland_ma.sensors.scent_kernel import read_points, sniff, spread, summed
from flatland_ma.world.entities import Item
from flatland_ma.world.navigation import NavGrid
from flatland_ma.world.world import World

COVER = 0.51
"""A cell is blocked when its centre lies inside a wall or an obstacle at least a cell
thick; around a thinner one, when its centre lies within this many cells of the middle:
just over half a cell, so that a wall, however thin and whatever its slant, blocks a chain
of cells the search cannot cross (it never steps diagonally past a blocked cell)."""
MAX_CELLS = 500_000
"""The most cells the fields of one scent field's channels have in all (about 16 MB): a
channel of a 300 x 300 arena may have cells down to 0.6 wide, one of a 10,000-unit arena
down to 14 (coarser cells are used if finer ones are asked for)."""


def scent_grid(world: World, cell: float, channels: int = 1) -> NavGrid:
    """The grid scent spreads over: ``cell`` wide (coarser if ``channels`` fields over the
    arena would need more than ``MAX_CELLS`` cells in all), the cells under walls and
    fixed obstacles blocked (see ``COVER``)."""
    w, h = world.size
    cell = max(cell, math.sqrt(w * h * channels / MAX_CELLS))
    grid = NavGrid(world.size, 0.0, cell)
    for entity in world.entities:
        if entity.blocks_paths:
            for shape in entity.shapes:
                wide = thickness(shape)
                if wide < cell:
                    grid.block_shape(shape, COVER * cell - wide / 2)
                else:
                    grid.block_shape(_nudged(shape, 1e-7 * cell))
    return grid


def _nudged(shape: pymunk.Shape, hair: float) -> pymunk.Shape:
    """A polygon moved a hair up and right, so that a cell centre lying exactly on its
    lower or left face is outside and one on its upper or right face inside: a polygon at
    least a cell thick then blocks at least one cell of every row and column it spans,
    and no more than needed. Circles are kept as they are."""
    if not isinstance(shape, pymunk.Poly):
        return shape
    body = shape.body
    assert body is not None, "a shape on no body"
    verts = [body.local_to_world(v) for v in shape.get_vertices()]
    moved = [(v.x + hair, v.y + hair) for v in verts]
    return pymunk.Poly(pymunk.Body(body_type=pymunk.Body.STATIC), moved)


def thickness(shape: pymunk.Shape) -> float:
    """How thick a circle or a convex polygon is at its thinnest."""
    if isinstance(shape, pymunk.Circle):
        return 2.0 * shape.radius
    assert isinstance(shape, pymunk.Poly), "the builder makes only circles and polygons"
    verts = [tuple(v) for v in shape.get_vertices()]
    widths = []
    for k, (ax, ay) in enumerate(verts):
        bx, by = verts[(k + 1) % len(verts)]
        length = math.hypot(bx - ax, by - ay)
        if length > 0:
            across = [abs((bx - ax) * (y - ay) - (by - ay) * (x - ax)) for x, y in verts]
            widths.append(max(across) / length)
    return min(widths, default=0.0)


class ScentField:
    """The scent of the live items of each channel over one world, searched again only
    when the world moved, hid or showed a fixed entity (its ``revision``) and the
    channel's items are no longer where they were.

    ``sources[c]`` is the item group channel c smells (None: every item)."""

    def __init__(self, world: World, cell: float, sources: tuple[str | None, ...], reach: float):
        self.world = world
        self.grid = grid = scent_grid(world, cell, len(sources))
        """The grid (unpadded): ``grid.blocked`` shows where scent cannot go."""
        self.cell = grid.cell
        self.reach = reach
        self.key = (cell, sources, reach)
        """What sensors that may share this field must ask for."""
        padded = np.pad(grid.blocked, 1, constant_values=True)
        self.width = padded.shape[1]
        self.blocked = padded.ravel()
        self.table = summed(padded)
        """Counts of blocked cells, for the straight-line checks."""
        self._top = np.array([padded.shape[1] - 1, padded.shape[0] - 1]) - 1e-9
        items = world.of_type(Item)
        self.members = [[it for it in items if s is None or it.group.name == s] for s in sources]
        size = (len(sources), padded.size)
        self.dist = np.full(size, np.inf)
        self.pivot = np.zeros(size + (2,))
        self.base = np.zeros(size)
        self._queue = (
            np.empty(padded.size, np.int64),
            np.empty(padded.size),
            np.empty(padded.size, np.int64),
        )
        self._seen = -1
        self._where: list[np.ndarray | None] = [None] * len(sources)
        self.searches = 0
        """How many times a channel was searched (for tests and the bench)."""

    def to_cells(self, points) -> np.ndarray:
        """World points in the kernels' units, kept inside the grid."""
        return np.clip(np.asarray(points, np.float64) / self.cell + 1.0, 1.0, self._top)

    def refresh(self) -> None:
        """Search again the channels whose items moved, went or came back."""
        if self.world.revision == self._seen:
            return
        self._seen = self.world.revision
        for c, members in enumerate(self.members):
            where = np.array(
                [tuple(it.body.position) for it in members if it.visible], np.float64
            ).reshape(-1, 2)
            last = self._where[c]
            if last is None or not np.array_equal(last, where):
                self._where[c] = where
                self.search(c)

    def search(self, c: int) -> None:
        """Search channel c from where its live items were last seen."""
        where = self._where[c]
        assert where is not None, "a channel searched before its items were looked at"
        args = (self.blocked, self.table, self.width, self.to_cells(where))
        args += (self.reach / self.cell, self.dist[c], self.pivot[c], self.base[c])
        while not spread(*args, *self._queue):
            self._queue = tuple(np.empty(2 * len(a), a.dtype) for a in self._queue)
        self.searches += 1

    def sniff(
        self,
        x: float,
        y: float,
        heading: float,
        reach_out: float,
        angle: float,
        spread: float,
        limit: float,
    ) -> np.ndarray:
        """(2, channels) float32: what nostrils ``reach_out`` from (x, y), ``angle`` radians
        left and right of ``heading``, smell: ``exp(-d / spread)`` for each channel's
        distance d below ``limit`` (world units), else 0 (see ``sniff``)."""
        self.refresh()
        out = np.empty((2, len(self.members)), np.float32)
        scale = 1.0 / self.cell
        sniff(
            self.blocked,
            self.width,
            self.dist,
            self.pivot,
            self.base,
            self._top,
            x,
            y,
            heading,
            reach_out,
            angle,
            scale,
            spread * scale,
            limit * scale,
            out,
        )
        return out

    def distances(self, points: np.ndarray, fallback: tuple[float, float]) -> np.ndarray:
        """(points, channels): how far each point (world units) is from each channel's
        nearest live item, around walls; infinity beyond reach or where none can be
        reached. A point inside a wall reads the free cell beside it, else ``fallback``."""
        self.refresh()
        out = np.empty((len(points), len(self.members)))
        cells, here = self.to_cells(points), self.to_cells(fallback)
        read_points(self.blocked, self.width, self.dist, self.pivot, self.base, cells, here, out)
        return out * self.cell
