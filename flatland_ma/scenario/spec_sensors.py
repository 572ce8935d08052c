"""Sensors in a scenario file: each kind's spec (camera, lidar, proprioception, top-down
view, touch, smell), their noise, and the registry of sensor kinds that extensions add to.
An agent lists them (``spec_agent.AgentSpec``)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import Field, model_validator

from flatland_ma.scenario.kinds import SpecKinds
from flatland_ma.scenario.types import (
    MAX_ARENA_SIDE,
    MAX_FORCE,
    Distance,
    Length,
    Name,
    Spec,
)

MIN_TOUCH_FORCE = 1.0
"""The lightest force a touch sensor may be scaled to read 1 at."""


Probability = Annotated[float, Field(strict=True, ge=0, le=1, allow_inf_nan=False)]


def _distinct_channels(spec):
    """``spec`` if no channel of its ``channels`` is given twice, else a ``ValueError``."""
    if len(set(spec.channels)) < len(spec.channels):
        raise ValueError("each channel may be given once")
    return spec


class NoiseSpec(Spec):
    """Noise on a sensor's readings, drawn from the env's seeded generator (the one
    ``reset(seed=...)`` seeds). A reading is one entry of a vector, or one ray of a camera
    or one pixel of an image (all its channels together). Applied in this order, then
    clipped into the sensor's space; each kind is off at 0."""

    gaussian: Annotated[float, Field(strict=True, ge=0, le=1, allow_inf_nan=False)] = 0.0
    """Standard deviation of normal noise added to every entry, as a fraction of the
    entry's range (high minus low)."""
    salt_pepper: Probability = 0.0
    """Chance that a reading is replaced by its lowest or highest value (even odds)."""
    dropout: Probability = 0.0
    """Chance that a reading is lost: set to its lowest value (zero for most sensors)."""

    @property
    def active(self) -> bool:
        return self.gaussian > 0 or self.salt_pepper > 0 or self.dropout > 0


class SensorBaseSpec(Spec):
    """What every sensor's spec has: a name and its noise. A sensor's spec subclasses it
    with ``type: Literal["..."]`` (its kind) and its own keys; one without a ``mount`` key
    sits on the base."""

    if TYPE_CHECKING:  # each sensor's spec declares it, as a ``Literal``
        type: Any  # (str: pyright holds a Literal override to the base)

    name: Name | None = None
    """Its observation's key when an agent has several sensors; none: its type."""
    noise: NoiseSpec | None = None
    """Noise on its readings; none (the default): exact readings."""

    @property
    def mounted_on(self) -> str:
        """What it sits on: its ``mount`` (``base`` or ``head``), or ``base`` for a sensor
        whose spec has no ``mount`` key."""
        return str(getattr(self, "mount", "base"))


class CameraSpec(SensorBaseSpec):
    """A first-person camera: a fan of rays giving a 1-D image of colour and depth."""

    type: Literal["camera"] = "camera"
    """Selects this sensor."""
    rays: Annotated[int, Field(strict=True, ge=1, le=4096)] = 64
    """Number of rays, i.e. the width of the 1-D image."""
    fov: Annotated[float, Field(strict=True, gt=0, le=360, allow_inf_nan=False)] = 120.0
    """Field of view in degrees, centred on the heading."""
    range: Annotated[float, Field(strict=True, ge=1, le=2 * MAX_ARENA_SIDE)] = 300.0
    """Farthest distance a ray sees; depth is normalised by it."""
    falloff: Literal["linear", "exponential", "none"] = "linear"
    """How colour intensity falls with distance ``d``: ``linear`` is ``1 - d / range``,
    ``exponential`` is ``exp(-d / decay)``, ``none`` keeps full colour at any distance."""
    decay: Annotated[float, Field(strict=True, gt=0, le=2 * MAX_ARENA_SIDE)] | None = None
    """For ``exponential`` falloff: the distance over which intensity falls to 1/e (about
    37%); none: a third of ``range``."""
    mount: Literal["base", "head"] = "base"
    """Where the camera sits: on the base (it looks where the agent heads) or on the head
    (it looks where the head turns; the agent needs a ``head``)."""
    channels: Annotated[
        tuple[Literal["rgb", "depth", "semantic"], ...], Field(min_length=1, max_length=3)
    ] = ("rgb", "depth")
    """What each ray gives, in this order: ``rgb`` (3 numbers), ``depth`` (1), ``semantic``
    (the kind of thing hit: 0 nothing, 1 wall, 2 door, 3 obstacle, 4 item, 5 agent)."""
    semantic: Literal["id", "onehot"] = "id"
    """The semantic channel as the kind's id (one number), or one-hot (six)."""

    @model_validator(mode="after")
    def _distinct_channels(self):
        return _distinct_channels(self)


