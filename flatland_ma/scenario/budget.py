"""The work budget: how much a scenario may ask to be built, counted from the file alone.

Every field has its own range, yet a file can still ask for too much in sum: two hundred
mazes, forty groups of ten thousand items. Building that takes minutes and gigabytes
before anything could say no. So the totals a file produces (after ``extends`` and
overrides) are counted before anything is built, each against a limit well above what the
shipped scenarios use, and a file over one is refused at the entry that adds the most.
Within these limits any file loads and resets in seconds and a few hundred MB.

Sensors count too: the memory every agent's sensors hold (observations, top-down maps,
scent grids; ``flatland_ma.scenario.sizes``) and the rays cast each step. And a batch of
worlds (``BatchedParallelEnv``, its shards, ``gymnasium.make_vec``) is held, before it
allocates anything, to ``MAX_BATCH_BYTES`` over all its worlds (``check_batch``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from flatland_ma.scenario import sizes
from flatland_ma.scenario.errors import KeyPath, SpecError, format_path
from flatland_ma.scenario.types import (
    MAX_GROUPS as MAX_GROUPS,  # a limit of the specs, listed here too
)

if TYPE_CHECKING:
    from flatland_ma.scenario.spec_scenario import ScenarioFields

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
MAX_SENSOR_BYTES = 256 * 2**20
"""Bytes every agent's sensors hold in one world, together (``sizes.sensor_bytes``): 64
agents may each carry a 256 x 256 RGB top-down map, not sixteen of them. The largest
shipped scenario holds about 3 MB."""
MAX_RAYS = 262_144
"""Rays cast in one world each step, every agent's cameras and lidars together: 64 agents
with a camera of 4,096 rays (the shipped scenarios cast at most 512)."""
MAX_BATCH_BYTES = 4 * 2**30
"""What a batch of worlds (and its processes) may take in all, estimated before it is
built (``batch_bytes``): at about 1 MB a world, some 4,000 worlds of a small scenario."""
WORLD_BYTES = 1 * 2**20
"""A world's own cost besides its shapes and sensors: its env, space, spaces and episode
(a world of fruits_poisons takes about 0.8 MB once reset)."""
SHAPE_BYTES = 8 * 1024
"""A solid shape or an item: its pymunk body and shape, its entity and its packed rows."""
PROCESS_BYTES = 256 * 2**20
"""A shard's process: Python, numpy, numba and pymunk loaded, before its worlds."""
BATCH_OBS_COPIES = 4
"""Arrays of every slot's observation a batch holds: its buffer, the copy handed out, and
its observation space's ``low`` and ``high``."""


@dataclass
class _Total:
    """A running total and where it came from."""

    what: str
    limit: int
    total: int = 0
    unit: str = ""
    """"bytes": shown in MB."""
    parts: dict[KeyPath, int] = field(default_factory=dict)

    def add(self, path: KeyPath, n: int) -> None:
        self.total += n
        self.parts[path] = self.parts.get(path, 0) + n

    def check(self) -> None:
        if self.total <= self.limit:
            return
        path, most = max(self.parts.items(), key=lambda kv: kv[1])
        show = _megabytes if self.unit == "bytes" else "{:,}".format
        raise SpecError(
            path,
            f"the scenario asks for {show(self.total)} {self.what} ({show(most)} from "
            f"{format_path(path)}); the work budget allows at most {show(self.limit)}, so "
            "that every scenario loads and resets in seconds",
        )


def _megabytes(n: int) -> str:
    return f"{n / 2**20:,.1f} MB" if n >= 2**20 else f"{n / 1024:,.1f} kB"


def check_budget(spec: ScenarioFields) -> None:
    """Raise ``SpecError`` at the entry adding most to a total that is over its limit."""
    totals = (_cells(spec), _shapes(spec), _scattered(spec), _items(spec), _keys(spec))
    for total in (*totals, *_sensors(spec)):
        total.check()


def world_bytes(spec: ScenarioFields) -> int:
    """An estimate from above of the memory one world of ``spec`` takes once reset in a
    batch: the world, its shapes and items, its sensors, and its slots' observations in
    the batch's arrays."""
    shapes = _shapes(spec).total + _items(spec).total
    return (
        WORLD_BYTES
        + shapes * SHAPE_BYTES
        + sizes.sensor_bytes(spec)
        + BATCH_OBS_COPIES * sizes.observation_bytes(spec)
    )


