"""Foraging: items reward or punish the agent that touches them, and may respawn.

The paper's task: orange fruits (+10) and purple poisons (-10) in one room. Each agent's
counters (its score and how many of each item group it ate) are its measurements, reported
in ``infos`` (what DFP learns to predict).
"""

from __future__ import annotations

import numpy as np

from flatland_ma.scenario.schema import ScenarioSpec
from flatland_ma.sensors.geometry import Geometry
from flatland_ma.world.entities import Item
from flatland_ma.world.placement import PlacementError, sample_free_position
from flatland_ma.world.world import World


class ForagingTask:
    """Rewards from items touched during the step; eaten items respawn or vanish."""

    def __init__(self, spec: ScenarioSpec, world: World, geometry: Geometry):
        self.world = world
        self.geometry = geometry
        self.group_names = [item.name for item in spec.items]
        self.respawns = [item.respawn == "immediate" for item in spec.items]
        self.n_agents = spec.n_agents
        self.score = np.zeros(spec.n_agents, np.float64)
        self.eaten = np.zeros((spec.n_agents, len(spec.items)), np.int64)
        self._waiting: list[Item] = []
        """Eaten items that found no free position yet; they retry every step."""

    def evaluate(self, rng: np.random.Generator) -> tuple[list[float], list[bool]]:
        """Rewards and terminations of every agent for the step just simulated."""
        rewards = [0.0] * self.n_agents
        eaten_now: list[Item] = []
        for agent, item in self.world.contacts:
            if not item.edible:
                continue  # already taken this step by another agent
            i = agent.owner
            rewards[i] += item.reward
            self.eaten[i, item.group] += 1
            item.visible = False
            eaten_now.append(item)
        for item in eaten_now:
            if self.respawns[item.group]:
                self._waiting.append(item)
            else:
                self.world.space.remove(*item.shapes)
                self.geometry.update_entity(item)
        if self._waiting:
            self._respawn(rng)
        if eaten_now:
            self.score += rewards
        return rewards, [False] * self.n_agents

    def _respawn(self, rng: np.random.Generator) -> None:
        still_waiting = []
        for item in self._waiting:
            try:
                x, y = sample_free_position(self.world, rng, item.radius)
            except PlacementError:
                still_waiting.append(item)
                self.geometry.update_entity(item)
                continue
            self.world.move_static(item, x, y)
            item.visible = True
            self.geometry.update_entity(item)
        self._waiting = still_waiting

    def info(self, agent_index: int) -> dict:
        """The agent's episode counters: ``score`` and one count per item group."""
        counts = self.eaten[agent_index]
        info = {"score": float(self.score[agent_index])}
        for g, name in enumerate(self.group_names):
            info[name] = int(counts[g])
        return info
