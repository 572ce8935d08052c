"""The ground of an episode under construction: walls, doors and obstacles, the occupancy
grid, and where agents start.

Wall and door pieces (from the file and from wall generators) are gathered as plain
geometry until something needs the physical world: then (``world``, ``grid``) the pieces
become pymunk bodies, the file's obstacles are placed (each checked clear of everything)
and the occupancy grid is laid. Pieces added after that are built at once, checked clear
of what is there, and blocked on the grid. So generators run in file order, each over what
the file and the generators before it made.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

import numpy as np

from flatland_ma.build.capacity import spawn_groups
from flatland_ma.build.entity_factories import (
    make_arena_walls,
    make_door,
    make_obstacle,
    make_walls,
)
from flatland_ma.build.layout import DoorPiece, Layout, WallPiece
from flatland_ma.scenario.errors import SpecError, format_path
from flatland_ma.scenario.schema import ScenarioSpec
from flatland_ma.world.entities import Door, Entity, Obstacle
from flatland_ma.world.navigation import NavGrid
from flatland_ma.world.physics import shape_counter
from flatland_ma.world.placement import ResetBudget
from flatland_ma.world.world import World


class Ground:
    """One episode's layout under construction, as generators see it (see the module's
    docstring): ``add`` wall and door pieces; ``world`` stands the world up (walls so
    far, the file's obstacles) for generators that place things in it
    (``place_clear``); ``grid`` and ``reach`` for those that keep the arena connected."""

    def __init__(self, spec: ScenarioSpec, budget: ResetBudget | None = None):
        self.spec = spec
        self.budget = budget if budget is not None else ResetBudget()
        """The work the reset may still spend placing things (generators spend it too)."""
        self.walls: list[WallPiece] = []
        self.door_pieces: list[DoorPiece] = []
        self.doors: list[Door] = []
        self.owners: dict = {}
        self.movers: list[tuple[int, int, Callable[[], Entity]]] = []
        """The file's obstacles that physics moves: index, the shape counter when added,
        and what makes them again (``World.mark``)."""
        """Each solid shape's key path in the scenario, for messages about overlaps."""
        self._world: World | None = None
        self._grid: NavGrid | None = None
        self._reach: np.ndarray | None = None
        self._start: np.ndarray | None = None

    def add(self, layout: Layout) -> None:
        """Add wall and door pieces (built at once if the world already stands)."""
        if self._world is None:
            self.walls += layout.walls
            self.door_pieces += layout.doors
            return
        self._build(layout.walls, layout.doors, check=True)

    @property
    def world(self) -> World:
        """The physical world, built from the pieces added so far on first use."""
        if self._world is None:
            self._materialise()
        return self._world  # type: ignore[return-value]

    @property
    def start(self) -> np.ndarray:
        """The cells where agents start (every spawn area)."""
        if self._start is None:
            self._materialise()
        return self._start  # type: ignore[return-value]  # set by _materialise

    @property
    def grid(self) -> NavGrid:
        """The occupancy grid of the standing world (free for the slimmest agent)."""
        if self._grid is None:
            self._materialise()
        return self._grid  # type: ignore[return-value]

    @property
    def reach(self) -> np.ndarray:
        """The free cells of the grid connected to where agents start: searched once (at a
        cost to the budget), then kept up to date by whoever blocks cells (``update``)."""
        if self._reach is None:
            self.budget.searched(self.grid.blocked.size)
            self._reach = self.grid.reachable(self.start)
        return self._reach

    def update(self, grid: NavGrid, reach: np.ndarray) -> None:
        """Take a grid with more cells blocked, and what is reachable on it."""
        self._grid, self._reach = grid, reach

    def _materialise(self) -> None:
        spec = self.spec
        physics = spec.physics
        world = World(spec.arena.size, physics.dt, physics.substeps, physics.iterations)
        world.add(make_arena_walls(spec.arena))
        self._world = world
        self._build(self.walls, self.door_pieces, check=False)
        for i, obstacle in enumerate(spec.obstacles):
            counter = shape_counter(world.space)
            entity = make_obstacle(obstacle, world.space)
            self.place_clear(entity, ("obstacles", i))
            if entity.moving:
                self.movers.append(
                    (entity.index, counter, partial(make_obstacle, obstacle, world.space))
                )
        # Free for the slimmest agent: every place some agent can go (planners that drive a
        # wider one plan on ``Episode.grid_for`` its radius).
        grid = NavGrid(spec.arena.size, min(a.radius for _, a, _ in spec.agent_kinds()))
        grid.block_entities(world.entities)
        self._grid = grid
        start = np.zeros_like(grid.blocked)
        for group in spawn_groups(spec):
            start |= grid.cells_in(group.spawn.area)
        self._start = start

    def _build(self, walls: list[WallPiece], doors: list[DoorPiece], check: bool) -> None:
        world = self.world
        built, paths = make_walls(walls, world.space.static_body)
        for wall in built:
            self._add(wall, [paths[s] for s in wall.shapes], check, walls_ok=True)
        for piece in doors:
            door = make_door(piece, world.space)
            self._add(door, [piece.path], check, walls_ok=True)
            self.doors.append(door)

    def _add(self, entity: Entity, paths: list[tuple], check: bool, walls_ok: bool) -> None:
        if check:
            _check_clear(self.world, entity, paths[0], self.owners, solid_only=walls_ok)
        self.world.add(entity)
        if len(paths) == 1:
            paths = paths * len(entity.shapes)
        for shape, path in zip(entity.shapes, paths):
            self.owners[shape] = path
        if self._grid is not None and entity.blocks_paths:
            self._reach = None
            for shape in entity.shapes:
                self._grid.block_shape(shape)

    def place_clear(self, entity: Entity, path: tuple) -> None:
        """Add an entity that must overlap nothing; raise at ``path`` if it does."""
        self._add(entity, [path], check=True, walls_ok=False)


def _check_clear(
    world: World, entity: Entity, path: tuple, owners: dict, solid_only: bool = False
) -> None:
    """Raise at ``path`` (and at what it overlaps) if the entity overlaps anything; with
    ``solid_only`` (walls and doors, which meet walls) only obstacles count."""
    for shape in entity.shapes:
        shape.cache_bb()
        for hit in world.space.shape_query(shape):
            other = owners.get(hit.shape, ())
            thing = world.entity_of_shape[hit.shape]
            if solid_only and not isinstance(thing, Obstacle):
                continue
            what = (
                "a door"
                if isinstance(thing, Door)
                else "another obstacle"
                if isinstance(thing, Obstacle)
                else "a wall"
            )
            where = f" ({format_path(other)})" if other else ""
            also = ((other, f"overlaps {format_path(path)}"),) if other else ()
            raise SpecError(path, f"overlaps {what}{where}", also)
