"""A game at the keyboard: one agent driven by keys, every other by a policy, and the
scores written down at the end of each episode.

The world advances one step per frame while an action key is held (the paper's bodies
have no action that does nothing, so it waits for you). Tab hands the keys to the next
live agent; an agent whose episode ends hands them on by itself. An agent's score is the
reward it earned while you drove it.
"""

from __future__ import annotations

import csv
import datetime
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from flatland_ma.envs.parallel import FlatlandParallelEnv
from flatland_ma.play.keys import NEXT_AGENT, QUIT, KeyMap, Keys
from flatland_ma.policies.named import SHIPPED, default_policy, is_checkpoint, make_policy

SCORE_COLUMNS = ("time", "scenario", "seed", "agent", "steps", "score")
"""The columns of the scores file, one row per agent you drove in an episode."""


OTHERS: dict[str, Callable] = dict(SHIPPED)
"""The policies the agents you do not drive can follow, by name (or a checkpoint's path)."""


@dataclass
class Tally:
    """What you did with one agent in the current episode."""

    steps: int = 0
    score: float = 0.0


@dataclass
class Session:
    """The state of a game: the env, whose keys drive which agent, and the scores.

    ``advance(keys)`` plays one frame and says whether to go on; ``changed`` says the
    picture is out of date. Episode ``e`` is played on seed ``seed + e``.
    """

    env: FlatlandParallelEnv
    scenario: str
    seed: int = 0
    others: str | None = None
    """The policy of every agent you do not drive (None: each its own default,
    ``policies.named.default_policy``: the scenario's reference solver where it suits)."""
    episodes: int = 1
    scores: Path | None = None
    episode: int = 0
    controlled: int = 0
    """The index of the agent the keys drive."""
    returns: dict[str, float] = field(default_factory=dict)
    """Each agent's return so far this episode, driven or not."""
    tallies: dict[str, Tally] = field(default_factory=dict)
    finished: list[dict] = field(default_factory=list)
    """The rows written for the episodes played to their end."""
    changed: bool = True
    stopped: bool = False
    """Whether the player left (Esc, or closing the window) before the last episode ended."""

    def __post_init__(self):
        if self.others is not None and self.others not in OTHERS and not is_checkpoint(self.others):
            raise ValueError(
                f"no policy {self.others!r} for the others; one of {', '.join(OTHERS)}, "
                "or a checkpoint file (.safetensors)"
            )
        env = self.env
        channel = env.spec.channel
        vocabulary = channel.vocabulary if channel is not None else 2
        self.maps = {
            a: KeyMap.for_space(env.action_names(a), env.action_space(a), vocabulary)
            for a in env.possible_agents
        }
        self.policies = {}  # none with one agent: nobody else to drive
        if len(env.possible_agents) > 1:
            self.policies = {
                a: make_policy(self.others or default_policy(env, a), env, a, self.seed + i)
                for i, a in enumerate(env.possible_agents)
            }
        self._start()

    @property
    def agent(self) -> str:
        """The name of the agent the keys drive."""
        return self.env.possible_agents[self.controlled]

    @property
    def done(self) -> bool:
        return self.stopped or self.episode >= self.episodes

    def _start(self) -> None:
        self.observations, _ = self.env.reset(seed=self.seed + self.episode)
        for policy in self.policies.values():
            _reset(policy)
        self.returns = {a: 0.0 for a in self.env.possible_agents}
        self.tallies = {}
        if self.agent not in self.env.agents:
            self.controlled = 0
        self.changed = True

    def advance(self, keys: Keys) -> bool:
        """Play one frame of keys; False once the game is over."""
        if self.done:
            return False
        if keys.quit or QUIT in keys.pressed:
            self.stopped = True
            return False
        if NEXT_AGENT in keys.pressed:
            self.switch()
        if self.maps[self.agent].press(keys.pressed):
            self.changed = True
        action = self.maps[self.agent].action(keys.down)
        if action is not None:
            self._step(action)
        return not self.done

    def switch(self) -> None:
        """Hand the keys to the next live agent (its policy resumes where you leave)."""
        names, live = self.env.possible_agents, self.env.agents
        for shift in range(1, len(names) + 1):
            candidate = (self.controlled + shift) % len(names)
            if names[candidate] in live:
                break
        else:
            return
        _reset(self.policies.get(self.agent))
        self.controlled = candidate
        self.changed = True

    def _step(self, action) -> None:
        env, me = self.env, self.agent
        actions = {
            a: action if a == me else self.policies[a].act(self.observations[a]) for a in env.agents
        }
        self.observations, rewards, _, _, _ = env.step(actions)
        tally = self.tallies.setdefault(me, Tally())
        tally.steps += 1
        tally.score += float(rewards.get(me, 0.0))
        for a, r in rewards.items():
            self.returns[a] += float(r)
        self.changed = True
        if not env.agents:
            self._finish()
        elif me not in env.agents:
            self.switch()

    def _finish(self) -> None:
        """Write this episode's rows, then start the next episode (if any)."""
        time = datetime.datetime.now().isoformat(timespec="seconds")
        rows = [
            {
                "time": time,
                "scenario": self.scenario,
                "seed": self.seed + self.episode,
                "agent": agent,
                "steps": tally.steps,
                "score": f"{tally.score:g}",
            }
            for agent, tally in self.tallies.items()
        ]
        self.finished += rows
        if self.scores is not None:
            append_scores(self.scores, rows)
        self.episode += 1
        if self.episode < self.episodes:
            self._start()


def _reset(policy) -> None:
    """Make a policy forget its past (those that remember have ``reset``)."""
    reset = getattr(policy, "reset", None)
    if callable(reset):
        reset()


def append_scores(path: Path, rows: list[dict]) -> None:
    """Add rows to a CSV file of scores (with its header when the file is new or empty)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    new = not path.exists() or path.stat().st_size == 0
    with path.open("a", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=SCORE_COLUMNS)
        if new:
            writer.writeheader()
        writer.writerows(rows)
