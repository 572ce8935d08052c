"""Agents from their spec: parts (head, arm segments, graspers), sensors, and the body.

The parts' names follow the action layout documented in ``agents/actuators.py``: with one
arm of one joint, ``arm`` (``arm_left`` / ``arm_right``, ``grasp`` / ``release``); with
several, ``arm<k>`` and ``arm<k>_joint<j>``; a single grasper's macros are ``grasp`` and
``release`` whatever the arms, several graspers' ``arm<k>_grasp`` and so on.
"""

from __future__ import annotations

import dataclasses
import math

import pymunk

from flatland_ma.agents.body import AgentBody, make_agent_body
from flatland_ma.agents.grasp import Grasper
from flatland_ma.agents.parts import PART_KINDS, ArmSegment, Head, Link, Part, agent_filter
from flatland_ma.build.kind_faults import made_from_spec, make_kind
from flatland_ma.kinds.registry import ExtensionError
from flatland_ma.scenario.spec_agent import AgentSpec, ChannelSpec
from flatland_ma.sensors.hearing import Hearing
from flatland_ma.sensors.noise import Noise
from flatland_ma.sensors.sensor import SENSOR_KINDS, Sensor
from flatland_ma.world import physics
from flatland_ma.world.looks import RGB

MOTOR_KEYS = ("radius", "mass", "max_speed", "max_turn_rate", "max_force", "max_torque")
"""The agent's keys that make its base and motor."""


def make_parts(agent: AgentSpec) -> list[Part]:
    """The agent's parts, in the order of their controls: head, arm segments, graspers,
    the entries of its ``parts`` (kinds registered from outside), then those other kinds
    make from its other keys (``Part.for_agent``, by kind name)."""
    parts: list[Part] = []
    if agent.head is not None:
        parts.append(Head(**agent.head.model_dump()))
    single = len(agent.arms) == 1
    tips = []
    for k, arm in enumerate(agent.arms):
        label = "arm" if single else f"arm{k}"
        previous = None
        for j, seg in enumerate(arm.segments):
            name = label if single and len(arm.segments) == 1 else f"{label}_joint{j}"
            previous = ArmSegment(
                name,
                f"arms[{k}]",
                agent.radius,
                previous,
                mount=arm.mount,
                joint_rate=arm.joint_rate,
                max_torque=arm.max_torque,
                **seg.model_dump(),
            )
            parts.append(previous)
        if arm.grasper is not None:
            tips.append((label, f"arms[{k}].grasper", previous, arm.grasper))
    for label, where, tip, grasper in tips:
        prefix = "" if len(tips) == 1 else f"{label}_"
        parts.append(Grasper(f"{label}_grip", prefix, where, tip, **grasper.model_dump()))
    for k, entry in enumerate(agent.parts):
        values = entry.model_dump(exclude={"type"})
        kind = PART_KINDS[entry.type]
        where = f"an agent's parts[{k}]"
        part = make_kind(kind, where, values, kind.from_spec, values, agent)
        part = made_from_spec(part, Part, kind, where)
        part.label = part.label or f"parts[{k}]"
        parts.append(part)
    for kind in PART_KINDS.every():  # any other kind the agent declares
        parts += kind.for_agent(agent)
    return parts


def footprint(agent: AgentSpec, parts: list[Part]) -> float:
    """Radius of the disc an agent with its parts needs to start in."""
    return max([agent.radius, *(part.reach() for part in parts)])


def fastest_parts(agent: AgentSpec, parts: list[Part]) -> list[tuple[str, float, float]]:
    """(part, top speed in units per second, half thickness) for the base and each part,
    the speed counting the base's motion and every joint turning at once."""
    turn = math.radians(agent.max_turn_rate)
    fastest = [("base", agent.max_speed, agent.radius)]
    for part in parts:
        fastest.append((part.label, part.top_speed(agent.max_speed, turn), part.half_width()))
    return fastest