class LidarSpec(SensorBaseSpec):
    """A ring of range-finding rays evenly all around: distances only, no colour."""

    type: Literal["lidar"]
    """Selects this sensor."""
    rays: Annotated[int, Field(strict=True, ge=1, le=4096)] = 32
    """Number of rays, the first straight ahead, then counter-clockwise."""
    range: Annotated[float, Field(strict=True, ge=1, le=2 * MAX_ARENA_SIDE)] = 300.0
    """Farthest distance a ray measures; distances are given as fractions of it."""
    mount: Literal["base", "head"] = "base"
    """Where it sits: on the base, or on the head (the agent needs a ``head``)."""


class ProprioceptionSpec(SensorBaseSpec):
    """The agent's own motion and posture: velocity ahead and to the left and turn rate
    (fractions of the top speeds), each joint's place between its limits (head, then arm
    segments), and whether each grasper holds something; all in [-1, 1]."""

    type: Literal["proprioception"]
    """Selects this sensor."""

    @property
    def mount(self) -> str:
        return "base"


class TopdownSpec(SensorBaseSpec):
    """A top-down image of the square around the agent, turned with it: the heading points
    up and the agent's left is the image's left (or, ``turned: false``, held north up).
    Walls, doors, obstacles, items and agents (itself included) are drawn filled, in the
    colours the cameras see (a texture shows its first colour). The observation is
    ``(size, size, width)`` float32, channels last, in [0, 1] (the semantic id in [0, 5]).
    """

    type: Literal["topdown"]
    """Selects this sensor."""
    size: Annotated[int, Field(strict=True, ge=4, le=256)] = 32
    """Pixels per side of the image."""
    extent: Annotated[float, Field(strict=True, ge=1, le=2 * MAX_ARENA_SIDE)] = 160.0
    """World units the image covers per side."""
    ahead: Annotated[float, Field(strict=True, ge=0, le=0.5, allow_inf_nan=False)] = 0.0
    """How far ahead of the mount the image's centre lies, as a fraction of ``extent``:
    0 centres the agent, 0.5 puts it on the bottom edge."""
    channels: Annotated[
        tuple[Literal["rgb", "semantic", "visibility"], ...], Field(min_length=1, max_length=3)
    ] = ("rgb",)
    """What each pixel gives, in this order: ``rgb`` (3 numbers, the colour of what lies
    there, black for bare floor), ``semantic`` (the kind, as for the camera),
    ``visibility`` (1 where the agent sees the pixel, else 0)."""
    semantic: Literal["id", "onehot"] = "id"
    """The semantic channel as the kind's id (one number), or one-hot (six)."""
    masked: Annotated[bool, Field(strict=True)] = False
    """Blank (0 in every channel but ``visibility``) the pixels the agent cannot see:
    behind a wall, a door, an obstacle or another agent as seen from the mount's centre
    (what it faces shows whole), or outside ``fov``."""
    fov: Annotated[float, Field(strict=True, gt=0, le=360, allow_inf_nan=False)] = 360.0
    """Field of view in degrees, centred on the heading, for ``masked`` and
    ``visibility``."""
    mount: Literal["base", "head"] = "base"
    """Where it sits: on the base, or on the head (it turns with the head)."""
    turned: Annotated[bool, Field(strict=True)] = True
    """Turn the image with the mount (the heading up); false: hold it north up, whichever
    way the agent faces (``ahead`` and ``fov`` then count from north)."""

    @model_validator(mode="after")
    def _distinct_channels(self):
        return _distinct_channels(self)


