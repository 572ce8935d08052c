"""Each agent's observation as one flat float32 vector, for learners that take one array.

An agent with several sensors observes a ``Dict`` (one entry per sensor), and a camera
gives a 2-D ``Box`` (rays x channels); RLlib refuses both without a flattening connector,
and many PPO implementations expect one vector. ``FlattenObservations`` wraps a parallel
env so that every observation is ``gymnasium.spaces.flatten`` of the original, in a
``Box`` from ``flatten_space``; ``unflatten(agent, vector)`` gives the original back::

    env = FlattenObservations(flatland_ma.parallel_env("fruits_poisons", agent={"sensors": [
        {"type": "camera"}, {"type": "lidar"}]}))

A ``Dict`` flattens its entries in the order of its keys (sorted by name).
"""

from __future__ import annotations

from gymnasium import spaces
from pettingzoo.utils.wrappers import BaseParallelWrapper


class FlattenObservations(BaseParallelWrapper):
    """A parallel env whose observations are flat vectors (see the module docstring)."""

    def __init__(self, env):
        super().__init__(env)
        self._inner = {a: env.observation_space(a) for a in env.possible_agents}
        self._flat = {a: spaces.flatten_space(space) for a, space in self._inner.items()}

    def observation_space(self, agent):
        return self._flat[agent]

    def reset(self, seed=None, options=None):
        observations, infos = self.env.reset(seed=seed, options=options)
        return self._flatten(observations), infos

    def step(self, actions):
        observations, rewards, terminations, truncations, infos = self.env.step(actions)
        return self._flatten(observations), rewards, terminations, truncations, infos

    def state(self):
        return self.env.state()

    def unflatten(self, agent: str, vector):
        """The agent's observation as the wrapped env gives it."""
        return spaces.unflatten(self._inner[agent], vector)

    def _flatten(self, observations: dict) -> dict:
        return {a: spaces.flatten(self._inner[a], o) for a, o in observations.items()}
