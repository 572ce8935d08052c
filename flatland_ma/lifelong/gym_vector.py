"""The Gymnasium vector env of a stream whose learner drives one agent.

``gymnasium.make_vec("flatland_ma/CrossObjectiveStream-v0", num_envs=N)`` builds
``StreamVectorEnv``: the stream's batched env (``flatland_ma.lifelong.batched``), one slot
per world, rather than Gymnasium's ``SyncVectorEnv`` over N single stream envs. Its worlds
live **one life together**: the stream's clock counts the learner's steps in every world,
so a task of ``steps`` lasts ``steps / N`` vector steps and every world switches task in
the same step (N separate lives, each of the whole length, are what
``gymnasium.make_vec(id, N, vectorization_mode="sync")`` still gives). With ``num_envs=1``
it returns exactly what ``SyncVectorEnv`` over one ``StreamGymEnv`` returns, for the same
seed, actions and autoreset mode, through every task switch.

``autoreset_mode`` is ``SAME_STEP`` by default (as for the scenario ids; TorchRL takes
it), or ``NEXT_STEP``; ``DISABLED`` is not offered, since the stream decides when its
worlds start again. Infos follow Gymnasium's convention for vector envs: ``task`` and the
episode counters for every env, ``task_switch`` where a task ended (inside ``final_info``
with ``SAME_STEP``, as ``SyncVectorEnv`` puts it).
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
from gymnasium.vector import AutoresetMode

from flatland_ma.envs.gym_vector import GYM_AUTORESET_MODE
from flatland_ma.envs.resets import FINAL_INFO, FINAL_OBS
from flatland_ma.envs.vector import VECTOR_RENDER_MODES, check_vector_render_mode
from flatland_ma.lifelong.batched import StreamBatchedEnv

SWITCH = "task_switch"


class StreamVectorEnv(gymnasium.vector.VectorEnv):
    """``num_envs`` worlds living one life through ``stream`` (see the module's docstring)."""

    metadata = {
        "autoreset_mode": GYM_AUTORESET_MODE,
        "render_modes": VECTOR_RENDER_MODES,
        "render_fps": 30,
    }

    def __init__(
        self,
        stream: Any = "cross_objective",
        num_envs: int = 1,
        autoreset_mode: AutoresetMode | str = GYM_AUTORESET_MODE,
        render_mode: str | None = None,
    ):
        check_vector_render_mode(render_mode)
        self.batch = StreamBatchedEnv(
            stream, num_worlds=num_envs, autoreset_mode=autoreset_mode, render_mode=render_mode
        )
        if self.batch.agents_per_world != 1:
            self.batch.close()
            raise ValueError(
                f"the stream's learner drives {self.batch.agents_per_world} agents per world; "
                "use flatland_ma.lifelong.StreamBatchedEnv for several"
            )
        self.autoreset_mode = self.batch.autoreset_mode
        self.metadata = {**self.metadata, "autoreset_mode": self.autoreset_mode}
        self.num_envs = num_envs
        self.render_mode = render_mode
        self.single_observation_space = self.batch.single_observation_space
        self.single_action_space = self.batch.single_action_space
        self.observation_space = gymnasium.vector.utils.batch_space(
            self.single_observation_space, num_envs
        )
        self.action_space = gymnasium.vector.utils.batch_space(self.single_action_space, num_envs)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        observations, infos = self.batch.reset(seed=seed, options=options)
        return observations, self._infos(infos)

    def step(self, actions):
        observations, rewards, terminations, truncations, infos = self.batch.step(actions)
        return observations, rewards, terminations, truncations, self._infos(infos)

    def render(self) -> tuple | None:
        return self.batch.render()

    def close_extras(self, **kwargs) -> None:
        self.batch.close()

    def _infos(self, infos: dict) -> dict:
        """The stream batched env's infos in Gymnasium's form (masks under ``_key``)."""
        infos.pop("active")
        switch = infos.pop(SWITCH, None)
        everyone = np.ones(self.num_envs, bool)
        out: dict = {}
        for key, values in infos.items():
            if key in (FINAL_OBS, f"_{FINAL_OBS}", f"_{FINAL_INFO}"):
                out[key] = values
            elif key == FINAL_INFO:
                out[key] = _masked(values, infos[f"_{FINAL_INFO}"])
            else:
                out[key], out[f"_{key}"] = values, everyone.copy()
        if switch is not None and switch.any() and self.autoreset_mode != AutoresetMode.SAME_STEP:
            out[SWITCH], out[f"_{SWITCH}"] = switch, switch.copy()
        return out


def _masked(final: dict, given: np.ndarray) -> dict:
    """``final_info`` with Gymnasium's masks: ``task_switch`` only where it is True (the
    single env's info has it only then), the counters where an episode ended."""
    out: dict = {}
    for key, values in final.items():
        if key == SWITCH:
            if values.any():
                out[key], out[f"_{key}"] = values, np.asarray(values, bool).copy()
        else:
            out[key], out[f"_{key}"] = values, given.copy()
    return out


def make_stream_vector(num_envs: int = 1, stream: str = "cross_objective", **kwargs):
    """The ``vector_entry_point`` of the stream ids."""
    return StreamVectorEnv(stream, num_envs=num_envs, **kwargs)
