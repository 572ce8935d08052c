"""Generated layouts: one ``Generator`` protocol, each generator applied in file order.

A generator draws part of a layout from the random generator it is given (the env's, or
the layout's own seeded one) onto the ``Ground`` under construction: wall and door pieces,
or obstacles placed in the standing world. A new generator is one subclass, named by its
``kind`` in the class statement (the ``generator`` its spec carries), plus that spec in
``scenario/spec_world.py``; ``GENERATOR_KINDS`` finds it.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from flatland_ma.build.ground import Ground
from flatland_ma.build.kind_faults import make_kind
from flatland_ma.build.layout import DoorPiece, Layout, axis_piece, axis_point, merge, style
from flatland_ma.build.scatter import scatter_obstacles
from flatland_ma.kinds.registry import Kinded, Kinds
from flatland_ma.scenario.budget import maze_size
from flatland_ma.scenario.errors import SpecError
from flatland_ma.scenario.schema import DoorSpec, ScenarioSpec
from flatland_ma.world.placement import OutOfBudget

GENERATOR_KINDS = Kinds("flatland_ma.build", "generator")
"""Every generator class, by the ``generator`` name files give it."""


class Generator(Kinded, ABC):
    """Base of every generator: ``spec`` is its entry in the file, ``scenario`` the whole
    file, ``path`` the entry's key path (for messages). Required: ``generate``. A
    generator of your own subclasses this with a spec subclassing
    ``scenario.spec_world.GeneratorBaseSpec``, joined by ``flatland_ma.register``; the
    extending guide shows walls and obstacles drawn from one."""

    KINDS = GENERATOR_KINDS

    def __init__(self, spec, scenario: ScenarioSpec, path: tuple):
        self.spec, self.scenario, self.path = spec, scenario, path

    @abstractmethod
    def generate(self, ground: Ground, rng: np.random.Generator) -> None:
        """Draw this generator's part of the layout onto ``ground``."""


def generator_for(spec, scenario: ScenarioSpec, index: int) -> Generator:
    """The generator of ``scenario.layout.generators[index]``."""
    kind = GENERATOR_KINDS[spec.generator]
    path = ("layout", "generators", index)
    where = f"layout.generators[{index}]"
    return make_kind(kind, where, {}, kind, spec, scenario, path)


class GridRooms(Generator, kind="grid_rooms"):
    """Inner walls of a rows x cols grid of rooms; one random opening per shared wall."""

    def generate(self, ground: Ground, rng: np.random.Generator) -> None:
        gen, spec = self.spec, self.scenario
        width, height = spec.arena.size
        t, color, texture = style(gen, spec)
        walls, doors = [], []
        cw, ch = width / gen.cols, height / gen.rows
        door_spec = None
        if gen.doors != "none":
            door_spec = DoorSpec(kind="hinged" if gen.doors == "hinged" else "sliding")
        # Vertical walls between columns, one piece per row; then horizontal ones.
        for axis, n_lines, n_cells, step, cell in (
            (1, gen.cols, gen.rows, cw, ch),
            (0, gen.rows, gen.cols, ch, cw),
        ):
            for line in range(1, n_lines):
                c = line * step
                for k in range(n_cells):
                    lo, hi = k * cell, (k + 1) * cell
                    margin = t + gen.door_width / 2
                    centre = (
                        float(rng.uniform(lo + margin, hi - margin))
                        if hi - lo > 2 * margin
                        else (lo + hi) / 2
                    )
                    gap = (centre - gen.door_width / 2, centre + gen.door_width / 2)
                    for a, b in ((lo - t / 2, gap[0]), (gap[1], hi + t / 2)):
                        walls.append(axis_piece(axis, c, a, b, t, color, texture, self.path))
                    if door_spec is not None:
                        start = axis_point(axis, c, gap[0])
                        end = axis_point(axis, c, gap[1])
                        doors.append(DoorPiece(start, end, t, door_spec, self.path))
        ground.add(Layout(merge(walls), doors))


class Maze(Generator, kind="maze"):
    """Inner walls of a maze over the arena: a random depth-first spanning tree of the
    cells, then a fraction ``loops`` of the walls left standing removed."""

    def generate(self, ground: Ground, rng: np.random.Generator) -> None:
        gen, spec = self.spec, self.scenario
        width, height = spec.arena.size
        cols, rows = maze_size(spec, gen.cell)
        open_east, open_north = _spanning_tree(rows, cols, rng)
        if gen.loops > 0:
            for grid, limit in ((open_east, (rows, cols - 1)), (open_north, (rows - 1, cols))):
                closed = [
                    (r, c) for r in range(limit[0]) for c in range(limit[1]) if not grid[r, c]
                ]
                for k in rng.permutation(len(closed))[: int(round(gen.loops * len(closed)))]:
                    grid[closed[k]] = True
        t, color, texture = style(gen, spec)
        cw, ch = width / cols, height / rows
        walls = []
        for r in range(rows):
            for c in range(cols - 1):
                if not open_east[r, c]:
                    lo, hi = r * ch - t / 2, (r + 1) * ch + t / 2
                    walls.append(axis_piece(1, (c + 1) * cw, lo, hi, t, color, texture, self.path))
        for r in range(rows - 1):
            for c in range(cols):
                if not open_north[r, c]:
                    lo, hi = c * cw - t / 2, (c + 1) * cw + t / 2
                    walls.append(axis_piece(0, (r + 1) * ch, lo, hi, t, color, texture, self.path))
        ground.add(Layout(merge(walls), []))


def _spanning_tree(rows: int, cols: int, rng: np.random.Generator):
    """A random depth-first spanning tree of a rows x cols grid of cells, as two masks:
    ``open_east[r, c]``, no wall between (r, c) and (r, c + 1); ``open_north`` upwards."""
    open_east = np.zeros((rows, cols), bool)
    open_north = np.zeros((rows, cols), bool)
    visited = np.zeros((rows, cols), bool)
    stack = [(int(rng.integers(rows)), int(rng.integers(cols)))]
    visited[stack[0]] = True
    while stack:
        r, c = stack[-1]
        options = [
            (dr, dc)
            for dr, dc in ((0, 1), (0, -1), (1, 0), (-1, 0))
            if 0 <= r + dr < rows and 0 <= c + dc < cols and not visited[r + dr, c + dc]
        ]
        if not options:
            stack.pop()
            continue
        dr, dc = options[int(rng.integers(len(options)))]
        if dc == 1:
            open_east[r, c] = True
        elif dc == -1:
            open_east[r, c - 1] = True
        elif dr == 1:
            open_north[r, c] = True
        else:
            open_north[r - 1, c] = True
        visited[r + dr, c + dc] = True
        stack.append((r + dr, c + dc))
    return open_east, open_north


class RandomObstacles(Generator, kind="random_obstacles"):
    """Obstacles scattered where they overlap nothing and wall no free place off from
    where agents start (see ``scatter.py``)."""

    def generate(self, ground: Ground, rng: np.random.Generator) -> None:
        try:
            reach = ground.reach
        except OutOfBudget as err:
            raise SpecError(self.path, f"could not scatter obstacles: {err}") from None
        grid, reach = scatter_obstacles(
            self.spec, ground.world, ground.grid, ground.start, reach, rng, self.path, ground.budget
        )
        ground.update(grid, reach)
