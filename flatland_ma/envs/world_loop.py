"""One world of a scenario and its episode loop: the step every env runs, world by world.

``WorldLoop`` holds what a world of a scenario is (its agents, actuators, sensors and
spaces) and what its episode is now (the built world, the live agents, the step count,
the generator), and steps it in public stages, in this order:

1. ``act(checked)``: every live agent's body and parts are commanded with its checked
   action (plain bodies through ``agents.motors``, in one compiled call, where the physics
   bridge's tier allows) and its words said on the channel; ``drove(checked)`` only says
   the words, for a caller that drove the bodies itself (``Worlds`` drives every plain body
   of every world in one such call);
2. ``simulate()``: the physics, then the task's rules (everyone's rewards and
   terminations);
3. the senses: ``running.sensors.observe()``, or ``running.sensors.prepare(...)`` when the
   caller casts the rays of many worlds in one kernel call;
4. ``conclude(rewards, terminated)``: the step is counted, the step limit truncates, and
   the agents that finished leave (their bodies stop, their words fall silent).

``advance()`` runs 2-4, observing, as the single env does. ``FlatlandParallelEnv`` is a
world loop with PettingZoo's dicts around it; ``Worlds`` (``flatland_ma.envs.worlds``) steps
many world loops together.

Pickling keeps the scenario, the generator state at the last reset and the actions taken
since; unpickling rebuilds the episode and replays them, so a copy continues exactly as
the original would (pymunk's own pickles lose cached contact impulses and drift).
"""

from __future__ import annotations

import threading
from collections.abc import Mapping

import gymnasium
import numpy as np
from gymnasium.utils import seeding

from flatland_ma.agents.actuators import Actuator
from flatland_ma.agents.motors import Motors, motors_of
from flatland_ma.build.bodies import make_parts, make_sensors
from flatland_ma.build.builder import Episode, build
from flatland_ma.build.census import state_entities, world_state
from flatland_ma.envs.flatten import FlatLayout, FlatPart
from flatland_ma.envs.render_modes import KNOWN_RENDER_MODES, RENDER_MODES
from flatland_ma.scenario.schema import ScenarioSpec
from flatland_ma.sensors.sensor_suite import observation_space

RENDER_FPS = 30
"""The frame rate of ``render_mode="human"``."""


