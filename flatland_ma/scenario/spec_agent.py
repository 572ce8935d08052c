"""Agents: their bodies, motors, cameras, action mode and where they start."""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import Field, field_validator, model_validator

from flatland_ma.scenario.kinds import SpecKinds
from flatland_ma.scenario.spec_sensors import SENSORS as SENSORS  # here too, as before
from flatland_ma.scenario.spec_sensors import CameraSpec, SensorSpec
from flatland_ma.scenario.spec_sensors import SensorBaseSpec as SensorBaseSpec  # here too
from flatland_ma.scenario.types import (
    MAX_FORCE,
    Color,
    Degrees,
    Distance,
    Length,
    Mass,
    Name,
    Real,
    Rect,
    Spec,
    Speed,
)

MAX_TORQUE = 1_000_000.0
"""The strongest motor torque allowed."""
MAX_RATE = 720.0
"""The fastest turn of a base, a head or a joint allowed, degrees per second."""


class PartBaseSpec(Spec):
    """What every part listed in an agent's ``parts`` is: a part kind's spec subclasses it
    with ``type: Literal["..."]`` (its kind) and its own keys. (The shipped parts, heads
    and arms, have keys of their own: ``head``, ``arms``.)"""

    if TYPE_CHECKING:  # each part's spec declares it, as a ``Literal``
        type: Any  # (str: pyright holds a Literal override to the base)


PARTS = SpecKinds("part", "type", PartBaseSpec)
"""Every spec of a part kind listed under ``parts``, by its ``type``: those registered
with ``flatland_ma.register`` or an entry point."""

if TYPE_CHECKING:
    PartSpec = PartBaseSpec
else:
    PartSpec = PARTS.field
    """A part in a file: a mapping whose ``type`` picks its spec in ``PARTS``."""


class SpawnSpec(Spec):
    area: Rect | None = None
    """Where agents start (uniformly, at free places reachable from each other);
    None: anywhere free in the arena."""
    heading: Real | None = None
    """Starting heading in degrees (counter-clockwise from +x); None: uniformly random."""


class HeadSpec(Spec):
    """A head: a small disc ahead of the base's centre, turning about that centre
    within limits, driven by a motor."""

    radius: Length = 4.0
    """Radius of the head's disc."""
    offset: Distance = 6.0
    """Distance of the head's centre from the base's centre."""
    max_angle: Annotated[float, Field(strict=True, gt=0, le=180)] = 90.0
    """How far the head turns either way from the heading, in degrees."""
    turn_rate: Annotated[float, Field(strict=True, gt=0, le=MAX_RATE)] = 300.0
    """Top speed of the head's turn relative to the base, degrees per second."""
    max_torque: Annotated[float, Field(strict=True, gt=0, le=MAX_TORQUE)] = 50_000.0
    """Largest torque of the head's motor."""
    mass: Mass = 0.1
    """Mass of the head."""


class ArmSegmentSpec(Spec):
    length: Length = 16.0
    """Length of the segment, from its joint to the next."""
    width: Length = 6.0
    """Thickness of the segment."""
    min_angle: Degrees = -90.0
    """Lowest angle of its joint, relative to the previous segment (or to the mount), in
    degrees."""
    max_angle: Degrees = 90.0
    """Highest angle of its joint."""
    mass: Mass = 0.2
    """Mass of the segment."""


class GrasperSpec(Spec):
    """A grasper (hook) at the tip of an arm: closing it while it touches a graspable
    object attaches the object; opening it lets go."""

    radius: Length = 3.0
    """Radius of the grasper's disc at the arm's tip."""
    strength: Annotated[float, Field(strict=True, gt=0, le=MAX_FORCE)] = 4_000.0
    """Largest force the hold transmits; pulled harder, the object slips."""
    break_distance: Length = 6.0
    """How far the object may slip from the grasper before the hold breaks."""


class ArmSpec(Spec):
    """An arm: segments in a chain from a joint on the base's rim, each joint motorised and
    limited; optionally a grasper at the tip."""

    mount: Degrees = 0.0
    """Where on the base's rim the arm is attached, in degrees from the heading."""
    segments: Annotated[tuple[ArmSegmentSpec, ...], Field(min_length=1, max_length=4)] = (
        ArmSegmentSpec(),
    )
    """The segments, from the base outwards."""
    joint_rate: Annotated[float, Field(strict=True, gt=0, le=MAX_RATE)] = 180.0
    """Top speed of each joint, degrees per second."""
    max_torque: Annotated[float, Field(strict=True, gt=0, le=MAX_TORQUE)] = 50_000.0
    """Largest torque of each joint's motor."""
    grasper: GrasperSpec | None = GrasperSpec()
    """The grasper at the tip; none: a plain arm for pushing."""


