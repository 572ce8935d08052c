"""The ``random_obstacles`` generator: obstacles scattered where they block nobody's way."""

from __future__ import annotations

import math

import numpy as np
import pymunk

from flatland_ma.build.entity_factories import make_obstacle
from flatland_ma.scenario.errors import SpecError
from flatland_ma.scenario.schema import (
    BoxObstacle,
    CircleObstacle,
    PolygonObstacle,
    RandomObstaclesSpec,
)
from flatland_ma.world.navigation import UNREACHED, NavGrid, grid_steps
from flatland_ma.world.placement import OutOfBudget, ResetBudget
from flatland_ma.world.world import World

TRIES_PER_OBSTACLE = 200


def scatter_obstacles(
    gen: RandomObstaclesSpec,
    world: World,
    grid: NavGrid,
    start: np.ndarray,
    reachable: np.ndarray,
    rng: np.random.Generator,
    path: tuple,
    budget: ResetBudget,
) -> tuple[NavGrid, np.ndarray]:
    """Add ``gen.count`` obstacles to the world; return the grid with them blocked, and
    the cells still reachable from ``start`` (``reachable``: those reachable before).

    Each keeps ``gen.gap`` of clearance from everything, and is refused if it would cut
    any free cell off from ``start`` (a mask of cells, e.g. the agents' spawn area). With a
    gap wider than an agent (and a grid cell) nothing can be cut off: agents can always go
    round a convex obstacle, so the check is skipped. Otherwise it is settled around the
    obstacle (``_cuts_off``), so an arena costs what it holds, not its area.
    """
    width, height = world.size
    grid, reachable = grid.copy(), reachable.copy()
    check = gen.gap < 2 * grid.clearance + 2 * grid.cell
    candidates = _draw(gen, rng, width, height, TRIES_PER_OBSTACLE * gen.count)
    for placed in range(gen.count):
        for shape, size, x, y in candidates:
            try:
                budget.draw()
                if world.space.point_query((x, y), size / 2 + gen.gap, _ALL):
                    continue
                obstacle = make_obstacle(_spec(gen, rng, shape, size, x, y), world.space)
                window, mask = grid.window(obstacle.shapes[0], pad=LOCAL_PADS[0])
                if check and _cuts_off(grid, start, reachable, window, mask):
                    continue
            except OutOfBudget as err:
                raise SpecError(
                    path + ("count",),
                    f"could not place {gen.count} obstacles ({placed} placed): {err}",
                ) from None
            world.add(obstacle)
            grid.blocked[window] |= mask
            reachable[window] &= ~mask
            break
        else:
            raise SpecError(path + ("count",), f"could not place {gen.count} obstacles")
    return grid, reachable


LOCAL_PADS = (8, 48)
"""Cells around an obstacle searched for a way round it, in turn, before the whole grid."""


def _cuts_off(grid: NavGrid, start, reachable, window, mask) -> bool:
    """Would blocking ``mask`` (over ``window`` of the grid) cut a reachable cell off?

    Blocking cells changes only the moves into them and the diagonal moves past them, all
    between cells next to them (``near``). Any path that crossed ``near`` entered and left
    it through the cells around it (``rim``). So if every reachable cell of ``near`` and
    ``rim`` left free stays connected to the others within a window, every cell reached
    before is reached still (a path from a start that gets blocked is picked up by a start
    left free among them, if there is one); so is every cell of them that a start in the
    window reaches. Windows ``LOCAL_PADS`` cells wider than the obstacle are tried in
    turn. An obstacle with no way round it within the wider one is refused as if it cut
    something off: a detour that long is as good as a wall, and refusing it keeps the
    check local, so its cost does not grow with the arena (on a grid that fits in the
    window, the check is exact).

    An obstacle alone in its window needs no search: its blocked cells are the grid points
    of a convex region, and from any other point two of the four axis directions lead out
    of the window without meeting it, so every free cell reaches the window's free border.
    """
    blocked = grid.blocked[window] | mask
    new = mask & ~grid.blocked[window]
    if not new.any():
        return False
    near = _grow(new)
    rim = _grow(near) & ~near
    targets = (near | rim) & reachable[window] & ~blocked
    if not targets.any():
        return False
    one_way = not (new & start[window]).any() or (targets & start[window]).any()
    if one_way and not grid.blocked[window].any():
        return False
    for pad in LOCAL_PADS:
        wide, inner = _widen(grid, window, pad - LOCAL_PADS[0])
        local = grid.blocked[wide].copy()
        local[inner] = blocked
        goals = np.zeros_like(local)
        goals[inner] = targets
        offset = (inner[0].start, inner[1].start)
        seeds = [np.argwhere(targets)[:1] + offset] if one_way else []
        seeds.append(np.argwhere(start[wide] & ~local))
        for cells in seeds:
            if len(cells) and (grid_steps(local, cells.astype(np.int64))[goals] != UNREACHED).all():
                return False
    return True


