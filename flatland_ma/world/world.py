"""The physical world: one pymunk space, its entities and zones, stepping, the contact
log, and which entities changed since the sensors last looked."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import cast

import pymunk

from flatland_ma.world import physics
from flatland_ma.world.channel import Channel
from flatland_ma.world.contacts import ContactLog
from flatland_ma.world.entities import Category, CollisionType, Door, Entity, Item, Obstacle, Zone

_SOLID_OR_ITEM = pymunk.ShapeFilter(mask=Category.EVERYTHING)
_AGENT_TYPES = (CollisionType.AGENT, CollisionType.GRASPER)


@dataclass(frozen=True)
class SiteMark:
    """Where a world stood when its static site was complete (``World.mark``), so that
    ``World.rewind`` can put it back there for another episode."""

    entities: int
    """How many entities the site has (the first ones of ``World.entities``)."""
    counter: int
    """The shape hash id Chipmunk was to give next (``physics.shape_counter``)."""
    revision: int
    movers: tuple[tuple[int, int, Callable[[], Entity]], ...]
    """The site's entities that physics moves, each made again at every rewind: its
    index, the shape counter when it was added, and what makes it."""


class World:
    """Owns the ``pymunk.Space``. Collision callbacks only record contacts in ``log``;
    rules decide what they mean. Moving, hiding or showing a fixed entity goes through
    the world, which notes it in ``changed`` for the sensors. Touch sensors have it
    ``feel`` agents' shapes: it then logs every push on them too."""

    def __init__(
        self, size: tuple[float, float], dt: float, substeps: int = 1, iterations: int = 10
    ):
        self.space = pymunk.Space()
        self.space.iterations = iterations
        self.size = size
        self.dt = dt
        self.substeps = substeps
        self.substep_dt = dt / substeps
        self._step = physics.stepper()
        self.entities: list[Entity] = []
        self.entity_of_shape: dict[pymunk.Shape, Entity] = {}
        self.agents: list[Entity] = []
        """Agents' bases, in agent order."""
        self.zones: list[Zone] = []
        self.channel: Channel | None = None
        """What the agents said, when the scenario gives them a channel."""
        self.tagged: list[Obstacle] = []
        """Objects with a delivery tag."""
        self.log = ContactLog()
        self.changed: list[Entity] = []
        """Fixed entities moved, hidden or shown since the sensors last looked."""
        self.revision = 0
        """How many times a fixed entity was moved, hidden or shown. ``changed`` belongs to
        the sensors' geometry; anything else that keeps something derived from those
        entities (the scent of items) compares this count with the one it last saw."""
        self.grips: dict[pymunk.Shape, list[Entity]] = {}
        """For each grasper's shape, the graspable objects it touches, first touched first."""
        self._inside: list[list[bool]] = []
        self._felt: dict[pymunk.Shape, tuple[int, pymunk.Body]] = {}
        """Each felt shape's row in ``log.pushes`` (see ``feel``), and its body."""
        self._felt_rows = 0
        self._site_size = 0
        self.site_moved = False
        """Whether a fixed entity of the marked site was moved, hidden or shown (then the
        site cannot be rewound: a new world is built)."""
        on = self.space.on_collision
        on(CollisionType.AGENT, CollisionType.ITEM, begin=self._on_item)
        on(CollisionType.GRASPER, CollisionType.ITEM, begin=self._on_item)
        on(CollisionType.AGENT, CollisionType.DOOR, begin=self._on_door)
        on(CollisionType.OBSTACLE, CollisionType.DOOR, begin=self._on_key)
        on(
            CollisionType.GRASPER,
            CollisionType.OBSTACLE,
            begin=self._on_grip,
            separate=self._on_ungrip,
        )
        for kind in (CollisionType.AGENT, CollisionType.GRASPER):
            on(kind, None, begin=self._on_agent_contact, separate=self._on_agent_release)

    # -- contents -----------------------------------------------------------------------

    def add(self, entity: Entity) -> Entity:
        entity.index = len(self.entities)
        self.entities.append(entity)
        for shape in entity.shapes:
            self.entity_of_shape[shape] = entity
        if entity.body is not self.space.static_body:
            self.space.add(entity.body)
        self.space.add(*entity.aux_bodies, *entity.shapes, *entity.constraints)
        if entity.actor is entity:
            self.agents.append(entity)
        if isinstance(entity, Obstacle) and entity.tag is not None:
            self.tagged.append(entity)
        return entity

    def add_zone(self, zone: Zone) -> Zone:
        zone.index = len(self.zones)
        self.zones.append(zone)
        return zone

    def of_type(self, kind: type) -> list:
        """The entities of one class (for rules and policies setting up, not per step)."""
        return [e for e in self.entities if isinstance(e, kind)]

    def withdraw(self, entity: Entity) -> None:
        """Take an entity's shapes out of the physics (it stays listed, hidden)."""
        self._note_site(entity)
        entity.visible = False
        present = [s for s in entity.shapes if s.space is not None]
        if present:
            self.space.remove(*present)
        self.changed.append(entity)
        self.revision += 1

    def restore(self, entity: Entity) -> None:
        """Put a withdrawn entity's shapes back."""
        self._note_site(entity)
        entity.visible = True
        absent = [s for s in entity.shapes if s.space is None]
        if absent:
            self.space.add(*absent)
        self.changed.append(entity)
        self.revision += 1

    def retire(self, entity: Entity) -> None:
        """Take an entity out of the physics for good (e.g. an agent whose episode ended)."""
        self.withdraw(entity)
        present = set(self.space.constraints)
        parts = [c for c in entity.constraints if c in present]
        parts += [b for b in (entity.body, *entity.aux_bodies) if b.space is not None]
        if parts:
            self.space.remove(*parts)

    def move_static(self, entity: Entity, x: float, y: float) -> None:
        """Move a static or kinematic entity (e.g. a respawned item)."""
        self._note_site(entity)
        entity.body.position = (x, y)
        self.space.reindex_shapes_for_body(entity.body)
        self.changed.append(entity)
        self.revision += 1

    def place(self, entity: Entity, x: float, y: float, angle: float) -> None:
        """Put a dynamic entity at (x, y) turned by ``angle``, at rest."""
        body = entity.body
        body.position, body.angle = (x, y), angle
        body.velocity, body.angular_velocity = (0.0, 0.0), 0.0
        self.space.reindex_shapes_for_body(body)

    def feel(self, shapes: Iterable[pymunk.Shape]) -> int:
        """Record the pushes on these shapes of an agent (its base, or one part) from now
        on, and return the row they are logged under: each step, ``log.pushes[row]``
        lists every push on any of them, as (bearing, impulse).

        The world registers the callback that records pushes only when the first shape
        is felt, so a world without touch sensors does no work for them.
        """
        shapes = list(shapes)
        for shape in shapes:
            if shape.collision_type not in _AGENT_TYPES:
                raise ValueError("only the shapes of agents (bases and parts) can be felt")
        if self._felt_rows == 0:
            for kind in _AGENT_TYPES:
                self.space.on_collision(kind, None, post_solve=self._on_push)
        row = self._felt_rows
        self._felt_rows += 1
        for shape in shapes:
            body = shape.body
            assert body is not None, "a shape to feel without its body"
            self._felt[shape] = (row, body)
        return row

    def _note_site(self, entity: Entity) -> None:
        if entity.index < self._site_size and not entity.moving:
            self.site_moved = True

    # -- resets in place ----------------------------------------------------------------

    def mark(self, movers: Iterable[tuple[int, int, Callable[[], Entity]]] = ()) -> SiteMark:
        """Remember this world as the static site of every episode: its entities so far,
        fixed but for ``movers`` (index, shape counter when added, maker), which
        ``rewind`` makes again. The world must hold no agent yet."""
        assert not self.agents and not self.zones, "a site is marked before the episode's things"
        self._site_size = len(self.entities)
        self.site_moved = False
        counter = physics.shape_counter(self.space)
        return SiteMark(len(self.entities), counter, self.revision, tuple(movers))

    def rewind(self, mark: SiteMark) -> None:
        """Put the world back to its marked site, as Chipmunk would hold it had the site
        just been built: everything added since leaves the space, the movers are made
        again where they started, with the hash ids their shapes had (each spatial index
        is then the tree it was, and works in the same order), and the next shape gets the
        id it got then. What the world kept of the episode (agents, zones, the channel,
        the contact log, grips, felt shapes) is dropped. Only while ``site_moved`` is
        False."""
        assert not self.site_moved, "a fixed entity of the site moved: it cannot be rewound"
        space = self.space
        movers = {index: (counter, make) for index, counter, make in mark.movers}
        kept = [e for e in self.entities[: mark.entities] if e.index not in movers]
        keep_shapes = {s for e in kept for s in e.shapes}
        keep_bodies = {b for e in kept for b in (e.body, *e.aux_bodies)}
        keep_constraints = {c for e in kept for c in e.constraints}
        leaving = [c for c in space.constraints if c not in keep_constraints]
        leaving += [s for s in space.shapes if s not in keep_shapes]
        leaving += [b for b in space.bodies if b not in keep_bodies]
        if leaving:
            space.remove(*leaving)
        entities = self.entities[: mark.entities]
        for index, (counter, make) in movers.items():
            physics.shape_counter(space, counter)
            entity = entities[index] = make()
            entity.index = index
            space.add(entity.body, *entity.aux_bodies, *entity.shapes, *entity.constraints)
        physics.shape_counter(space, mark.counter)
        physics.forget_time_step(space)
        self.entities = entities
        self.entity_of_shape = {s: e for e in entities for s in e.shapes}
        self.agents, self.zones, self.channel = [], [], None
        self.tagged = [e for e in entities if isinstance(e, Obstacle) and e.tag is not None]
        self.log.clear()
        self.changed = []
        self.revision = mark.revision
        self.grips = {}
        self._inside, self._felt, self._felt_rows = [], {}, 0

    def take_changed(self) -> list[Entity]:
        """The entities changed since the last call, each once."""
        changed = list(dict.fromkeys(self.changed))
        self.changed.clear()
        return changed

    # -- questions ----------------------------------------------------------------------

    def is_free(self, x: float, y: float, radius: float, ignore: Entity | None = None) -> bool:
        """True if a disc of ``radius`` at (x, y) lies in the arena and touches nothing
        (but ``ignore``'s own shapes)."""
        width, height = self.size
        if not (radius <= x <= width - radius and radius <= y <= height - radius):
            return False
        hits = self.space.point_query((x, y), radius, _SOLID_OR_ITEM)
        if ignore is not None:
            hits = [hit for hit in hits if hit.shape not in ignore.shapes]
        return not hits

    def is_clear(self, entity: Entity) -> bool:
        """Whether nothing solid overlaps the entity's shapes (e.g. a doorway)."""
        for shape in entity.shapes:
            shape.cache_bb()
            if any(not hit.shape.sensor for hit in self.space.shape_query(shape)):
                return False
        return True

    # -- stepping -----------------------------------------------------------------------

    def step(self) -> None:
        """Advance one environment step (``substeps`` pymunk steps) and fill the log."""
        self.log.clear()
        if self.zones:
            self._inside = self._occupancy()
        self._step(self.space, self.substep_dt, self.substeps)
        if self.zones:
            self._log_zones()

    def _occupancy(self) -> list[list[bool]]:
        """For each agent, whether its centre lies in each zone (plain Python: a handful
        of agents and zones is faster so than through numpy); retired agents lie nowhere."""
        rects = [z.rect for z in self.zones]
        inside = []
        for agent in self.agents:
            if not agent.visible:
                inside.append([False] * len(rects))
                continue
            x, y = agent.body.position
            inside.append([x0 <= x <= x1 and y0 <= y <= y1 for x0, y0, x1, y1 in rects])
        return inside

    def _log_zones(self) -> None:
        log, zones, before = self.log, self.zones, self._inside
        now = self._occupancy()
        for a, row in enumerate(now):
            for z, here in enumerate(row):
                if here and not before[a][z]:
                    log.entered.append((self.agents[a], zones[z]))
        for z, zone in enumerate(zones):
            if zone.name is not None and any(row[z] for row in now):
                log.occupied.add(zone.name)
        for thing in self.tagged:
            x, y = thing.body.position
            for zone in zones:
                if zone.accepts == thing.tag and zone.contains(x, y):
                    log.deliveries.append((thing, zone))
                    break

    # -- collision callbacks (record only) ----------------------------------------------

    def _actor(self, shape: pymunk.Shape) -> Entity:
        """The agent's base that ``shape`` (of a collision type of agents) belongs to."""
        actor = self.entity_of_shape[shape].actor
        assert actor is not None, "an agent's shape without its agent"
        return actor

    def _on_item(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data) -> None:
        agent_shape, item_shape = arbiter.shapes
        item = cast(Item, self.entity_of_shape[item_shape])
        self.log.items.append((self._actor(agent_shape), item))

    def _on_door(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data) -> None:
        agent_shape, door_shape = arbiter.shapes
        door = cast(Door, self.entity_of_shape[door_shape])
        self.log.doors.append((self._actor(agent_shape), door))

    def _on_key(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data) -> None:
        thing, door = (self.entity_of_shape[s] for s in arbiter.shapes)
        if thing.key is not None:
            self.log.keys.append((thing, cast(Door, door)))

    def _on_grip(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data) -> None:
        grip, other = arbiter.shapes
        thing = self.entity_of_shape[other]
        touching = self.grips.get(grip)
        if touching is not None and getattr(thing, "graspable", False) and thing not in touching:
            touching.append(thing)

    def _on_ungrip(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data) -> None:
        grip, other = arbiter.shapes
        if grip.collision_type != CollisionType.GRASPER:
            grip, other = other, grip
        touching = self.grips.get(grip)
        thing = self.entity_of_shape.get(other)
        if touching is not None and thing in touching:
            touching.remove(thing)

    def _on_push(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data) -> None:
        """Log a push on a felt shape. pymunk calls this handler (agents' types against
        anything) with the agent's shape first, and once for each agent's shape of a
        contact between two agents; the normal points from that shape into the other."""
        felt = self._felt.get(arbiter.shapes[0])
        if felt is None:
            return
        row, body = felt
        nx, ny = arbiter.normal
        jx, jy = arbiter.total_impulse  # on the first shape: against the normal
        push = -(jx * nx + jy * ny)
        if push <= 0.0:  # touching without pushing (sensors, like items, never come here)
            return
        bearing = math.atan2(ny, nx) - body.angle
        logged = self.log.pushes
        pushes = logged.get(row)
        if pushes is None:
            logged[row] = [(bearing, push)]
        else:
            pushes.append((bearing, push))

    def _on_agent_contact(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data) -> None:
        self._count_contact(arbiter, +1)

    def _on_agent_release(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data) -> None:
        self._count_contact(arbiter, -1)

    def _count_contact(self, arbiter: pymunk.Arbiter, change: int) -> None:
        """Keep each agent's count of solid contacts (pymunk calls the wildcard handler
        once for each agent of an agent-agent contact)."""
        agent_shape, other = arbiter.shapes
        if agent_shape.collision_type not in _AGENT_TYPES:  # e.g. when a shape is removed
            agent_shape, other = other, agent_shape
        if not other.sensor:
            self._actor(agent_shape).touching += change