class WorldLoop:
    """One world of ``spec`` (checked already: ``envs.checked_spec``) and its episode loop;
    see the module's docstring. ``render_mode`` and ``flatten`` as for
    ``FlatlandParallelEnv``.

    After ``start``: ``episode`` (``running`` raises before), ``live`` (the indices of the
    agents still playing, in order), ``agents`` (their names), ``num_steps``."""

    def __init__(self, spec: ScenarioSpec, render_mode: str | None, flatten: bool = False):
        if render_mode is not None and render_mode not in KNOWN_RENDER_MODES:
            raise ValueError(f"render_mode {render_mode!r} is not one of {RENDER_MODES}")
        if not isinstance(flatten, bool):
            raise TypeError(f"flatten must be True or False, not {flatten!r}")
        self.spec = spec
        self.render_mode = render_mode
        self.flatten = flatten
        """Whether observations are flat float32 vectors (``flatland_ma.envs.flatten``)."""
        self.possible_agents = list(spec.agent_names)
        self.agents: list[str] = []
        self._index = {name: i for i, name in enumerate(self.possible_agents)}
        words, vocabulary = (
            (spec.channel.tokens, spec.channel.vocabulary) if spec.channel else (0, 2)
        )
        self.actuators = [
            Actuator(agent.actions, make_parts(agent), words, vocabulary)
            for agent in spec.agent_specs
        ]
        """Each agent's actuator, in agent order: its action space, checks and commands."""
        self._alike = all(a.commands_like(self.actuators[0]) for a in self.actuators)
        """Whether every agent's actions give the same base commands (one call gives
        them all)."""
        self._motors: Motors | None = None
        """The episode's plain bodies' motors (None: a body with parts, or a tier in
        which compiled code cannot drive them)."""
        self.sensors = [
            make_sensors(agent, spec.channel, spec.n_agents) for agent in spec.agent_specs
        ]
        """Each agent's sensors, in agent order."""
        self.action_spaces = {a: act.space for a, act in zip(self.possible_agents, self.actuators)}
        self.observation_spaces = {
            a: observation_space(own) for a, own in zip(self.possible_agents, self.sensors)
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
        self.step_limit: int | None = spec.episode.max_steps
        """Steps after which every agent is truncated; None for no limit (the Gymnasium env
        made by gymnasium.make, where the TimeLimit wrapper truncates)."""
        self.live: list[int] = []
        """The indices of the agents still playing, in agent order."""
        self._np_random: np.random.Generator | None = None
        self._np_random_seed: int | None = None
        self._reset_state: Mapping | None = None
        self._log: list = []
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
        return self.actuators[self.agent_index(agent)].names

    def action_index(self, name: str, agent: str | None = None) -> int:
        """The discrete action (or continuous entry) called ``name``, e.g. ``"grasp"`` (of
        the first agent, unless ``agent`` says whose)."""
        return self.actuators[self.agent_index(agent)].index(name)

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
        return self._layouts[self.agent_index(agent)]

    def agent_index(self, agent: str | None) -> int:
        """The index of the agent called ``agent`` (0 for None); ``KeyError`` if none is."""
        if agent is None:
            return 0
        if agent not in self._index:
            raise KeyError(f"no agent {agent!r}; agents: {self.possible_agents}")
        return self._index[agent]

    def is_agent(self, name) -> bool:
        """Whether ``name`` names an agent of the world (live or not)."""
        return isinstance(name, str) and name in self._index

    def observe(self, i: int):
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
        """The generator of every draw of the world (seeded by ``start``)."""
        if self._np_random is None:
            self._np_random, self._np_random_seed = seeding.np_random()
        return self._np_random

    @property
    def np_random_seed(self) -> int | None:
        """The seed of ``np_random``'s last seeding (None before any)."""
        return self._np_random_seed

    @property
    def seeded(self) -> bool:
        """Whether ``np_random`` exists yet (``start`` or a read of it made it)."""
        return self._np_random is not None

    # -- the loop -----------------------------------------------------------------------

    def enter(self) -> None:
        """Claim the world for one call. pymunk spaces are not thread-safe: a second thread
        inside at once would corrupt it, so it gets a clear error instead (and the world is
        left as it was). ``leave`` releases it."""
        if not self._in_use.acquire(blocking=False):
            raise RuntimeError(
                "this env is in use by another thread at the same time; an env (its "
                "pymunk space) must be used from one thread at a time: make one env per thread"
            )

    def leave(self) -> None:
        self._in_use.release()

    def start(self, seed: int | None) -> None:
        """Start an episode: the generator is seeded with ``seed`` (or, if None, continues;
        fresh entropy the first time), the world built and observed."""
        if seed is not None or self._np_random is None:
            self._np_random, self._np_random_seed = seeding.np_random(seed)
        self._reset_state = self.np_random.bit_generator.state
        self._start_episode()

    def _start_episode(self) -> None:
        site = None if self.episode is None else self.episode.site
        self.episode = episode = build(self.spec, self.np_random, self.sensors, site)
        self._motors = motors_of(episode.bodies)
        self._state_parts = state_entities(episode)
        episode.sensors.observe()
        self.num_steps = 0
        self.live = list(range(len(self.possible_agents)))
        self.agents = list(self.possible_agents)
        self._log = []

    def check_action(self, agent: str, action) -> object:
        """``action`` as the step loop will use it, if it belongs to the action space of
        ``agent`` (a live agent); otherwise an error naming the agent, the value and the
        space. Changes nothing."""
        if agent not in self._index or self._index[agent] not in self.live:
            raise ValueError(
                f"action {action!r} given for {agent!r}, which is not a live agent; "
                f"live agents: {self.agents}"
            )
        return self.actuators[self._index[agent]].check(agent, action)

    def act(self, checked) -> None:
        """Command the live agents (``checked``: their checked actions, in agent order)."""
        episode, actuators, motors = self.running, self.actuators, self._motors
        bodies, live = episode.bodies, self.live
        if motors is None:
            for i, action in zip(live, checked):
                actuators[i].apply(bodies[i], action)
        elif live:
            if self._alike:
                commands = actuators[0].base_commands(checked)
            else:
                rows = [actuators[i].base_commands([a]) for i, a in zip(live, checked)]
                commands = np.concatenate(rows)
            if len(live) == len(bodies):
                motors.drive_all(commands)
            else:
                touching = np.array([bodies[i].touching for i in live], bool)
                motors.drive(np.array(live, np.intp), commands, touching)
        if episode.world.channel is not None:
            self._say(checked)
        self._log.append(checked)

    def drove(self, checked) -> None:
        """What ``act`` does but for commanding the bodies: the caller drove them."""
        if self.running.world.channel is not None:
            self._say(checked)
        self._log.append(checked)

    def _say(self, checked) -> None:
        channel, actuators = self.running.world.channel, self.actuators
        assert channel is not None
        for i, action in zip(self.live, checked):
            channel.say(i, actuators[i].said(action))

    def simulate(self) -> tuple[list[float], list[bool]]:
        """The physics and the task's rules of one step: everyone's rewards and
        terminations, in agent order."""
        episode = self.running
        episode.world.step()
        episode.hands.update()
        return episode.task.evaluate(self.np_random)

    def conclude(self, rewards: list[float], terminated: list[bool]):
        """Count the step and let the agents that finished in it leave: the agents that
        were live for it, ``rewards``, ``terminated`` and whether the step limit truncated
        the episode."""
        live = self.live
        self.num_steps += 1
        truncated = self.step_limit is not None and self.num_steps >= self.step_limit
        if truncated or (True in terminated and any(terminated[i] for i in live)):
            self.live = [i for i in live if not (truncated or terminated[i])]
            bodies, channel = self.running.bodies, self.running.world.channel
            for i in live:
                if i not in self.live:
                    bodies[i].command(0.0, 0.0, 0.0)
                    if channel is not None:
                        channel.silence(i)
            self.agents = [self.possible_agents[i] for i in self.live]
        return live, rewards, terminated, truncated

    def advance(self) -> tuple[list[int], list[float], list[bool], bool]:
        """One step after ``act``: ``simulate``, observe, ``conclude``."""
        rewards, terminated = self.simulate()
        self.running.sensors.observe()
        return self.conclude(rewards, terminated)

    # -- global state, rendering --------------------------------------------------------

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
            self._renderer = Renderer(self.spec, self.sensors)
        self.enter()
        try:
            frame = self._renderer.frame(self)
        finally:
            self.leave()
        if self.render_mode == "rgb_array":
            return frame
        self._renderer.show(frame, RENDER_FPS)
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
        WorldLoop.__init__(self, state["spec"], state["render_mode"], state.get("flatten", False))
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
            self.act(checked)
            for i in self.advance()[0]:
                sensors.observation(i)
