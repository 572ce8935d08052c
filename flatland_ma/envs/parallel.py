"""The PettingZoo parallel environment: one world loop with PettingZoo's dicts around it.

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

The step itself is the world loop's (``flatland_ma.envs.world_loop``): act, physics and
rules, senses, ends; pickling too (a copy replays the episode's actions and continues
exactly as the original would).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from pettingzoo import ParallelEnv

from flatland_ma.envs.checked_spec import checked_spec, no_window_without_display
from flatland_ma.envs.render_modes import RENDER_MODES
from flatland_ma.envs.world_loop import RENDER_FPS, WorldLoop
from flatland_ma.scenario.schema import ScenarioSpec


class FlatlandParallelEnv(WorldLoop, ParallelEnv):
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
        "render_fps": RENDER_FPS,
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
        no_window_without_display(render_mode)
        spec = checked_spec(scenario, max_cycles, overrides)
        WorldLoop.__init__(self, spec, render_mode, flatten)

    def reset(self, seed: int | None = None, options: dict | None = None):
        """Start an episode: ``(observations, infos)``, one entry per agent. The same
        ``seed`` gives the same layout, spawns and draws; None draws a fresh seed."""
        self.enter()
        try:
            self.start(seed)
            task = self.running.task
            observations = {a: self.observe(i) for i, a in enumerate(self.possible_agents)}
            infos = {a: task.info(i) for i, a in enumerate(self.possible_agents)}
            return observations, infos
        finally:
            self.leave()

    def step(self, actions: Mapping):
        """Advance one step with one action per live agent: ``(observations, rewards,
        terminations, truncations, infos)``, each a dict by agent (the agents that were
        live). Actions for finished agents are ignored; a bad one raises ``ValueError``
        naming the agent and its space, and changes nothing."""
        self.enter()
        try:
            self.act(self._check(actions))
            live, rewards, terminated, truncated = self.advance()
            task, names = self.running.task, self.possible_agents
            observations = {names[i]: self.observe(i) for i in live}
            reward_d = {names[i]: rewards[i] for i in live}
            terminated_d = {names[i]: terminated[i] for i in live}
            truncated_d = {names[i]: truncated for i in live}
            infos = {names[i]: task.info(i) for i in live}
            return observations, reward_d, terminated_d, truncated_d, infos
        finally:
            self.leave()

    def _check(self, actions: Mapping) -> list:
        """Every live agent's action, validated, in agent order; nothing is changed.
        Actions for agents that have finished are ignored; other names raise."""
        if not self.agents:
            raise RuntimeError("no live agents: the episode is over, call reset()")
        if not isinstance(actions, Mapping):
            raise TypeError(f"actions must be a dict from agent name to action, not {actions!r}")
        for name in actions:
            if not self.is_agent(name):
                raise ValueError(
                    f"action {actions[name]!r} given for {name!r}, which is not a live agent "
                    f"(nor a finished one); "
                    f"expected one action for each live agent {self.agents}, "
                    f"in {self._spaces_text(self.agents)}"
                )
        checked = []
        for i in self.live:
            name = self.possible_agents[i]
            if name not in actions:
                raise ValueError(
                    f"no action given for live agent {name!r}; "
                    f"expected an element of {self.action_spaces[name]}"
                )
            checked.append(self.actuators[i].check(name, actions[name]))
        return checked

    def _spaces_text(self, agents: list[str]) -> str:
        """The action space shared by ``agents``, or each one's if they differ."""
        spaces = {str(self.action_spaces[a]) for a in agents}
        if len(spaces) == 1:
            return spaces.pop()
        return ", ".join(f"{a}: {self.action_spaces[a]}" for a in agents)
