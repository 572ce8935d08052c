"""An agent's round base as a pymunk body, driven through a motor.

The base is dynamic: it collides with walls, obstacles and other agents. A kinematic
control body carries the commanded velocity; a pivot joint and a gear joint with zero
bias drag the base towards it with at most ``max_force`` / ``max_torque``. So commands are
velocities, but contacts are solved physically (the pymunk top-down "tank" pattern).

pymunk moves bodies before it solves joints, so a joint alone would act one substep late
(a left turn right after a right turn would not turn at all). ``command`` therefore also
gives the base, at once, the change of turn rate the motor can make in one substep, and
the change of velocity too while the base touches nothing. Touching something, the
velocity is left to the motor and the contact solver: moving a body into a contact before
the solver runs would push it into walls and other agents.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import pymunk

from flatland_ma.scenario.schema import AgentSpec
from flatland_ma.world.entities import RGB, Category, CollisionType, Entity, shape_filter


@dataclass(eq=False)
class AgentBody(Entity):
    control: pymunk.Body | None = None
    max_speed: float = 0.0
    """Units per second."""
    max_turn_rate: float = 0.0
    """Radians per second."""
    max_dv: float = 0.0
    """Largest change of linear speed the motor makes in one substep (units per second)."""
    max_dw: float = 0.0
    """Largest change of turn rate the motor makes in one substep (radians per second)."""
    touching: int = 0
    """Number of solid shapes the base touches (kept by the world's contact callbacks)."""

    def command(self, forward: float, lateral: float, turn: float) -> None:
        """Set the target velocity as fractions of the top speeds, in the body frame.

        ``forward`` along the heading, ``lateral`` to the left, ``turn`` counter-clockwise.
        """
        body = self.body
        angle = body.angle
        c, s = math.cos(angle), math.sin(angle)
        v = self.max_speed
        vx, vy = v * (forward * c - lateral * s), v * (forward * s + lateral * c)
        w = self.max_turn_rate * turn
        self.control.velocity = (vx, vy)
        self.control.angular_velocity = w

        dw = w - body.angular_velocity
        body.angular_velocity += max(-self.max_dw, min(self.max_dw, dw))
        if self.touching:
            return
        bvx, bvy = body.velocity
        dvx, dvy = vx - bvx, vy - bvy
        dv = math.hypot(dvx, dvy)
        if dv > self.max_dv:
            dvx, dvy = dvx * self.max_dv / dv, dvy * self.max_dv / dv
        body.velocity = (bvx + dvx, bvy + dvy)


def make_agent_body(
    spec: AgentSpec,
    agent_index: int,
    position: tuple[float, float],
    angle: float,
    color: RGB,
    substep_dt: float,
) -> AgentBody:
    moment = pymunk.moment_for_circle(spec.mass, 0.0, spec.radius)
    body = pymunk.Body(spec.mass, moment)
    body.position = position
    body.angle = angle
    shape = pymunk.Circle(body, spec.radius)
    shape.collision_type = CollisionType.AGENT
    shape.filter = shape_filter(Category.AGENT)
    shape.friction = 0.3
    shape.elasticity = 0.0
    control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
    control.position = position
    pivot = pymunk.PivotJoint(control, body, (0.0, 0.0), (0.0, 0.0))
    pivot.max_bias = 0.0
    pivot.max_force = spec.max_force
    gear = pymunk.GearJoint(control, body, 0.0, 1.0)
    gear.max_bias = 0.0
    gear.max_force = spec.max_torque
    agent = AgentBody(
        body=body,
        shapes=(shape,),
        color=color,
        constraints=(pivot, gear),
        aux_bodies=(control,),
        owner=agent_index,
        control=control,
        max_speed=spec.max_speed,
        max_turn_rate=math.radians(spec.max_turn_rate),
        max_dv=spec.max_force * substep_dt / spec.mass,
        max_dw=spec.max_torque * substep_dt / moment,
    )
    return agent
