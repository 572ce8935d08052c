"""One observation space for agents whose observations differ, so that one network can
drive them all (parameter sharing across roles).

Agents' spaces are grouped into roles: agents with the same observation space share a
role, numbered in the order of their first agent. The padded space is a ``Dict`` of every
entry any role observes (a ``Box`` observation is the entry ``observation``, or, where
roles observe ``Box`` es of different ranks, ``observation_<rank>d``: a map and a camera
cannot share one entry), each as large along every axis as the largest of the roles that
have it, and a one-hot ``role`` entry that tells the network whose observation it reads.
An agent's observation fills the leading corner of each of its entries; the rest, and
entries its role lacks, are zeros.
Bounds are the union of the roles', and include 0 where padding may be.

This follows the recipe of SuperSuit's ``pad_observations_v0`` and
``agent_indicator_v0`` (Terry et al., "Revisiting Parameter Sharing in Multi-Agent Deep
Reinforcement Learning", 2020), done in place into the batched env's arrays.
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

ROLE = "role"
"""The entry of the padded observation that names the agent's role (one-hot)."""
OBSERVATION = "observation"
"""The entry a ``Box`` observation becomes."""


def _entries(space: gymnasium.Space, box_key: str) -> dict[str, spaces.Box]:
    if isinstance(space, spaces.Dict):
        entries = dict(space.spaces)
    else:
        entries = {box_key: space}
    for key, entry in entries.items():
        if not isinstance(entry, spaces.Box):
            raise ValueError(f"padding covers Box entries; {key!r} is {entry}")
    if ROLE in entries:
        raise ValueError(f"an observation entry is already called {ROLE!r}")
    return entries  # type: ignore[return-value]


class Padding:
    """The padded space of agents whose observation spaces are ``observation_spaces``
    (one per agent of a world, in agent order); see the module's docstring."""

    def __init__(self, observation_spaces: list[gymnasium.Space]):
        texts = [str(space) for space in observation_spaces]
        distinct = list(dict.fromkeys(texts))
        self.roles = len(distinct)
        self.role_of = [distinct.index(text) for text in texts]
        """Each agent's role."""
        ranks = {len(s.shape) for s in observation_spaces if isinstance(s, spaces.Box)}
        self._box_key = [
            f"{OBSERVATION}_{len(s.shape)}d"
            if len(ranks) > 1 and isinstance(s, spaces.Box)
            else OBSERVATION
            for s in observation_spaces
        ]
        """The entry each agent's ``Box`` observation becomes (if it observes one)."""
        self._own = [_entries(s, key) for s, key in zip(observation_spaces, self._box_key)]
        boxes: dict[str, list[spaces.Box]] = {}
        for entries in self._own:
            for key, box in entries.items():
                boxes.setdefault(key, []).append(box)
        padded: dict[str, gymnasium.Space] = {
            key: self._union(key, found, len(self._own)) for key, found in boxes.items()
        }
        padded[ROLE] = spaces.Box(0.0, 1.0, (self.roles,), np.float32)
        self.space = spaces.Dict(padded)
        self._corner = [
            {key: tuple(slice(0, n) for n in box.shape) for key, box in entries.items()}
            for entries in self._own
        ]

    @staticmethod
    def _union(key: str, found: list[spaces.Box], agents: int) -> spaces.Box:
        ndims = {len(box.shape) for box in found}
        if len(ndims) != 1:
            shapes = ", ".join(str(box.shape) for box in found)
            raise ValueError(f"entry {key!r} has shapes of different ranks ({shapes}): no padding")
        shape = tuple(int(n) for n in np.max([box.shape for box in found], axis=0))
        dtype = np.result_type(*(box.dtype for box in found))
        partial = len(found) < agents or any(box.shape != shape for box in found)
        low = np.full(shape, np.inf if not partial else 0.0)
        high = np.full(shape, -np.inf if not partial else 0.0)
        for box in found:
            corner = tuple(slice(0, n) for n in box.shape)
            low[corner] = np.minimum(low[corner], box.low)
            high[corner] = np.maximum(high[corner], box.high)
        return spaces.Box(low.astype(dtype), high.astype(dtype), shape, dtype)

    @classmethod
    def of(cls, env: Any) -> Padding | None:
        """The padding of a parallel env's agents, or None if they all observe alike."""
        observation_spaces = [env.observation_space(agent) for agent in env.possible_agents]
        if len({str(space) for space in observation_spaces}) == 1:
            return None
        return cls(observation_spaces)

    def pad(self, agent: int, observation) -> dict[str, np.ndarray]:
        """Agent ``agent``'s (its index in the world) observation in the padded space."""
        out = {key: np.zeros(box.shape or (), box.dtype) for key, box in self.space.spaces.items()}
        self.mark(out, agent)
        self.put(out, agent, observation)
        return out

    def mark(self, buffer: Any, agent: int, slot: Any = ()) -> None:
        """Write agent ``agent``'s role (one-hot) into ``buffer`` at index ``slot``: once
        per episode, as a slot's role does not change within one."""
        role = buffer[ROLE][slot]
        role[...] = 0.0
        role[self.role_of[agent]] = 1.0

    def put(self, buffer: Any, agent: int, observation, slot: Any = ()) -> None:
        """Write agent ``agent``'s observation into ``buffer`` (a dict of arrays of the
        padded space's entries, at index ``slot`` of each): its entries in their corners.
        Other places, its role's among them (``mark``), are left as they are."""
        if not isinstance(observation, dict):
            observation = {self._box_key[agent]: observation}
        entries = observation
        for key, corner in self._corner[agent].items():
            buffer[key][slot][corner] = entries[key]
