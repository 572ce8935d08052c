"""The work budget: how much a scenario may ask to be built, counted from the file alone.

Every field has its own range, yet a file can still ask for too much in sum: two hundred
mazes, forty groups of ten thousand items. Building that takes minutes and gigabytes
before anything could say no. So the totals a file produces (after ``extends`` and
overrides) are counted before anything is built, each against a limit well above what the
shipped scenarios use, and a file over one is refused at the entry that adds the most.
Within these limits any file loads and resets in seconds and a few hundred MB.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from flatland_ma.scenario.errors import KeyPath, SpecError, format_path

if TYPE_CHECKING:  # the schema imports this check
    from flatland_ma.scenario.schema import ScenarioSpec

MAX_GROUPS = 64
"""Item groups, zones, teams, rules and layout generators, each (the shipped scenarios
have at most 4 of any): several checks and every step go over them one by one."""
MAX_SHAPES = 20_000
"""Solid shapes in all: walls (the file's, rooms', corridors' and generated ones), doors,
obstacles (fixed and scattered) and agents' bodies with their parts. The largest shipped
scenario has about 300."""
MAX_SCATTERED = 2_500
"""Obstacles scattered at random in all (``random_obstacles``): each is drawn, checked
clear and checked to cut nothing off at every reset (the shipped ones scatter 25)."""
MAX_ITEMS = 10_000
"""Items in all groups together, at once (the largest shipped scenario has 24)."""
MAX_GENERATOR_CELLS = 10_000
"""Cells of every maze and grid of rooms together (the largest shipped maze has 256)."""
MAX_KEYS = 32
"""Locked doors, and the keys that open them (key item groups, key objects and switch
zones): each is a gate or an opener in the reachability check, whose cost grows with their
product (the shipped scenarios have at most 2)."""


@dataclass
class _Total:
    """A running total and where it came from."""

    what: str
    limit: int
    total: int = 0
    parts: dict[KeyPath, int] = field(default_factory=dict)

    def add(self, path: KeyPath, n: int) -> None:
        self.total += n
        self.parts[path] = self.parts.get(path, 0) + n

    def check(self) -> None:
        if self.total <= self.limit:
            return
        path, most = max(self.parts.items(), key=lambda kv: kv[1])
        raise SpecError(
            path,
            f"the scenario asks for {self.total:,} {self.what} ({most:,} from "
            f"{format_path(path)}); the work budget allows at most {self.limit:,}, so that "
            "every scenario loads and resets in seconds",
        )


def check_budget(spec: ScenarioSpec) -> None:
    """Raise ``SpecError`` at the entry adding most to a total that is over its limit."""
    for total in (_cells(spec), _shapes(spec), _scattered(spec), _items(spec), _keys(spec)):
        total.check()


def maze_size(spec: ScenarioSpec, cell: float) -> tuple[int, int]:
    """Columns and rows of a maze of ``cell``-sized cells over the arena."""
    width, height = spec.arena.size
    return max(1, round(width / cell)), max(1, round(height / cell))


def _cells(spec: ScenarioSpec) -> _Total:
    total = _Total("maze and room-grid cells", MAX_GENERATOR_CELLS)
    for g, gen in enumerate(spec.layout.generators):
        if gen.generator == "maze":
            cols, rows = maze_size(spec, gen.cell)
            total.add(("layout", "generators", g, "cell"), cols * rows)
        elif gen.generator == "grid_rooms":
            total.add(("layout", "generators", g), gen.rows * gen.cols)
    return total


def _shapes(spec: ScenarioSpec) -> _Total:
    """An upper bound on the solid shapes built (a gap splits a wall in two)."""
    total = _Total("solid shapes (walls, doors, obstacles, agents' parts)", MAX_SHAPES)
    total.add(("arena",), 4)
    total.add(("walls",), len(spec.walls))
    for r, room in enumerate(spec.rooms):
        total.add(("rooms", r), 4 + 2 * len(room.openings))
    total.add(("corridors",), 4 * len(spec.corridors))  # two walls, and two cuts
    total.add(("doors",), len(spec.doors))
    total.add(("obstacles",), len(spec.obstacles))
    for g, gen in enumerate(spec.layout.generators):
        path = ("layout", "generators", g)
        if gen.generator == "maze":
            cols, rows = maze_size(spec, gen.cell)
            inner = rows * (cols - 1) + cols * (rows - 1)
            total.add(path + ("cell",), inner - (rows * cols - 1))  # a tree opens cells - 1
        elif gen.generator == "grid_rooms":
            shared = gen.rows * (gen.cols - 1) + gen.cols * (gen.rows - 1)
            total.add(path, 3 * shared)  # two pieces of wall and a door in each
        else:
            total.add(path + ("count",), gen.count)
    for path, agent, count in spec.agent_kinds():
        parts = (
            1
            + (agent.head is not None)
            + sum(len(a.segments) + (a.grasper is not None) for a in agent.arms)
        )
        total.add(("n_agents",) if path == ("agent",) else path, count * parts)
    return total


def _scattered(spec: ScenarioSpec) -> _Total:
    total = _Total("obstacles scattered at random", MAX_SCATTERED)
    for g, gen in enumerate(spec.layout.generators):
        if gen.generator == "random_obstacles":
            total.add(("layout", "generators", g, "count"), gen.count)
    return total


def _items(spec: ScenarioSpec) -> _Total:
    total = _Total("items", MAX_ITEMS)
    for g, item in enumerate(spec.items):
        key = "positions" if item.positions is not None else "count"
        total.add(("items", g, key), item.n_items)
    return total


def _keys(spec: ScenarioSpec) -> _Total:
    total = _Total("locked doors and keys", MAX_KEYS)
    for path, door in spec.all_doors():
        if door.state == "locked":
            total.add(path, 1)
    for g, item in enumerate(spec.items):
        if item.key:
            total.add(("items", g), 1)
    for o, obstacle in enumerate(spec.obstacles):
        if obstacle.key is not None:
            total.add(("obstacles", o), 1)
    switches = {door.switch for _, door in spec.all_doors() if door.switch is not None}
    for z, zone in enumerate(spec.zones):
        if zone.name in switches:
            total.add(("zones", z), 1)
    return total
