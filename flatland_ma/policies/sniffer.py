"""A scripted forager that follows its nose: it reads only its smell sensor.

Scent spreads around walls (``sensors.scent``), so the nostril nearer the way to the food
smells it more even when the food lies behind a wall. The sniffer turns towards the
stronger nostril and walks on while both smell about alike, or when it would turn back the
way it just turned (the way lies between its last two headings). If the scent weakens as
it walks (the food is behind it, where both nostrils smell alike too) it turns round; if
it stops growing stronger for a while (the agent is pressed against a wall round whose
corner the scent comes) it turns away, walks a few steps and tries again; with nothing to
smell it wanders.

Channels of item groups with a negative reward count against the others: the sniffer
heads up the scent of good items and down that of bad ones. The one-channel smell of every
item counts as good.
"""

from __future__ import annotations

import numpy as np

from flatland_ma.build.bodies import make_sensors
from flatland_ma.policies.motion import BaseMotion
from flatland_ma.scenario.schema import ScenarioSpec
from flatland_ma.scenario.spec_sensors import SmellSpec

TOLERANCE = 0.02
"""Nostrils whose scents differ by less than this fraction smell alike: walk on."""
PATIENCE = 12
"""Steps without the scent growing stronger (by ``PROGRESS``) before the agent counts as
stuck (pressed against a wall round whose corner the scent comes)."""
PROGRESS = 1e-3
"""The fraction by which the scent must grow to count as progress."""
DODGE_TURNS, DODGE_WALK = 9, 6
"""When stuck, it turns this many steps one way (chosen at random), then walks this many
before following its nose again."""
WANDER_TURNS = 0.1
"""With nothing to smell, the chance of turning at each step (else it walks)."""


class Sniffer:
    def __init__(self, spec: ScenarioSpec, seed: int | None = None, agent: int = 0):
        """Drives agent number ``agent`` of ``spec`` (its body, smell and actions)."""
        body = spec.agent_of(agent)
        found = [k for k, s in enumerate(body.sensor_specs) if isinstance(s, SmellSpec)]
        if not found:
            raise ValueError("the sniffer reads a smell sensor: the agent has none")
        smell = body.sensor_specs[found[0]]
        assert isinstance(smell, SmellSpec)
        several = len(make_sensors(body, spec.channel, spec.n_agents)) > 1  # a Dict then
        self.key = (smell.name or smell.type) if several else None
        """The smell's entry in a ``Dict`` observation (None: the observation is it)."""
        rewards = {item.name: item.reward for item in spec.items}
        sources = smell.sources if smell.sources is not None else (None,)
        self.weights = np.array(
            [-1.0 if s is not None and rewards[s] < 0 else 1.0 for s in sources], np.float64
        )
        """How each channel counts: +1 a good group (or every item), -1 a bad one."""
        self.motion = BaseMotion(body, spec.channel)
        self.rng = np.random.default_rng(seed)
        self.reset()

    def reset(self) -> None:
        """Forget the last steps; call at the start of each episode."""
        self._last: float | None = None
        self._walked = False
        self._turned = 0.0
        self._best = 0.0
        self._waited = 0
        self._plan: list[tuple[float, float]] = []

    def act(self, observation):
        """The action for one observation: the smell's (2, channels) reading, or a
        ``Dict`` holding it."""
        if self.key is not None:
            observation = observation[self.key]
        left, right = np.asarray(observation, np.float64) @ self.weights
        forward, turn = self._decide(float(left), float(right))
        if turn * self._turned < 0:  # the aim lies between the last two headings: walk
            forward, turn = 1.0, 0.0
        self._walked, self._turned = turn == 0.0, turn
        return self.motion.action(forward, turn)

    def _decide(self, left: float, right: float) -> tuple[float, float]:
        here = left + right
        last, self._last = self._last, here
        if self._plan:
            return self._plan.pop()
        if left == 0.0 and right == 0.0:  # nothing to smell: wander
            if self.rng.random() < WANDER_TURNS:
                return 0.0, float(self.rng.choice((-1.0, 1.0)))
            return 1.0, 0.0
        if here > self._best + PROGRESS * abs(self._best):
            self._best, self._waited = here, 0
        else:
            self._waited += 1
        if self._waited >= PATIENCE:  # stuck: turn away and walk a little
            self._best, self._waited = here, 0
            way = float(self.rng.choice((-1.0, 1.0)))
            self._plan = [(1.0, 0.0)] * DODGE_WALK + [(0.0, way)] * (DODGE_TURNS - 1)
            return 0.0, way
        if self._walked and last is not None and here < last:
            return 0.0, 1.0 if left >= right else -1.0  # walking away: turn round
        if abs(left - right) > TOLERANCE * max(abs(left), abs(right)):
            return 0.0, 1.0 if left > right else -1.0
        return 1.0, 0.0
