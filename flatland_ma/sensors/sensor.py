"""The sensor interface: what every sensor of an agent declares and does.

A sensor declares the space of its observation and, each step, reads its observation from
the step's sensing results. Sensors that cast rays (cameras, and later lidars) add their
rays to the ONE kernel call that casts every ray of every agent: they say how many rays,
at which angles from the heading of what they are mounted on, how far they see, and how
colour fades with distance; the suite packs them and hands each its slice of the results.

A new sensor is one subclass, named by its ``kind`` in the class statement (the ``type``
its scenario spec carries), plus that spec (a subclass of
``scenario.spec_sensors.SensorBaseSpec`` with ``type: Literal["compass"]``), registered
with ``flatland_ma.register(CompassSpec, Compass)`` (or an entry point; see
``flatland_ma.scenario.extensions``); the builder finds it in ``SENSOR_KINDS`` and makes it with
``from_spec``, which passes the spec's keys (but ``type`` and ``noise``; ``name`` is the
observation's key) as keyword arguments:

    class Compass(Sensor, kind="compass"):
        def __init__(self, name="compass"):
            self.name = name
            self.space = spaces.Box(-1.0, 1.0, (2,), np.float32)

        def read(self, results, k):
            body = results.carriers[k].actor.body  # the agent's base (a pymunk.Body)
            return np.array([math.cos(body.angle), math.sin(body.angle)], np.float32)

Required: ``name``, ``space``, ``read``. ``mount`` is ``base`` unless the sensor sets it
(``head``: it sits on the agent's head, and ``results.carriers[k]`` is the head's link).
Ray sensors also set ``angles``, ``view_range``, ``half_fov`` and ``falloff``; a sensor
that depends on the agent's parts overrides ``from_spec``, and one that depends on the
episode (its world, its navigation grid) overrides ``attach``.

``read(results, k)`` is called at each reset and step, after the physics, the rules and
the one kernel call; ``results`` is the episode's sensor suite
(``sensors.sensor_suite.Sensors``) and ``k`` this sensor's index in it. It returns a fresh array
of the space's shape and dtype (the suite adds the noise and clips into the space). What
it may read:

- ``results.carriers[k]``: what carries it (the agent's ``AgentBody`` for ``base``, the
  head's ``Link`` for ``head``); ``.actor`` is always the agent's ``AgentBody``: its
  pymunk ``body`` (position, angle, velocity), ``max_speed``, ``max_turn_rate``,
  ``parts``, ``links``, ``hands`` and ``owner`` (the agent's index);
- ``results.world``: the episode's ``World`` (its ``entities``, ``zones``, contact
  ``log``), ``results.grid``: its navigation grid;
- for ray sensors, this sensor's rays at ``results.slices[k]`` of ``results.image``
  (rays x 4: r, g, b, depth), ``results.distance`` and ``results.hit_entity`` (the
  index of the entity hit, -1 for nothing).

Optional: ``picture(reading)``, how the renderer's senses panel draws one reading, as a
uint8 ``H x W x 3`` image (rows of a few pixels are drawn as strips, taller ones as an
image, scaled to fit). Without it (it returns None) the panel draws the reading from its
shape: a vector as bars or a heat strip, ``rays x channels`` as one strip per channel, an
``H x W x C`` image as itself (C = 3) or its first channel in grey, all over the space's
low..high. So a new sensor shows in pictures without any change to the renderer.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any

import numpy as np
from gymnasium import spaces

from flatland_ma.kinds.registry import Kinded, Kinds
from flatland_ma.sensors.noise import Noise

SENSOR_KINDS = Kinds("flatland_ma.sensors", "sensor")
"""Every sensor class, by the ``type`` that scenario files give it."""


class Sensor(Kinded, ABC):
    """Base of every sensor (see the module docstring)."""

    KINDS = SENSOR_KINDS
    name: str
    """The observation's key when an agent has several sensors."""
    mount: str = "base"
    """What it sits on: ``base`` (it turns with the agent; the default) or ``head``."""
    space: spaces.Space
    angles: np.ndarray = np.zeros(0)
    """Ray angles from the mount's heading, radians, counter-clockwise (none: no rays)."""
    view_range: float = 0.0
    half_fov: float = 0.0
    falloff: int = 0
    noise: Noise | None = None
    """Noise the suite adds to each reading (none: exact); set from the spec's ``noise``."""

    @property
    def n_rays(self) -> int:
        return len(self.angles)

    @classmethod
    def from_spec(cls, values: dict, parts: list) -> Sensor:
        """The sensor a scenario's spec describes (``values``: its keys but ``type``), on
        an agent with these parts (``agents.parts.Part``); most sensors ignore them."""
        return cls(**values)

    def attach(self, suite: Any, k: int) -> None:
        """Called when each episode's suite is built, before the first ``read``: a sensor
        that needs the episode (``suite.world``, the navigation grid ``suite.grid``, its
        carrier ``suite.carriers[k]``) sets itself up here. Most sensors need nothing."""

    def picture(self, reading: np.ndarray) -> np.ndarray | None:
        """A uint8 ``H x W x 3`` picture of one reading for the renderer, or None (the
        default) to let it draw the reading from its shape (see the module docstring)."""
        return None

    @abstractmethod
    def read(self, results: Any, k: int) -> np.ndarray:
        """This step's observation (a fresh array in ``space``) of the suite's sensor
        ``k`` (this one), from the suite's results (see the module docstring): what
        carries it at ``carriers[k]`` (``carriers[k].actor`` is its agent's body),
        ``world``, and per ray ``image``, ``distance``, ``hit_entity``, this sensor's
        rays at ``slices[k]``."""
