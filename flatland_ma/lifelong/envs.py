"""One life through a stream's tasks: the PettingZoo parallel and AEC envs and the
Gymnasium env.

The stream's clock counts the learner's agent-steps: each step adds the number of focal
agents that acted in it. A task lasts its ``steps`` (see ``Stream.segments``). On the
step at which the clock reaches the end of the task's segment, every focal agent still
playing is truncated (its ``infos`` say ``task_switch``), and the next ``reset()`` starts
the next task's world. The last segment ends the same way; after it the last task goes on.
Every step's and reset's ``infos`` carry the index of the task on (``"task"``) for
analysis; the learner's observation says it only if the stream ``announce``s it (a
``Dict`` observation with a one-hot ``task`` entry beside the scenario's: its own entries,
or its Box under ``observation``).

``reset(seed=s)`` starts a life: the clock at 0, the first task's world reset with ``s``,
each later task's with a seed drawn from a generator seeded with ``s``, so the same seed
and actions give the same life. ``reset()`` without a seed goes on with the life.

In a multi-agent task with ``focal`` and ``background``, only the focal agents are the
env's agents; the background policy drives the others (built anew for each world, with
seeds drawn from the life's generator).

In the never-ending mode the only world never truncates and drifts after every step
(``flatland_ma.lifelong.drift``).

``state()`` is the world's global state (``FlatlandParallelEnv.state``: every agent's,
background ones too), for centralised critics; its space is the longest of the tasks'
state spaces, and a shorter task's state is padded with zeros (``state_labels`` names the
entries of the task on, ``""`` for padding).
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv
from pettingzoo.utils.conversions import parallel_to_aec

from flatland_ma.build.census import world_state
from flatland_ma.envs.parallel import FlatlandParallelEnv
from flatland_ma.envs.render_modes import RENDER_MODES
from flatland_ma.lifelong.drift import Drift
from flatland_ma.lifelong.streams import Stream, load_stream

TASK = "task"
"""The observation entry (when announced) and the info key of the task's index."""


def announced(space: gymnasium.Space, tasks: int) -> spaces.Dict:
    """The observation space with the task's one-hot ``task`` entry."""
    entries = dict(space.spaces) if isinstance(space, spaces.Dict) else {"observation": space}
    return spaces.Dict({**entries, TASK: spaces.Box(0.0, 1.0, (tasks,), np.float32)})


def announce(observation, task: int, tasks: int) -> dict:
    one_hot = np.zeros(tasks, np.float32)
    one_hot[task] = 1.0
    entries = dict(observation) if isinstance(observation, dict) else {"observation": observation}
    return {**entries, TASK: one_hot}


def background_policies(stream: Stream, task: int, env, rng: np.random.Generator) -> dict:
    """The background policy of each agent of ``env`` the learner does not drive."""
    if stream.never_ending or stream.task(task).background is None:
        return {}
    name = stream.task(task).background
    assert name is not None
    return policies_beside(name, env, stream.focal(task), rng)


def policies_beside(name: str, env, focal, rng: np.random.Generator) -> dict:
    """The shipped policy ``name`` for each agent of ``env`` whose index is not in
    ``focal``, by agent, each seeded from ``rng`` in the agents' order."""
    from flatland_ma.policies.named import make_policy

    return {
        agent: make_policy(name, env, agent, seed=int(rng.integers(2**31)))
        for i, agent in enumerate(env.possible_agents)
        if i not in focal
    }


def state_space(stream: Stream) -> spaces.Box:
    """The longest of the tasks' global state spaces, padded entries bounded to 0."""
    boxes = [world_state(spec).space for spec in stream.scenarios]
    n = max(box.shape[0] for box in boxes)
    low, high = np.zeros(n, np.float32), np.zeros(n, np.float32)
    for box in boxes:
        k = box.shape[0]
        low[:k] = np.minimum(low[:k], box.low)
        high[:k] = np.maximum(high[:k], box.high)
    return spaces.Box(low, high, dtype=np.float32)


