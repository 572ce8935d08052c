"""One life through a stream's tasks for many worlds at once: the batched env.

``StreamBatchedEnv`` has the interface of ``flatland_ma.envs.vector.BatchedParallelEnv``
(stacked observations, arrays of rewards, terminations and truncations, ``infos`` of
arrays with ``active``; Gymnasium's NEXT_STEP autoreset), and its slots are the focal
agents of every world: world ``w``'s ``j``-th focal agent is slot
``w * agents_per_world + j``. Every world lives the one life of one learner:

- the clock counts the agent-steps of every focal slot whose action the env used (not
  inert slots, not the slots of a world being reset);
- on the step at which the clock reaches the end of the task's segment, every focal slot
  still playing is truncated and ``infos["task_switch"]`` is True; one step adds up to
  ``num_slots`` agent-steps, so the switch comes on the first step whose count reaches the
  end (it is exact when the segment's length is a multiple of the slots that act);
- the next step starts every world in the next task (its actions are not used; reward 0,
  neither termination nor truncation), world ``w`` seeded from the life's generator.

With ``autoreset_mode="same_step"`` (``flatland_ma.envs.resets``) nothing waits for a
step: a world whose episode ends resets in that step, and the step at which the segment
ends also starts every world in the next task; the last observations and counters are in
``infos["final_obs"]`` / ``infos["final_info"]`` (with the task that ended), Gymnasium's
keys. ``DISABLED`` is not offered: a stream decides when its worlds start again.

``infos["task"]`` holds the task's index for every slot. ``reset(seed=s)`` starts the
life: the first task's worlds reset with ``s + w``. ``state()`` holds each world's global
state, padded to the stream's longest as in ``StreamParallelEnv``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from flatland_ma.envs.guards import OneCaller, check_batch_of_actions
from flatland_ma.envs.resets import FINAL_INFO, FINAL_OBS, autoreset_mode_of, final_infos
from flatland_ma.envs.vector import BatchedParallelEnv, slot_observation
from flatland_ma.lifelong.drift import Drift
from flatland_ma.lifelong.envs import (
    TASK,
    announce,
    announced,
    background_policies,
    padded_state,
    state_space,
)
from flatland_ma.lifelong.streams import Stream, load_stream


def task_batched(
    stream: Stream,
    task: int,
    num_worlds: int,
    copy: bool = False,
    parallel: bool = True,
    autoreset_mode: AutoresetMode = AutoresetMode.NEXT_STEP,
    render_mode: str | None = None,
) -> BatchedParallelEnv:
    """The worlds of the stream's task ``task``, all agents slots, no switching (rays
    cast over numba's threads unless ``parallel`` is False)."""
    env = BatchedParallelEnv(
        stream.scenarios[task],
        num_worlds=num_worlds,
        copy=copy,
        parallel=parallel,
        autoreset_mode=autoreset_mode,
        render_mode=render_mode,
    )
    if stream.never_ending:
        for world in env.worlds:
            world.step_limit = None
    return env


