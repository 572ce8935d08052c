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
        self.rect_list = [tuple(map(float, r)) for r in self.rects]
        self.names = [z.name for z in spec.zones]
        self.spawns = [spec.spawn_of(i) for i in range(len(bodies))]
        self.inside = self._inside()
        self.visited = [list(row) for row in self.inside]

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

    def _inside(self) -> list[list[bool]]:
        """For each agent, whether its centre lies in each zone (plain Python: a handful of
        agents and zones is faster so than through numpy)."""
        rects = self.rect_list
        inside = []
        for agent in self.bodies:
            x, y = agent.body.position
            inside.append([x0 <= x <= x1 and y0 <= y <= y1 for x0, y0, x1, y1 in rects])
        return inside

    def apply(self, records, rewards, terminated, rng) -> dict[str, bool]:
        """Act on entries; return which named zones have a live agent in them."""
        if not self.rect_list:
            return {}
        inside = self._inside()
        moved = False
        for a, row in enumerate(inside):
            if records[a].done:
                inside[a] = row = [False] * len(row)
                continue
            was = self.inside[a]
            for z, now in enumerate(row):
                if not now or was[z]:
                    continue
                zone = self.specs[z]
                if zone.team is not None and self.teams[a] != zone.team:
                    continue
                if not (zone.once and self.visited[a][z]):
                    rewards[a] += zone.reward
                self.visited[a][z] = True
                if zone.terminal:
                    terminated[a] = True
                if zone.teleport:
                    moved |= self._teleport(a, rng)
        if moved:
            inside = [
                [False] * len(row) if records[a].done else row
                for a, row in enumerate(self._inside())
            ]
        self.inside = inside
        return {
            name: any(row[z] for row in inside)
            for z, name in enumerate(self.names)
            if name is not None
        }

    def _teleport(self, a: int, rng) -> bool:
        spawn = self.spawns[a]
        try:
            x, y = self.placer.sample(rng, self.agent_spec.radius, spawn.area)
        except PlacementError:
            return False  # nowhere to go: stay
        heading = spawn.heading
        angle = float(rng.uniform(-math.pi, math.pi)) if heading is None else math.radians(heading)
        self.bodies[a].teleport(x, y, angle)
        return True
