"""The physical world: one pymunk space, its entities, stepping and the contact log."""

from __future__ import annotations

import pymunk

from flatland_ma.scenario.schema import PhysicsSpec
from flatland_ma.world.entities import Category, CollisionType, Entity

_SOLID_OR_ITEM = pymunk.ShapeFilter(mask=Category.EVERYTHING)
_AGENT_TYPES = (CollisionType.AGENT, CollisionType.GRASPER)


class World:
    """Owns the ``pymunk.Space``. Collision callbacks only record contacts; the task
    decides what they mean."""

    def __init__(self, physics: PhysicsSpec, size: tuple[float, float]):
        self.space = pymunk.Space()
        self.space.iterations = physics.iterations
        self.size = size
        self.dt = physics.dt
        self.substeps = physics.substeps
        self.substep_dt = physics.dt / physics.substeps
        self.entities: list[Entity] = []
        self.entity_of_shape: dict[pymunk.Shape, Entity] = {}
        self.contacts: list[tuple[Entity, Entity]] = []
        """(agent entity, item entity) pairs that began touching during the last step."""
        self.door_touches: list[tuple[Entity, Entity]] = []
        """(agent entity, door entity) pairs that began touching during the last step."""
        self.key_touches: list[tuple[Entity, Entity]] = []
        """(object, door) pairs that began touching during the last step."""
        self.hand_of_shape: dict = {}
        """Each grasper's shape and its hand (``agents.grasp.Hand``)."""
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

    def add(self, entity: Entity) -> Entity:
        entity.index = len(self.entities)
        self.entities.append(entity)
        for shape in entity.shapes:
            self.entity_of_shape[shape] = entity
        if entity.body is not self.space.static_body:
            self.space.add(entity.body)
        self.space.add(*entity.aux_bodies, *entity.shapes, *entity.constraints)
        return entity

    def withdraw(self, entity: Entity) -> None:
        """Take an entity's shapes out of the physics (it stays listed, hidden)."""
        entity.visible = False
        present = [s for s in entity.shapes if s.space is not None]
        if present:
            self.space.remove(*present)

    def restore(self, entity: Entity) -> None:
        """Put a withdrawn entity's shapes back."""
        entity.visible = True
        absent = [s for s in entity.shapes if s.space is None]
        if absent:
            self.space.add(*absent)

    def retire(self, entity: Entity) -> None:
        """Take an entity out of the physics for good (e.g. an agent whose episode ended)."""
        self.withdraw(entity)
        present = set(self.space.constraints)
        parts = [c for c in entity.constraints if c in present]
        parts += [b for b in (entity.body, *entity.aux_bodies) if b.space is not None]
        if parts:
            self.space.remove(*parts)

    def step(self) -> None:
        """Advance one environment step: ``substeps`` pymunk steps."""
        self.contacts.clear()
        self.door_touches.clear()
        self.key_touches.clear()
        step, dt = self.space.step, self.substep_dt
        for _ in range(self.substeps):
            step(dt)

    def _on_item(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data) -> None:
        agent_shape, item_shape = arbiter.shapes
        agent = self.entity_of_shape[agent_shape].actor
        self.contacts.append((agent, self.entity_of_shape[item_shape]))

    def _on_door(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data) -> None:
        agent_shape, door_shape = arbiter.shapes
        agent = self.entity_of_shape[agent_shape].actor
        self.door_touches.append((agent, self.entity_of_shape[door_shape]))

    def _on_key(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data) -> None:
        thing, door = (self.entity_of_shape[s] for s in arbiter.shapes)
        if thing.key is not None:
            self.key_touches.append((thing, door))

    def _on_grip(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data) -> None:
        grip, other = arbiter.shapes
        thing = self.entity_of_shape[other]
        hand = self.hand_of_shape.get(grip)
        if hand is not None and thing.graspable and thing not in hand.touching:
            hand.touching.append(thing)

    def _on_ungrip(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data) -> None:
        grip, other = arbiter.shapes
        if grip.collision_type != CollisionType.GRASPER:
            grip, other = other, grip
        hand = self.hand_of_shape.get(grip)
        thing = self.entity_of_shape.get(other)
        if hand is not None and thing in hand.touching:
            hand.touching.remove(thing)

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
            self.entity_of_shape[agent_shape].actor.touching += change

    def is_free(self, x: float, y: float, radius: float) -> bool:
        """True if a disc of ``radius`` at (x, y) lies in the arena and touches nothing."""
        width, height = self.size
        if not (radius <= x <= width - radius and radius <= y <= height - radius):
            return False
        return not self.space.point_query((x, y), radius, _SOLID_OR_ITEM)

    def move_static(self, entity: Entity, x: float, y: float) -> None:
        """Move a static or kinematic entity (e.g. a respawned item)."""
        entity.body.position = (x, y)
        self.space.reindex_shapes_for_body(entity.body)
