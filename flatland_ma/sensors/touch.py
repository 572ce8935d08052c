"""Touch: how hard things press on the agent's body, in a ring of sectors and per part."""

from __future__ import annotations

import math

import numpy as np
from gymnasium import spaces

from flatland_ma.sensors.sensor import Sensor

MIN_TOUCH_FORCE = 1.0
"""The smallest ``max_force`` (newtons) a touch sensor takes: below it a reading's scale
loses meaning (scenario files are held to the same bound by their spec)."""

TAU = 2.0 * math.pi


class Touch(Sensor, kind="touch"):
    """A ring of ``sectors`` contact sensors around the base, then one per body part.

    Each entry is the pressure felt during the last env step: the normal impulses of every
    contact, summed over the physics substeps and divided by the step's duration (the
    mean force), as a fraction of ``max_force`` and capped at 1. Whatever is solid
    presses: walls, closed doors, obstacles, other agents and their parts; items are not
    solid (an agent passes over them), so they are not felt. A contact that merely rests
    or slides along, without pushing, gives nothing.

    Sector i is centred ``360 * i / sectors`` degrees counter-clockwise from the heading
    (sector 0 straight ahead, like ray 0 of a lidar) and spans ``360 / sectors`` degrees; a
    push on the base falls in the sector of the direction it comes from. Each part (head,
    arm segments, graspers, in action order, named by ``labels``) gives its total, without
    direction. The observation is ``Box(0, 1, (sectors + parts,), float32)``.

    The world logs the pushes while it steps (``World.feel``); reading sorts this step's
    few pushes into the entries.
    """

    def __init__(
        self,
        sectors: int = 8,
        max_force: float = 20_000.0,
        part_names: tuple[str, ...] = (),
        name: str = "touch",
    ):
        self.name = name
        self.mount = "base"
        self.sectors = sectors
        self.max_force = float(max_force)
        if not MIN_TOUCH_FORCE <= self.max_force < math.inf:
            raise ValueError(
                f"a touch sensor's max_force must be finite and at least {MIN_TOUCH_FORCE}, "
                f"not {max_force!r}"
            )
        self.labels = tuple(f"sector_{i}" for i in range(sectors)) + tuple(part_names)
        self.space = spaces.Box(0.0, 1.0, (len(self.labels),), np.float32)
        self._log = None
        self._base = -1
        self._parts: list[int] = []
        self._rows: list[int] = []
        """The base's row and the parts' in the world's log of pushes."""
        self._scale = 0.0

    @classmethod
    def from_spec(cls, values: dict, parts: list) -> Touch:
        values = dict(values)
        per_part = values.pop("parts", True)
        names = tuple(_part_name(p) for p in parts) if per_part else ()
        return cls(part_names=names, **values)

    def attach(self, suite, k: int) -> None:
        """Ask the episode's world to log the pushes on the agent's base and parts."""
        world = suite.world
        agent = suite.carriers[k].actor
        self._log = world.log
        self._base = world.feel(agent.shapes)
        n_parts = len(self.labels) - self.sectors
        self._parts = [world.feel(part.own_shapes()) for part in agent.parts[:n_parts]]
        self._rows = [self._base, *self._parts]
        self._scale = 1.0 / (world.dt * self.max_force)

    def read(self, results, k: int) -> np.ndarray:
        assert self._log is not None, "a touch sensor reads only once attached to a world"
        pushes = self._log.pushes
        if not pushes or not any(row in pushes for row in self._rows):
            return np.zeros(len(self.labels), np.float32)
        n = self.sectors
        impulse = [0.0] * len(self.labels)
        for bearing, push in pushes.get(self._base, ()):
            impulse[math.floor(bearing * n / TAU + 0.5) % n] += push
        for i, row in enumerate(self._parts):
            impulse[n + i] = sum(push for _, push in pushes.get(row, ()))
        scale = self._scale  # impulse over the step to the fraction of max_force
        return np.array([min(j * scale, 1.0) for j in impulse], np.float32)


def _part_name(part) -> str:
    """A part's entry's label: its first control's name, else its label (``parts[0]``)."""
    return part.controls[0].name if part.controls else (part.label or part.kind)
