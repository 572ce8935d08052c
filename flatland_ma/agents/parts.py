"""Body parts: a head and arms, each a pymunk body joined to the agent's base.

Every joint is a pivot, a rotary limit and a motor (``SimpleMotor``, torque-limited): the
action sets the motor's rate, and with rate 0 the motor holds the joint where it is. An
agent's shapes share a collision group, so its parts never collide with each other; they
collide with the world and with other agents, and other agents' cameras see them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import pymunk

from flatland_ma.agents.body import AgentBody
from flatland_ma.agents.grasp import Hand
from flatland_ma.scenario.schema import AgentSpec, ArmSpec, HeadSpec
from flatland_ma.world.entities import Category, CollisionType, Entity


@dataclass(eq=False)
class Part(Entity):
    """A head or an arm segment of an agent."""

    base: AgentBody | None = None
    parent: pymunk.Body | None = None
    motor: pymunk.SimpleMotor | None = None
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


def attach_parts(spec: AgentSpec, base: AgentBody, agent_index: int) -> list[Part]:
    """Build the head and arms of ``spec`` on ``base``; fill the base's part lists."""
    for shape in base.shapes:
        shape.filter = agent_filter(agent_index)
    parts: list[Part] = []
    if spec.head is not None:
        base.head = _head(spec.head, base, agent_index)
        parts.append(base.head)
    for arm in spec.arms:
        segments, hand = _arm(arm, base, agent_index, spec.radius)
        parts += segments
        base.joints += segments
        if hand is not None:
            base.hands.append(hand)
    base.parts = parts
    return parts


def _joint(parent: pymunk.Body, child: pymunk.Body, pivot, lo, hi, rate, torque):
    pin = pymunk.PivotJoint(parent, child, pivot)
    limit = pymunk.RotaryLimitJoint(parent, child, lo, hi)
    motor = pymunk.SimpleMotor(parent, child, 0.0)
    motor.max_force = torque
    return pin, limit, motor


def _head(spec: HeadSpec, base: AgentBody, agent_index: int) -> Part:
    anchor = base.body
    body = pymunk.Body(spec.mass, pymunk.moment_for_circle(spec.mass, 0, spec.radius))
    body.center_of_gravity = (spec.offset, 0.0)
    # pymunk turns a body about its centre of gravity: set the angle, then the position.
    body.angle, body.position = anchor.angle, anchor.position
    shape = pymunk.Circle(body, spec.radius, (spec.offset, 0.0))
    shape.collision_type = CollisionType.AGENT
    shape.filter = agent_filter(agent_index)
    limit = math.radians(spec.max_angle)
    pin, stop, motor = _joint(anchor, body, anchor.position, -limit, limit, 0, spec.max_torque)
    return Part(
        body=body,
        shapes=(shape,),
        color=_darker(base.color),
        constraints=(pin, stop, motor),
        owner=agent_index,
        base=base,
        parent=anchor,
        motor=motor,
        limits=(-limit, limit),
        max_rate=math.radians(spec.turn_rate),
        cog=(spec.offset, 0.0),
    )


def _arm(arm: ArmSpec, base: AgentBody, agent_index: int, radius: float):
    mount = math.radians(arm.mount)
    parent = base.body
    heading = parent.angle + mount
    joint_point = parent.local_to_world((radius * math.cos(mount), radius * math.sin(mount)))
    segments = []
    for k, seg in enumerate(arm.segments):
        verts = [
            (0.0, -seg.width / 2),
            (seg.length, -seg.width / 2),
            (seg.length, seg.width / 2),
            (0.0, seg.width / 2),
        ]
        body = pymunk.Body(seg.mass, pymunk.moment_for_poly(seg.mass, verts))
        body.center_of_gravity = (seg.length / 2, 0.0)
        body.angle, body.position = heading, joint_point
        shape = pymunk.Poly(body, verts)
        shape.collision_type = CollisionType.AGENT
        shape.filter = agent_filter(agent_index)
        shape.friction = 0.6
        shapes = [shape]
        rest = mount if k == 0 else 0.0
        lo, hi = rest + math.radians(seg.min_angle), rest + math.radians(seg.max_angle)
        constraints = _joint(parent, body, joint_point, lo, hi, 0, arm.max_torque)
        part = Part(
            body=body,
            shapes=tuple(shapes),
            color=_darker(base.color),
            constraints=constraints,
            owner=agent_index,
            base=base,
            parent=parent,
            motor=constraints[2],
            limits=(lo, hi),
            max_rate=math.radians(arm.joint_rate),
            cog=(seg.length / 2, 0.0),
        )
        segments.append(part)
        parent = body
        joint_point = body.local_to_world((seg.length, 0.0))
    hand = None
    if arm.grasper is not None:
        tip = segments[-1]
        grip = pymunk.Circle(tip.body, arm.grasper.radius, (arm.segments[-1].length, 0.0))
        grip.collision_type = CollisionType.GRASPER
        grip.filter = agent_filter(agent_index)
        grip.friction = 1.0
        tip.shapes = (*tip.shapes, grip)
        hand = Hand(arm.grasper, grip, tip)
    return segments, hand


def _darker(color) -> tuple[float, float, float]:
    return tuple(0.7 * c for c in color)
