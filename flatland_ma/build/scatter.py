"""The ``random_obstacles`` generator: obstacles scattered where they block nobody's way."""

from __future__ import annotations

import math

import numpy as np
import pymunk

from flatland_ma.build.entities import make_obstacle
from flatland_ma.scenario.errors import SpecError
from flatland_ma.scenario.schema import (
    BoxObstacle,
    CircleObstacle,
    PolygonObstacle,
    RandomObstaclesSpec,
)
from flatland_ma.world.navigation import NavGrid
from flatland_ma.world.world import World

TRIES_PER_OBSTACLE = 200


def scatter_obstacles(
    gen: RandomObstaclesSpec,
    world: World,
    grid: NavGrid,
    start: np.ndarray,
    rng: np.random.Generator,
    path: tuple,
) -> NavGrid:
    """Add ``gen.count`` obstacles to the world; return the grid with them blocked.

    Each keeps ``gen.gap`` of clearance from everything, and is refused if it would cut
    any free cell off from ``start`` (a mask of cells, e.g. the agents' spawn area). With a
    gap wider than an agent (and a grid cell) nothing can be cut off: agents can always go
    round a convex obstacle, so the check is skipped.
    """
    width, height = world.size
    reachable = grid.reachable(start)
    check = gen.gap < 2 * grid.clearance + 2 * grid.cell
    candidates = _draw(gen, rng, width, height, TRIES_PER_OBSTACLE * gen.count)
    for _ in range(gen.count):
        for shape, size, x, y in candidates:
            if world.space.point_query((x, y), size / 2 + gen.gap, _ALL):
                continue
            obstacle = make_obstacle(_spec(gen, rng, shape, size, x, y), world.space)
            obstacle.shapes[0].cache_bb()
            trial = grid.copy()
            trial.block_shape(obstacle.shapes[0])
            if check:
                still = trial.reachable(start)
                if np.any(reachable & ~trial.blocked & ~still):
                    continue  # it would wall something off
                reachable = still
            world.add(obstacle)
            grid = trial
            break
        else:
            raise SpecError(path + ("count",), f"could not place {gen.count} obstacles")
    return grid


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
