"""Building an episode from a validated scenario and the env's random generator.

``build`` is the only place where scenario specs become a world. The layout is drawn
first (the file's walls, rooms, corridors, doors and obstacles, then each generator in
file order), from the env's generator when the scenario asks for a new layout each
episode, otherwise from the layout's own seed. Then agents, then items group by group,
then zones placed at random, at free places the agents can reach, from the env's
generator, in that order; then the sensors and the task.

Resets in place: a scenario of a fixed layout (``fixed_layout``) draws the same site every
episode, so its site (the world with its walls and fixed obstacles, the grid, what agents
can reach, the placer) is built once and kept; each later episode rewinds the world to it
(``World.rewind``: what the last episode added leaves, the movable obstacles are made
again) and places what moves. The env's generator is drawn from in the same order as by
a fresh build (the site draws nothing from it), so trajectories are the same. A site with
doors, or with anything but fixed and movable obstacles, or whose fixed entities the
episode moved (``World.site_moved``), is built again instead.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pymunk

from flatland_ma.agents.body import AgentBody
from flatland_ma.agents.grasp import Hands
from flatland_ma.build.bodies import footprint, make_agent, make_parts
from flatland_ma.build.capacity import spawn_group_of, spawn_groups
from flatland_ma.build.entity_factories import item_group, make_item, make_zone
from flatland_ma.build.generators import generator_for
from flatland_ma.build.ground import Ground
from flatland_ma.build.kind_faults import make_kind
from flatland_ma.build.layout import explicit_layout
from flatland_ma.build.reach import reachable_region
from flatland_ma.scenario.errors import SpecError
from flatland_ma.scenario.schema import ChannelSpec, ScenarioSpec
from flatland_ma.sensors.sensor import Sensor
from flatland_ma.sensors.sensor_suite import Sensors
from flatland_ma.tasks.rule import RULE_KINDS, Rule, Spawn, TaskContext
from flatland_ma.tasks.task import Task, new_records
from flatland_ma.world.channel import Channel
from flatland_ma.world.entities import Door, Entity, Item, ItemGroup
from flatland_ma.world.navigation import NavGrid
from flatland_ma.world.placement import PlacementError, Placer, ResetBudget
from flatland_ma.world.world import SiteMark, World

LAYOUT_TRIES = 20
"""Fresh draws of a generated layout before giving up on one that cannot be built."""


@dataclass
class Episode:
    """What one episode runs on; made at every reset (on the last episode's site when
    it is kept: see the module's docstring)."""

    world: World
    bodies: list[AgentBody]
    sensors: Sensors
    task: Task
    grid: NavGrid
    """Free places for an agent's centre; doors and movable things count as free."""
    placer: Placer
    hands: Hands
    """Every agent's graspers."""
    doors: list[Door]
    eyes: list[Entity]
    """Each sensor's carrier (agent by agent, sensor by sensor): its base, or its head."""
    site: Site | None = None
    """The site the episode stands on (the next episode's, when it can be kept)."""
    _grids: dict[float, NavGrid] = field(default_factory=dict, repr=False)

    def grid_for(self, radius: float) -> NavGrid:
        """``grid`` for agents of ``radius``: where their centre fits (the episode's grid
        is the slimmest agent's; in a scenario of one body, the same)."""
        if radius == self.grid.clearance:
            return self.grid
        if radius not in self._grids:
            grid = NavGrid(self.grid.size, radius, self.grid.cell)
            grid.block_entities(self.world.entities)
            self._grids[radius] = grid
        return self._grids[radius]


@dataclass
class Site:
    """The static part of an episode: walls, doors and obstacles, and where agents go."""

    world: World
    doors: list[Door]
    grid: NavGrid
    placer: Placer
    """Places agents can reach (through the doors they can open)."""
    spec: ScenarioSpec | None = None
    mark: SiteMark | None = None
    """Where the world stood when the site was complete; None: it is not kept."""
    budget_left: tuple[int, int] = (0, 0)
    """The places and grid cells the reset could still spend once the site stood."""
    agents: list[AgentBody] = field(default_factory=list)
    items: list[Item] = field(default_factory=list)
    """The last episode's agents and items, in the order they were made (the next
    episode's are made on their bodies and shapes)."""


def fixed_layout(spec: ScenarioSpec) -> bool:
    """Whether every episode of ``spec`` stands on the same site: its layout is not drawn
    again each episode (no generator, or ``per_episode`` false: drawn from the layout's
    own seed). The one place that decides which scenarios reset in place."""
    return not spec.layout.per_episode or not spec.layout.generators


def build(
    spec: ScenarioSpec,
    rng: np.random.Generator,
    sensors: list[list[Sensor]],
    previous: Site | None = None,
) -> Episode:
    """A new episode; ``sensors[i]`` are agent i's; on ``previous``, the last episode's
    site, when it can be kept (see the module's docstring). A scenario that cannot be
    built (e.g. no room left for an item at this seed) raises ``ScenarioError`` naming
    its file, line and key."""
    try:
        site = rewound(previous, spec)
        return populate(spec, site if site is not None else lay_ground(spec, rng), rng, sensors)
    except SpecError as err:
        raise spec.locate(err) from None


def rewound(site: Site | None, spec: ScenarioSpec) -> Site | None:
    """``site`` put back as it stood when built, ready for an episode of ``spec``; None
    when it cannot be kept."""
    if site is None or site.mark is None or site.spec is not spec or site.world.site_moved:
        return None
    site.world.rewind(site.mark)
    budget = ResetBudget()
    budget.tries, budget.search = site.budget_left
    site.placer.budget = budget
    return site


def lay_ground(spec: ScenarioSpec, rng: np.random.Generator) -> Site:
    """The ground of an episode; a layout generated per episode is drawn again (up to
    ``LAYOUT_TRIES`` times) while it cannot be used."""
    fixed = fixed_layout(spec)
    layout_rng = np.random.default_rng(spec.layout.seed) if fixed else rng
    budget = ResetBudget()  # shared by every attempt, and then by populate
    for attempt in range(1 if fixed else LAYOUT_TRIES):
        try:
            return _site(spec, layout_rng, budget)
        except SpecError:
            if fixed or attempt == LAYOUT_TRIES - 1 or budget.spent:
                raise
    raise AssertionError("unreachable")  # pragma: no cover


def _site(spec: ScenarioSpec, rng: np.random.Generator, budget: ResetBudget) -> Site:
    """The walls, doors and obstacles of one layout, and where agents fit and can go."""
    ground = Ground(spec, budget)
    ground.add(explicit_layout(spec))
    for index, gen in enumerate(spec.layout.generators):
        generator_for(gen, spec, index).generate(ground, rng)
    world, grid, start = ground.world, ground.grid, ground.start
    for group in spawn_groups(spec):
        if not (grid.cells_in(group.spawn.area) & ~grid.blocked).any():
            where = group.area_path or ("arena", "size")
            raise SpecError(where, "no free place where agents could start")
    region = reachable_region(spec, grid, ground.doors, start, budget)
    site = Site(world, ground.doors, grid, Placer(world, grid, region, budget), spec)
    movers = {index for index, _, _ in ground.movers}
    if (
        fixed_layout(spec)
        and not ground.doors
        and all(e.index in movers or not _moves(e) for e in world.entities)
    ):
        site.mark = world.mark(ground.movers)
        site.budget_left = (budget.tries, budget.search)
    return site


def _moves(entity: Entity) -> bool:
    """Whether an entity of the site may change in an episode (a body that is not
    static, or constraints)."""
    return entity.body.body_type != pymunk.Body.STATIC or bool(entity.constraints)


def populate(
    spec: ScenarioSpec, site: Site, rng: np.random.Generator, sensors: list[list[Sensor]]
) -> Episode:
    """Place the agents, then the items, then zones drawn at random; the sensors and the
    task."""
    world, placer = site.world, site.placer
    kept = site.mark is not None
    bodies = _place_agents(spec, world, placer, rng, site.agents if kept else [])
    groups = [item_group(item, g) for g, item in enumerate(spec.items)]
    items = _place_items(spec, site, rng, groups, site.items if kept else [])
    if kept:
        site.agents, site.items = bodies, items
    for zone in spec.zones:
        world.add_zone(make_zone(zone, zone.rect or _draw_zone(zone, placer, rng)))
    placer.budget = None  # the reset is done; respawns are bounded one by one

    if spec.channel is not None:
        world.channel = _channel(spec, spec.channel, bodies)
    eyes: list[Entity] = [
        b.head if s.mount == "head" else b for b, own in zip(bodies, sensors) for s in own
    ]
    own_sensors = [s for own in sensors for s in own]
    suite = Sensors(world, eyes, own_sensors, [len(s) for s in sensors], site.grid, rng)
    hands = Hands(world.space, [hand for body in bodies for hand in body.hands])
    for hand in hands.hands:
        world.grips[hand.shape] = hand.touching
    ctx = TaskContext(
        world=world,
        bodies=bodies,
        placer=placer,
        hands=hands,
        rng=rng,
        groups=groups,
        teams=[getattr(spec.team_of(i), "name", None) for i in range(spec.n_agents)],
        spawns=[Spawn(s.area, s.heading) for s in map(spec.spawn_of, range(spec.n_agents))],
        records=new_records(spec.n_agents),
    )
    extra = [_make_rule(k, r) for k, r in enumerate(spec.rules)]
    episode = spec.episode
    task = Task(ctx, extra, episode.shared_end, episode.end_when_eaten)
    return Episode(world, bodies, suite, task, site.grid, placer, hands, site.doors, eyes, site)


def _place_items(
    spec: ScenarioSpec,
    site: Site,
    rng: np.random.Generator,
    groups: list[ItemGroup],
    before: list[Item],
) -> list[Item]:
    """Each item group's items, at their given positions or drawn at random (in its spawn
    area if it has one), added to the world; ``before``, the items of the last episode of
    the same site, are reused in order."""
    reused = iter(before)
    items: list[Item] = []
    for g, item in enumerate(spec.items):
        if item.positions is not None:
            for x, y in item.positions:
                items.append(make_item(item, groups[g], x, y, (x, y), next(reused, None)))
                site.world.add(items[-1])
            continue
        for k in range(item.count):
            if item.spawn is not None:
                path = ("items", g, "spawn")
            else:
                path = ("items", g, "radius" if k == 0 else "count")
            x, y = _place(site.placer, rng, item.radius, item.spawn, path, "item")
            items.append(make_item(item, groups[g], x, y, reuse=next(reused, None)))
            site.world.add(items[-1])
    return items


def _channel(spec: ScenarioSpec, channel: ChannelSpec, bodies: list[AgentBody]) -> Channel:
    """The message channel between the agents (within each team only, if ``team``)."""
    teams = [getattr(spec.team_of(i), "name", None) for i in range(spec.n_agents)]
    made = Channel(
        spec.n_agents,
        channel.tokens,
        channel.vocabulary,
        channel.range,
        teams if channel.team else None,
    )
    made.bodies = bodies
    return made


def _make_rule(k: int, rule) -> Rule:
    """The rule of ``rules[k]``, from its spec's keys but ``rule``."""
    kind = RULE_KINDS[rule.rule]
    values = rule.model_dump(exclude={"rule"})
    return make_kind(kind, f"rules[{k}]", values, kind, **values)


def _place_agents(
    spec: ScenarioSpec, world: World, placer: Placer, rng, before: list[AgentBody]
) -> list[AgentBody]:
    bodies = []
    groups = spawn_groups(spec)
    reaches = {g.team: footprint(g.agent, make_parts(g.agent)) for g in groups}
    placed = {g.team: 0 for g in groups}
    for i in range(spec.n_agents):
        spawn, team = spec.spawn_of(i), spec.team_of(i)
        group = spawn_group_of(spec, groups, i)
        k = placed[group.team]
        placed[group.team] += 1
        x, y = _place(placer, rng, reaches[group.team], spawn.area, group.fault_path(k), "agent")
        angle = (
            float(rng.uniform(-math.pi, math.pi))
            if spawn.heading is None
            else math.radians(spawn.heading)
        )
        agent = spec.agent_of(i)
        color = (
            team.color
            if team is not None and team.color is not None
            else agent.colors[i % len(agent.colors)]
        )
        again = before[i] if i < len(before) else None
        body = make_agent(agent, i, (x, y), angle, color, world.substep_dt, world.dt, again)
        bodies.append(world.add(body))
        for link in body.links:
            world.add(link)
    return bodies


def _draw_zone(zone, placer: Placer, rng: np.random.Generator) -> tuple:
    """A ``zone.size`` rectangle centred on reachable floor inside ``zone.area``."""
    w, h = zone.size
    x0, y0, x1, y1 = zone.area or (0.0, 0.0, *placer.world.size)
    inner = (x0 + w / 2, y0 + h / 2, x1 - w / 2, y1 - h / 2)
    cells = placer.candidates(inner)
    if len(cells) == 0:
        cx, cy = (inner[0] + inner[2]) / 2, (inner[1] + inner[3]) / 2
    else:
        cx, cy = placer.grid.centre(*cells[rng.integers(len(cells))])
    return (cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2)


def _place(placer: Placer, rng, radius, area, path, what) -> tuple[float, float]:
    try:
        return placer.sample(rng, radius, area)
    except PlacementError as err:
        raise SpecError(path, f"no room to place every {what}: {err}") from None
