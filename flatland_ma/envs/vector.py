"""Many worlds of one scenario in one process, stepped together.

``BatchedParallelEnv`` presents every agent of every world as one slot, for learners that
share one policy's parameters among agents: world ``w``'s agent ``j`` is slot
``w * agents_per_world + j``. Observations come stacked along a leading slot axis (a
``Dict`` observation as a dict of stacked arrays), and rewards, terminations and
truncations as arrays of one entry per slot.

Worlds reset in Gymnasium's ``NEXT_STEP`` mode: the step after the one in which a
world's last agent finished resets that world (its actions are not used) and returns the
first observation of its new episode, with reward 0 and neither termination nor
truncation. A world reset this way continues its own generator, so world ``w`` of a
batch reset with seed ``s`` plays exactly the episodes of a ``FlatlandParallelEnv`` reset
with seed ``s + w`` and then reset without a seed each time its episode ends.

Agents that finish while their world plays on leave it (as in the parallel env): from the
next step their slot is inert, ``infos["active"]`` is False for it, its observation is
zeros, its reward 0, and its action is not used; a learner drops those entries.

Its size is held to the work budget before anything is allocated
(``flatland_ma.scenario.budget.check_batch``: ``num_worlds`` times what a world of the
scenario takes, sensors included), and one thread at a time may call it (a second thread
calling in meanwhile gets a ``RuntimeError``; ``flatland_ma.envs.guards``).

The arrays returned are copies, unless ``copy=False``: then they are the env's own buffers,
overwritten by the next ``step`` or ``reset``.

A step acts and simulates world by world, then casts the rays of every world in one call
of the compiled kernel, spread over numba's threads (``parallel=False``: on one).
"""

from __future__ import annotations

from typing import Any, TypeGuard

import gymnasium
import numpy as np
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from flatland_ma.envs.guards import OneCaller, check_batch_of_actions
from flatland_ma.envs.padding import Padding
from flatland_ma.envs.parallel import FlatlandParallelEnv
from flatland_ma.scenario.budget import check_batch
from flatland_ma.sensors.suite import WorldsKernel

AUTORESET_MODE = AutoresetMode.NEXT_STEP


def _buffer(space: gymnasium.Space, n: int):
    """Zeros for ``n`` stacked values of ``space`` (a dict of them for a ``Dict``)."""
    if isinstance(space, gymnasium.spaces.Dict):
        return {key: _buffer(sub, n) for key, sub in space.spaces.items()}
    assert space.shape is not None, f"{space} has no shape to stack"
    return np.zeros((n, *space.shape), space.dtype)


def _put(buffer, slot: int, value) -> None:
    if isinstance(buffer, dict):
        for key, sub in buffer.items():
            sub[slot] = value[key]
    else:
        buffer[slot] = value


def _clear(buffer, slot: int) -> None:
    if isinstance(buffer, dict):
        for sub in buffer.values():
            sub[slot] = 0
    else:
        buffer[slot] = 0


def _copied(buffer):
    if isinstance(buffer, dict):
        return {key: sub.copy() for key, sub in buffer.items()}
    return buffer.copy()


