"""Stable-Baselines3's ``VecEnv`` over the batched env: every agent of every world a slot.

::

    from stable_baselines3 import PPO
    from flatland_ma.integrations.sb3 import SB3VecEnv

    env = SB3VecEnv("fruits_poisons_multi", num_worlds=8)   # 8 worlds x 4 agents = 32 envs
    PPO("MlpPolicy", env).learn(10_000)                     # "MultiInputPolicy" for Dict

Slot ``w * agents_per_world + j`` is world ``w``'s agent ``j``, as in
``flatland_ma.envs.vector.BatchedParallelEnv`` (any of its keyword arguments, such as
``max_cycles``, ``flatten`` or ``pad``, may be given). Observations are the batched env's:
one stacked array, or a dict of them for senses in a ``Dict`` (SB3's
``MultiInputPolicy``).

Resets are SB3's: at a step where a slot is done, the observation returned for it is the
first of its next episode, and ``infos[slot]["terminal_observation"]`` holds the last one
of the episode that ended, with ``"TimeLimit.truncated"`` True when the episode was cut
rather than ended (SB3 then bootstraps from the terminal observation); the info holds the
ended episode's counters and ``reset_infos[slot]`` the new one's. So no transition
SB3 records is made up: there is no step whose action is thrown away while a world resets
(the fake transition a ``NEXT_STEP`` vector env gives a learner that steps through it).

Agents that finish early: SB3 needs an observation, a reward and a done flag from every
slot at every step, and a finished agent whose world plays on has none to give until its
world resets; any value sent for it would be a made-up transition. So here **an agent that
finishes ends its world's episode**: the world's other agents are truncated in that step
(done, ``"TimeLimit.truncated"``, their real current observation as the terminal one, so
SB3 bootstraps their value as it does at a time limit) and the world resets at once.
Every transition is then one the world made, and every slot acts at every step. In a
scenario whose agents finish together (a time limit) nothing changes; in one where some
leave early (terminal items, goals), the others' episodes end with the first to leave,
which is what this adapter trains on (use the batched env and its ``infos["active"]`` to
keep worlds going with agents gone).

Seeds: ``env.seed(s)`` then ``reset()`` resets world ``w`` with ``s + w`` (the batched
env's rule). ``infos[slot]`` also holds the agent's episode counters (``score``, ...).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode

from flatland_ma.envs.vector import BatchedParallelEnv

try:
    from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvObs, VecEnvStepReturn
except ImportError as err:  # the client is an extra, imported only with this module
    raise ImportError(
        "flatland_ma.integrations.sb3 needs Stable-Baselines3: pip install stable-baselines3"
    ) from err

TERMINAL = "terminal_observation"
TRUNCATED = "TimeLimit.truncated"
"""SB3's info keys for the last observation of an episode and for an episode cut short."""


class SB3VecEnv(VecEnv):
    """A Stable-Baselines3 ``VecEnv`` of ``num_worlds`` worlds of ``scenario``, one env per
    agent of every world (see the module's docstring); ``kwargs`` go to
    ``BatchedParallelEnv``."""

    def __init__(self, scenario: Any = "fruits_poisons_multi", num_worlds: int = 1, **kwargs):
        if "autoreset_mode" in kwargs:
            raise TypeError("SB3VecEnv resets worlds itself (SB3's rule): drop autoreset_mode")
        self.batch = BatchedParallelEnv(
            scenario, num_worlds=num_worlds, autoreset_mode=AutoresetMode.DISABLED, **kwargs
        )
        self.agents_per_world = self.batch.agents_per_world
        self._actions: np.ndarray | None = None
        super().__init__(
            self.batch.num_slots,
            self.batch.single_observation_space,
            self.batch.single_action_space,
        )

    # -- SB3's loop ---------------------------------------------------------------------

    def reset(self) -> VecEnvObs:
        observations, infos = self.batch.reset(seed=self._seeds[0])  # world w: seed + w
        self._reset_seeds()
        self._reset_options()
        self.reset_infos = self._slot_infos(infos)
        return observations

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        if self._actions is None:
            raise RuntimeError("call step_async(actions) before step_wait()")
        actions, self._actions = self._actions, None
        observations, rewards, terminations, truncations, infos = self.batch.step(actions)
        m = self.agents_per_world
        terminations, truncations = np.asarray(terminations), np.asarray(truncations)
        finished = terminations | truncations
        ended = finished.reshape(-1, m).any(axis=1)  # a finisher ends its world's episode
        done = np.repeat(ended, m)
        cut = done & ~terminations  # truncated, or cut by another agent's finish
        slot_infos = self._slot_infos(infos)
        for slot in np.flatnonzero(done):
            slot_infos[slot][TERMINAL] = _slot(observations, int(slot))
            slot_infos[slot][TRUNCATED] = bool(cut[slot])
        if ended.any():
            fresh, reset_infos = self.batch.reset(options={"reset_mask": ended})
            observations = fresh
            starts = self._slot_infos(reset_infos)
            for slot in np.flatnonzero(done):  # the new episode's counters, as SB3 keeps them
                self.reset_infos[slot] = starts[slot]
        return observations, np.asarray(rewards, np.float32), done, slot_infos

    def close(self) -> None:
        self.batch.close()

    # -- attributes and renders ---------------------------------------------------------

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        """The batched env's attribute, once per slot asked (every slot shares it)."""
        value = getattr(self.batch, attr_name)
        return [value for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        setattr(self.batch, attr_name, value)

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs):
        result = getattr(self.batch, method_name)(*method_args, **method_kwargs)
        return [result for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class, indices=None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        """Each slot's world's frame (``render_mode="rgb_array"``)."""
        frames = self.batch.render() or (None,) * self.batch.num_worlds
        return [frames[slot // self.agents_per_world] for slot in range(self.num_envs)]

    # -- inside -------------------------------------------------------------------------

    def _slot_infos(self, infos: dict) -> list[dict]:
        keys = [key for key in infos if key != "active"]
        return [{key: infos[key][slot] for key in keys} for slot in range(self.num_envs)]


def _slot(observations, slot: int):
    if isinstance(observations, dict):
        return {key: values[slot].copy() for key, values in observations.items()}
    return observations[slot].copy()