def _widen(grid: NavGrid, window, extra: int):
    """``window`` grown by ``extra`` cells each way (within the grid), and where the
    original lies inside it."""
    rows, cols = window
    i0, j0 = max(0, rows.start - extra), max(0, cols.start - extra)
    i1, j1 = min(grid.ny, rows.stop + extra), min(grid.nx, cols.stop + extra)
    inner = (
        slice(rows.start - i0, rows.stop - i0),
        slice(cols.start - j0, cols.stop - j0),
    )
    return (slice(i0, i1), slice(j0, j1)), inner


def _grow(mask: np.ndarray) -> np.ndarray:
    """``mask`` and its 8 neighbours of every cell in it."""
    out = mask.copy()
    out[1:, :] |= mask[:-1, :]
    out[:-1, :] |= mask[1:, :]
    grown = out.copy()
    grown[:, 1:] |= out[:, :-1]
    grown[:, :-1] |= out[:, 1:]
    return grown


def _draw(gen: RandomObstaclesSpec, rng: np.random.Generator, width: float, height: float, n: int):
    """An iterator over ``n`` candidates (shape, diameter, centre), drawn at once."""
    shapes = rng.integers(len(gen.shapes), size=n)
    sizes = np.minimum(rng.uniform(*sorted(gen.size), size=n), 0.99 * min(width, height))
    u = rng.uniform(size=(n, 2))
    xs = sizes / 2 + u[:, 0] * (width - sizes)
    ys = sizes / 2 + u[:, 1] * (height - sizes)
    return iter(
        (gen.shapes[k], float(d), float(x), float(y)) for k, d, x, y in zip(shapes, sizes, xs, ys)
    )


def _spec(gen: RandomObstaclesSpec, rng: np.random.Generator, shape: str, size: float, x, y):
    color = gen.colors[int(rng.integers(len(gen.colors)))]
    angle = float(rng.uniform(0.0, 360.0))
    r = size / 2
    # Valid by construction, so built without validation.
    common = dict(_DEFAULTS, position=(x, y), angle=angle, color=color)
    if shape == "circle":
        return CircleObstacle.model_construct(shape="circle", radius=r, **common)
    if shape == "box":
        side = size / math.sqrt(2.0)  # its corners on the circle of diameter ``size``
        box = (side, side * float(rng.uniform(0.5, 1.0)))
        return BoxObstacle.model_construct(shape="box", size=box, **common)
    n = 3 if shape == "triangle" else 5
    verts = tuple(
        (r * math.cos(2 * math.pi * k / n), r * math.sin(2 * math.pi * k / n)) for k in range(n)
    )
    return PolygonObstacle.model_construct(shape="polygon", vertices=verts, **common)


_DEFAULTS = {
    name: field.default
    for name, field in CircleObstacle.model_fields.items()
    if name not in ("shape", "radius", "position", "angle", "color")
}


_ALL = pymunk.ShapeFilter()