class BatchedParallelEnv:
    """``num_worlds`` worlds of ``scenario`` (with ``overrides`` and ``max_cycles`` as
    for ``FlatlandParallelEnv``), every agent of every world one slot (see the module's
    docstring). Every agent must have the same spaces (one shared policy), unless ``pad``:
    then agents that observe differently (but act alike) are given one padded observation
    space with their role in it (``flatland_ma.envs.padding``); ``padding`` is None when
    nothing needed padding. ``num_worlds`` worlds must fit the work budget
    (``flatland_ma.scenario.budget.check_batch``); ``_counted_as`` is the name the refusal
    gives them (``num_envs`` for ``gymnasium.make_vec``)."""

    metadata = {"autoreset_mode": AUTORESET_MODE}

    def __init__(
        self,
        scenario: Any = "fruits_poisons",
        num_worlds: int = 1,
        max_cycles: int | None = None,
        copy: bool = True,
        parallel: bool = True,
        pad: bool = False,
        *,
        _counted_as: str = "num_worlds",
        **overrides,
    ):
        if isinstance(num_worlds, bool) or not isinstance(num_worlds, int) or num_worlds < 1:
            raise ValueError(f"{_counted_as} must be a positive integer, not {num_worlds!r}")
        first = FlatlandParallelEnv(scenario, max_cycles=max_cycles, **overrides)
        check_batch(first.spec, num_worlds, _counted_as)  # before the other worlds are built
        self._guard = OneCaller("this batched env")
        self.worlds = [first] + [_same(first) for _ in range(num_worlds - 1)]
        self.spec = first.spec
        self.num_worlds = num_worlds
        self.possible_agents = list(first.possible_agents)
        """The agents of each world, in slot order."""
        self.agents_per_world = len(first.possible_agents)
        self.num_slots = num_worlds * self.agents_per_world
        self.copy = copy
        agents = first.possible_agents
        self.padding = Padding.of(first) if pad else None
        """How observations are padded to one space, or None (see ``pad``)."""
        self.single_observation_space = (
            first.observation_space(agents[0]) if self.padding is None else self.padding.space
        )
        self.single_action_space = first.action_space(agents[0])
        for agent in agents[1:]:
            observes = str(first.observation_space(agent)) == str(
                first.observation_space(agents[0])
            )
            if (
                not (observes or self.padding)
                or first.action_space(agent) != self.single_action_space
            ):
                raise ValueError(
                    f"{agent} observes {first.observation_space(agent)} and acts in "
                    f"{first.action_space(agent)}, {agents[0]} observes "
                    f"{first.observation_space(agents[0])} and acts in "
                    f"{self.single_action_space}: a batch's slots share one space (one "
                    "policy); pad=True pads observations that differ (actions must agree), "
                    "SuperSuit pads both (docs/integrations.md)"
                )
        self.single_state_space = first.state_space
        """One world's global state space (``FlatlandParallelEnv.state``)."""
        self.state_space = batch_space(first.state_space, num_worlds)
        self.observation_space = batch_space(self.single_observation_space, self.num_slots)
        self.action_space = batch_space(self.single_action_space, self.num_slots)
        self._observations = _buffer(self.single_observation_space, self.num_slots)
        self._rewards = np.zeros(self.num_slots, np.float64)
        self._terminations = np.zeros(self.num_slots, bool)
        self._truncations = np.zeros(self.num_slots, bool)
        self._active = np.zeros(self.num_slots, bool)
        self._counters: dict[str, np.ndarray] = {}
        self._ended = [False] * num_worlds
        """Worlds whose episode ended on the last step: the next step resets them."""
        self._rays = WorldsKernel(num_worlds, parallel)
        """Every world's ray kernel arguments: one call casts the rays of all, over every
        core numba may use unless ``parallel`` is False."""

    # -- the loop -----------------------------------------------------------------------

    def reset(self, seed: int | list[int | None] | None = None, options: dict | None = None):
        """Reset every world: world ``w`` with ``seed + w`` (or ``seed[w]``; None: from
        fresh entropy)."""
        with self._guard:
            return self._reset(seed)

    def _reset(self, seed):
        seeds = _seeds(seed, self.num_worlds)
        self._rewards[:] = 0.0
        self._terminations[:] = False
        self._truncations[:] = False
        for w, env in enumerate(self.worlds):
            self._restart(w, env, seeds[w])
        return self._out(self._observations), self._infos()

    def step(self, actions):
        """One step of every world; ``actions[slot]`` for each slot (those of inert slots
        and of worlds being reset are not used). Every action is checked before anything
        moves: a bad one raises an error naming its world, agent, value and space (and
        anything but one action per slot a ``TypeError`` or ``ValueError`` saying what a batch
        takes)."""
        with self._guard:
            return self._step(actions)

    def _step(self, actions):
        checked = self._check(actions)
        m = self.agents_per_world
        self._rewards[:] = 0.0
        self._terminations[:] = False
        self._truncations[:] = False
        advanced, entered = [], []
        try:
            # Act and simulate world by world; cast every advanced world's rays in one call.
            for w, env in enumerate(self.worlds):
                if self._ended[w]:
                    self._restart(w, env, None)
                    continue
                base = w * m
                for j in range(m):  # agents gone before this step are inert from now
                    if self._active[base + j] and j not in env._live:
                        self._active[base + j] = False
                        _clear(self._observations, base + j)
                env.enter()
                entered.append(env)
                advanced.append((w, env, *env._advance(checked[w], observe=False)))
            if advanced:
                self._rays.observe(np.array([a[0] for a in advanced], np.int64))
            for w, env, live, rewards, terminated, truncated in advanced:
                sensors, task = env.running.sensors, env.running.task
                base = w * m
                for i in live:
                    slot = base + i
                    self._put(slot, i, sensors.observation(i))
                    self._rewards[slot] = rewards[i]
                    self._terminations[slot] = terminated[i]
                    self._truncations[slot] = truncated
                    self._count(slot, task.info(i))
                self._ended[w] = not env.agents
        finally:
            for env in entered:
                env.leave()
        observations = self._out(self._observations)
        return (
            observations,
            self._out(self._rewards),
            self._out(self._terminations),
            self._out(self._truncations),
            self._infos(),
        )

    def state(self) -> np.ndarray:
        """Every world's global state (``FlatlandParallelEnv.state``), one row per world,
        for centralised critics: slot ``s`` plays in world ``s // agents_per_world``. A
        world whose episode ended on the last step shows its final state until the next
        step resets it."""
        with self._guard:
            if any(env.episode is None for env in self.worlds):
                raise RuntimeError("call reset() before state()")
            return np.stack([env.state() for env in self.worlds])

    def close(self) -> None:
        for env in self.worlds:
            env.close()

    @property
    def layout(self) -> str:
        """Which slot is which, in words."""
        return f"{self.num_worlds} worlds x {self.agents_per_world} agents"

    # -- inside -------------------------------------------------------------------------

    def _restart(self, w: int, env: FlatlandParallelEnv, seed: int | None) -> None:
        observations, infos = env.reset(seed=seed)
        self._rays.set(w, env.running.sensors)
        base = w * self.agents_per_world
        for j, agent in enumerate(env.possible_agents):
            if self.padding is not None:  # inert slots were zeroed: name the role again
                self.padding.mark(self._observations, j, base + j)
            self._put(base + j, j, observations[agent])
            self._active[base + j] = True
            self._count(base + j, infos[agent])
        self._ended[w] = False

    def _put(self, slot: int, agent: int, observation) -> None:
        if self.padding is None:
            _put(self._observations, slot, observation)
        else:
            self.padding.put(self._observations, agent, observation, slot)

    def _check(self, actions) -> list[list]:
        """Each live agent's action, checked, world by world; nothing is changed."""
        if any(env.episode is None for env in self.worlds):
            raise RuntimeError("call reset() first")
        check_batch_of_actions(actions, self.num_slots, self.single_action_space, self.layout)
        m = self.agents_per_world
        checked: list[list] = []
        for w, env in enumerate(self.worlds):
            own = []
            if not self._ended[w]:
                for i in env._live:
                    agent = env.possible_agents[i]
                    try:
                        own.append(env.check_action(agent, actions[w * m + i]))
                    except ValueError as err:
                        raise ValueError(f"world {w}, slot {w * m + i}: {err}") from None
            checked.append(own)
        return checked

    def _count(self, slot: int, info: dict) -> None:
        for key, value in info.items():
            if key not in self._counters:
                self._counters[key] = _counter_array(value, self.num_slots)
            self._counters[key][slot] = value

    def _infos(self) -> dict:
        infos = {key: self._out(values) for key, values in self._counters.items()}
        infos["active"] = self._out(self._active)
        return infos

    def _out(self, buffer):
        return _copied(buffer) if self.copy else buffer