def padded_state(own: np.ndarray, size: int) -> np.ndarray:
    """A task's global state (one row, or one row per world) padded with zeros to
    ``size`` entries."""
    padded = np.zeros((*own.shape[:-1], size), np.float32)
    padded[..., : own.shape[-1]] = own
    return padded


def task_env(stream: Stream, task: int, render_mode: str | None = None) -> FlatlandParallelEnv:
    """A world of the stream's task ``task`` (all its agents; no switching)."""
    env = FlatlandParallelEnv(stream.scenarios[task], render_mode=render_mode)
    if stream.never_ending:
        env.step_limit = None
    return env


class StreamParallelEnv(ParallelEnv):
    """A life through ``stream`` (a shipped stream's name, a file, or a loaded
    ``Stream``), for the focal agents; see the module's docstring."""

    metadata = {
        "render_modes": RENDER_MODES,
        "name": "flatland_ma_stream",
        "is_parallelizable": True,
    }

    def __init__(self, stream: Any, render_mode: str | None = None):
        self.stream = load_stream(stream)
        self.render_mode = render_mode
        self.segments = self.stream.segments()
        self.tasks = len(self.stream.scenarios)
        self._envs: dict[int, FlatlandParallelEnv] = {}
        first = self._env(0)
        self.possible_agents = [first.possible_agents[i] for i in self.stream.focal(0)]
        self.agents: list[str] = []
        self.observation_spaces = {}
        for agent in self.possible_agents:
            space = first.observation_space(agent)
            self.observation_spaces[agent] = (
                announced(space, self.tasks) if self.stream.spec.announce else space
            )
        self.action_spaces = {a: first.action_space(a) for a in self.possible_agents}
        self.state_space = state_space(self.stream)
        """Room for every task's global state: see ``state()``."""
        ne = self.stream.spec.never_ending
        self._drift = Drift(ne.drift) if ne is not None else None
        self.clock = 0
        """The learner's agent-steps in this life."""
        self.segment = 0
        """The segment of the life being played (``len(segments)``: the life is over)."""
        self._life: np.random.Generator | None = None
        self._pending = False
        self._backgrounds: dict = {}
        self._observations: dict = {}

    # -- spaces and facts ---------------------------------------------------------------

    def observation_space(self, agent: str) -> gymnasium.Space:
        return self.observation_spaces[agent]

    def action_space(self, agent: str) -> gymnasium.Space:
        return self.action_spaces[agent]

    @property
    def task(self) -> int:
        """The index of the task on."""
        if not self.segments:
            return 0
        return self.segments[min(self.segment, len(self.segments) - 1)][0]

    @property
    def env(self) -> FlatlandParallelEnv:
        """The world of the task on."""
        return self._env(self.task)

    def _env(self, task: int) -> FlatlandParallelEnv:
        if task not in self._envs:
            self._envs[task] = task_env(self.stream, task, self.render_mode)
        return self._envs[task]

    # -- the loop -----------------------------------------------------------------------

    def reset(self, seed: int | None = None, options: dict | None = None):
        if seed is not None or self._life is None:
            self._life = np.random.default_rng(seed)
            self.clock, self.segment, self._pending = 0, 0, False
            world_seed = seed
            self._backgrounds = background_policies(self.stream, self.task, self.env, self._life)
        elif self._pending:
            self._pending = False
            self.segment += 1
            world_seed = int(self._life.integers(2**31))
            self._backgrounds = background_policies(self.stream, self.task, self.env, self._life)
        else:
            world_seed = None
        env = self.env
        observations, infos = env.reset(seed=world_seed, options=options)
        for policy in self._backgrounds.values():
            if hasattr(policy, "reset"):
                policy.reset()
        self._observations = observations
        self.agents = list(self.possible_agents)
        return (
            {a: self._seen(observations[a]) for a in self.agents},
            {a: {**infos[a], TASK: self.task} for a in self.agents},
        )

    def step(self, actions: dict):
        if not self.agents:
            raise RuntimeError("no live agents: the episode is over, call reset()")
        env = self.env
        acting = self.agents
        if self._backgrounds:  # the learner's actions are checked before the partners act
            full = self._with_partners(env, actions)
        else:  # the learner drives every agent: the world checks them before anything moves
            full = actions
        observations, rewards, terminations, truncations, infos = env.step(full)
        if self._drift is not None:
            self._drift.apply(env)
        self._observations = observations
        self.clock += len(acting)
        task = self.task
        obs = {a: self._seen(observations[a]) for a in acting}
        rew, term, trunc = rewards, terminations, truncations  # the learner's alone, unless
        if self._backgrounds:  # partners play too
            rew = {a: rewards[a] for a in acting}
            term = {a: terminations[a] for a in acting}
            trunc = {a: truncations[a] for a in acting}
        info = {a: {**infos[a], TASK: task} for a in acting}
        if (
            self.segments
            and self.segment < len(self.segments)
            and self.clock >= self.segments[self.segment][2]
        ):
            for agent in acting:
                if not (term[agent] or trunc[agent]):
                    trunc[agent] = True
                info[agent]["task_switch"] = True
            self._pending = True
            self.agents = []
        else:
            self.agents = [a for a in acting if not (term[a] or trunc[a])]
        return obs, rew, term, trunc, info

    def _with_partners(self, env: FlatlandParallelEnv, actions: dict) -> dict:
        """The learner's actions, checked, with the background partners' beside them."""
        for agent in actions:
            if agent not in self.agents:
                raise ValueError(
                    f"action {actions[agent]!r} given for {agent!r}, which is not a live "
                    f"agent; live agents: {self.agents}"
                )
        for agent in self.agents:
            if agent not in actions:
                raise ValueError(
                    f"no action given for live agent {agent!r}; expected an element of "
                    f"{self.action_spaces[agent]}"
                )
            env.check_action(agent, actions[agent])
        full = dict(actions)
        for agent, policy in self._backgrounds.items():
            if agent in env.agents:
                full[agent] = policy.act(self._observations[agent])
        return full

    def _seen(self, observation):
        if self.stream.spec.announce:
            return announce(observation, self.task, self.tasks)
        return observation

    def state(self) -> np.ndarray:
        """The global state of the task's world, padded with zeros to ``state_space``."""
        return padded_state(self.env.state(), self.state_space.shape[0])

    @property
    def state_labels(self) -> tuple[str, ...]:
        """The name of each entry of ``state()`` in the task on (``""``: padding)."""
        own = self.env.state_labels
        return own + ("",) * (self.state_space.shape[0] - len(own))

    def render(self):
        return self.env.render()

    def close(self) -> None:
        for env in self._envs.values():
            env.close()