class StreamBatchedEnv:
    """``num_worlds`` worlds living one life through ``stream``; see the module's docstring."""

    def __init__(
        self,
        stream: Any,
        num_worlds: int = 1,
        copy: bool = True,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        render_mode: str | None = None,
    ):
        self.autoreset_mode = autoreset_mode_of(autoreset_mode)
        if self.autoreset_mode == AutoresetMode.DISABLED:
            raise ValueError(
                "a stream's worlds start again when the stream says (autoreset_mode "
                "NEXT_STEP or SAME_STEP), not by reset_mask: DISABLED is not offered"
            )
        self.metadata = {"autoreset_mode": self.autoreset_mode, "render_modes": ["rgb_array"]}
        self.render_mode = render_mode
        self.stream = load_stream(stream)
        self._guard = OneCaller("this stream's batched env")
        self.num_worlds = num_worlds
        self.copy = copy
        self.segments = self.stream.segments()
        self.tasks = len(self.stream.scenarios)
        self._envs: dict[int, BatchedParallelEnv] = {}
        first = self._env(0)
        focal = self.stream.focal(0)
        self.possible_agents = [first.possible_agents[i] for i in focal]
        self.agents_per_world = len(focal)
        self.num_slots = num_worlds * self.agents_per_world
        space = first.worlds[0].observation_space(self.possible_agents[0])
        self.single_observation_space = (
            announced(space, self.tasks) if self.stream.spec.announce else space
        )
        self.single_action_space = first.worlds[0].action_space(self.possible_agents[0])
        self.single_state_space = state_space(self.stream)
        """Room for any task's global state (see ``state()``)."""
        self.state_space = batch_space(self.single_state_space, num_worlds)
        self.clock = 0
        self.segment = 0
        self._life: np.random.Generator | None = None
        self._pending = False
        self._acting = np.zeros(self.num_slots, bool)
        self._backgrounds: list[dict] = []
        self._observations: Any = None
        ne = self.stream.spec.never_ending
        self._drift = Drift(ne.drift) if ne is not None else None

    @property
    def task(self) -> int:
        if not self.segments:
            return 0
        return self.segments[min(self.segment, len(self.segments) - 1)][0]

    @property
    def env(self) -> BatchedParallelEnv:
        return self._env(self.task)

    def _env(self, task: int) -> BatchedParallelEnv:
        if task not in self._envs:
            self._envs[task] = task_batched(
                self.stream,
                task,
                self.num_worlds,
                autoreset_mode=self.autoreset_mode,
                render_mode=self.render_mode,
            )
        return self._envs[task]

    def _slots(self) -> np.ndarray:
        """The inner env's slot of each focal slot."""
        m = self.env.agents_per_world
        focal = self.stream.focal(self.task)
        return np.array([w * m + f for w in range(self.num_worlds) for f in focal], np.int64)

    # -- the loop -----------------------------------------------------------------------

    def reset(self, seed: int | list | None = None, options: dict | None = None):
        """Start a life (see the module's docstring)."""
        with self._guard:
            return self._begin(seed)

    def _begin(self, seed):
        self._life = np.random.default_rng(seed if isinstance(seed, int) else None)
        self.clock, self.segment, self._pending = 0, 0, False
        return self._start(seed)

    def _start(self, seed) -> tuple[Any, dict[str, Any]]:
        env = self.env
        assert self._life is not None
        self._backgrounds = [
            background_policies(self.stream, self.task, world, self._life) for world in env.worlds
        ]
        observations, infos = env.reset(seed=seed)
        self._observations = observations
        self._acting[:] = True
        rewards = np.zeros(self.num_slots)
        flags = np.zeros(self.num_slots, bool)
        out = self._out(observations, rewards, flags, flags, infos)
        return out[0], out[4]

    def step(self, actions):
        """One step of every world: one action per focal slot (as ``BatchedParallelEnv``)."""
        with self._guard:
            return self._step(actions)

    def _step(self, actions):
        layout = f"{self.num_worlds} worlds x {self.agents_per_world} focal agents"
        check_batch_of_actions(actions, self.num_slots, self.single_action_space, layout)
        actions = np.asarray(actions)
        if self._life is None:
            raise RuntimeError("call reset() first")
        if self._pending:  # every world starts the next task; the actions are not used
            self._pending = False
            self.segment += 1
            seeds = [int(s) for s in self._life.integers(2**31, size=self.num_worlds)]
            observations, infos = self._start(seeds)
            zeros = np.zeros(self.num_slots, bool)
            return observations, np.zeros(self.num_slots), zeros, zeros.copy(), infos
        env = self.env
        slots = self._slots()
        self._check(env, actions, slots)
        full = self._full(env, actions, slots)
        acted = int(self._acting.sum())
        observations, rewards, terminations, truncations, infos = env.step(full)
        if self._drift is not None:
            for world in env.worlds:
                self._drift.apply(world)
        self._observations = observations
        self.clock += acted
        rewards, terminations, truncations = rewards[slots], terminations[slots], truncations[slots]
        done = terminations | truncations
        switch = np.zeros(self.num_slots, bool)
        if (
            self.segments
            and self.segment < len(self.segments)
            and self.clock >= self.segments[self.segment][2]
        ):
            switch = infos["active"][slots] & ~done | done
            truncations = truncations | (infos["active"][slots] & ~done)
            self._pending = True
        if self.autoreset_mode == AutoresetMode.SAME_STEP:  # worlds that ended reset already
            self._acting = env.acting()[slots]
        else:
            self._acting = infos["active"][slots] & ~(terminations | truncations)
        out = self._out(observations, rewards, terminations, truncations, infos)
        out[4]["task_switch"] = switch
        if self.autoreset_mode == AutoresetMode.SAME_STEP and self._pending:
            return self._switch_now(out, switch)
        return out

    def _switch_now(self, out: tuple, switch: np.ndarray) -> tuple:
        """``SAME_STEP``: start the next task in this step; the slots that played keep
        their last observations and counters (with the task that ended) in the infos."""
        observations, rewards, terminations, truncations, infos = out
        finals = {}
        for k in np.flatnonzero(switch):
            if infos.get(f"_{FINAL_OBS}", np.zeros(self.num_slots, bool))[k]:
                last = infos[FINAL_OBS][k]  # its world had reset already in this step
                counted = {key: values[k] for key, values in infos[FINAL_INFO].items()}
            else:
                last = _one(observations, int(k))
                counted = {
                    key: values[k]
                    for key, values in infos.items()
                    if "final" not in key and key not in ("active", "task_switch")
                }
            finals[int(k)] = (last, {**counted, "task_switch": True})
        assert self._life is not None
        self._pending = False
        self.segment += 1
        seeds = [int(s) for s in self._life.integers(2**31, size=self.num_worlds)]
        fresh, started = self._start(seeds)
        counters = {key: values for key, values in started.items() if key != "active"}
        counters["task_switch"] = np.zeros(self.num_slots, bool)
        started.update(final_infos(finals, counters, self.num_slots))
        started["task_switch"] = switch
        return fresh, rewards, terminations, truncations, started

    def _check(self, env: BatchedParallelEnv, actions: np.ndarray, slots: np.ndarray) -> None:
        """The learner's actions, checked before the partners act: an error names the
        world, the learner's slot, the agent, the value and the space; nothing changes."""
        m = env.agents_per_world
        acting = env.acting()
        for k, slot in enumerate(slots):
            w, j = divmod(int(slot), m)
            world = env.worlds[w]
            if not acting[slot]:
                continue  # its action is not used
            try:
                world.check_action(world.possible_agents[j], actions[k])
            except ValueError as err:
                raise ValueError(f"world {w}, slot {k}: {err}") from None

    def _full(self, env: BatchedParallelEnv, actions: np.ndarray, slots: np.ndarray):
        """Every inner slot's action: the learner's at its slots, the background's elsewhere
        (None where the inner env does not use it)."""
        if len(slots) == env.num_slots and not any(self._backgrounds):
            return actions
        full = np.empty(env.num_slots, object)
        for k, slot in enumerate(slots):
            full[slot] = actions[k]
        m = env.agents_per_world
        observations = self._observations
        for w, policies in enumerate(self._backgrounds):
            for agent, policy in policies.items():
                slot = w * m + env.possible_agents.index(agent)
                if not env.active[slot]:
                    continue
                full[slot] = policy.act(slot_observation(observations, slot))
        return full

    def _out(
        self, observations, rewards, terminations, truncations, infos
    ) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        slots = self._slots()
        if isinstance(observations, dict):
            observations = {key: value[slots] for key, value in observations.items()}
        else:
            observations = observations[slots]
        if self.stream.spec.announce:
            one_hot = np.zeros((self.num_slots, self.tasks), np.float32)
            one_hot[:, self.task] = 1.0
            if not isinstance(observations, dict):
                observations = {"observation": observations}
            observations = {**observations, TASK: one_hot}
        out_infos: dict[str, Any] = {
            key: np.asarray(value)[slots] for key, value in infos.items() if key != FINAL_INFO
        }
        out_infos[TASK] = np.full(self.num_slots, self.task, np.int64)
        if FINAL_INFO in infos:  # SAME_STEP: the worlds that reset within the task
            final = {key: np.asarray(value)[slots] for key, value in infos[FINAL_INFO].items()}
            final[TASK] = out_infos[TASK].copy()
            out_infos[FINAL_INFO] = final
            if self.stream.spec.announce:
                last = out_infos[FINAL_OBS]
                for k in np.flatnonzero(out_infos[f"_{FINAL_OBS}"]):
                    last[k] = announce(last[k], self.task, self.tasks)
        return observations, rewards, terminations, truncations, out_infos

    def state(self) -> np.ndarray:
        """Each world's global state in the task on, one row per world, padded with zeros
        to ``single_state_space``."""
        with self._guard:
            return padded_state(self.env.state(), self.single_state_space.shape[0])

    def render(self) -> tuple | None:
        """With ``render_mode="rgb_array"``: every world's frame in the task on."""
        return self.env.render()

    def close(self) -> None:
        for env in self._envs.values():
            env.close()


def _one(observations, k: int):
    """A copy of focal slot ``k``'s observation."""
    if isinstance(observations, dict):
        return {key: np.array(values[k]) for key, values in observations.items()}
    return np.array(observations[k])
