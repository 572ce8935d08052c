"""Deliveries: a tagged object whose centre enters a zone that accepts its tag is
delivered. The zone's team (or everyone) is rewarded, the others lose as much if the zone
is zero-sum; then the episode ends, or the object goes back to where it started."""

from __future__ import annotations

from flatland_ma.agents.grasp import Hands
from flatland_ma.scenario.schema import ScenarioSpec
from flatland_ma.world.entities import Obstacle
from flatland_ma.world.world import World


class DeliveryRules:
    def __init__(self, spec: ScenarioSpec, world: World, rects, hands: Hands, teams: list):
        self.zones = [(z, zone) for z, zone in enumerate(spec.zones) if zone.accepts is not None]
        self.rects = rects
        self.hands = hands
        self.teams = teams
        """Each agent's team name (None without teams)."""
        tags = {zone.accepts for _, zone in self.zones}
        self.objects = [
            e
            for e in world.entities
            if isinstance(e, Obstacle) and e.tag is not None and e.tag in tags
        ]

    def apply(self, records, rewards: list[float]) -> bool:
        """Reward this step's deliveries; True if one of them ends the episode."""
        ended = False
        for thing in self.objects:
            x, y = thing.body.position
            for z, zone in self.zones:
                x0, y0, x1, y1 = self.rects[z]
                if zone.accepts != thing.tag or not (x0 <= x <= x1 and y0 <= y <= y1):
                    continue
                for i, record in enumerate(records):
                    if record.done:
                        continue
                    if zone.team is None or self.teams[i] == zone.team:
                        rewards[i] += zone.delivery_reward
                        record.deliveries += 1
                    elif zone.zero_sum:
                        rewards[i] -= zone.delivery_reward
                if zone.end_on_delivery:
                    ended = True
                else:
                    self._send_back(thing)
                break
        return ended

    def _send_back(self, thing: Obstacle) -> None:
        self.hands.drop(thing)
        body = thing.body
        x, y, angle = thing.home
        body.position, body.angle = (x, y), angle
        body.velocity, body.angular_velocity = (0.0, 0.0), 0.0
        body.space.reindex_shapes_for_body(body)
