"""The Gymnasium environment for single-agent scenarios: a thin shell over the parallel env."""

from __future__ import annotations

from collections.abc import Mapping

import gymnasium

from flatland_ma.envs.parallel import FlatlandParallelEnv
from flatland_ma.envs.render_modes import RENDER_MODES


class FlatlandGymEnv(gymnasium.Env):
    """One agent of a ``FlatlandParallelEnv``; observations, actions, rewards and infos are
    that agent's. Registered as ``flatland_ma/<Scenario>-v0`` for each single-agent
    scenario (e.g. ``flatland_ma/FruitsPoisons-v0``).

    Built directly, it truncates at the scenario's ``episode.max_steps``. Each id is
    registered with that limit as its ``max_episode_steps`` and with ``time_limit=False``:
    ``gymnasium.make``'s ``TimeLimit`` wrapper is then the one that truncates, after
    ``max_episode_steps`` steps, longer or shorter than the scenario's.

    ``flatten=True`` (also ``gymnasium.make(id, flatten=True)``) gives one float32 vector
    per observation (``flatland_ma.envs.flatten``; ``unflatten(vector)`` gives the parts).
    ``metadata["render_modes"]`` lists ``human`` only where pygame can be imported.
    """

    metadata = {"render_modes": RENDER_MODES, "render_fps": 30}

    def __init__(
        self,
        scenario="fruits_poisons",
        render_mode: str | None = None,
        time_limit: bool = True,
        flatten: bool = False,
        **overrides,
    ):
        if not time_limit and _sets_episode_length(overrides):
            raise TypeError(
                "with time_limit=False (as gymnasium.make builds it) a wrapper truncates: "
                "set the episode length with gymnasium.make(..., max_episode_steps=N)"
            )
        self.parallel_env = FlatlandParallelEnv(
            scenario, render_mode=render_mode, flatten=flatten, **overrides
        )
        if not time_limit:
            self.parallel_env.step_limit = None
        if self.parallel_env.spec.n_agents != 1:
            raise ValueError(
                f"scenario {scenario!r} has {self.parallel_env.spec.n_agents} agents; "
                "use flatland_ma.parallel_env or flatland_ma.env for several agents"
            )
        self.agent = self.parallel_env.possible_agents[0]
        self.observation_space = self.parallel_env.observation_space(self.agent)
        self.action_space = self.parallel_env.action_space(self.agent)
        self.render_mode = render_mode
        self._actuator = self.parallel_env.actuators[0]

    def action_names(self) -> tuple[str, ...]:
        """What each discrete action or each continuous entry means, in order."""
        return self.parallel_env.action_names(self.agent)

    def action_index(self, name: str) -> int:
        """The discrete action (or continuous entry) called ``name``, e.g. ``"grasp"``."""
        return self.parallel_env.action_index(name, self.agent)

    def unflatten(self, vector):
        """With ``flatten=True``: the observation ``vector`` as the env gives it without."""
        return self.parallel_env.unflatten(self.agent, vector)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        observations, infos = self.parallel_env.reset(seed=seed, options=options)
        self._np_random = self.parallel_env.np_random
        self._np_random_seed = self.parallel_env.np_random_seed
        return observations[self.agent], infos[self.agent]

    def step(self, action):
        par = self.parallel_env
        if not par.agents:
            raise RuntimeError("the episode is over: call reset()")
        checked = self._actuator.check(self.agent, action)
        par.enter()
        try:
            par.act((checked,))
            _, rewards, terminated, truncated = par.advance()
            episode = par.running
            return (
                par.observe(0),
                rewards[0],
                terminated[0],
                truncated,
                episode.task.info(0),
            )
        finally:
            par.leave()

    def render(self):
        return self.parallel_env.render()

    def close(self):
        self.parallel_env.close()
        super().close()

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._actuator = self.parallel_env.actuators[0]
        if self.parallel_env.seeded:
            self._np_random = self.parallel_env.np_random


def _sets_episode_length(overrides: dict) -> bool:
    """Whether the overrides set the scenario's ``episode.max_steps`` (or ``max_cycles``)."""
    episode = overrides.get("episode")
    return "max_cycles" in overrides or (isinstance(episode, Mapping) and "max_steps" in episode)
