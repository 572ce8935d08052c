"""The PettingZoo parallel environment: the one step loop every interface runs on.

Agents are ``agent_0 ... agent_{n-1}``; in a scenario with teams they are named by team,
numbered within it (``scout_0``, ``runner_0``: ``spec.agent_names``), since clients group
agents by the name's prefix. Each observes its own first-person camera: a
float32 array of shape ``(rays, 4)`` (RGB times intensity, and depth), and acts through
``Discrete(3)`` (forward, rotate left, rotate right) or ``Box(-1, 1, (3,))`` (longitudinal,
lateral, angular), as the scenario says; a head and arms add their own actions
(``action_names`` lists them). Rewards come from the scenario's task; reaching
``episode.max_steps`` (``max_cycles=N`` sets it, as in PettingZoo's own environments)
truncates every agent. ``infos[agent]`` holds the agent's episode counters: ``score`` and
one count per item group (e.g. ``fruits``, ``poisons``). Keyword overrides are merged into
the scenario file; one that is no top-level key of a scenario raises ``TypeError``.

``flatten=True`` gives every agent one float32 vector in a ``Box`` instead of its sensors'
``Dict`` or 2-D ``Box`` (``flatland_ma.envs.flatten`` documents the layout;
``flat_layout(agent)`` lists the parts, ``unflatten(agent, vector)`` gives them back).

Each step takes one action per live agent. An action for an agent that has finished
(terminated or truncated, and so no longer in ``agents``) is ignored, as PettingZoo's
conversions do, so clients that send an action for every possible agent need no filter;
a name that is no agent of the env raises ``ValueError``, as does a missing or bad action.

Pickling keeps the scenario, the generator state at the last reset and the actions taken
since; unpickling rebuilds the episode and replays them, so a copy continues exactly as
the original would (pymunk's own pickles lose cached contact impulses and drift).
"""

from __future__ import annotations

import threading
from collections.abc import Mapping
from pathlib import Path

import gymnasium
import numpy as np
from gymnasium.utils import seeding
from pettingzoo import ParallelEnv

from flatland_ma.agents.actuators import Actuator
from flatland_ma.build.bodies import make_parts, make_sensors
from flatland_ma.build.builder import Episode, build
from flatland_ma.build.census import state_entities, world_state
from flatland_ma.build.feasibility import check_scenario
from flatland_ma.envs.flatten import FlatLayout, FlatPart
from flatland_ma.envs.render_modes import KNOWN_RENDER_MODES, RENDER_MODES
from flatland_ma.render.display import missing_display, no_window
from flatland_ma.scenario.loader import load_scenario
from flatland_ma.scenario.schema import ScenarioSpec
from flatland_ma.sensors.sensor_suite import observation_space


