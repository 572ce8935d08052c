"""An agent's round base as a pymunk body, driven through a motor.

The base is dynamic: it collides with walls, obstacles and other agents. A kinematic
control body carries the commanded velocity; a pivot joint and a gear joint with zero
bias drag the base towards it with at most ``max_force`` / ``max_torque``. So commands are
velocities, but contacts are solved physically (the pymunk top-down "tank" pattern).

pymunk moves bodies before it solves joints, so a joint alone would act one substep late
(a left turn right after a right turn would not turn at all). ``drive`` therefore also
gives the agent, at once, the change of velocity its motors can make in one substep: a
plain base always gets its change of turn rate, and its change of velocity while it
touches nothing; an agent with parts gets both, carried rigidly through its joints and
adding each joint's change of rate, while it touches nothing. Touching something,
velocities are left to the motors and the contact solver: moving a body into a contact
before the solver runs would push it into walls and other agents.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import pymunk

from flatland_ma.world.entities import Category, CollisionType, Entity, shape_filter
from flatland_ma.world.looks import RGB


@dataclass(eq=False)
class AgentBody(Entity):
    control: pymunk.Body = None  # type: ignore[assignment]  # set by make_agent_body
    max_speed: float = 0.0
    """Units per second."""
    max_turn_rate: float = 0.0
    """Radians per second."""
    max_dv: float = 0.0
    """Largest change of linear speed the motor makes in one substep (units per second)."""
    max_dw: float = 0.0
    """Largest change of turn rate the motor makes in one substep (radians per second)."""
    step_dt: float = 1.0 / 30.0
    """Seconds per environment step."""
    parts: list = field(default_factory=list)
    """Its parts (``parts.Part``: head, arm segments, graspers), in the order of their
    controls."""
    links: list = field(default_factory=list)
    """The bodies its parts add (``parts.Link``: head, arm segments), each on a joint,
    parents before children."""
    head: Entity = None  # type: ignore[assignment]  # None unless it has a head
    """The head's link, if any (a camera may sit on it)."""
    joints: list = field(default_factory=list)
    """The arm segments' links, in action order."""
    hands: list = field(default_factory=list)
    """The graspers (``grasp.Grasper``), in action order."""
    target: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Commanded velocity and turn rate of the base, in world coordinates."""

    @property
    def actor(self) -> AgentBody:
        return self

    def command_parts(self, values) -> None:
        """One value per control of the parts, in order (None: not commanded this step);
        each part reads its own values (see ``parts.Part.command``)."""
        # Each body's angle read once (pymunk's accessors dominate this step's cost).
        angles = {self.body: self.body.angle}
        for link in self.links:
            angles[link.body] = link.body.angle
        k = 0
        for part in self.parts:
            n = len(part.controls)
            part.command(values[k : k + n], angles)
            k += n

    def set_rate(self, part, fraction: float, angles: dict) -> None:
        """Drive a joint at ``fraction`` of its top speed, slowed so as to stop at its
        limits by the end of the step (pymunk's motor rate is parent minus child)."""
        wanted = fraction * part.max_rate
        lo, hi = part.limits
        angle = angles[part.body] - angles[part.parent]
        wanted = min(wanted, max(0.0, (hi - angle) / self.step_dt))
        wanted = max(wanted, min(0.0, (lo - angle) / self.step_dt))
        if part.rate != -wanted:
            part.rate = -wanted
            _set(part.motor, "rate", -wanted)

    def teleport(self, x: float, y: float, angle: float) -> None:
        """Put the agent (its parts carried along rigidly) at (x, y) facing ``angle``, at rest."""
        body = self.body
        ox, oy = body.position
        turn = angle - body.angle
        c, s = math.cos(turn), math.sin(turn)
        for b in (body, *(link.body for link in self.links)):
            px, py = b.position
            dx, dy = px - ox, py - oy
            b.angle += turn  # (pymunk turns about the centre of gravity: angle first)
            b.position = (x + c * dx - s * dy, y + s * dx + c * dy)
            b.velocity, b.angular_velocity = (0.0, 0.0), 0.0
            if b.space is not None:
                b.space.reindex_shapes_for_body(b)
        self.control.velocity, self.control.angular_velocity = (0.0, 0.0), 0.0

    def command(self, forward: float, lateral: float, turn: float) -> None:
        """Set the target velocity as fractions of the top speeds, in the body frame.

        ``forward`` along the heading, ``lateral`` to the left, ``turn`` counter-clockwise.
        """
        angle = self.body.angle
        c, s = math.cos(angle), math.sin(angle)
        v = self.max_speed
        vx, vy = v * (forward * c - lateral * s), v * (forward * s + lateral * c)
        w = self.max_turn_rate * turn
        control = self.control
        _set(control, "velocity", (vx, vy))
        _set(control, "angular_velocity", w)
        self.target = (vx, vy, w)

    def drive(self) -> None:
        """Give the agent now the velocity change its motors make in one substep."""
        body = self.body
        vx, vy, w = self.target
        dw = max(-self.max_dw, min(self.max_dw, w - body.angular_velocity))
        links = self.links
        if links and self.touching:
            return
        if not links:
            _set(body, "angular_velocity", body.angular_velocity + dw)
            if self.touching:
                return
        bvx, bvy = body.velocity
        dvx, dvy = vx - bvx, vy - bvy
        dv = math.hypot(dvx, dvy)
        if dv > self.max_dv:
            dvx, dvy = dvx * self.max_dv / dv, dvy * self.max_dv / dv
        if not links:
            _set(body, "velocity", (bvx + dvx, bvy + dvy))
            return
        # Read each body once: position of its origin (the joint), angle, velocity, spin.
        bx, by = body.position
        bw = body.angular_velocity
        _set(body, "velocity", (bvx + dvx, bvy + dvy))
        _set(body, "angular_velocity", bw + dw)
        change = {body: (dvx, dvy, dw, bx, by, bw)}  # and the centre of gravity, old spin
        for part in links:
            child = part.body
            pdx, pdy, pdw, px, py, pw = change[part.parent]
            jx, jy = child.position
            a = child.angle
            lx, ly = part.cog
            cx, cy = (
                jx + math.cos(a) * lx - math.sin(a) * ly,
                jy + math.sin(a) * lx + math.cos(a) * ly,
            )
            cw = child.angular_velocity
            # Carried rigidly with its parent (at the child's centre of gravity), plus the
            # change of its joint's rate (pymunk's motor rate is parent minus child).
            d_rel = -part.rate - (cw - pw)
            dx = pdx - pdw * (cy - py) - d_rel * (cy - jy)
            dy = pdy + pdw * (cx - px) + d_rel * (cx - jx)
            vx0, vy0 = child.velocity
            _set(child, "velocity", (vx0 + dx, vy0 + dy))
            _set(child, "angular_velocity", cw + pdw + d_rel)
            change[child] = (dx, dy, pdw + d_rel, cx, cy, cw)


_set = object.__setattr__
"""pymunk's own ``__setattr__`` only serves type checkers; the hot path goes round it."""


def make_agent_body(
    agent_index: int,
    position: tuple[float, float],
    angle: float,
    color: RGB,
    substep_dt: float,
    step_dt: float,
    radius: float = 10.0,
    mass: float = 1.0,
    max_speed: float = 200.0,
    max_turn_rate: float = 300.0,
    max_force: float = 15_000.0,
    max_torque: float = 100_000.0,
) -> AgentBody:
    """A round base of ``radius`` and ``mass`` with its motor: top ``max_speed`` (units
    per second) and ``max_turn_rate`` (degrees per second), reached with at most
    ``max_force`` and ``max_torque``."""
    moment = pymunk.moment_for_circle(mass, 0.0, radius)
    body = pymunk.Body(mass, moment)
    body.position = position
    body.angle = angle
    shape = pymunk.Circle(body, radius)
    shape.collision_type = CollisionType.AGENT
    shape.filter = shape_filter(Category.AGENT)
    shape.friction = 0.3
    shape.elasticity = 0.0
    control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
    control.position = position
    pivot = pymunk.PivotJoint(control, body, (0.0, 0.0), (0.0, 0.0))
    pivot.max_bias = 0.0
    pivot.max_force = max_force
    gear = pymunk.GearJoint(control, body, 0.0, 1.0)
    gear.max_bias = 0.0
    gear.max_force = max_torque
    return AgentBody(
        body=body,
        shapes=(shape,),
        color=color,
        constraints=(pivot, gear),
        aux_bodies=(control,),
        owner=agent_index,
        control=control,
        max_speed=max_speed,
        max_turn_rate=math.radians(max_turn_rate),
        max_dv=max_force * substep_dt / mass,
        max_dw=max_torque * substep_dt / moment,
        step_dt=step_dt,
    )
