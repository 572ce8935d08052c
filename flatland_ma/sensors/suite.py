"""All agents' sensors over one world, observed with one kernel call per step."""

from __future__ import annotations

import numba as nb
import numpy as np

from flatland_ma.sensors import kernel
from flatland_ma.sensors.camera import Camera
from flatland_ma.sensors.geometry import Geometry
from flatland_ma.sensors.scene import Outputs, Scratch, pack_eyes
from flatland_ma.world.entities import Entity
from flatland_ma.world.world import World


class Sensors:
    """Each agent's camera; ``observe`` fills one preallocated image for all rays.

    ``image`` (rays, 4) float32, ``distance`` (rays,) float64 and ``hit_entity`` (rays,)
    int32 hold every camera's rays, camera i's at ``slices[i]``.
    """

    def __init__(self, world: World, eyes: list[Entity], cameras: list[Camera]):
        """``eyes[i]`` carries camera i: an agent's base or head (``owner`` is the agent)."""
        self.geometry = geo = Geometry(world)
        self.cameras = cameras
        self.eyes = pack_eyes(
            body=[geo.body_row[e.index] for e in eyes],
            local=[(0.0, 0.0, 0.0)] * len(eyes),
            owner=[e.owner for e in eyes],
            view_range=[c.spec.range for c in cameras],
            half_fov=[c.half_fov for c in cameras],
            falloff=[c.falloff for c in cameras],
            angles=[c.angles for c in cameras],
        )
        starts = self.eyes.rays
        self.slices = [slice(int(a), int(b)) for a, b in zip(starts[:-1], starts[1:])]
        self.out = Outputs.zeros(int(starts[-1]))
        self.image, self.distance, self.hit_entity = self.out
        self._args = (geo.pose, geo.shapes, geo.grid, geo.looks, self.eyes, self.out)
        self._args += (Scratch.for_shapes(geo.shapes),)
        # numba types named tuples in Python on every call (several microseconds, a tenth
        # of a small world's kernel time): type these arguments once and keep the
        # compiled function. The arrays are only ever written in place.
        signature = tuple(nb.typeof(a) for a in self._args)
        self._kernel = kernel.observe.compile(signature)

    def observe(self) -> None:
        """Read the moving bodies' poses and cast every ray of every camera."""
        self.geometry.refresh_poses()
        self._kernel(*self._args)

    def observation(self, agent_index: int) -> np.ndarray:
        """A fresh copy of the agent's image, shape (rays, 4), float32."""
        return self.image[self.slices[agent_index]].copy()
