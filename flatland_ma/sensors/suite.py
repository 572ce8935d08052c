"""All agents' sensors over one world, observed with one kernel call per step."""

from __future__ import annotations

import numpy as np

from flatland_ma.sensors import kernel
from flatland_ma.sensors.camera import CHANNELS, Camera
from flatland_ma.sensors.geometry import Geometry
from flatland_ma.world.entities import Entity
from flatland_ma.world.world import World


class Sensors:
    """Each agent's camera; ``observe`` fills one preallocated image for all rays."""

    def __init__(self, world: World, eyes: list[Entity], cameras: list[Camera]):
        """``eyes[i]`` carries camera i: an agent's base or head (``owner`` is the agent)."""
        self.geometry = geo = Geometry(world)
        self.cameras = cameras
        starts = np.cumsum([0] + [cam.n_rays for cam in cameras])
        self.slices = [slice(int(a), int(b)) for a, b in zip(starts[:-1], starts[1:])]
        n = int(starts[-1])
        self.eye_body = np.array([geo.body_row[e.index] for e in eyes], np.int32)
        self.eye_local = np.zeros((len(eyes), 3), np.float64)
        self.eye_owner = np.array([e.owner for e in eyes], np.int32)
        self.eye_view = np.array([(c.spec.range, c.half_fov) for c in cameras], np.float64)
        self.eye_falloff = np.array([c.falloff for c in cameras], np.int32)
        self.eye_rays = starts.astype(np.int32)
        angles = np.concatenate([c.angles for c in cameras])
        self.ray_dir = np.stack([np.cos(angles), np.sin(angles)], axis=1)
        self.image = np.zeros((n, len(CHANNELS)), np.float32)
        self.distance = np.zeros(n, np.float64)
        self.hit_entity = np.full(n, -1, np.int32)
        self.cand_seg, self.cand_circ = kernel.empty_work(len(geo.seg_local), len(geo.circ_local))

    def observe(self) -> None:
        """Read the moving bodies' poses and cast every ray of every camera."""
        g = self.geometry
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

    def observation(self, agent_index: int) -> np.ndarray:
        """A fresh copy of the agent's image, shape (rays, 4), float32."""
        return self.image[self.slices[agent_index]].copy()