def make_sensors(
    agent: AgentSpec, channel: ChannelSpec | None = None, n_agents: int = 1
) -> list[Sensor]:
    """The agent's sensors, from each spec's ``type``; with a ``channel`` (of a scenario
    of ``n_agents``), its hearing last."""
    sensors: list[Sensor] = []
    parts = make_parts(agent)
    for k, spec in enumerate(agent.sensor_specs):
        values = spec.model_dump(exclude={"type", "noise"})
        values["name"] = spec.name or spec.type
        kind = SENSOR_KINDS[spec.type]
        where = f"an agent's sensors[{k}]"
        sensor = make_kind(kind, where, values, kind.from_spec, values, parts)
        sensor = made_from_spec(sensor, Sensor, kind, where)
        if spec.noise is not None and spec.noise.active:
            sensor.noise = Noise(**spec.noise.model_dump())
        sensors.append(sensor)
    if channel is not None:
        sensors.append(Hearing(n_agents, channel.tokens, channel.vocabulary))
    return sensors


def make_agent(
    agent: AgentSpec,
    index: int,
    position: tuple[float, float],
    angle: float,
    color: RGB,
    substep_dt: float,
    step_dt: float,
    reuse: AgentBody | None = None,
) -> AgentBody:
    """Agent ``index``'s base and parts at ``position`` facing ``angle`` (radians); the
    parts are built but not yet added to a world (``body.links`` are). With ``reuse`` (the
    same agent's base in the last episode, out of the space), a base without parts is
    made on its bodies and shape (see ``placed_again``)."""
    if reuse is not None and not reuse.parts and not agent.parts and physics.BIAS_CLEARABLE:
        return placed_again(reuse, position, angle, color)
    motor = agent.model_dump(include=set(MOTOR_KEYS))
    body = make_agent_body(index, position, angle, color, substep_dt, step_dt, **motor)
    for shape in body.shapes:
        shape.filter = agent_filter(index)
    body.parts = make_parts(agent)
    for part in body.parts:
        built = part.build(body)
        if part.jointed != isinstance(built, Link):
            what = "a Link" if part.jointed else "no Link (it is not jointed)"
            raise ExtensionError(
                f"{type(part).__name__}.build must return {what}: a part's class says "
                f"whether it is jointed (Part.jointed), and the agent registers its link"
            )
        if isinstance(built, Link):
            body.links.append(built)  # parents before children: parts build in that order
    return body


def placed_again(old: AgentBody, position: tuple[float, float], angle: float, color) -> AgentBody:
    """A base without parts as ``make_agent_body`` makes it, on ``old``'s pymunk bodies
    and shape (a reset in place makes no pymunk bodies for plain agents, so leaves none to
    the garbage collector): both bodies at rest where the base starts, their solver's
    pseudo-velocities cleared (``physics.clear_bias``), the agent's state as new. Its two
    joints are made again, since Chipmunk carries each joint's impulse from step to step
    and pymunk cannot clear it."""
    body, control = old.body, old.control
    for moved in (body, control):
        moved.velocity, moved.angular_velocity = (0.0, 0.0), 0.0
        moved.force, moved.torque = (0.0, 0.0), 0.0
        physics.clear_bias(moved)
    body.position, body.angle = position, angle
    control.position, control.angle = position, 0.0
    pivot, gear = old.constraints
    slide = pymunk.PivotJoint(control, body, (0.0, 0.0), (0.0, 0.0))
    slide.max_bias, slide.max_force = pivot.max_bias, pivot.max_force
    spin = pymunk.GearJoint(control, body, gear.phase, gear.ratio)  # type: ignore[attr-defined]
    spin.max_bias, spin.max_force = gear.max_bias, gear.max_force
    return dataclasses.replace(
        old,
        constraints=(slide, spin),
        color=color,
        index=-1,
        visible=True,
        touching=0,
        target=(0.0, 0.0, 0.0),
        parts=[],
        links=[],
        joints=[],
        hands=[],
    )
