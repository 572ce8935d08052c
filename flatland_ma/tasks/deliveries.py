"""Deliveries: a tagged object whose centre lies in a zone that accepts its tag is
delivered. The zone's team (or everyone) is rewarded, the others lose as much if the zone
is zero-sum; then the episode ends, or the object goes back to where it started."""

from __future__ import annotations

import numpy as np

from flatland_ma.tasks.rule import Rule, Step, TaskContext


class DeliveryRule(Rule):
    def reset(self, ctx: TaskContext) -> None:
        self.world, self.hands, self.teams = ctx.world, ctx.hands, ctx.teams
        self.counted = any(z.accepts is not None for z in ctx.world.zones)
        self.deliveries = np.zeros(len(ctx.bodies), np.int64)
        """Deliveries credited to each agent (its team's, or everyone's)."""

    def apply(self, step: Step) -> None:
        for thing, zone in step.log.deliveries:
            for i, record in enumerate(step.records):
                if record.done:
                    continue
                if zone.team is None or self.teams[i] == zone.team:
                    step.rewards[i] += zone.delivery_reward
                    self.deliveries[i] += 1
                elif zone.zero_sum:
                    step.rewards[i] -= zone.delivery_reward
            if zone.end_on_delivery:
                step.end_all = True
            else:
                self.hands.drop(thing)
                self.world.place(thing, *thing.home)

    def info(self, agent: int, out: dict) -> None:
        if self.counted:
            out["deliveries"] = int(self.deliveries[agent])