def batch_bytes(spec: ScenarioFields, worlds: int, processes: int = 0) -> int:
    """An estimate of what ``worlds`` worlds of ``spec`` take, in ``processes`` shards."""
    return worlds * world_bytes(spec) + processes * PROCESS_BYTES


def max_worlds(spec: ScenarioFields, processes: int = 0) -> int:
    """The most worlds of ``spec`` a batch may hold (in ``processes`` shards)."""
    return max(0, (MAX_BATCH_BYTES - processes * PROCESS_BYTES) // world_bytes(spec))


def check_batch(spec: ScenarioFields, worlds: object, name: str = "num_worlds", processes=0):
    """Raise ``ValueError`` naming ``name`` unless ``worlds`` is a positive integer and that
    many worlds of ``spec`` (in ``processes`` shards) fit the work budget; call it before
    allocating anything."""
    if isinstance(worlds, bool) or not isinstance(worlds, int) or worlds < 1:
        raise ValueError(f"{name} must be a positive integer, not {worlds!r}")
    total = batch_bytes(spec, worlds, processes)
    if total <= MAX_BATCH_BYTES:
        return
    most = max_worlds(spec, processes)
    shards = f" in {processes} processes" if processes else ""
    raise ValueError(
        f"{name}={worlds:,} worlds{shards} would take about {_megabytes(total)} (about "
        f"{_megabytes(world_bytes(spec))} a world: its shapes, its sensors' "
        f"{_megabytes(sizes.sensor_bytes(spec))} and its observations); the work budget "
        f"allows a batch at most {_megabytes(MAX_BATCH_BYTES)}, so {name} may be at most "
        f"{most:,} for this scenario"
        + (f" with {processes} processes" if processes else "")
        + ": use fewer worlds, smaller sensors, or several machines"
    )


def _sensors(spec: ScenarioFields) -> tuple[_Total, _Total]:
    memory = _Total(
        "of sensor memory (observations, maps, scent grids, across agents)",
        MAX_SENSOR_BYTES,
        unit="bytes",
    )
    rays = _Total("rays cast each step (every agent's cameras and lidars)", MAX_RAYS)
    for sensor in sizes.sensor_sizes(spec):
        memory.add(sensor.path, sensor.memory)
        if sensor.size.rays:
            rays.add(sensor.path, sensor.size.rays * sensor.count)
    return memory, rays


def maze_size(spec: ScenarioFields, cell: float) -> tuple[int, int]:
    """Columns and rows of a maze of ``cell``-sized cells over the arena."""
    width, height = spec.arena.size
    return max(1, round(width / cell)), max(1, round(height / cell))


def _cells(spec: ScenarioFields) -> _Total:
    total = _Total("maze and room-grid cells", MAX_GENERATOR_CELLS)
    for g, gen in enumerate(spec.layout.generators):
        if gen.generator == "maze":
            cols, rows = maze_size(spec, gen.cell)
            total.add(("layout", "generators", g, "cell"), cols * rows)
        elif gen.generator == "grid_rooms":
            total.add(("layout", "generators", g), gen.rows * gen.cols)
    return total


def _shapes(spec: ScenarioFields) -> _Total:
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
        elif isinstance(count := getattr(gen, "count", None), int):  # and generators alike
            total.add(path + ("count",), count)
    for path, agent, count in spec.agent_kinds():
        parts = (
            1
            + (agent.head is not None)
            + sum(len(a.segments) + (a.grasper is not None) for a in agent.arms)
            + len(agent.parts)
        )
        total.add(("n_agents",) if path == ("agent",) else path, count * parts)
    return total


def _scattered(spec: ScenarioFields) -> _Total:
    total = _Total("obstacles scattered at random", MAX_SCATTERED)
    for g, gen in enumerate(spec.layout.generators):
        if gen.generator == "random_obstacles":
            total.add(("layout", "generators", g, "count"), gen.count)
    return total


def _items(spec: ScenarioFields) -> _Total:
    total = _Total("items", MAX_ITEMS)
    for g, item in enumerate(spec.items):
        key = "positions" if item.positions is not None else "count"
        total.add(("items", g, key), item.n_items)
    return total


def _keys(spec: ScenarioFields) -> _Total:
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
