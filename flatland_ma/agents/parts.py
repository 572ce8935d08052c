"""Body parts: what an agent has beyond its round base (a head, arm segments, graspers).

Every part follows one protocol (``Part``): it lists its ``controls`` (each one entry of a
continuous action and two discrete macro actions), ``build``s its bodies, shapes and
joints onto the agent, turns this step's values of its controls into motor commands
(``command``), and says how far from the base's centre it reaches and how fast it can
move (for start places and for the check that no part is fast enough to cross a wall in
one physics substep). The actuator derives the action spaces from the parts' controls.

A new part is one subclass, named by its ``kind`` in the class statement, plus its spec
(a subclass of ``scenario.spec_agent.PartBaseSpec`` with ``type: Literal["<kind>"]``),
registered with ``flatland_ma.register(spec, part)``; a file lists it in an agent's
``parts``, and the builder makes it with ``from_spec`` (the spec's keys but ``type``, as
keyword arguments). (Heads, arm segments and graspers are made by the builder itself from
the ``head`` and ``arms`` keys, which names their controls after the arms' layout; a kind
may also make parts from other keys of the agent's spec with ``for_agent``.)

Parts with a body (``Link``: the head, each arm segment) sit on a pivot with a rotary
limit and a torque-limited motor (``jointed_link`` makes one): the command sets the
motor's rate, and with rate 0 the motor holds the joint where it is. Such a part sets
``jointed`` and returns its link from ``build``; the agent then registers it (its
``links``: teleports carry it, its motor is driven, proprioception reads its angle). An
agent's shapes share a collision group (``agent_filter``), so its parts never collide with
each other; they collide with the world and with other agents, and other agents' cameras
see them.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass

import pymunk

from flatland_ma.agents.body import AgentBody
from flatland_ma.kinds.registry import Kinded, Kinds
from flatland_ma.world.entities import Category, CollisionType, Entity, darker

PART_KINDS = Kinds("flatland_ma.agents", "part")
"""Every part class, by its kind."""


@dataclass(frozen=True)
class Control:
    """One control of a part: the name of its continuous entry (a value in [-1, 1]) and
    of the discrete macros that set it to +1 and to -1."""

    name: str
    plus: str
    minus: str


class Part(Kinded, ABC):
    """Base of every body part (see the module docstring).

    Required: ``controls``, ``build``, ``command``, ``reach``, ``top_speed``,
    ``half_width``; ``label`` names it in messages (e.g. ``arms[0]``).
    """

    KINDS = PART_KINDS
    controls: tuple[Control, ...] = ()
    label: str = ""
    jointed: bool = False
    """Whether ``build`` returns a ``Link`` (a body on a motorised joint), which the agent
    registers in its ``links`` and proprioception reads (one entry per jointed part)."""
    holds: bool = False
    """Whether it is a hand that holds things: its ``held`` is what it holds, or None
    (proprioception reads one entry for it)."""

    @classmethod
    def from_spec(cls, values: dict, agent) -> Part:
        """The part an entry of an agent's ``parts`` describes: ``values`` are the entry's
        keys but ``type``, ``agent`` the agent's spec. By default ``cls(**values)``."""
        return cls(**values)

    @classmethod
    def for_agent(cls, agent) -> list[Part]:
        """The parts of this kind that other keys of ``agent`` (the scenario's agent spec)
        declare, in order; none by default (its ``parts`` entries are ``from_spec``'s)."""
        return []

    @abstractmethod
    def build(self, agent: AgentBody) -> Entity | None:
        """Make its bodies, shapes and joints on ``agent`` (at the agent's pose); return
        the entity to add to the world, if it has a body of its own: a ``Link`` if
        ``jointed`` (the agent registers it; ``build`` does not touch ``agent.links``)."""

    @abstractmethod
    def command(self, values, angles: dict) -> None:
        """Act on this step's values of its controls (each in [-1, 1], or None when a
        discrete action left it alone); ``angles`` holds each body's angle, read once."""

    @abstractmethod
    def reach(self) -> float:
        """How far from the base's centre it reaches."""

    @abstractmethod
    def top_speed(self, base_speed: float, base_turn: float) -> float:
        """Its fastest speed (units per second) when the base moves at ``base_speed`` and
        turns at ``base_turn`` (radians per second) and every joint turns at once."""

    @abstractmethod
    def half_width(self) -> float:
        """Half its thickness: how far into a wall it may go before crossing it."""

    def own_shapes(self) -> tuple[pymunk.Shape, ...]:
        """The shapes that are this part's own, once built (a touch sensor feels each
        part on them); none by default."""
        return ()


