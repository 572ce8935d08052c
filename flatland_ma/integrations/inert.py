"""Finished agents kept present and inert until their world ends, for clients that expect
every possible agent in every step (AgileRL's vector envs, fixed-slot buffers)::

    from flatland_ma.integrations.inert import InertFinished

    env = InertFinished(flatland_ma.parallel_env("fruits_poisons_multi", zones=[...]))

PettingZoo's parallel API drops an agent from ``agents`` in the step it terminates. Some
clients cannot take that: AgileRL 2.58's ``AsyncPettingZooVecEnv`` fills a missing agent's
observation, reward and flags with NaN, which its IPPO then samples actions from. Over this
wrapper an agent that finishes while others play on stays in ``agents``:

- the step it finishes returns its real last observation and reward, with ``terminated``
  and ``truncated`` False, and ``infos[agent]["active"]`` False from then on (True while it
  acts): that is the step to cut bootstrapping at;
- in later steps its observation is zeros (the nearest value of its space where a bound
  excludes 0), its reward 0.0, its info its last one with ``active`` False, and any
  action given for it is ignored, whatever it is; none need be given;
- when the world's episode ends (the last acting agent finishes, or the step limit),
  every agent is done in that one step: those that had finished report ``terminated``
  True, the others what the env says, and ``agents`` is empty.

So each world's episode ends for every agent at once, as SuperSuit's ``black_death_v3``
intends (its 3.11 release never ends an episode whose agents terminate rather than
truncate). Spaces, ``state()`` and rendering are the wrapped env's; the wrapper passes
PettingZoo's ``parallel_api_test``.
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces
from pettingzoo.utils.wrappers import BaseParallelWrapper


def blank(space: spaces.Space):
    """The observation of an inert agent: zeros, each clipped into the space's bounds."""
    if isinstance(space, spaces.Box):
        return np.clip(np.zeros(space.shape), space.low, space.high).astype(space.dtype)
    if isinstance(space, spaces.Dict):
        return {key: blank(sub) for key, sub in space.spaces.items()}
    raise TypeError(f"no inert observation for a {type(space).__name__} space: {space}")


class InertFinished(BaseParallelWrapper):
    """A parallel env whose finished agents stay present and inert until their world's
    episode ends (the module's docstring)."""

    def __init__(self, env):
        super().__init__(env)
        for a in env.possible_agents:
            blank(env.observation_space(a))  # every space has an inert observation
        self.agents: list[str] = []
        self._finished: dict[str, dict] = {}
        """Agents that finished while their world plays on -> their last info."""

    def reset(self, seed=None, options=None):
        observations, infos = self.env.reset(seed=seed, options=options)
        self.agents = list(self.env.agents)
        self._finished = {}
        return observations, {a: {**info, "active": True} for a, info in infos.items()}

    def step(self, actions):
        if not self.agents:
            raise RuntimeError("no agents: the episode is over, call reset()")
        acting = list(self.env.agents)
        observations, rewards, terminated, truncated, infos = self.env.step(
            {a: actions[a] for a in acting if a in actions}
        )
        over = not self.env.agents
        for a in acting:
            if terminated[a] or truncated[a]:
                self._finished[a] = infos[a]
                if not over:
                    terminated[a] = truncated[a] = False
            infos[a] = {**infos[a], "active": a in self.env.agents}
        for a in self.agents:
            if a not in acting:  # inert since an earlier step
                observations[a] = blank(self.observation_space(a))
                rewards[a] = 0.0
                terminated[a], truncated[a] = over, False
                infos[a] = {**self._finished[a], "active": False}
        self.agents = [] if over else list(self.agents)
        order = [a for a in self.possible_agents if a in observations]
        return (
            {a: observations[a] for a in order},
            {a: rewards[a] for a in order},
            {a: terminated[a] for a in order},
            {a: truncated[a] for a in order},
            {a: infos[a] for a in order},
        )
