"""Scripted play for tasks that need the channel (``channel`` in the scenario): a guide
that tells where the goal is and a seeker that goes where it is told.

The scenario's rooms are its zones that reward nothing (in file order): word ``j`` means
"room ``j``". ``Signaller`` (privileged: it reads the world) says the room that holds the
nearest item worth having, and turns on the spot (without a channel it only turns).
``Follower`` drives with the planner's search, but only towards what it could know: it
heads for the room the first agent it hears (other than itself) names, or with nobody to
hear (after listening for ``WAIT`` steps) for a room drawn at random; inside a room it
sees what lies there, takes the best item if there is one, and else tries the next room.
``Heeder`` is a ``Follower`` that heeds every word until it has tried a room, not only the
first: it heads for the room named most often so far, so that each of a guide's words
counts (a partner for a guide learning to tell, whose first word alone would pay).
"""

from __future__ import annotations

import numpy as np

from flatland_ma.policies.motion import BaseMotion
from flatland_ma.policies.planner import PlannerPolicy, mask_at
from flatland_ma.sensors.hearing import MESSAGES
from flatland_ma.world.entities import Item


def rooms_of(spec) -> list[tuple[float, float, float, float]]:
    """The rooms words refer to: the scenario's zones that reward nothing, in file order."""
    return [z.rect for z in spec.zones if z.rect is not None and z.reward == 0]


def _inside(rect, point) -> bool:
    return rect[0] <= point[0] <= rect[2] and rect[1] <= point[1] <= rect[3]


def room_holding(rooms, point) -> int | None:
    """The index of the first of ``rooms`` (``rooms_of``) that holds ``point``, or None."""
    return next((k for k, rect in enumerate(rooms) if _inside(rect, point)), None)


def _wanted(episode, rect) -> list[Item]:
    return [
        i
        for i in episode.world.of_type(Item)
        if i.visible and i.reward > 0 and _inside(rect, i.body.position)
    ]


WAIT = 2
"""Steps the follower listens before it guesses, in a scenario with a channel."""


class Signaller:
    def __init__(self, env, agent: str):
        self.env = env
        self.index = env.possible_agents.index(agent)
        spec = env.spec
        self.rooms = rooms_of(spec)
        self.motion = BaseMotion(spec.agent_of(self.index), spec.channel)

    def act(self, observation=None):
        episode = self.env.episode
        me = episode.bodies[self.index].body.position
        goal = min(
            (i for i in episode.world.of_type(Item) if i.visible and i.reward > 0),
            key=lambda i: (i.body.position - me).length,
            default=None,
        )
        room = None if goal is None else room_holding(self.rooms, goal.body.position)
        word = 0 if room is None else room
        return self.motion.action(0.0, 1.0, [word] * self.motion.words)


class Follower(PlannerPolicy):
    def __init__(self, env, agent: str, seed: int | None = None):
        self.rooms = rooms_of(env.spec)
        if not self.rooms:
            raise ValueError("the follower goes to the scenario's rooms: it has none")
        self.rng = np.random.default_rng(seed)
        super().__init__(env, agent)

    def reset(self) -> None:
        super().reset()
        self.room: int | None = None
        self.tried: set[int] = set()
        self.waited = 0

    def act(self, observation=None):
        if self.room is None:
            told = self._told(observation)
            if told is None and self.env.spec.channel is not None and self.waited < WAIT:
                self.waited += 1  # nobody has spoken before the first step
                return self.motion.action(0.0, 1.0)
            self.room = told if told is not None else int(self.rng.integers(len(self.rooms)))
        return super().act(observation)

    def _told(self, observation) -> int | None:
        """The room the first other speaker heard names, or None."""
        if not isinstance(observation, dict) or MESSAGES not in observation:
            return None
        vocabulary = self.env.spec.channel.vocabulary
        for speaker, row in enumerate(observation[MESSAGES]):
            if speaker != self.index and row[0] > 0:
                word = int(np.argmax(row[1 : 1 + vocabulary]))
                return word if word < len(self.rooms) else None
        return None

    def _choose(self, episode, grid, from_me):
        assert self.room is not None
        here = episode.bodies[self.index].body.position
        room = self.rooms[self.room]
        if _inside(room, here):
            items = _wanted(episode, room)
            if items:
                self._target = ("item", items[0].index)
                self._target_point = items[0].body.position
                return mask_at(grid, [grid.cell_of(*items[0].body.position)])
            self.tried.add(self.room)
            left = [j for j in range(len(self.rooms)) if j not in self.tried]
            if not left:
                return None
            self.room = left[0]
            room = self.rooms[self.room]
        self._target = ("room", self.room)
        self._target_point = ((room[0] + room[2]) / 2, (room[1] + room[3]) / 2)
        return grid.cells_in(room)


class Heeder(Follower):
    """A ``Follower`` that heeds every word until it has tried a room: it heads for the
    room named most often so far this episode (on a tie, the latest named), where the
    ``Follower`` keeps to the first word. Each word a guide says then counts, and a guide
    whose words say nothing sends it to a room as good as a guess."""

    def reset(self) -> None:
        super().reset()
        self.tally = np.zeros(len(self.rooms), np.int64)

    def act(self, observation=None):
        told = self._told(observation)
        if told is not None and not self.tried:
            self.tally[told] += 1
            if self.tally[told] == self.tally.max():  # else the room named most stays
                self.room = told
        return super().act(observation)
