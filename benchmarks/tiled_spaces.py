"""Many worlds in one pymunk space against one space per world (issue 40, part 4).

The batched env steps one pymunk space per world. The alternative tried here tiles every
world in one space, far enough apart that nothing touches across worlds, so that one
``space.step`` and one ``pymunk.batch.get_space_bodies`` serve them all.

Each row takes ``worlds`` worlds of a shipped scenario, built by ``FlatlandParallelEnv``
(seeds ``seed`` to ``seed + worlds - 1``) and copied at their reset (bodies, shapes and
joints, before any step) into these arrangements:

``separate``
    one space per world, as the env runs them, each stepped in turn through the bridge's
    stepper (``flatland_ma.world.physics.stepper``, the tier in use);
``tiled``
    every world in one space, world ``k`` moved by ``offsets[k]`` (a square grid, ``GAP``
    arena sizes apart), stepped once through the same stepper; Chipmunk's default
    bounding-box trees index the shapes;
``tiled_hash``
    the same, with Chipmunk's spatial hash (``Space.use_spatial_hash``) in place of the
    trees;
``tiled_groups``
    tiled in spaces of ``GROUP`` worlds each;
``stacked`` (rows of at most ``STACKED_MAX`` worlds)
    every world in one space at the origin, kept apart by shape-filter categories, one
    bit per world (no offset).

Every space gets the same contact handlers, which record each world's contacts (agents
against items, and every begin and end of an agent's contact) as the world's own do, so
that the callbacks' cost is in every arrangement alike. Between steps (not timed), each
agent's body is given a velocity along its heading and a spin drawn beforehand, the same
in every arrangement. The arrangements are stepped in turn, ``STEPS`` steps each, for
``ROUNDS`` rounds, the order rotating each round. Timed, in CPU time of this thread
(``time.thread_time``), per world-step:

- ``physics``: stepping every world (``substeps`` pymunk steps each);
- ``physics`` of ``empty_spaces``: as many empty spaces stepped in turn: the floor of
  one space per world;
- ``poses``: reading the agents' poses (x, y, angle) of every world after the step: for
  the separate spaces through each reader of the bridge (``compiled``: struct reads of
  every world in one compiled call, when that tier is available; ``batch``: one
  ``pymunk.batch`` read per space; ``attributes``), and for the tiled arrangements one
  ``pymunk.batch`` read per space, less each world's offset.

Beside the timing, the trajectories: fresh copies of the row's first ``STUDY_WORLDS``
worlds in every timed arrangement and in ``separate_shifted`` (one space per world, moved
by its tile's offset) run ``STUDY_STEPS`` steps of the same
commands. Each pair of ``STUDIED`` is compared: the worlds whose poses differ in any bit,
the step of the first difference, the largest difference of position at some steps, and
the worlds whose contacts differ (in order, as a set per step, and agents against items
only). Against ``separate_shifted`` the tiled space shows what tiling changes beyond the
offset. The run also checks that a separate copy replays the env's own ``World.step`` to
the bit (``faithful``), so that its figures are the env's physics.

Everything is bounded by steps, never by the clock.

    python -m benchmarks.tiled_spaces [--worlds 16,256,1024] [--steps 20] [--rounds 3]
        [--study-steps 500] [--json benchmarks/results/tiled_spaces.json]
"""

from __future__ import annotations

import argparse
import copy
import datetime
import json
import math
import os
import statistics
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import pymunk

from flatland_ma.envs.parallel import FlatlandParallelEnv
from flatland_ma.sensors import lists
from flatland_ma.world import physics
from flatland_ma.world.entities import CollisionType
from flatland_ma.world.poses import AttributePoses, SpacePoses

SCENARIOS = ("fruits_poisons", "fruits_poisons_multi")
WORLDS = (16, 256, 1024)
STEPS = 20
"""Steps of each arrangement per round."""
ROUNDS = 3
WARM_STEPS = 20
"""Steps each arrangement takes before the timing, so that bodies move and touch."""
STUDY_STEPS = 500
"""Steps of the study: a whole episode of both scenarios."""
STUDY_WORLDS = 256
"""Worlds of the study, at most (the first of the row's)."""
STUDY_AT = (1, 10, 100, 250, 500)
"""Steps after which the study reports the largest difference of position."""
GAP = 2.0
"""Tiles lie this many arena sizes apart (their largest side): an arena's walls keep its
bodies inside it, so any gap above one keeps worlds from touching."""
COMMANDS = 16
"""Distinct steps of drawn commands the timing cycles through."""
KINDS = ("separate", "separate_shifted", "tiled", "tiled_hash", "tiled_groups", "stacked")
GROUP = 16
"""Worlds per space in ``tiled_groups``."""
STACKED_MAX = 27
"""Worlds a stack can hold: the shape-filter category bits that flatland_ma's own
categories (``Category``, five bits) leave free."""
TIMED = ("separate", "tiled", "tiled_hash", "tiled_groups", "stacked")


