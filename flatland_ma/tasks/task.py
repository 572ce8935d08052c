"""The task: what each step's contacts and positions mean for the agents.

Items reward (or punish) the agent that touches them, may be keys or goals, and come back
as their scenario says; doors open to touch, to keys and to switches; zones reward, end
episodes or move agents on entry. Each agent's record holds its episode counters, which
``info`` reports (its ``score``, one count per item group, and the keys it holds).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from flatland_ma.agents.body import AgentBody
from flatland_ma.agents.grasp import Hands
from flatland_ma.scenario.schema import ScenarioSpec
from flatland_ma.sensors.geometry import Geometry
from flatland_ma.tasks.deliveries import DeliveryRules
from flatland_ma.tasks.doors import DoorRules
from flatland_ma.tasks.items import ItemRules
from flatland_ma.tasks.zones import ZoneRules
from flatland_ma.world.entities import Door
from flatland_ma.world.placement import Placer
from flatland_ma.world.world import World


@dataclass
class AgentRecord:
    """One agent's episode so far."""

    eaten: np.ndarray
    """How many items of each group it took."""
    score: float = 0.0
    keys: set[str] = field(default_factory=set)
    deliveries: int = 0
    """Deliveries credited to the agent (its team's, or everyone's)."""
    done: bool = False


class Task:
    def __init__(
        self,
        spec: ScenarioSpec,
        world: World,
        geometry: Geometry,
        bodies: list[AgentBody],
        doors: list[Door],
        placer: Placer,
        rng: np.random.Generator,
        hands: Hands,
    ):
        self.spec = spec
        self.world = world
        self.geometry = geometry
        self.bodies = bodies
        self.records = [AgentRecord(np.zeros(len(spec.items), np.int64)) for _ in bodies]
        self.hands = hands
        teams = [getattr(spec.team_of(i), "name", None) for i in range(len(bodies))]
        self.items = ItemRules(spec, world, geometry, placer)
        self.doors = DoorRules(world, geometry, doors)
        self.zones = ZoneRules(spec, bodies, placer, rng, teams)
        self.deliveries = DeliveryRules(spec, world, self.zones.rects, hands, teams)
        self.group_names = [item.name for item in spec.items]
        self.has_keys = any(item.key for item in spec.items)
        self.has_deliveries = bool(self.deliveries.zones)
        self.steps = 0

    def evaluate(self, rng: np.random.Generator) -> tuple[list[float], list[bool]]:
        """Rewards and terminations of every agent for the step just simulated."""
        self.steps += 1
        n = len(self.bodies)
        rewards = [0.0] * n
        terminated = [False] * n
        records = self.records
        self.items.apply(records, rewards, terminated, rng, self.steps)
        occupied = self.zones.apply(records, rewards, terminated, rng)
        self.doors.apply(records, occupied)
        delivered_end = self.deliveries.apply(records, rewards)
        episode = self.spec.episode
        ended = (
            delivered_end
            or (episode.shared_end and any(terminated))
            or (episode.end_when_eaten is not None and self.items.none_left(episode.end_when_eaten))
        )
        for i, record in enumerate(records):
            if record.done:
                continue
            if ended:
                terminated[i] = True
            if rewards[i]:
                record.score += rewards[i]
            if terminated[i]:
                record.done = True
                self._retire(self.bodies[i])
        return rewards, terminated

    def _retire(self, body: AgentBody) -> None:
        """An agent whose episode ended leaves the world, parts and all."""
        self.hands.drop_all_of(body.hands)
        for entity in (*body.parts, body):
            self.world.retire(entity)
            self.geometry.update_visibility(entity)

    def info(self, agent_index: int) -> dict:
        """The agent's episode counters: ``score``, one count per item group, and (in
        scenarios with keys) the sorted names of the keys it holds, (in scenarios with
        deliveries) how many deliveries it was credited with."""
        record = self.records[agent_index]
        info = {"score": float(record.score)}
        for g, name in enumerate(self.group_names):
            info[name] = int(record.eaten[g])
        if self.has_keys:
            info["keys"] = tuple(sorted(record.keys))
        if self.has_deliveries:
            info["deliveries"] = record.deliveries
        return info
