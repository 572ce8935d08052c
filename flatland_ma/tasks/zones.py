"""Zones: areas of floor that act when an agent's centre enters them."""

from __future__ import annotations

import math

import numpy as np

from flatland_ma.agents.body import AgentBody
from flatland_ma.scenario.schema import ScenarioSpec
from flatland_ma.world.placement import PlacementError, Placer


class ZoneRules:
    def __init__(
        self,
        spec: ScenarioSpec,
        bodies: list[AgentBody],
        placer: Placer,
        rng: np.random.Generator,
        teams: list,
    ):
        self.specs = spec.zones
        self.teams = teams
        self.bodies = bodies
        self.placer = placer
        self.agent_spec = spec.agent
        self.rects = np.array(
            [z.rect if z.rect is not None else self._draw(z, rng) for z in spec.zones], np.float64
        ).reshape(-1, 4)
        self.names = [z.name for z in spec.zones]
        self.inside = self._inside()
        self.visited = self.inside.copy()

    def _draw(self, zone, rng: np.random.Generator) -> tuple[float, float, float, float]:
        """A ``zone.size`` rectangle centred on reachable floor inside ``zone.area``."""
        w, h = zone.size
        x0, y0, x1, y1 = zone.area or (0.0, 0.0, *self.placer.world.size)
        inner = (x0 + w / 2, y0 + h / 2, x1 - w / 2, y1 - h / 2)
        cells = self.placer.candidates(inner)
        if len(cells) == 0:
            cx, cy = (inner[0] + inner[2]) / 2, (inner[1] + inner[3]) / 2
        else:
            cx, cy = self.placer.grid.centre(*cells[rng.integers(len(cells))])
        return (cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2)

    def _inside(self) -> np.ndarray:
        if len(self.rects) == 0:
            return np.zeros((len(self.bodies), 0), bool)
        pos = np.array([tuple(b.body.position) for b in self.bodies], np.float64)
        r = self.rects
        return (
            (pos[:, 0:1] >= r[:, 0])
            & (pos[:, 0:1] <= r[:, 2])
            & (pos[:, 1:2] >= r[:, 1])
            & (pos[:, 1:2] <= r[:, 3])
        )

    def apply(self, records, rewards, terminated, rng) -> dict[str, bool]:
        """Act on entries; return which named zones have a live agent in them."""
        if len(self.rects) == 0:
            return {}
        inside = self._inside()
        live = np.array([not r.done for r in records])
        inside &= live[:, None]
        entered = inside & ~self.inside
        for a, z in np.argwhere(entered):
            zone = self.specs[z]
            if zone.team is not None and self.teams[a] != zone.team:
                continue
            if not (zone.once and self.visited[a, z]):
                rewards[a] += zone.reward
            self.visited[a, z] = True
            if zone.terminal:
                terminated[a] = True
            if zone.teleport:
                self._teleport(self.bodies[a], rng)
        if entered.any() and any(z.teleport for z in self.specs):
            inside = self._inside() & live[:, None]
        self.inside = inside
        occupied = inside.any(axis=0)
        return {name: bool(occupied[z]) for z, name in enumerate(self.names) if name is not None}

    def _teleport(self, agent: AgentBody, rng) -> None:
        try:
            x, y = self.placer.sample(rng, self.agent_spec.radius, self.agent_spec.spawn.area)
        except PlacementError:
            return  # nowhere to go: stay
        heading = self.agent_spec.spawn.heading
        body = agent.body
        body.position = (x, y)
        body.angle = (
            float(rng.uniform(-math.pi, math.pi)) if heading is None else math.radians(heading)
        )
        body.velocity = (0.0, 0.0)
        body.angular_velocity = 0.0
        body.space.reindex_shapes_for_body(body)
