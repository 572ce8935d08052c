"""The Gymnasium vector env of a single-agent scenario.

``FlatlandVectorEnv`` is a ``gymnasium.vector.VectorEnv`` with one slot per world;
``gymnasium.make_vec("flatland_ma/FruitsPoisons-v0", num_envs=N)`` builds it (the ids name
``make_vector`` as their ``vector_entry_point``). Its worlds are one ``BatchedParallelEnv``
(``flatland_ma.envs.vector``), or a ``ShardedParallelEnv`` over processes with
``shards=K``. It returns exactly what Gymnasium's ``SyncVectorEnv`` over the same envs
returns, for the same seeds and actions, resetting worlds in Gymnasium's ``NEXT_STEP`` mode.
``num_envs`` is held to the work budget before anything is allocated, and ``step`` takes
one action per env (an array or a sequence of ``num_envs``), each in
``single_action_space``: anything else is refused before any world moves.
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np

from flatland_ma.envs.shards import ShardedParallelEnv
from flatland_ma.envs.vector import AUTORESET_MODE, BatchedParallelEnv


class FlatlandVectorEnv(gymnasium.vector.VectorEnv):
    """The Gymnasium vector env of a single-agent scenario: ``num_envs`` worlds, one slot
    each (see ``flatland_ma.envs.vector``); with ``shards`` they are spread over that many
    processes (``flatland_ma.envs.shards``). ``infos`` follow Gymnasium's convention for vector
    envs: per key an array over the envs, and under ``"_" + key`` which envs have it."""

    metadata = {"autoreset_mode": AUTORESET_MODE, "render_modes": []}

    def __init__(
        self,
        scenario: Any = "fruits_poisons",
        num_envs: int = 1,
        shards: int | None = None,
        **kwargs,
    ):
        self.batch: Any
        if shards is None:
            self.batch = BatchedParallelEnv(
                scenario, num_worlds=num_envs, _counted_as="num_envs", **kwargs
            )
        else:
            self.batch = ShardedParallelEnv(
                scenario, num_envs, shards=shards, _counted_as="num_envs", **kwargs
            )
        if self.batch.agents_per_world != 1:
            raise ValueError(
                f"scenario {scenario!r} has {self.batch.agents_per_world} agents; "
                "use flatland_ma.envs.vector.BatchedParallelEnv for several agents"
            )
        self.num_envs = num_envs
        self.single_observation_space = self.batch.single_observation_space
        self.single_action_space = self.batch.single_action_space
        self.observation_space = self.batch.observation_space
        self.action_space = self.batch.action_space
        self.render_mode = None

    def reset(self, *, seed: int | list[int | None] | None = None, options: dict | None = None):
        observations, infos = self.batch.reset(seed=seed, options=options)
        return observations, self._infos(infos)

    def step(self, actions):
        observations, rewards, terminations, truncations, infos = self.batch.step(actions)
        return observations, rewards, terminations, truncations, self._infos(infos)

    def close_extras(self, **kwargs) -> None:
        self.batch.close()

    def _infos(self, infos: dict) -> dict:
        infos.pop("active")  # one agent per world: always acting
        out: dict = {}
        for key, values in infos.items():
            out[key] = values
            out[f"_{key}"] = np.ones(self.num_envs, bool)
        return out


def make_vector(
    num_envs: int = 1,
    scenario: str = "fruits_poisons",
    time_limit: bool = False,
    max_episode_steps: int | None = None,
    **kwargs,
) -> FlatlandVectorEnv:
    """The ``vector_entry_point`` of the Gymnasium ids: ``max_episode_steps`` (the id's
    unless ``gymnasium.make_vec`` is given one) is where every world truncates, as
    ``gymnasium.make``'s ``TimeLimit`` does for one env."""
    del time_limit  # the single env's switch; here the episode length is max_episode_steps
    if max_episode_steps is not None and max_episode_steps > 0:
        kwargs["max_cycles"] = max_episode_steps
    return FlatlandVectorEnv(scenario, num_envs=num_envs, **kwargs)
