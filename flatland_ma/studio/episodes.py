"""An episode a page watches or plays, advanced one frame at a time.

``Watch`` runs every agent by a policy of its own; ``Play`` hands one agent to the
keyboard through ``play.Session`` (the keys from the agent's action names, Tab to switch,
one row of the scores CSV per agent driven in an episode, exactly as ``flatland-ma play``).
Both answer ``advance``, ``frame`` and ``state``; neither knows about sockets.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np

from flatland_ma.envs.parallel import FlatlandParallelEnv
from flatland_ma.play.keys import QUIT, Keys
from flatland_ma.play.session import Session
from flatland_ma.policies.named import SHIPPED, default_policy, make_policy, suited_policies
from flatland_ma.scenario.schema import ScenarioSpec
from flatland_ma.studio.folders import CHECKPOINT_SUFFIXES, check_name, inside
from flatland_ma.studio.scenarios import renderer_for
from flatland_ma.studio.workspace import CHECKPOINT_PREFIX

PLAYED_EPISODES = 10_000
"""Episodes one play connection may go through (seed, seed + 1, ...)."""
MAX_INFO_ITEMS = 64


def policy_names(checkpoints: list[str]) -> list[str]:
    """Every policy a page may choose: the shipped ones, then the checkpoints."""
    return [*SHIPPED, *(CHECKPOINT_PREFIX + name for name in checkpoints)]


def agent_policies(spec: ScenarioSpec, fitting: Callable[..., list[str]]) -> list[dict]:
    """Each agent of ``spec``: the policies that suit it (the shipped ones that can drive
    it, then ``fitting(env, agent)``'s checkpoints) and the one it plays by default."""
    env = FlatlandParallelEnv(spec)
    try:
        return [
            {
                "agent": agent,
                "policies": suited_policies(env, agent)
                + [CHECKPOINT_PREFIX + name for name in fitting(env, agent)],
                "default": default_policy(env, agent),
            }
            for agent in env.possible_agents
        ]
    finally:
        env.close()


def resolve_policy(name: object, checkpoints: Path | None) -> str:
    """What ``make_policy`` takes for a page's policy ``name``: a shipped policy's name,
    or the path of a checkpoint inside the checkpoint folder; ``ValueError`` otherwise."""
    if isinstance(name, str) and name in SHIPPED:
        return name
    if isinstance(name, str) and name.startswith(CHECKPOINT_PREFIX):
        if checkpoints is None:
            raise ValueError("no checkpoint folder was given to the studio (--checkpoints)")
        relative = check_name(name.removeprefix(CHECKPOINT_PREFIX), CHECKPOINT_SUFFIXES, True)
        return str(inside(checkpoints, relative))
    raise ValueError(
        f"no policy {name!r}: one of {', '.join(SHIPPED)}, or checkpoint:NAME of the folder"
    )


class PolicyRefused(ValueError):
    """A policy that cannot drive ``agent`` (it needs a sense the agent lacks, or a
    checkpoint was trained for other spaces)."""

    def __init__(self, agent: str, message: str):
        super().__init__(f"{agent}: {message}")
        self.agent = agent


def plain(value, depth: int = 0):
    """``value`` as JSON can hold it (NumPy numbers and arrays, non-finite floats)."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else str(float(value))
    if isinstance(value, str):
        return value
    if depth > 3:
        return str(value)
    if isinstance(value, Mapping):
        items = list(value.items())[:MAX_INFO_ITEMS]
        return {str(k): plain(v, depth + 1) for k, v in items}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [plain(v, depth + 1) for v in list(value)[:MAX_INFO_ITEMS]]
    return str(value)


class Watch:
    """Every agent by its policy (``policies``: agent -> resolved name; by default its
    own, ``policies.named.default_policy``). A policy that cannot drive its agent raises
    ``PolicyRefused`` naming the agent."""

    mode = "watch"

    def __init__(self, spec: ScenarioSpec, seed: int, policies: Mapping[str, str]):
        self.env = FlatlandParallelEnv(spec)
        self.seed = seed
        self.observations, infos = self.env.reset(seed=seed)
        agents = self.env.possible_agents
        self.policies = {}
        for i, agent in enumerate(agents):
            name = policies.get(agent) or default_policy(self.env, agent)
            try:
                self.policies[agent] = make_policy(name, self.env, agent, seed + i)
            except ValueError as err:
                self.env.close()
                raise PolicyRefused(agent, str(err)) from None
        self.renderer = renderer_for(self.env)
        self.returns = {a: 0.0 for a in agents}
        self.infos: dict = {a: plain(i) for a, i in infos.items()}

    @property
    def done(self) -> bool:
        return not self.env.agents

    def advance(self, keys: Keys | None = None) -> bool:
        """One step of every live agent; False once the episode is over."""
        env = self.env
        if not env.agents:
            return False
        actions = {a: self.policies[a].act(self.observations[a]) for a in env.agents}
        self.observations, rewards, _, _, infos = env.step(actions)
        for agent, reward in rewards.items():
            self.returns[agent] += float(reward)
        self.infos.update({a: plain(i) for a, i in infos.items()})
        return True

    def frame(self) -> np.ndarray:
        return self.renderer.frame(self.env)

    def state(self) -> dict:
        return {
            "mode": self.mode,
            "step": self.env.num_steps,
            "seed": self.seed,
            "returns": self.returns,
            "infos": self.infos,
            "live": list(self.env.agents),
            "done": self.done,
        }

    def close(self) -> None:
        self.env.close()


class Play:
    """One agent from the keys, the others by ``others`` (a resolved policy name)."""

    mode = "play"

    def __init__(self, spec: ScenarioSpec, seed: int, others: str | None, label: str, scores):
        self.env = FlatlandParallelEnv(spec)
        try:
            self.session = Session(self.env, label, seed, others, PLAYED_EPISODES, scores)
        except ValueError:
            self.env.close()
            raise
        self.renderer = renderer_for(self.env)

    @property
    def done(self) -> bool:
        return self.session.done

    def advance(self, keys: Keys | None = None) -> bool:
        """One frame of held keys (a step only if one of them is an action key)."""
        keys = keys or Keys()
        keys = Keys(keys.pressed - {QUIT}, keys.held - {QUIT})
        steps = self.env.num_steps
        self.session.advance(keys)
        return self.env.num_steps != steps or self.session.changed

    def frame(self) -> np.ndarray:
        self.session.changed = False
        return self.renderer.frame(self.env, focus=self.session.controlled)

    def keys(self) -> dict[str, list[str]]:
        """Each agent's keys and what they do."""
        return {a: m.help() for a, m in self.session.maps.items()}

    def state(self) -> dict:
        s = self.session
        tally = s.tallies.get(s.agent)
        return {
            "mode": self.mode,
            "step": self.env.num_steps,
            "seed": s.seed + s.episode,
            "agent": s.agent,
            "said": list(s.maps[s.agent].said),
            "score": tally.score if tally else 0.0,
            "episode": s.episode + 1,
            "returns": dict(s.returns),
            "finished": s.finished[-8:],
            "live": list(self.env.agents),
            "done": self.done,
        }

    def close(self) -> None:
        self.env.close()