def stream_aec_env(stream: Any, render_mode: str | None = None):
    """The AEC env of a life through ``stream`` (PettingZoo's conversion of the parallel)."""
    return parallel_to_aec(StreamParallelEnv(stream, render_mode=render_mode))


class StreamGymEnv(gymnasium.Env):
    """A life through a stream whose learner drives one agent, as a Gymnasium env."""

    metadata = {"render_modes": RENDER_MODES, "render_fps": 30}

    def __init__(self, stream: Any = "cross_objective", render_mode: str | None = None):
        self.parallel_env = StreamParallelEnv(stream, render_mode=render_mode)
        if len(self.parallel_env.possible_agents) != 1:
            raise ValueError(
                f"the stream's learner drives {len(self.parallel_env.possible_agents)} agents; "
                "use StreamParallelEnv for several"
            )
        self.agent = self.parallel_env.possible_agents[0]
        self.observation_space = self.parallel_env.observation_space(self.agent)
        self.action_space = self.parallel_env.action_space(self.agent)
        self.render_mode = render_mode

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        observations, infos = self.parallel_env.reset(seed=seed, options=options)
        return observations[self.agent], infos[self.agent]

    def step(self, action):
        obs, rew, term, trunc, info = self.parallel_env.step({self.agent: action})
        a = self.agent
        return obs[a], rew[a], term[a], trunc[a], info[a]

    def render(self):
        return self.parallel_env.render()

    def close(self):
        self.parallel_env.close()
        super().close()