@dataclass(eq=False)
class Link(Entity):
    """The body of a head or an arm segment, joined to its parent by a motorised joint."""

    base: AgentBody = None  # type: ignore[assignment]  # set when built
    parent: pymunk.Body = None  # type: ignore[assignment]
    motor: pymunk.Constraint | None = None
    limits: tuple[float, float] = (0.0, 0.0)
    """Lowest and highest angle of the body relative to its parent, in radians."""
    max_rate: float = 0.0
    """Top speed of its joint, radians per second."""
    cog: tuple[float, float] = (0.0, 0.0)
    """Its centre of gravity in body coordinates."""
    rate: float = 0.0
    """The rate last given to its motor (pymunk's sign: parent minus child)."""

    @property
    def actor(self) -> AgentBody:
        return self.base

    @property
    def angle_to_parent(self) -> float:
        return self.body.angle - self.parent.angle


def agent_filter(agent_index: int) -> pymunk.ShapeFilter:
    """All shapes of one agent: one group (no collisions among them), category AGENT."""
    return pymunk.ShapeFilter(group=agent_index + 1, categories=Category.AGENT)


def motor_joint(parent: pymunk.Body, child: pymunk.Body, pivot, lo: float, hi: float, torque):
    """The three constraints of a motorised joint: a pivot at ``pivot`` (world
    coordinates), a rotary limit of the child's angle relative to the parent between
    ``lo`` and ``hi`` (radians), and a motor of at most ``torque`` (its rate starts at 0)."""
    pin = pymunk.PivotJoint(parent, child, pivot)
    limit = pymunk.RotaryLimitJoint(parent, child, lo, hi)
    motor = pymunk.SimpleMotor(parent, child, 0.0)
    motor.max_force = torque
    return pin, limit, motor


def jointed_link(
    agent: AgentBody,
    body: pymunk.Body,
    shapes: tuple[pymunk.Shape, ...],
    parent: pymunk.Body,
    pivot,
    limits: tuple[float, float],
    max_rate: float,
    max_torque: float,
) -> Link:
    """A part's body on ``parent`` (the agent's base body, or another link's), joined at
    ``pivot`` (world coordinates) by a ``motor_joint``: ``limits`` (radians, relative to
    the parent), top rate ``max_rate`` (radians per second), ``max_torque``. ``body`` is
    placed already (set its angle, then its position: pymunk turns a body about its
    centre of gravity); its ``shapes`` are made the agent's (collision type and group)
    and drawn a shade darker than the agent. Return it from a ``jointed`` part's
    ``build``."""
    for shape in shapes:
        shape.collision_type = CollisionType.AGENT
        shape.filter = agent_filter(agent.owner)
    constraints = motor_joint(parent, body, pivot, *limits, max_torque)
    return Link(
        body=body,
        shapes=tuple(shapes),
        color=darker(agent.color),
        constraints=constraints,
        owner=agent.owner,
        base=agent,
        parent=parent,
        motor=constraints[2],
        limits=limits,
        max_rate=max_rate,
        cog=(body.center_of_gravity.x, body.center_of_gravity.y),
    )


class Jointed(Part):
    """A part with a body of its own on a motorised joint: its one control is the joint's
    rate, as a fraction of its top speed (held still when not commanded)."""

    jointed = True
    link: Link  # made by ``build``

    def command(self, values, angles: dict) -> None:
        (value,) = values
        self.link.base.set_rate(self.link, 0.0 if value is None else value, angles)

    def own_shapes(self) -> tuple[pymunk.Shape, ...]:
        return self.link.shapes[:1]  # a grasper adds its disc to the tip's link after it


