"""All agents' sensors over one world, observed with one kernel call per step.

Each step the suite picks up the fixed entities the world changed (moved, hidden, shown),
reads the moving bodies' poses, casts every ray of every ray sensor of every agent in one
kernel call, and lets each sensor read its observation from the results.
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces

from flatland_ma.sensors import kernel
from flatland_ma.sensors.camera import CHANNELS
from flatland_ma.sensors.geometry import Geometry
from flatland_ma.sensors.sensor import Sensor
from flatland_ma.world.entities import Entity
from flatland_ma.world.world import World


def observation_space(sensors: list[Sensor]) -> spaces.Space:
    """An agent's observation space: its one sensor's, or a ``Dict`` by sensor name."""
    if len(sensors) == 1:
        return sensors[0].space
    return spaces.Dict({s.name: s.space for s in sensors})


class Sensors:
    """Every agent's sensors; ``observe`` fills one preallocated image for all rays."""

    def __init__(
        self,
        world: World,
        eyes: list[Entity],
        cameras: list[Sensor],
        counts: list[int] | None = None,
    ):
        """``cameras``: every sensor, agent by agent; ``counts[i]``: how many are agent
        i's (default one each); ``eyes[k]`` carries sensor k: its agent's base or head
        (``owner`` is the agent)."""
        self.world = world
        self.geometry = geo = Geometry(world)
        self.cameras = cameras
        counts = counts if counts is not None else [1] * len(cameras)
        firsts = np.cumsum([0] + list(counts))
        self.per_agent = [list(range(a, b)) for a, b in zip(firsts[:-1], firsts[1:])]
        starts = np.cumsum([0] + [cam.n_rays for cam in cameras])
        self.slices = [slice(int(a), int(b)) for a, b in zip(starts[:-1], starts[1:])]
        n = int(starts[-1])
        self.eye_body = np.array([geo.body_row[e.index] for e in eyes], np.int32)
        self.eye_local = np.zeros((len(eyes), 3), np.float64)
        self.eye_owner = np.array([e.owner for e in eyes], np.int32)
        self.eye_view = np.array([(c.view_range, c.half_fov) for c in cameras], np.float64)
        self.eye_falloff = np.array([c.falloff for c in cameras], np.int32)
        self.eye_rays = starts.astype(np.int32)
        angles = np.concatenate([c.angles for c in cameras])
        self.ray_dir = np.stack([np.cos(angles), np.sin(angles)], axis=1)
        self.image = np.zeros((n, len(CHANNELS)), np.float32)
        self.distance = np.zeros(n, np.float64)
        self.hit_entity = np.full(n, -1, np.int32)
        self.cand_seg, self.cand_circ = kernel.empty_work(len(geo.seg_local), len(geo.circ_local))

    def observe(self) -> None:
        """Pick up what the world changed, read the moving bodies' poses and cast every
        ray of every sensor."""
        g = self.geometry
        if self.world.changed:
            for entity in self.world.take_changed():
                g.update_entity(entity)
        g.refresh_poses()
        kernel.observe(
            g.pose,
            g.seg_local,
            g.seg_world,
            g.seg_body,
            g.seg_entity,
            g.seg_u0,
            g.circ_local,
            g.circ_world,
            g.circ_body,
            g.circ_entity,
            g.circ_angle,
            g.loose_seg,
            g.loose_circ,
            g.grid,
            g.cell_seg_start,
            g.cell_seg,
            g.cell_circ_start,
            g.cell_circ,
            g.ent_owner,
            g.ent_visible,
            g.ent_colors,
            g.ent_texture,
            g.ent_texture_kind,
            self.eye_body,
            self.eye_local,
            self.eye_owner,
            self.eye_view,
            self.eye_falloff,
            self.eye_rays,
            self.ray_dir,
            self.image,
            self.distance,
            self.hit_entity,
            self.cand_seg,
            self.cand_circ,
        )

    def observation(self, agent_index: int):
        """A fresh copy of the agent's observation: its one sensor's, or a dict by name."""
        own = self.per_agent[agent_index]
        if len(own) == 1:
            k = own[0]
            return self.cameras[k].read(self, self.slices[k])
        return {self.cameras[k].name: self.cameras[k].read(self, self.slices[k]) for k in own}