def timed_arrangements(worlds: int) -> tuple[str, ...]:
    """The arrangements timed for ``worlds`` worlds (a stack holds ``STACKED_MAX``)."""
    return TIMED if worlds <= STACKED_MAX else TIMED[:-1]


STUDIED = (
    ("separate_shifted", "separate"),
    ("tiled", "separate"),
    ("tiled_hash", "separate"),
    ("tiled", "separate_shifted"),
    ("tiled_hash", "separate_shifted"),
    ("tiled_groups", "separate"),
    ("stacked", "separate"),
)
"""The pairs the study compares: (arrangement, against): against the separate spaces, and
against separate spaces moved by the same offsets (what tiling changes beyond them)."""


# -- the worlds, copied out of the env ---------------------------------------------------


@dataclass
class Template:
    """One world's pymunk objects at its reset, in no space: the copies start from it."""

    bodies: list
    shapes: list
    constraints: list
    entity: list[int]
    """Each shape's entity index in its world."""
    agents: list
    """The agents' bodies, in agent order."""
    size: tuple[float, float]
    dt: float
    substeps: int
    space: dict
    """The space's settings (iterations, gravity, damping, collision slop and bias)."""
    limits: list[tuple[float, float]]
    """Each agent's top speed and turn rate (radians per second)."""


def _settings(space: pymunk.Space) -> dict:
    return {
        "iterations": space.iterations,
        "gravity": tuple(space.gravity),
        "damping": space.damping,
        "collision_slop": space.collision_slop,
        "collision_bias": space.collision_bias,
    }


def template_of(world) -> Template:
    """A detached copy of ``world``'s bodies, shapes and joints (a ``World`` before its
    first step: no contact is cached yet)."""
    space = world.space
    shapes = list(space.shapes)
    agents = [agent.body for agent in world.agents]
    memo = {id(space.static_body): pymunk.Body(body_type=pymunk.Body.STATIC)}
    bodies, shapes_copy, constraints, agents_copy = copy.deepcopy(
        (list(space.bodies), shapes, list(space.constraints), agents), memo
    )
    return Template(
        bodies,
        shapes_copy,
        constraints,
        [world.entity_of_shape[s].index for s in shapes],
        agents_copy,
        tuple(world.size),
        world.substep_dt,
        world.substeps,
        _settings(space),
        [(a.max_speed, a.max_turn_rate) for a in world.agents],
    )


def templates(scenario: str, worlds: int, seed: int) -> list[Template]:
    """``worlds`` worlds of ``scenario`` at their resets, seeds ``seed`` onwards."""
    env = FlatlandParallelEnv(scenario)
    try:
        out = []
        for k in range(worlds):
            env.reset(seed=seed + k)
            out.append(template_of(env.running.world))
        return out
    finally:
        env.close()