class Head(Jointed, kind="head"):
    """A small disc ``offset`` ahead of the base's centre, turning about that centre up to
    ``max_angle`` degrees either way of the heading, at up to ``turn_rate`` degrees per
    second."""

    def __init__(
        self,
        radius: float = 4.0,
        offset: float = 6.0,
        max_angle: float = 90.0,
        turn_rate: float = 300.0,
        max_torque: float = 50_000.0,
        mass: float = 0.1,
    ):
        self.radius, self.offset, self.mass = radius, offset, mass
        self.limit = math.radians(max_angle)
        self.turn_rate = math.radians(turn_rate)
        self.max_torque = max_torque
        self.controls = (Control("head", "head_left", "head_right"),)
        self.label = "head"
        self.link: Link  # made by ``build``

    def build(self, agent: AgentBody) -> Link:
        anchor = agent.body
        body = pymunk.Body(self.mass, pymunk.moment_for_circle(self.mass, 0, self.radius))
        body.center_of_gravity = (self.offset, 0.0)
        # pymunk turns a body about its centre of gravity: set the angle, then the position.
        body.angle, body.position = anchor.angle, anchor.position
        shape = pymunk.Circle(body, self.radius, (self.offset, 0.0))
        limits = (-self.limit, self.limit)
        self.link = jointed_link(
            agent, body, (shape,), anchor, anchor.position, limits, self.turn_rate, self.max_torque
        )
        agent.head = self.link
        return self.link

    def reach(self) -> float:
        return self.offset + self.radius

    def top_speed(self, base_speed: float, base_turn: float) -> float:
        return base_speed + (base_turn + self.turn_rate) * self.reach()

    def half_width(self) -> float:
        return self.radius


class ArmSegment(Jointed, kind="arm_segment"):
    """One segment of an arm: a bar ``length`` long and ``width`` thick on a motorised
    joint, at the base's rim (``mount`` degrees from the heading) for the first segment,
    at the tip of the ``previous`` one otherwise; its joint turns between ``min_angle`` and
    ``max_angle`` degrees from the previous segment (or the mount direction)."""

    def __init__(
        self,
        name: str,
        label: str,
        base_radius: float,
        previous: ArmSegment | None = None,
        mount: float = 0.0,
        length: float = 16.0,
        width: float = 6.0,
        min_angle: float = -90.0,
        max_angle: float = 90.0,
        mass: float = 0.2,
        joint_rate: float = 180.0,
        max_torque: float = 50_000.0,
    ):
        self.previous, self.base_radius = previous, base_radius
        self.mount = math.radians(mount)
        self.length, self.width, self.mass = length, width, mass
        rest = self.mount if previous is None else 0.0
        self.limits = (rest + math.radians(min_angle), rest + math.radians(max_angle))
        self.joint_rate = math.radians(joint_rate)
        self.max_torque = max_torque
        self.depth = 1 if previous is None else previous.depth + 1
        """How many joints lie between it and the base, its own included."""
        self.controls = (Control(name, f"{name}_left", f"{name}_right"),)
        self.label = label
        self.link: Link  # made by ``build``

    def build(self, agent: AgentBody) -> Link:
        if self.previous is None:
            parent = agent.body
            heading = parent.angle + self.mount
            r = self.base_radius
            joint = parent.local_to_world((r * math.cos(self.mount), r * math.sin(self.mount)))
        else:
            parent = self.previous.link.body
            heading = parent.angle
            joint = parent.local_to_world((self.previous.length, 0.0))
        h = self.width / 2
        verts = [(0.0, -h), (self.length, -h), (self.length, h), (0.0, h)]
        body = pymunk.Body(self.mass, pymunk.moment_for_poly(self.mass, verts))
        body.center_of_gravity = (self.length / 2, 0.0)
        body.angle, body.position = heading, joint
        shape = pymunk.Poly(body, verts)
        shape.friction = 0.6
        self.link = jointed_link(
            agent, body, (shape,), parent, joint, self.limits, self.joint_rate, self.max_torque
        )
        agent.joints.append(self.link)
        return self.link

    def reach(self) -> float:
        start = self.base_radius if self.previous is None else self.previous.reach()
        return start + self.length

    def top_speed(self, base_speed: float, base_turn: float) -> float:
        return base_speed + (base_turn + self.joint_rate * self.depth) * self.reach()

    def half_width(self) -> float:
        return self.width / 2