class FlatlandParallelEnv(ParallelEnv):
    """A scenario as a PettingZoo parallel environment (see the module's docstring).

    ``scenario``: a shipped scenario's name (``flatland_ma.list_scenarios()``), the path
    of a scenario file, or a ``ScenarioSpec`` already loaded. ``render_mode``: None,
    ``"rgb_array"`` (``render()`` returns the map and every agent's senses as one uint8
    image) or ``"human"`` (a window; needs pygame and a display). ``max_cycles``: the
    episode's length in steps (the scenario's ``episode.max_steps`` by default).
    ``flatten``: one float32 vector per agent. Other keywords override the scenario's
    top-level keys (``n_agents=4``, ``agent={"sensors": [...]}``), validated as the file
    is; an unknown one raises ``TypeError``. The scenario is checked (it must build at
    several seeds) before the env exists.

    After ``reset(seed=...)``: ``agents`` (the live ones), ``observation_space(agent)``
    and ``action_space(agent)`` (the same object each call), ``action_names(agent)``,
    ``state()`` and ``state_space`` for centralised critics, ``spec`` (the scenario),
    ``episode`` (the world, bodies and sensors, for scripted policies and tests).
    """

    metadata = {
        "name": "flatland_ma_v1",
        "render_modes": RENDER_MODES,
        "render_fps": 30,
        "is_parallelizable": True,
    }

    def __init__(
        self,
        scenario: str | Path | ScenarioSpec = "fruits_poisons",
        render_mode: str | None = None,
        max_cycles: int | None = None,
        flatten: bool = False,
        **overrides,
    ):
        if render_mode == "human":
            no_window(missing_display())
        if max_cycles is not None:
            overrides = with_episode_length(overrides, max_cycles)
        if isinstance(scenario, ScenarioSpec):
            if overrides:
                raise TypeError("overrides apply to scenario names or files, not to a spec")
            spec = scenario
        else:
            spec = load_scenario(scenario, **overrides)
        check_scenario(spec)
        self._setup(spec, render_mode, flatten)

    def _setup(self, spec: ScenarioSpec, render_mode: str | None, flatten: bool = False) -> None:
        """Everything but the checks of the scenario (a copy being unpickled skips them)."""
        if render_mode is not None and render_mode not in KNOWN_RENDER_MODES:
            raise ValueError(f"render_mode {render_mode!r} is not one of {RENDER_MODES}")
        if not isinstance(flatten, bool):
            raise TypeError(f"flatten must be True or False, not {flatten!r}")
        self.spec = spec
        self.render_mode = render_mode
        self.flatten = flatten
        """Whether observations are flat float32 vectors (see the module's docstring)."""
        self.possible_agents = list(spec.agent_names)
        self.agents: list[str] = []
        self._index = {name: i for i, name in enumerate(self.possible_agents)}
        words, vocabulary = (
            (spec.channel.tokens, spec.channel.vocabulary) if spec.channel else (0, 2)
        )
        self._actuators = [
            Actuator(agent.actions, make_parts(agent), words, vocabulary)
            for agent in spec.agent_specs
        ]
        self._sensors = [
            make_sensors(agent, spec.channel, spec.n_agents) for agent in spec.agent_specs
        ]
        self.action_spaces = {a: act.space for a, act in zip(self.possible_agents, self._actuators)}
        self.observation_spaces = {
            a: observation_space(own) for a, own in zip(self.possible_agents, self._sensors)
        }
        self._layouts: list[FlatLayout] | None = None
        if flatten:
            self._layouts = [FlatLayout(self.observation_spaces[a]) for a in self.possible_agents]
            self.observation_spaces = {
                a: layout.space for a, layout in zip(self.possible_agents, self._layouts)
            }
        self._world_state = world_state(spec)
        self.state_space = self._world_state.space
        """The global state's space: see ``state()``."""
        self._state_parts: tuple = ()
        self.episode: Episode | None = None
        self.num_steps = 0
        # Steps after which every agent is truncated; None for no limit (the Gymnasium env
        # made by gymnasium.make, where the TimeLimit wrapper truncates).
        self.step_limit: int | None = spec.episode.max_steps
        self._live: list[int] = []
        self._np_random: np.random.Generator | None = None
        self._np_random_seed: int | None = None
        self._reset_state: Mapping | None = None
        self._log: list[list] = []
        self._renderer = None
        self._in_use = threading.Lock()

    # -- spaces -------------------------------------------------------------------------

    def observation_space(self, agent: str) -> gymnasium.Space:
        """The agent's observation space: its one sensor's, or a ``Dict`` by sensor name
        (a ``Box`` of one vector with ``flatten=True``); the same object every call."""
        return self.observation_spaces[agent]

    def action_space(self, agent: str) -> gymnasium.Space:
        """The agent's action space, ``Discrete`` or ``Box`` as its body acts
        (``action_names`` says what each action or entry means); the same object every
        call."""
        return self.action_spaces[agent]

    def action_names(self, agent: str | None = None) -> tuple[str, ...]:
        """What each discrete action or each continuous entry means, in order (of the
        first agent, unless ``agent`` says whose)."""
        return self._actuators[self._agent_index(agent)].names

    def action_index(self, name: str, agent: str | None = None) -> int:
        """The discrete action (or continuous entry) called ``name``, e.g. ``"grasp"`` (of
        the first agent, unless ``agent`` says whose)."""
        return self._actuators[self._agent_index(agent)].index(name)

    def flat_layout(self, agent: str) -> tuple[FlatPart, ...]:
        """With ``flatten=True``: where each entry of the agent's observation lies in its
        flat vector (name, start, stop, shape; ``flatland_ma.envs.flatten``)."""
        return self._layout(agent).parts

    def unflatten(self, agent: str, vector) -> np.ndarray | dict[str, np.ndarray]:
        """With ``flatten=True``: the agent's observation ``vector`` as the env gives it
        without flattening (a ``Dict``'s entries, or the 2-D ``Box``)."""
        return self._layout(agent).unflatten(vector)

    def _layout(self, agent: str) -> FlatLayout:
        if self._layouts is None:
            raise ValueError("observations are flat only with flatten=True")
        return self._layouts[self._agent_index(agent)]

    def _agent_index(self, agent: str | None) -> int:
        if agent is None:
            return 0
        if agent not in self._index:
            raise KeyError(f"no agent {agent!r}; agents: {self.possible_agents}")
        return self._index[agent]

    def _observe(self, i: int):
        """Agent ``i``'s (its index) current observation, flat with ``flatten=True``."""
        observation = self.running.sensors.observation(i)
        if self._layouts is None:
            return observation
        return self._layouts[i].flatten(observation)

    @property
    def running(self) -> Episode:
        """The current episode (there is one once ``reset`` has been called)."""
        if self.episode is None:
            raise RuntimeError("call reset() first")
        return self.episode

    @property
    def np_random(self) -> np.random.Generator:
        if self._np_random is None:
            self._np_random, self._np_random_seed = seeding.np_random()
        return self._np_random

    # -- the loop -----------------------------------------------------------------------

    def enter(self) -> None:
        """Claim the env for one call. pymunk spaces are not thread-safe: a second thread
        inside the env at once would corrupt it, so it gets a clear error instead (and the
        env is left as it was). ``leave`` releases it."""
        if not self._in_use.acquire(blocking=False):
            raise RuntimeError(
                "this env is in use by another thread at the same time; an env (its "
                "pymunk space) must be used from one thread at a time: make one env per thread"
            )

    def leave(self) -> None:
        self._in_use.release()

    def reset(self, seed: int | None = None, options: dict | None = None):
        """Start an episode: ``(observations, infos)``, one entry per agent. The same
        ``seed`` gives the same layout, spawns and draws; None draws a fresh seed."""
        self.enter()
        try:
            return self._reset(seed)
        finally:
            self.leave()

    def step(self, actions: Mapping):
        """Advance one step with one action per live agent: ``(observations, rewards,
        terminations, truncations, infos)``, each a dict by agent (the agents that were
        live). Actions for finished agents are ignored; a bad one raises ``ValueError``
        naming the agent and its space, and changes nothing."""
        self.enter()
        try:
            return self._step(actions)
        finally:
            self.leave()

    def _reset(self, seed: int | None):
        if seed is not None or self._np_random is None:
            self._np_random, self._np_random_seed = seeding.np_random(seed)
        self._reset_state = self.np_random.bit_generator.state
        self._start_episode()
        task = self.running.task
        observations = {a: self._observe(i) for i, a in enumerate(self.possible_agents)}
        infos = {a: task.info(i) for i, a in enumerate(self.possible_agents)}
        return observations, infos

    def _step(self, actions: Mapping):
        checked = self._check(actions)
        live, rewards, terminated, truncated = self._advance(checked)
        task, names = self.running.task, self.possible_agents
        observations = {names[i]: self._observe(i) for i in live}
        reward_d = {names[i]: rewards[i] for i in live}
        terminated_d = {names[i]: terminated[i] for i in live}
        truncated_d = {names[i]: truncated for i in live}
        infos = {names[i]: task.info(i) for i in live}
        return observations, reward_d, terminated_d, truncated_d, infos

    def _start_episode(self) -> None:
        site = None if self.episode is None else self.episode.site
        self.episode = episode = build(self.spec, self.np_random, self._sensors, site)
        self._state_parts = state_entities(episode)
        episode.sensors.observe()
        self.num_steps = 0
        self._live = list(range(len(self.possible_agents)))
        self.agents = list(self.possible_agents)
        self._log = []

    def _check(self, actions: Mapping) -> list:
        """Every live agent's action, validated, in agent order; nothing is changed.
        Actions for agents that have finished are ignored; other names raise."""
        if not self.agents:
            raise RuntimeError("no live agents: the episode is over, call reset()")
        if not isinstance(actions, Mapping):
            raise TypeError(f"actions must be a dict from agent name to action, not {actions!r}")
        for name in actions:
            if not isinstance(name, str) or name not in self._index:
                raise ValueError(
                    f"action {actions[name]!r} given for {name!r}, which is not a live agent "
                    f"(nor a finished one); "
                    f"expected one action for each live agent {self.agents}, "
                    f"in {self._spaces_text(self.agents)}"
                )
        checked = []
        for i in self._live:
            name = self.possible_agents[i]
            if name not in actions:
                raise ValueError(
                    f"no action given for live agent {name!r}; "
                    f"expected an element of {self.action_spaces[name]}"
                )
            checked.append(self._actuators[i].check(name, actions[name]))
        return checked

    def check_action(self, agent: str, action) -> object:
        """``action`` as the step loop will use it, if it belongs to the action space of
        ``agent`` (a live agent); otherwise an error naming the agent, the value and the
        space. Changes nothing."""
        if agent not in self._index or self._index[agent] not in self._live:
            raise ValueError(
                f"action {action!r} given for {agent!r}, which is not a live agent; "
                f"live agents: {self.agents}"
            )
        return self._actuators[self._index[agent]].check(agent, action)

    def _spaces_text(self, agents: list[str]) -> str:
        """The action space shared by ``agents``, or each one's if they differ."""
        spaces = {str(self.action_spaces[a]) for a in agents}
        if len(spaces) == 1:
            return spaces.pop()
        return ", ".join(f"{a}: {self.action_spaces[a]}" for a in agents)

    def _advance(
        self, checked: list, observe: bool = True, acted: bool = False, poses: bool = True
    ) -> tuple[list[int], list[float], list[bool], bool]:
        """Apply checked actions of the live agents (unless the caller ``acted``: drove
        the bodies itself, as the batched env does for every world at once), simulate one
        step, observe (unless the caller casts the rays itself: then the sensors are only
        prepared, and with ``poses=False`` the caller reads the moving bodies' poses).

        Returns the agents that were live for this step, everyone's rewards and
        terminations, and whether the step limit truncated the episode.
        """
        episode = self.running
        live = self._live
        bodies, actuators = episode.bodies, self._actuators
        channel = episode.world.channel
        if not acted or channel is not None:
            for i, action in zip(live, checked):
                if not acted:
                    actuators[i].apply(bodies[i], action)
                if channel is not None:
                    channel.say(i, actuators[i].said(action))
        self._log.append(checked)
        episode.world.step()
        episode.hands.update()
        rewards, terminated = episode.task.evaluate(self.np_random)
        if observe:
            episode.sensors.observe()
        else:
            episode.sensors.prepare(poses)
        self.num_steps += 1
        truncated = self.step_limit is not None and self.num_steps >= self.step_limit
        if truncated or (True in terminated and any(terminated[i] for i in live)):
            self._live = [i for i in live if not (truncated or terminated[i])]
            for i in live:
                if i not in self._live:
                    bodies[i].command(0.0, 0.0, 0.0)
                    if channel is not None:
                        channel.silence(i)
            self.agents = [self.possible_agents[i] for i in self._live]
        return live, rewards, terminated, truncated

    # -- global state -------------------------------------------------------------------

    def state(self) -> np.ndarray:
        """The whole world as one vector, for centralised critics: every agent's pose,
        velocity and whether it still acts, every item's place and presence, every movable
        object's pose and every door's state (``flatland_ma.sensors.world_state`` gives the
        layout; ``state_labels`` names each entry)."""
        if self.episode is None:
            raise RuntimeError("call reset() before state()")
        self.enter()
        try:
            channel = self.running.world.channel
            said = None if channel is None else channel.said
            return self._world_state.read(*self._state_parts, said=said)
        finally:
            self.leave()

    @property
    def state_labels(self) -> tuple[str, ...]:
        """The name of each entry of ``state()``, e.g. ``agent_0.x`` (``scout_0.x`` in a
        scenario with teams), ``fruits[2].present``."""
        return self._world_state.labels

    # -- rendering ----------------------------------------------------------------------

    def render(self):
        """With ``render_mode="rgb_array"``, the map with every sensor's field of view
        and each agent's senses beneath, as a uint8 ``H x W x 3`` array; with
        ``"human"``, the same in a window (None is returned). Rendering only reads."""
        if self.render_mode is None:
            gymnasium.logger.warn("render() called without a render_mode; nothing to draw")
            return None
        if self.episode is None:
            raise RuntimeError("call reset() before render()")
        from flatland_ma.render.renderer import Renderer

        if self._renderer is None:
            self._renderer = Renderer(self.spec, self._sensors)
        self.enter()
        try:
            frame = self._renderer.frame(self)
        finally:
            self.leave()
        if self.render_mode == "rgb_array":
            return frame
        self._renderer.show(frame, self.metadata["render_fps"])
        return None

    def close(self) -> None:
        """Close the window, if one is open; safe to call twice."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    # -- pickling -----------------------------------------------------------------------

    def __getstate__(self) -> dict:
        return {
            "spec": self.spec,
            "render_mode": self.render_mode,
            "flatten": self.flatten,
            "seed": self._np_random_seed,
            "reset_state": self._reset_state,
            "rng_state": None if self._np_random is None else self._np_random.bit_generator.state,
            "log": self._log,
            "step_limit": self.step_limit,
        }

    def __setstate__(self, state: dict) -> None:
        self._setup(state["spec"], state["render_mode"], state.get("flatten", False))
        self.step_limit = state["step_limit"]
        if state["rng_state"] is None:
            return
        self._np_random, _ = seeding.np_random(0)
        self._np_random_seed = state["seed"]
        if state["reset_state"] is None:
            self._np_random.bit_generator.state = state["rng_state"]
            return
        self._np_random.bit_generator.state = state["reset_state"]
        self._reset_state = state["reset_state"]
        self._start_episode()
        # Read the observations the original handed out, in its order: sensor noise draws
        # from the generator, so respawns after it draw the same numbers as they did.
        sensors = self.running.sensors
        for i in range(len(self.possible_agents)):
            sensors.observation(i)
        for checked in state["log"]:
            for i in self._advance(checked)[0]:
                sensors.observation(i)


def with_episode_length(overrides: dict, max_cycles: int) -> dict:
    """``overrides`` with ``episode.max_steps`` set to ``max_cycles`` (PettingZoo's name)."""
    episode = overrides.get("episode", {})
    if not isinstance(episode, Mapping):
        return overrides  # validation reports the bad ``episode``
    if "max_steps" in episode:
        raise TypeError("max_cycles and episode.max_steps both set the episode length; give one")
    return {**overrides, "episode": {**episode, "max_steps": max_cycles}}
