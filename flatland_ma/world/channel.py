"""The channel agents talk on: what each one said on the last step, and who hears whom.

Each step every live agent says ``tokens`` words, each one of ``vocabulary`` (part of its
action); an agent hears a speaker within ``range`` of it (any distance without one) and,
with ``team`` set, of its own team. What was said with the actions of a step is heard in
the observations that step returns, which agents act on at the next step. An agent hears
itself (its own last words), and nothing from an agent whose episode has ended.
"""

from __future__ import annotations

import math

import numpy as np

SILENT = -1
"""A word not said: before the first step, and for agents whose episode has ended."""


class Channel:
    def __init__(
        self,
        n_agents: int,
        tokens: int,
        vocabulary: int,
        range: float | None = None,
        teams: list[str | None] | None = None,
    ):
        self.tokens, self.vocabulary, self.range = tokens, vocabulary, range
        self.teams = teams
        """Each agent's team, when only teammates hear each other (else None)."""
        self.said = np.full((n_agents, tokens), SILENT, np.int64)
        """What each agent said on the last step, word by word."""
        self.bodies: list = []
        """The agents' bases, in agent order (set when they are built)."""

    def say(self, agent: int, words) -> None:
        self.said[agent] = words

    def silence(self, agent: int) -> None:
        self.said[agent] = SILENT

    def hears(self, listener: int, speaker: int) -> bool:
        """Whether ``listener`` hears what ``speaker`` said."""
        if self.said[speaker, 0] == SILENT:
            return False
        if speaker == listener:
            return True
        if self.teams is not None and self.teams[speaker] != self.teams[listener]:
            return False
        if self.range is None:
            return True
        a, b = self.bodies[listener].body.position, self.bodies[speaker].body.position
        return math.dist(a, b) <= self.range

    def heard(self, listener: int) -> np.ndarray:
        """What ``listener`` hears: a row per agent (in agent order), 1 if heard, then
        each word one-hot over the vocabulary (all 0 when not heard)."""
        n, k, v = self.said.shape[0], self.tokens, self.vocabulary
        out = np.zeros((n, 1 + k * v), np.float32)
        for speaker in range(n):
            if self.hears(listener, speaker):
                out[speaker, 0] = 1.0
                out[speaker, 1 + np.arange(k) * v + self.said[speaker]] = 1.0
        return out
