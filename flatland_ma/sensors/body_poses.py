"""The one way every env reads its moving bodies' poses for the rays: ``Poses``, for one
world (``Geometry.refresh_poses``) or for every world of a batch at once (``Worlds``).

In the physics bridge's compiled tier the poses of every world asked for are read in one
compiled call (``physics.read_poses_at``); in its batch tier a space at a time through
``pymunk.batch`` (``world.poses.SpacePoses``), and in its attribute tier, or for a world
of few moving bodies, through pymunk's attributes (``world.poses.AttributePoses``). Every
tier hands out exactly ``(*body.position, body.angle)``."""

from __future__ import annotations

import numpy as np
import pymunk

from flatland_ma.sensors.lists import filled, put
from flatland_ma.world import physics, poses

ONE = np.zeros(1, np.int64)
"""``which`` for a reader of one world."""


class Poses:
    """Many worlds' moving bodies' poses, read back at once: ``place(w, pose, bodies)``
    when world ``w`` gets a new episode (``pose``: its (bodies, 3) array, a row per body
    of ``bodies``), ``read(which)`` for the worlds ``which`` (an int64 array)."""

    def __init__(self, worlds: int):
        self.compiled = physics.TIER is physics.Tier.COMPILED
        """Whether the poses are read in one compiled call (the bridge's tier in use)."""
        self._poses = filled(np.zeros((0, 3), np.float64), worlds)
        self._bodies = filled(np.zeros(0, np.intp), worlds)
        self._keep: list[list] = [[] for _ in range(worlds)]
        """Each world's bodies: their structs live while they are referenced here."""
        self._own: list[tuple[np.ndarray, np.ndarray] | None] = [None] * worlds
        """Each world's pose array and its bodies' addresses (one world is read without
        the typed lists)."""
        self._spaces: list[poses.SpacePoses | poses.AttributePoses | None] = [None] * worlds

    def place(self, w: int, pose: np.ndarray, bodies: list[pymunk.Body]) -> None:
        if not self.compiled:
            batch = physics.TIER >= physics.Tier.BATCH
            self._spaces[w] = (poses.poses_of if batch else poses.AttributePoses)(pose, bodies)
            return
        self._keep[w] = list(bodies)
        addresses = np.array([physics.address(b) for b in bodies], np.intp)
        self._own[w] = (pose, addresses)
        put(self._poses, w, pose)
        put(self._bodies, w, addresses)

    def read(self, which: np.ndarray) -> None:
        if self.compiled:
            if len(which) == 1:  # one world: the same reads, without the typed lists
                own = self._own[which[0]]
                if own is not None:
                    physics.read_poses_of(*own)
                return
            physics.read_poses_at(self._poses, self._bodies, which)
            return
        for w in which.tolist():
            space = self._spaces[w]
            if space is not None:
                space.read()


def poses_of_world(pose: np.ndarray, bodies: list[pymunk.Body]) -> Poses:
    """A reader of one world's poses (``read(ONE)``)."""
    reader = Poses(1)
    reader.place(0, pose, bodies)
    return reader
