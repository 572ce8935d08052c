"""Each agent's observation as one flat float32 vector, for learners that take one array.

An agent with several sensors observes a ``Dict`` (one entry per sensor), and a camera
gives a 2-D ``Box`` (rays x channels) that is no image; AgileRL, BenchMARL and RLlib
refuse one or the other, and many PPO implementations expect one vector. ``flatten=True``
on ``flatland_ma.parallel_env``, ``flatland_ma.env`` and ``gymnasium.make`` gives every
agent one float32 ``Box`` of shape ``(n,)`` instead::

    env = flatland_ma.parallel_env("sensor_suite", flatten=True)
    env.observation_space("agent_0")     # Box(-inf, inf, (n,), float32) with the parts' bounds
    env.flat_layout("agent_0")           # (FlatPart("camera", 0, 256, (64, 4)), ...)
    env.unflatten("agent_0", vector)     # the Dict of the unflattened env

The layout: a ``Box`` is its array in C order (a camera's ``(rays, 4)``: ray 0's four
channels, then ray 1's, ...). A ``Dict`` is its entries one after another in the order of
its keys (sorted by name, as ``gymnasium.spaces.Dict`` keeps them), each in C order. This
is ``gymnasium.spaces.flatten``'s layout, cast to float32 (uint8 pixels are exact there).
``FlatLayout.parts`` lists each entry's name, start, stop and shape.

``FlattenObservations`` does the same for any parallel env, as a wrapper.
"""

from __future__ import annotations

from typing import NamedTuple

import gymnasium
import numpy as np
from gymnasium import spaces
from pettingzoo.utils.wrappers import BaseParallelWrapper

WHOLE = ""
"""The name of the one part of a ``Box`` observation."""


class FlatPart(NamedTuple):
    """One entry of an observation inside the flat vector: ``vector[start:stop]``, shaped
    ``shape``, is entry ``name`` (``WHOLE`` for a ``Box`` observation)."""

    name: str
    start: int
    stop: int
    shape: tuple[int, ...]


class FlatLayout:
    """How one agent's observation space lies in one float32 vector (the module's
    docstring): ``space`` is the flat ``Box``, ``parts`` the entries in order."""

    def __init__(self, space: gymnasium.Space):
        if isinstance(space, spaces.Dict):
            entries = list(space.spaces.items())
        else:
            entries = [(WHOLE, space)]
        parts, start = [], 0
        self._entries: dict[str, spaces.Box] = {}
        for name, entry in entries:
            if not isinstance(entry, spaces.Box):
                raise ValueError(f"a flat observation covers Box entries; {name!r} is {entry}")
            self._entries[name] = entry
            size = int(np.prod(entry.shape, dtype=np.int64))
            parts.append(FlatPart(name, start, start + size, tuple(entry.shape)))
            start += size
        self.original = space
        """The observation space before flattening."""
        self.parts: tuple[FlatPart, ...] = tuple(parts)
        flat = spaces.flatten_space(space)
        assert isinstance(flat, spaces.Box) and flat.shape == (start,)
        low, high = _float32_bound(flat.low, -np.inf), _float32_bound(flat.high, np.inf)
        self.space = spaces.Box(low, high, (start,), np.float32)

    def flatten(self, observation) -> np.ndarray:
        """The observation as a fresh float32 vector of ``space``."""
        if len(self.parts) == 1 and self.parts[0].name == WHOLE:
            return np.asarray(observation, np.float32).reshape(-1)
        return np.concatenate(
            [np.asarray(observation[p.name], np.float32).reshape(-1) for p in self.parts]
        )

    def unflatten(self, vector) -> np.ndarray | dict[str, np.ndarray]:
        """The observation ``vector`` was made from, in the original space's dtypes."""
        vector = np.asarray(vector)
        if vector.shape != self.space.shape:
            raise ValueError(f"a flat observation has shape {self.space.shape}, not {vector.shape}")
        out = {}
        for part in self.parts:
            entry = self._entries[part.name]
            values = vector[part.start : part.stop].reshape(part.shape)
            if np.issubdtype(entry.dtype, np.integer):
                values = np.rint(values)
            out[part.name] = values.astype(entry.dtype)
        return out[WHOLE] if WHOLE in out else out


def _float32_bound(bound: np.ndarray, outward: float) -> np.ndarray:
    """``bound`` in float32, moved one step ``outward`` (towards -inf for a low bound,
    +inf for a high one) where float32 rounds it inward, so nothing inside leaves it."""
    as32 = np.asarray(bound).astype(np.float32)
    inward = (as32 > bound) if outward < 0 else (as32 < bound)
    return np.where(inward, np.nextafter(as32, np.float32(outward)), as32).astype(np.float32)


class FlattenObservations(BaseParallelWrapper):
    """A parallel env whose observations are flat float32 vectors (the module's
    docstring); ``unflatten(agent, vector)`` gives the wrapped env's observation back."""

    def __init__(self, env):
        super().__init__(env)
        self._layouts = {a: FlatLayout(env.observation_space(a)) for a in env.possible_agents}

    def observation_space(self, agent):
        return self._layouts[agent].space

    def reset(self, seed=None, options=None):
        observations, infos = self.env.reset(seed=seed, options=options)
        return self._flatten(observations), infos

    def step(self, actions):
        observations, rewards, terminations, truncations, infos = self.env.step(actions)
        return self._flatten(observations), rewards, terminations, truncations, infos

    def state(self):
        return self.env.state()

    def flat_layout(self, agent: str) -> tuple[FlatPart, ...]:
        """Where each entry of the agent's observation lies in its flat vector."""
        return self._layouts[agent].parts

    def unflatten(self, agent: str, vector):
        """The agent's observation as the wrapped env gives it."""
        return self._layouts[agent].unflatten(vector)

    def _flatten(self, observations: dict) -> dict:
        return {a: self._layouts[a].flatten(o) for a, o in observations.items()}