def offsets(sources: list[Template]) -> np.ndarray:
    """Where each world's tile starts: a square grid, ``GAP`` arena sizes apart."""
    pitch = GAP * max(max(t.size) for t in sources)
    columns = math.ceil(math.sqrt(len(sources)))
    return np.array([((k % columns) * pitch, (k // columns) * pitch) for k in range(len(sources))])


# -- arrangements ------------------------------------------------------------------------


def _new_space(settings: dict) -> pymunk.Space:
    space = pymunk.Space()
    for name, value in settings.items():
        setattr(space, name, value)
    return space


def _recorder(owner: dict, kind: str):
    """A handler that logs ``(kind, entity, other entity)`` in the first shape's world."""

    def record(arbiter: pymunk.Arbiter, space: pymunk.Space, data) -> None:
        a, b = arbiter.shapes
        log, first = owner[a]
        log.append((kind, first, owner[b][1]))

    return record


def _listen(space: pymunk.Space, owner: dict) -> None:
    """The same pairs as ``World`` handles, each logging its contacts."""
    on = space.on_collision
    for kind in (CollisionType.AGENT, CollisionType.GRASPER):
        on(kind, CollisionType.ITEM, begin=_recorder(owner, "item"))
        on(kind, None, begin=_recorder(owner, "touch"), separate=_recorder(owner, "release"))
    on(CollisionType.AGENT, CollisionType.DOOR, begin=_recorder(owner, "door"))


class Arrangement:
    """Copies of the worlds of ``sources``, arranged as ``kind`` says (the module's
    docstring; ``separate_shifted``: a space each, moved by the tiles' offsets).
    ``stacked`` gives world ``k``'s shapes category bit ``5 + k`` alone, which drops
    flatland_ma's own categories: right only for worlds whose filters let every shape
    meet every other, as those of fruits_poisons do; at most ``STACKED_MAX`` worlds."""

    def __init__(self, sources: list[Template], kind: str):
        if kind not in KINDS or (kind == "stacked" and len(sources) > STACKED_MAX):
            raise ValueError(f"{kind!r} of {len(sources)} worlds: one of {KINDS}")
        shifted = kind in ("separate_shifted", "tiled", "tiled_hash", "tiled_groups")
        self.tiled = kind in ("tiled", "tiled_hash", "stacked", "tiled_groups")
        group = GROUP if kind == "tiled_groups" else len(sources) if self.tiled else 1
        self.offsets = np.zeros((len(sources), 2))
        if shifted:
            tiles = offsets(sources[:group] if kind == "tiled_groups" else sources)
            self.offsets[:] = tiles[np.arange(len(sources)) % len(tiles)]
        self.group = group
        """Worlds per space."""
        self.dt, self.substeps = sources[0].dt, sources[0].substeps
        self.logs: list[list] = [[] for _ in sources]
        self.agents: list[list[pymunk.Body]] = []
        self.limits = [t.limits for t in sources]
        owner: dict = {}
        self.world_of: dict[pymunk.Shape, int] = {}
        """Each shape's world."""
        self.spaces: list[pymunk.Space] = []
        for k, source in enumerate(sources):
            if k % group == 0:
                self.spaces.append(_new_space(source.space))
            space = self.spaces[-1]
            bodies, shapes, constraints, agents = copy.deepcopy(
                (source.bodies, source.shapes, source.constraints, source.agents)
            )
            dx, dy = self.offsets[k]
            for body in bodies:
                x, y = body.position
                body.position = (x + dx, y + dy)
            if kind == "stacked":
                for shape in shapes:
                    bit = 1 << (5 + k)
                    shape.filter = pymunk.ShapeFilter(shape.filter.group, bit, bit)
            space.add(*bodies, *shapes, *constraints)
            for shape, index in zip(shapes, source.entity):
                owner[shape] = (self.logs[k], index)
                self.world_of[shape] = k
            self.agents.append(agents)
        for space in self.spaces:
            _listen(space, owner)
            if kind == "tiled_hash":
                shapes = len(space.shapes)
                space.use_spatial_hash(2 * max(s.radius for s in _circles(space)), 10 * shapes)
        self._step = physics.stepper()

    def drive(self, commands: np.ndarray) -> None:
        """Clear the logs and drive every world's agents (``drive``; not timed)."""
        for w, agents in enumerate(self.agents):
            self.logs[w].clear()
            drive(agents, self.limits[w], commands[w])

    def step(self) -> None:
        step, dt, substeps = self._step, self.dt, self.substeps
        for space in self.spaces:
            step(space, dt, substeps)

    def poses(self) -> np.ndarray:
        """Every agent's (x, y, angle) in its own world's coordinates, ``(worlds, agents,
        3)`` (read through attributes: for the study, not timed)."""
        out = np.array([[(*b.position, b.angle) for b in agents] for agents in self.agents])
        out[:, :, :2] -= self.offsets[:, None, :]
        return out


class EmptySpaces:
    """As many empty spaces as worlds, stepped as ``separate`` steps its spaces: what
    stepping a space costs before it holds anything (pymunk's and the bridge's Python
    around Chipmunk's step, and Chipmunk's fixed cost)."""

    def __init__(self, sources: list[Template]):
        self.spaces = [_new_space(t.space) for t in sources]
        self.dt, self.substeps = sources[0].dt, sources[0].substeps
        self._step = physics.stepper()

    def drive(self, commands: np.ndarray) -> None:
        pass

    def step(self) -> None:
        step, dt, substeps = self._step, self.dt, self.substeps
        for space in self.spaces:
            step(space, dt, substeps)


def drive(agents: list[pymunk.Body], limits: list, commands: np.ndarray) -> None:
    """Each agent's body: velocity ``commands[a, 0]`` of its top speed along its heading,
    spin ``commands[a, 1]`` of its top turn rate (``limits[a]``)."""
    for a, body in enumerate(agents):
        speed = float(commands[a, 0]) * limits[a][0]
        angle = body.angle
        body.velocity = (speed * math.cos(angle), speed * math.sin(angle))
        body.angular_velocity = float(commands[a, 1]) * limits[a][1]


def _own_poses(agents: list[pymunk.Body]) -> np.ndarray:
    return np.array([(*b.position, b.angle) for b in agents])


def _circles(space: pymunk.Space) -> list[pymunk.Circle]:
    return [s for s in space.shapes if isinstance(s, pymunk.Circle)] or [pymunk.Circle(None, 10)]


# -- pose readers ------------------------------------------------------------------------


class TiledReader:
    """Every agent's pose from the tiled spaces in one ``pymunk.batch`` read per space,
    each world's offset taken off: ``pose`` is ``(worlds, agents, 3)``."""

    def __init__(self, arrangement: Arrangement):
        worlds, agents = len(arrangement.agents), len(arrangement.agents[0])
        self.pose = np.zeros((worlds, agents, 3))
        group = arrangement.group
        self._readers = [
            SpacePoses(
                self.pose[w : w + group].reshape(-1, 3),
                [b for own in arrangement.agents[w : w + group] for b in own],
            )
            for w in range(0, worlds, group)
        ]
        self._offsets = arrangement.offsets[:, None, :]

    def read(self) -> None:
        for reader in self._readers:
            reader.read()
        self.pose[:, :, :2] -= self._offsets


class SeparateReaders:
    """Every agent's pose from one space per world, through one of the bridge's readers."""

    def __init__(self, arrangement: Arrangement, kind: str):
        worlds, agents = len(arrangement.agents), len(arrangement.agents[0])
        self.pose = np.zeros((worlds, agents, 3))
        self.kind = kind
        if kind == "compiled":
            addresses = [
                np.array([physics.address(b) for b in own], np.intp) for own in arrangement.agents
            ]
            self._poses = lists.filled(self.pose[0], worlds)
            self._bodies = lists.filled(addresses[0], worlds)
            for w in range(worlds):
                lists.put(self._poses, w, self.pose[w])
                lists.put(self._bodies, w, addresses[w])
            self._which = np.arange(worlds, dtype=np.intp)
            self._keep = arrangement.agents  # the structs live while their bodies do
        else:
            make = SpacePoses if kind == "batch" else AttributePoses
            self._readers = [make(self.pose[w], b) for w, b in enumerate(arrangement.agents)]

    def read(self) -> None:
        if self.kind == "compiled":
            physics.read_poses_at(self._poses, self._bodies, self._which)
        else:
            for reader in self._readers:
                reader.read()


def separate_kinds() -> list[str]:
    kinds = ["batch", "attributes"]
    return ["compiled", *kinds] if physics.TIER is physics.Tier.COMPILED else kinds


# -- timing ------------------------------------------------------------------------------


@dataclass
class Timing:
    """CPU microseconds per world-step, one figure per round."""

    physics: dict[str, list[float]] = field(default_factory=dict)
    poses: dict[str, list[float]] = field(default_factory=dict)


def _commands(sources: list[Template], steps: int, seed: int) -> np.ndarray:
    agents = len(sources[0].agents)
    rng = np.random.default_rng(seed)
    return rng.uniform(-1.0, 1.0, size=(steps, len(sources), agents, 2))


def time_row(sources: list[Template], steps: int, rounds: int, seed: int) -> Timing:
    built: dict = {name: Arrangement(sources, name) for name in timed_arrangements(len(sources))}
    built["empty_spaces"] = EmptySpaces(sources)
    readers: dict[str, SeparateReaders | TiledReader]
    readers = {f"separate_{k}": SeparateReaders(built["separate"], k) for k in separate_kinds()}
    readers["tiled_batch"] = TiledReader(built["tiled"])
    readers["tiled_hash_batch"] = TiledReader(built["tiled_hash"])
    readers["tiled_groups_batch"] = TiledReader(built["tiled_groups"])
    if "stacked" in built:
        readers["stacked_batch"] = TiledReader(built["stacked"])
    commands = _commands(sources, COMMANDS, seed)
    for arrangement in built.values():
        for k in range(WARM_STEPS):
            arrangement.drive(commands[k % COMMANDS])
            arrangement.step()
    for reader in readers.values():  # compiled code loaded before the clock starts
        reader.read()
    worlds = len(sources)
    timing = Timing({n: [] for n in built}, {n: [] for n in readers})
    for r in range(rounds):
        names = list(built)
        names = names[r % len(names) :] + names[: r % len(names)]
        for name in names:
            arrangement = built[name]
            mine = {n: reader for n, reader in readers.items() if _reads(n, name)}
            spent = dict.fromkeys(["physics", *mine], 0.0)
            for k in range(steps):
                arrangement.drive(commands[k % COMMANDS])
                start = time.thread_time()
                arrangement.step()
                spent["physics"] += time.thread_time() - start
                for n, reader in mine.items():
                    start = time.thread_time()
                    reader.read()
                    spent[n] += time.thread_time() - start
            per = 1e6 / (steps * worlds)
            timing.physics[name].append(spent.pop("physics") * per)
            for n, seconds in spent.items():
                timing.poses[n].append(seconds * per)
    _check_readers(readers, built)
    return timing


def _reads(reader: str, arrangement: str) -> bool:
    """Whether ``reader`` reads ``arrangement``'s bodies."""
    if arrangement == "separate":
        return reader.startswith("separate_")
    return reader == f"{arrangement}_batch"


def _check_readers(readers: dict, built: dict) -> None:
    """Each reader read what the attributes say (the tiled ones less the offsets, to
    within the rounding of that subtraction)."""
    for name, reader in readers.items():
        arrangement = built["separate" if name.startswith("separate_") else name[:-6]]
        reader.read()
        if arrangement.tiled:
            if not np.allclose(reader.pose, arrangement.poses(), rtol=0, atol=1e-9):
                raise AssertionError(f"{name} read other poses than the bodies'")
        elif not np.array_equal(reader.pose, arrangement.poses()):
            raise AssertionError(f"{name} read other poses than the bodies'")


# -- trajectories ------------------------------------------------------------------------


def study(sources: list[Template], steps: int, seed: int) -> dict:
    """How far each arrangement's trajectories move from another's (``STUDIED``)."""
    names = ("separate", "separate_shifted", *timed_arrangements(len(sources))[1:])
    built = {name: Arrangement(sources, name) for name in names}
    commands = _commands(sources, steps, seed + 1)
    worlds = len(sources)
    poses = {n: [] for n in built}
    contacts = {n: [[] for _ in range(worlds)] for n in built}
    for k in range(steps):
        for name, arrangement in built.items():
            arrangement.drive(commands[k])
            arrangement.step()
            poses[name].append(arrangement.poses())
            for w, log in enumerate(arrangement.logs):
                contacts[name][w].append(tuple(log))
    out = {}
    for name, against in STUDIED:
        if name not in built:
            continue
        out[f"{name} vs {against}"] = _differences(
            np.array(poses[against]), np.array(poses[name]), contacts[against], contacts[name]
        )
    out["contacts_per_world_step"] = sum(
        len(step) for world in contacts["separate"] for step in world
    ) / (worlds * steps)
    return out


def _differences(reference: np.ndarray, other: np.ndarray, ref_log: list, log: list) -> dict:
    """``reference`` and ``other``: poses ``(steps, worlds, agents, 3)``."""
    steps, worlds = reference.shape[:2]
    differs = (reference != other).any(axis=(2, 3))  # (steps, worlds)
    first = [int(np.argmax(differs[:, w])) + 1 for w in range(worlds) if differs[:, w].any()]
    gap = np.abs(reference[..., :2] - other[..., :2]).max(axis=(1, 2, 3))
    ordered = [_first_difference(ref_log[w], log[w], ordered=True) for w in range(worlds)]
    as_sets = [_first_difference(ref_log[w], log[w], ordered=False) for w in range(worlds)]
    return {
        "worlds_bit_identical": worlds - len(first),
        "first_pose_difference_step": min(first) if first else None,
        "median_first_pose_difference_step": statistics.median(first) if first else None,
        "max_position_difference_at": {
            str(at): float(gap[at - 1]) for at in STUDY_AT if at <= steps
        },
        "worlds_same_contacts_in_order": sum(d is None for d in ordered),
        "worlds_same_contacts_as_sets": sum(d is None for d in as_sets),
        "first_contact_difference_step": min((d for d in ordered if d is not None), default=None),
        "worlds_same_item_contacts_as_sets": sum(
            _items(ref_log[w], sort=True) == _items(log[w], sort=True) for w in range(worlds)
        ),
        "worlds_same_item_contacts_in_order": sum(
            _items(ref_log[w], sort=False) == _items(log[w], sort=False) for w in range(worlds)
        ),
    }


def _first_difference(a: list, b: list, ordered: bool) -> int | None:
    for k, (x, y) in enumerate(zip(a, b)):
        if (x != y) if ordered else (sorted(x) != sorted(y)):
            return k + 1
    return None


def _items(log: list, sort: bool) -> list:
    """Each step's contacts of agents with items (what the rules reward; in order, the
    first agent to touch an item in a step takes it), sorted or in the log's order."""
    steps = [[e for e in step if e[0] == "item"] for step in log]
    return [sorted(step) for step in steps] if sort else steps


# -- faithfulness ------------------------------------------------------------------------


def faithful(scenario: str, steps: int, seed: int = 0) -> bool:
    """Whether a separate copy of a world replays the env's own ``World.step`` to the bit
    under the same commands (the copy's handlers only record, as the world's do)."""
    env = FlatlandParallelEnv(scenario)
    try:
        env.reset(seed=seed)
        world = env.running.world
        source = template_of(world)
        copied = Arrangement([source], "separate")
        original = [agent.body for agent in world.agents]
        commands = _commands([source], steps, seed + 2)
        for k in range(steps):
            drive(original, source.limits, commands[k, 0])
            world.step()
            copied.drive(commands[k])
            copied.step()
            if not np.array_equal(_own_poses(original), copied.poses()[0]):
                return False
        return True
    finally:
        env.close()


# -- the run -----------------------------------------------------------------------------


@dataclass
class Row:
    scenario: str
    worlds: int
    agents: int
    bodies_per_world: int
    steps: int
    rounds: int
    physics: dict
    poses: dict
    trajectories: dict
    load: tuple[float, float]
    """The load average (1 minute) before and after the row."""


def run_row(scenario: str, worlds: int, steps: int, rounds: int, study_steps: int, seed: int):
    load = os.getloadavg()[0]
    sources = templates(scenario, worlds, seed)
    timing = time_row(sources, steps, rounds, seed)
    trajectories = study(sources[:STUDY_WORLDS], study_steps, seed) if study_steps else {}
    return Row(
        scenario,
        worlds,
        len(sources[0].agents),
        len(sources[0].bodies),
        steps,
        rounds,
        timing.physics,
        timing.poses,
        trajectories,
        (load, os.getloadavg()[0]),
    )


def summary(figures: dict[str, list[float]]) -> dict[str, dict[str, float]]:
    return {
        name: {"median": statistics.median(v), "min": min(v), "max": max(v)}
        for name, v in figures.items()
    }


def format_row(row: Row) -> str:
    phys, poses = summary(row.physics), summary(row.poses)
    lines = [
        f"{row.scenario} x {row.worlds} ({row.agents} agents, {row.bodies_per_world} bodies "
        f"a world; load {row.load[0]:.1f}-{row.load[1]:.1f}), us of CPU per world-step, "
        "median (min-max) of rounds:"
    ]
    for name, s in phys.items():
        ratio = phys["separate"]["median"] / s["median"]
        lines.append(
            f"  physics {name:12} {s['median']:7.2f} ({s['min']:.2f}-{s['max']:.2f})"
            f"  separate / this {ratio:.2f}x"
        )
    for name, s in poses.items():
        lines.append(f"  poses   {name:22} {s['median']:7.2f} ({s['min']:.2f}-{s['max']:.2f})")
    for name, d in row.trajectories.items():
        if isinstance(d, dict):
            lines.append(f"  {name}: {json.dumps(d)}")
    return "\n".join(lines)


def _as_json(row: Row) -> dict:
    return {
        **asdict(row),
        "physics_summary": summary(row.physics),
        "poses_summary": summary(row.poses),
    }


def markdown(result: dict) -> str:
    """The tables of docs/performance.md's "Many worlds in one space", from a run's JSON:
    medians of the rounds (lowest-highest), us of CPU per world-step."""
    physics_names = ["separate", "tiled", "tiled_groups", "tiled_hash", "stacked"]
    head = "| worlds x agents | load | " + " | ".join(physics_names) + " | empty spaces |"
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for row in result["rows"]:
        phys, sep = row["physics_summary"], row["physics_summary"]["separate"]["median"]
        cells = []
        for name in physics_names:
            s = phys.get(name)
            ratio = "" if name == "separate" or s is None else f", {sep / s['median']:.2f}x"
            cells.append(
                "-" if s is None else f"{s['median']:.1f} ({s['min']:.1f}-{s['max']:.1f}{ratio})"
            )
        empty = phys["empty_spaces"]
        lines.append(
            f"| {row['worlds']} x {row['agents']} | {row['load'][0]:.1f}-{row['load'][1]:.1f} | "
            + " | ".join(cells)
            + f" | {empty['median']:.1f} |"
        )
    readers = [
        "separate_compiled",
        "separate_attributes",
        "separate_batch",
        "tiled_batch",
        "tiled_groups_batch",
    ]
    lines += [
        "",
        "| worlds x agents | " + " | ".join(readers) + " |",
        "|---|" + "---|" * len(readers),
    ]
    for row in result["rows"]:
        poses = row["poses_summary"]
        cells = [f"{poses[n]['median']:.2f}" if n in poses else "-" for n in readers]
        lines.append(f"| {row['worlds']} x {row['agents']} | " + " | ".join(cells) + " |")
    lines += ["", TRAJECTORY_HEAD, "|" + "---|" * (TRAJECTORY_HEAD.count("|") - 1)]
    seen = set()
    for row in result["rows"]:
        for pair, d in row["trajectories"].items():
            worlds = min(row["worlds"], STUDY_WORLDS)  # the study takes the first ones
            key = (row["scenario"], worlds, pair)
            if not isinstance(d, dict) or key in seen or "hash" in pair:
                continue
            seen.add(key)
            gaps = d["max_position_difference_at"]
            lines.append(
                f"| {row['scenario']} x {worlds} | {pair} | {d['worlds_bit_identical']} | "
                f"{d['first_pose_difference_step'] or '-'} | {gaps.get('100', 0):.1e} | "
                f"{gaps.get('500', 0):.1e} | {d['worlds_same_contacts_in_order']} | "
                f"{d['worlds_same_contacts_as_sets']} | {d['worlds_same_item_contacts_in_order']} |"
            )
    return "\n".join(lines)


TRAJECTORY_HEAD = (
    "| worlds | pair | worlds bit-identical | first differing step | largest position "
    "difference at step 100 | at step 500 | same contacts in order | same contacts as "
    "sets | same item contacts in order |"
)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("--scenarios", default=",".join(SCENARIOS))
    parser.add_argument("--worlds", default=",".join(map(str, WORLDS)))
    parser.add_argument("--steps", type=int, default=STEPS)
    parser.add_argument("--rounds", type=int, default=ROUNDS)
    parser.add_argument("--study-steps", type=int, default=STUDY_STEPS)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", type=Path, default=None, help="write the results here")
    parser.add_argument("--table", type=Path, default=None, help="print a run's JSON as tables")
    args = parser.parse_args(argv)
    if args.table is not None:
        print(markdown(json.loads(args.table.read_text())))
        return
    worlds = [int(w) for w in args.worlds.split(",")]
    scenarios = args.scenarios.split(",")
    if min(worlds) < 1 or args.steps < 1 or args.rounds < 1 or args.study_steps < 0:
        parser.error("--worlds, --steps and --rounds must be positive, --study-steps not negative")
    checks = {s: faithful(s, 50, args.seed) for s in scenarios}
    print(f"physics tier: {physics.describe()}; separate copies replay World.step: {checks}")
    rows = []
    for scenario in scenarios:
        for n in worlds:
            row = run_row(scenario, n, args.steps, args.rounds, args.study_steps, args.seed)
            print(format_row(row), flush=True)
            rows.append(row)
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        result = {
            "measured": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "pymunk": pymunk.version,
            "tier": physics.describe(),
            "cores": os.cpu_count(),
            "gap_arena_sizes": GAP,
            "faithful": checks,
            "rows": [
                {
                    **asdict(r),
                    "physics_summary": summary(r.physics),
                    "poses_summary": summary(r.poses),
                }
                for r in rows
            ],
        }
        args.json.write_text(json.dumps(result, indent=1) + "\n")


if __name__ == "__main__":
    main()