def _counter_array(value, n: int) -> np.ndarray:
    """Room for one info entry per slot: integers, other numbers, or anything else (such
    as the tuple of keys held) as objects."""
    if isinstance(value, bool | np.bool_):
        return np.zeros(n, bool)
    if isinstance(value, int | np.integer):
        return np.zeros(n, np.int64)
    if isinstance(value, float | np.floating):
        return np.zeros(n, np.float64)
    return np.empty(n, object)


def _same(first: FlatlandParallelEnv) -> FlatlandParallelEnv:
    """Another env of ``first``'s checked spec, without loading and checking it again."""
    env = FlatlandParallelEnv.__new__(FlatlandParallelEnv)
    env._setup(first.spec, first.render_mode)
    env.step_limit = first.step_limit
    return env


def _seeds(seed: int | list[int | None] | None, n: int) -> list[int | None]:
    """Each world's seed, all checked before any world resets."""
    if seed is None:
        return [None] * n
    if _whole(seed):
        seeds: list = [int(seed) + w for w in range(n)]
    elif isinstance(seed, list | tuple):
        seeds = list(seed)
        if len(seeds) != n:
            raise ValueError(f"expected {n} seeds, one per world, got {len(seeds)}")
    else:
        raise TypeError(f"seed must be an integer or a list of one per world, not {seed!r}")
    for w, value in enumerate(seeds):
        if value is not None and not (_whole(value) and value >= 0):
            raise ValueError(
                f"world {w}'s seed must be a non-negative integer or None, not {value!r}"
            )
    return [None if value is None else int(value) for value in seeds]


def _whole(value) -> TypeGuard[int | np.integer]:
    return isinstance(value, int | np.integer) and not isinstance(value, bool | np.bool_)
