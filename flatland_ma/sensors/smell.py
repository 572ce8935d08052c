"""Smell: two nostrils that sense how near items are, around walls, so that an agent can
tell left from right even when the food lies out of sight behind a wall."""

from __future__ import annotations

import math

import numpy as np
import pymunk
from gymnasium import spaces

from flatland_ma.sensors.scent import ScentField
from flatland_ma.sensors.sensor import Sensor


class Smell(Sensor, kind="smell"):
    """Two nostrils on the base (or the head: ``mount``), ``nostril_angle`` degrees to the
    left and to the right of its heading, ``nostril_distance`` from its centre (None: on
    its rim). Each smells
    each channel: one channel per item group in ``sources``, in that order, or one channel
    for every item (``sources`` None).

    A nostril's reading of a channel is ``exp(-d / spread)``, where ``d`` is how far it is
    from the nearest live item of the channel going around walls and fixed obstacles
    (``sensors.scent``): 1 at the item, falling by a factor e every ``spread`` units, and
    0 from ``range`` on, or when no item of the channel can be reached. Eaten items stop
    smelling and respawned ones smell where they come back. The observation is
    ``Box(0, 1, (2, channels), float32)``: row 0 the left nostril, row 1 the right.

    The scent spreads over a grid of ``cell`` wide cells (None: the agent's radius, or the
    navigation grid's cell in an arena so large that it is coarser): distances are exact
    in the open and off by less than a cell per corner they turn around, and a finer grid
    costs more each time items change (``sensors.scent``). The field is searched again
    only when items are taken, come back or move; smell sensors of the same grid, range
    and channels (every agent's, usually) share it.
    """

    def __init__(
        self,
        sources: tuple[str, ...] | list[str] | None = None,
        spread: float = 100.0,
        range: float = 500.0,  # noqa: A002 - the scenario key
        nostril_angle: float = 45.0,
        nostril_distance: float | None = None,
        cell: float | None = None,
        name: str = "smell",
        mount: str = "base",
    ):
        self.name = name
        self.mount = mount
        self.sources: tuple[str | None, ...] = tuple(sources) if sources else (None,)
        self.spread = float(spread)
        self.range = float(range)
        self.nostril_angle = math.radians(nostril_angle)
        self.nostril_distance = nostril_distance
        self.cell = cell
        self.space = spaces.Box(0.0, 1.0, (2, len(self.sources)), np.float32)
        self.field: ScentField | None = None
        """The episode's scent field (set by ``attach``)."""
        self.reach_out = 0.0
        """How far the nostrils are from the centre (set by ``attach``)."""

    def attach(self, suite, k: int) -> None:
        carrier = suite.carriers[k]
        self.body = carrier.body
        radii = [s.radius for s in carrier.shapes if isinstance(s, pymunk.Circle)]
        rim = max(radii, default=0.0)
        self.reach_out = rim if self.nostril_distance is None else float(self.nostril_distance)
        cell = self.cell
        if cell is None:  # the agent's radius, or the navigation grid's cell if coarser
            radius = rim if rim > 0 else 1.0
            cell = max(radius, suite.grid.cell) if suite.grid is not None else radius
        key = (cell, self.sources, self.range)
        for other in suite.cameras[:k]:
            field = getattr(other, "field", None)
            if isinstance(other, Smell) and field is not None and field.key == key:
                if field.world is suite.world:
                    self.field = field
                    return
        self.field = ScentField(suite.world, cell, self.sources, self.range)

    def nostrils(self) -> np.ndarray:
        """Where the two nostrils are now: (2, 2), left then right, world units."""
        (x, y), heading = self.body.position, self.body.angle
        r, t = self.reach_out, self.nostril_angle
        sides = (heading + t, heading - t)
        return np.array([(x + r * math.cos(a), y + r * math.sin(a)) for a in sides])

    def read(self, results, k: int) -> np.ndarray:
        field = self.field
        assert field is not None, "a smell sensor read before it was attached"
        body = self.body
        x, y = body.position
        args = (self.reach_out, self.nostril_angle, self.spread, self.range)
        return field.sniff(x, y, body.angle, *args)
