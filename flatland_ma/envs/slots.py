"""The slots of a batched env: the one space they share, and the stacked arrays it hands
out (observations, rewards, terminations, truncations, which slots are active and the
info counters), one row per slot."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import gymnasium
import numpy as np

from flatland_ma.envs.buffers import copied, counter_array, put, stacked
from flatland_ma.envs.flatten import FlatLayout
from flatland_ma.envs.padding import Padding
from flatland_ma.envs.resets import flatten_into, slot_of
from flatland_ma.envs.world_loop import WorldLoop


@dataclass
class SlotSpaces:
    """What every slot of a batch observes and does."""

    own: gymnasium.Space
    """A slot's observation space before flattening (padded with ``pad``)."""
    observation: gymnasium.Space
    """A slot's observation space as handed out (flat with ``flatten``)."""
    action: gymnasium.Space
    padding: Padding | None
    """How observations are padded to one space, or None when nothing needed padding."""
    flat: FlatLayout | None
    """How a slot's observation lies in its flat vector, with ``flatten``."""


def slot_spaces(first: WorldLoop, pad: bool, flatten: bool) -> SlotSpaces:
    """The spaces of the slots of ``first``'s worlds; a ``ValueError`` naming the agents
    when they do not share one (observations that differ are padded with ``pad``)."""
    agents = first.possible_agents
    padding = Padding.of(first) if pad else None
    own = first.observation_space(agents[0]) if padding is None else padding.space
    flat = FlatLayout(own) if flatten else None
    action = first.action_space(agents[0])
    for agent in agents[1:]:
        observes = str(first.observation_space(agent)) == str(first.observation_space(agents[0]))
        if not (observes or padding) or first.action_space(agent) != action:
            raise ValueError(
                f"{agent} observes {first.observation_space(agent)} and acts in "
                f"{first.action_space(agent)}, {agents[0]} observes "
                f"{first.observation_space(agents[0])} and acts in "
                f"{action}: a batch's slots share one space (one "
                "policy); pad=True pads observations that differ (actions must agree), "
                "SuperSuit pads both (docs/integrations.md)"
            )
    return SlotSpaces(own, own if flat is None else flat.space, action, padding, flat)


class SlotBuffers:
    """The stacked arrays of ``num_slots`` slots of ``spaces``; what ``observed``,
    ``infos`` and ``out`` hand out are copies unless ``copy`` is False."""

    def __init__(self, spaces: SlotSpaces, num_slots: int, copy: bool):
        self.spaces, self.num_slots, self.copy = spaces, num_slots, copy
        self.observations = stacked(spaces.own, num_slots)
        flat = spaces.flat
        self.flat_observations = (
            None if flat is None else np.zeros((num_slots, *flat.space.shape), np.float32)
        )
        self.rewards = np.zeros(num_slots, np.float64)
        self.terminations = np.zeros(num_slots, bool)
        self.truncations = np.zeros(num_slots, bool)
        self.active = np.zeros(num_slots, bool)
        self.counters: dict[str, np.ndarray] = {}

    def put(self, slot: int, agent: int, observation) -> None:
        """Agent ``agent``'s (of its world) ``observation`` into ``slot``."""
        padding = self.spaces.padding
        if padding is None:
            put(self.observations, slot, observation)
        else:
            padding.put(self.observations, agent, observation, slot)

    def count(self, slot: int, info: dict) -> None:
        for key, value in info.items():
            self.counter(key, value)[slot] = value

    def counter(self, key: str, value) -> np.ndarray:
        """The array of the info entry ``key`` (made to hold values like ``value``)."""
        counter = self.counters.get(key)
        if counter is None:
            counter = self.counters[key] = counter_array(value, self.num_slots)
        return counter

    def infos(self) -> dict:
        infos = {key: self.out(values) for key, values in self.counters.items()}
        infos["active"] = self.out(self.active)
        return infos

    def out(self, buffer) -> Any:
        return copied(buffer) if self.copy else buffer

    def observed(self) -> Any:
        """The observations handed out: the stacked buffers, or their flat vectors."""
        flat = self.spaces.flat
        if flat is None:
            return self.out(self.observations)
        assert self.flat_observations is not None
        flatten_into(flat, self.observations, self.flat_observations)
        return self.out(self.flat_observations)

    def seen(self, slot: int) -> Any:
        """A copy of one slot's current observation as handed out (flat with flatten)."""
        observation = slot_of(self.observations, slot)
        flat = self.spaces.flat
        return observation if flat is None else flat.flatten(observation)
