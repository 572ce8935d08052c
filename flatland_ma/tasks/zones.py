"""Zones: areas of floor that reward, punish, end the episode or move an agent whose
centre enters them (a zone of a team acts only for that team)."""

from __future__ import annotations

import math

from flatland_ma.tasks.rule import Rule, Step, TaskContext
from flatland_ma.world.placement import PlacementError


class ZoneRule(Rule):
    def reset(self, ctx: TaskContext) -> None:
        self.teams, self.bodies, self.placer = ctx.teams, ctx.bodies, ctx.placer
        self.spawns = ctx.spawns

    def apply(self, step: Step) -> None:
        for agent, zone in step.log.entered:
            a = agent.owner
            record = step.records[a]
            if record.done or (zone.team is not None and self.teams[a] != zone.team):
                continue
            if not (zone.once and zone.index in record.visited):
                step.rewards[a] += zone.reward
            record.visited.add(zone.index)
            if zone.terminal:
                step.terminated[a] = True
            if zone.teleport:
                self._teleport(a, step.rng)

    def _teleport(self, a: int, rng) -> None:
        spawn = self.spawns[a]
        body = self.bodies[a]
        try:
            x, y = self.placer.sample(rng, body.shapes[0].radius, spawn.area)
        except PlacementError:
            return  # nowhere to go: stay
        heading = spawn.heading
        angle = float(rng.uniform(-math.pi, math.pi)) if heading is None else math.radians(heading)
        body.teleport(x, y, angle)