class AgentSpec(Spec):
    """The body, motor, camera and start of every agent."""

    radius: Length = 10.0
    """Agents are discs of this radius."""
    mass: Mass = 1.0
    """Mass of an agent's body."""
    colors: Annotated[tuple[Color, ...], Field(min_length=1)] = Field(
        default=("blue", "red", "green", "yellow", "cyan", "magenta", "teal", "brown"),
        validate_default=True,
    )
    """Agent i is drawn (and seen by other agents) in ``colors[i % len(colors)]``."""
    actions: Literal["discrete", "continuous"] = "discrete"
    """``discrete``: Discrete(3) forward / rotate left / rotate right, and with a head or
    arms ``stay`` plus two actions per head or joint and ``grasp`` / ``release`` per
    grasper; ``continuous``: Box(-1, 1, (n,)) longitudinal, lateral, angular, then one
    entry per head, joint and grasper (``n`` is 3 for a plain body). ``action_names()`` on
    the env lists them."""
    max_speed: Speed = 200.0
    """Top linear speed, units per second."""
    max_turn_rate: Annotated[float, Field(strict=True, gt=0, le=MAX_RATE)] = 300.0
    """Top angular speed, degrees per second."""
    max_force: Annotated[float, Field(strict=True, gt=0, le=MAX_FORCE)] = 15_000.0
    """Largest force the agent's motor applies to reach its commanded velocity."""
    max_torque: Annotated[float, Field(strict=True, gt=0, le=MAX_TORQUE)] = 100_000.0
    """Largest torque the agent's motor applies to reach its commanded turn rate."""
    camera: CameraSpec = CameraSpec()
    """The first-person camera: the agent's one sensor, unless ``sensors`` is given (then
    this key is not used)."""
    sensors: Annotated[tuple[SensorSpec, ...], Field(max_length=16)] | None = None
    """Several sensors instead of the one ``camera``, each with its ``type``: ``camera``,
    ``lidar``, ``proprioception``, ``topdown``, ``touch``, ``smell``, or a kind registered
    from another package (``flatland_ma.register``). Their names (type, unless given) must
    differ, and the observation is then a mapping from name to each sensor's."""
    head: HeadSpec | None = None
    """A head that turns relative to the base (for a camera that looks around)."""
    arms: Annotated[tuple[ArmSpec, ...], Field(max_length=4)] = ()
    """Arms on the base's rim, for pushing, grasping and carrying."""
    parts: Annotated[tuple[PartSpec, ...], Field(max_length=8)] = ()
    """Parts of kinds registered from another package (``flatland_ma.register``), each
    with its ``type``; built after the head and arms, their controls after theirs."""
    spawn: SpawnSpec = SpawnSpec()
    """Where and how agents start."""

    @property
    def sensor_specs(self) -> tuple[SensorSpec, ...]:
        """The agent's sensors: ``sensors`` if given, else its ``camera``."""
        return self.sensors if self.sensors is not None else (self.camera,)

    @field_validator("sensors")
    @classmethod
    def _some_sensor(cls, sensors):
        # Not ``min_length``: pydantic would also report a list whose one entry is wrong
        # as too short.
        if sensors is not None and not sensors:
            raise ValueError("give at least one sensor, or leave 'sensors' out for the camera")
        return sensors

    @model_validator(mode="after")
    def _parts(self):
        for sensor in self.sensor_specs:
            if sensor.mounted_on not in ("base", "head"):
                raise ValueError(f"a {sensor.type}'s mount is 'base' or 'head'")
            if sensor.mounted_on == "head" and self.head is None:
                raise ValueError(f"a {sensor.type} mounted on the head needs a 'head'")
        names = [sensor.name or sensor.type for sensor in self.sensor_specs]
        for name in names:
            if names.count(name) > 1:
                raise ValueError(f"two sensors are called {name!r}: give them distinct names")
        for arm in self.arms:
            for segment in arm.segments:
                if segment.min_angle > segment.max_angle:
                    raise ValueError("an arm joint's min_angle is above its max_angle")
        return self


class ChannelSpec(Spec):
    """A channel the agents talk on. Each step every agent says ``tokens`` words, each one
    of ``vocabulary``, as part of its action: a discrete agent's action becomes
    ``MultiDiscrete([moves, vocabulary, ...])`` (its move, then ``say_0``, ``say_1``, ...),
    a continuous agent's Box gains one entry per word in [-1, 1] (cut into ``vocabulary``
    equal bins). What was said with a step's actions is heard in the observations that
    step returns (so acted on at the next step), under the key ``messages``: per agent, 1
    if heard, then each word one-hot. It is part of the global state."""

    tokens: Annotated[int, Field(strict=True, ge=1, le=8)] = 1
    """Words per message."""
    vocabulary: Annotated[int, Field(strict=True, ge=2, le=32)] = 2
    """How many different words there are."""
    range: Distance | None = None
    """Agents hear speakers whose centre is within this distance of theirs; none: at any
    distance."""
    team: Annotated[bool, Field(strict=True)] = False
    """Only teammates hear each other (the scenario needs ``teams``)."""


class TeamSpec(Spec):
    """A team: consecutive agents sharing a colour, a start area, zone rewards and,
    optionally, a body of their own."""

    name: Name
    """Zones name it to reward it."""
    size: Annotated[int, Field(strict=True, ge=1, le=64)] = 1
    """How many agents it has (agents are numbered team by team)."""
    color: Color | None = None
    """Colour of its agents; none: the agents' colours."""
    spawn: SpawnSpec | None = None
    """Where its agents start; none: the agents' spawn."""
    agent: AgentSpec | None = None
    """What its agents are where they differ from the top-level ``agent``: each key given
    here (``radius``, ``sensors``, ``arms``, ``actions``, ...) replaces that key of
    ``agent`` whole, and the keys not given are ``agent``'s. Their observation and action
    spaces follow (``env.observation_space(name)`` differs per agent); none: ``agent``."""