class TouchSpec(SensorBaseSpec):
    """Pressure on the body: a ring of contact sensors around the base, sector 0 straight
    ahead and the rest counter-clockwise, then one entry per part (head, arm segments,
    graspers); each the mean force of the last step's pushes (walls, obstacles, doors,
    agents; not items) as a fraction of ``max_force``, capped at 1."""

    type: Literal["touch"]
    """Selects this sensor."""
    sectors: Annotated[int, Field(strict=True, ge=1, le=360)] = 8
    """Number of sectors around the base, each ``360 / sectors`` degrees wide."""
    max_force: Annotated[
        float, Field(strict=True, ge=MIN_TOUCH_FORCE, le=100 * MAX_FORCE, allow_inf_nan=False)
    ] = 20_000.0
    """The force that reads 1 (stronger pushes read 1 too), at least 1 (a lighter one reads
    1 at the faintest touch, and a tiny one would divide by zero). An agent driving into
    something it cannot move pushes with its motor's ``max_force`` (15000 by default:
    0.75); a collision adds, for one step, its mass times its speed over the step's
    duration."""
    parts: Annotated[bool, Field(strict=True)] = True
    """Also one entry per body part, after the sectors (nothing for a plain body)."""

    @property
    def mount(self) -> str:
        return "base"


class SmellSpec(SensorBaseSpec):
    """Two nostrils on the base, left and right of the heading, that smell items around
    walls: per nostril and channel, ``exp(-d / spread)`` in [0, 1], where ``d`` is the
    distance to the nearest live item of the channel going around walls and fixed
    obstacles (not through them; doors let scent through), and 0 from ``range`` on. The
    observation is ``(2, channels)``: row 0 the left nostril, row 1 the right."""

    type: Literal["smell"]
    """Selects this sensor."""
    sources: Annotated[tuple[Name, ...], Field(min_length=1, max_length=16)] | None = None
    """Item groups (their ``name``) smelled, one channel each in this order; none: one
    channel for every item."""
    spread: Length = 100.0
    """Distance over which a scent weakens by a factor e."""
    range: Annotated[float, Field(strict=True, ge=1, le=2 * MAX_ARENA_SIDE)] = 500.0
    """Distance (around walls) from which an item is not smelled at all."""
    nostril_angle: Annotated[float, Field(strict=True, gt=0, le=90)] = 45.0
    """Degrees from the heading of each nostril, one to the left and one to the right."""
    nostril_distance: Distance | None = None
    """Distance of the nostrils from the base's centre; none: on its rim."""
    cell: Length | None = None
    """Width of the cells the scent spreads over; none: the agent's radius. Distances are
    exact in the open and off by less than a cell per corner they turn around; finer cells
    cost more each time items change (and are coarsened to at most 500,000 cells over all
    channels)."""
    mount: Literal["base", "head"] = "base"
    """Where the nostrils sit: on the base's rim, either side of its heading, or on the
    head's rim, turning with it (the agent needs a ``head``)."""

    @model_validator(mode="after")
    def _distinct_sources(self):
        if self.sources is not None and len(set(self.sources)) < len(self.sources):
            raise ValueError("each item group may be smelled once")
        return self


SENSORS = SpecKinds("sensor", "type", SensorBaseSpec)
"""Every sensor's spec, by its ``type``: the shipped ones, and those registered with
``flatland_ma.register`` or an entry point (``flatland_ma.scenario.extensions``)."""
for _spec in (CameraSpec, LidarSpec, ProprioceptionSpec, TopdownSpec, TouchSpec, SmellSpec):
    SENSORS.add(_spec)

if TYPE_CHECKING:
    SensorSpec = SensorBaseSpec
else:
    SensorSpec = SENSORS.field
    """A sensor in a file: a mapping whose ``type`` picks its spec in ``SENSORS``."""
