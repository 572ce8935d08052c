"""The Gymnasium vector env of a single-agent scenario.

``FlatlandVectorEnv`` is a ``gymnasium.vector.VectorEnv`` with one slot per world;
``gymnasium.make_vec("flatland_ma/FruitsPoisons-v0", num_envs=N)`` builds it (the ids name
``make_vector`` as their ``vector_entry_point``). Its worlds are one ``BatchedParallelEnv``
(``flatland_ma.envs.vector``), or a ``ShardedParallelEnv`` over processes with
``shards=K``. It returns exactly what Gymnasium's ``SyncVectorEnv`` over the same envs
returns with the same ``autoreset_mode``, for the same seeds and actions.

``autoreset_mode`` (``flatland_ma.envs.resets``) defaults to ``SAME_STEP`` here (the final
observation in ``infos["final_obs"]``), the mode TorchRL's ``GymWrapper`` requires;
``NEXT_STEP`` (Gymnasium's own default) and ``DISABLED`` are one argument away:
``gymnasium.make_vec(id, num_envs=N, autoreset_mode=AutoresetMode.NEXT_STEP)``.
``flatten=True`` gives one float32 vector per env (``flatland_ma.envs.flatten``);
``render_mode="rgb_array"`` makes ``render()`` return one frame per env, in a tuple.
``num_envs`` is held to the work budget before anything is allocated, and ``step`` takes
one action per env (an array or a sequence of ``num_envs``), each in
``single_action_space``: anything else is refused before any world moves.
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
from gymnasium.vector import AutoresetMode

from flatland_ma.envs.resets import FINAL_INFO, FINAL_OBS, autoreset_mode_of, reset_mask_of
from flatland_ma.envs.shards import ShardedParallelEnv
from flatland_ma.envs.vector import VECTOR_RENDER_MODES, BatchedParallelEnv

GYM_AUTORESET_MODE = AutoresetMode.SAME_STEP
"""``gymnasium.make_vec``'s default autoreset mode for the ids of this package."""


class FlatlandVectorEnv(gymnasium.vector.VectorEnv):
    """The Gymnasium vector env of a single-agent scenario: ``num_envs`` worlds, one slot
    each (see ``flatland_ma.envs.vector``); with ``shards`` they are spread over that many
    processes (``flatland_ma.envs.shards``). ``infos`` follow Gymnasium's convention for vector
    envs: per key an array over the envs, and under ``"_" + key`` which envs have it."""

    metadata = {
        "autoreset_mode": GYM_AUTORESET_MODE,
        "render_modes": VECTOR_RENDER_MODES,
        "render_fps": 30,
    }

    def __init__(
        self,
        scenario: Any = "fruits_poisons",
        num_envs: int = 1,
        shards: int | None = None,
        autoreset_mode: AutoresetMode | str = GYM_AUTORESET_MODE,
        render_mode: str | None = None,
        **kwargs,
    ):
        self.autoreset_mode = autoreset_mode_of(autoreset_mode)
        """The autoreset mode (TorchRL reads this attribute; ``metadata`` says it too)."""
        self.metadata = {**self.metadata, "autoreset_mode": self.autoreset_mode}
        kwargs.update(autoreset_mode=self.autoreset_mode, render_mode=render_mode)
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
            self.batch.close()
            raise ValueError(
                f"scenario {scenario!r} has {self.batch.agents_per_world} agents; "
                "use flatland_ma.envs.vector.BatchedParallelEnv for several agents"
            )
        self.num_envs = num_envs
        self.single_observation_space = self.batch.single_observation_space
        self.single_action_space = self.batch.single_action_space
        self.observation_space = self.batch.observation_space
        self.action_space = self.batch.action_space
        self.render_mode = render_mode

    def reset(self, *, seed: int | list[int | None] | None = None, options: dict | None = None):
        mask = reset_mask_of(options, self.num_envs)
        observations, infos = self.batch.reset(seed=seed, options=options)
        return observations, self._infos(infos, mask)

    def step(self, actions):
        observations, rewards, terminations, truncations, infos = self.batch.step(actions)
        return observations, rewards, terminations, truncations, self._infos(infos)

    def render(self) -> tuple | None:
        """Every env's frame (``render_mode="rgb_array"``), as ``SyncVectorEnv`` gives."""
        return self.batch.render()

    def unflatten(self, vector):
        """With ``flatten=True``: one env's flat observation as it is without flattening."""
        return self.batch.unflatten(vector)

    def close_extras(self, **kwargs) -> None:
        self.batch.close()

    def _infos(self, infos: dict, mask: np.ndarray | None = None) -> dict:
        """The batched env's infos in Gymnasium's form: ``mask`` (after a partial reset)
        says which envs gave infos; the others' entries are blank, as in SyncVectorEnv."""
        infos.pop("active")  # one agent per world: always acting
        given = np.ones(self.num_envs, bool) if mask is None else mask
        out: dict = {}
        for key, values in infos.items():
            if key in (FINAL_OBS, f"_{FINAL_OBS}", f"_{FINAL_INFO}"):
                out[key] = values
            elif key == FINAL_INFO:
                final = infos[f"_{FINAL_INFO}"]
                out[key] = {k: v for k, v in values.items()}
                out[key].update({f"_{k}": final.copy() for k in values})
            else:
                if mask is not None:
                    values = values.copy()
                    values[~mask] = None if values.dtype == object else 0
                out[key] = values
                out[f"_{key}"] = given.copy()
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
