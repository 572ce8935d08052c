"""The global state for centralised critics (MAPPO, QMIX): one flat vector of the whole
world, in a fixed order and range, whatever any agent sees.

Layout (every entry float32; positions as fractions of the arena's width and height,
headings as cosine and sine, velocities as fractions of the agents' top speeds, clipped):

- per agent, in agent order, ``AGENT_FIELDS`` = 8 numbers: x, y, cos, sin of its heading,
  vx, vy, turn rate, and 1 while its episode runs (0 after; the rest then stay as they
  were when it ended);
- per item, group by group in file order, ``ITEM_FIELDS`` = 3: x, y, and 1 while it lies
  in the arena (0 while taken and waiting to come back, or gone);
- per movable object, in file order, ``OBJECT_FIELDS`` = 4: x, y, cos, sin;
- per door, in build order (the file's, then each generator's), ``DOOR_FIELDS`` = 3: 1
  while it is not open (a hinged door is never "open": its panel's turn says how far it
  swung), and the cos and sin of its panel's turn from shut;
- with a channel, per agent and word, ``say_<j>``: what it said on the last step, as
  ``(word + 1) / vocabulary`` (0 for silence).

``WorldState.labels`` names every entry by the agents' names, e.g. ``agent_1.vx`` (or
``runner_0.vx`` in a scenario with teams) or ``fruits[3].present``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import gymnasium
import numpy as np

AGENT_FIELDS = ("x", "y", "cos", "sin", "vx", "vy", "turn", "alive")
ITEM_FIELDS = ("x", "y", "present")
OBJECT_FIELDS = ("x", "y", "cos", "sin")
DOOR_FIELDS = ("closed", "cos", "sin")
_SIGNED = {"cos", "sin", "vx", "vy", "turn"}


@dataclass(frozen=True)
class StateCounts:
    """How many of each thing the state describes (fixed for a scenario)."""

    agents: int
    items: tuple[tuple[str, int], ...]
    """Each item group's name and size, in file order."""
    objects: int
    doors: int


class WorldState:
    """Reads the state vector from an episode's world (see the module's docstring)."""

    def __init__(
        self,
        size: tuple[float, float],
        counts: StateCounts,
        speeds: list[float],
        turn_rates: list[float],
        words: int = 0,
        vocabulary: int = 2,
        names: tuple[str, ...] | None = None,
    ):
        """``speeds`` and ``turn_rates`` (degrees per second): each agent's top speeds,
        which its velocities are given as fractions of; ``names``: the agents' names in
        the labels (default ``agent_0, agent_1, ...``)."""
        self.size, self.counts = size, counts
        self.speeds = list(speeds)
        self.turn_rates = [math.radians(rate) for rate in turn_rates]
        if names is None:
            names = tuple(f"agent_{i}" for i in range(counts.agents))
        labels = [f"{name}.{f}" for name in names for f in AGENT_FIELDS]
        for name, n in counts.items:
            labels += [f"{name}[{k}].{f}" for k in range(n) for f in ITEM_FIELDS]
        labels += [f"object[{k}].{f}" for k in range(counts.objects) for f in OBJECT_FIELDS]
        labels += [f"door[{k}].{f}" for k in range(counts.doors) for f in DOOR_FIELDS]
        labels += [f"{name}.say_{j}" for name in names for j in range(words)]
        self.words, self.vocabulary = words, vocabulary
        self.labels = tuple(labels)
        signed = np.array([label.rsplit(".", 1)[1] in _SIGNED for label in labels], bool)
        self.space = gymnasium.spaces.Box(
            low=np.where(signed, -1.0, 0.0).astype(np.float32),
            high=np.ones(len(labels), np.float32),
            dtype=np.float32,
        )

    def read(self, bodies, items, objects, doors, said=None) -> np.ndarray:
        """The state of agents' bases ``bodies``, ``items``, movable ``objects`` and
        ``doors`` (entities, each in the documented order), and with a channel what each
        agent ``said`` (agents x words, -1 for silence)."""
        counts = self.counts
        if (len(bodies), len(items), len(objects), len(doors)) != (
            counts.agents,
            sum(n for _, n in counts.items),
            counts.objects,
            counts.doors,
        ):
            raise RuntimeError("the world does not hold what the state was laid out for")
        width, height = self.size
        out: list[float] = []
        for body, speed, turn_rate in zip(bodies, self.speeds, self.turn_rates):
            b = body.body
            (x, y), (vx, vy), angle = b.position, b.velocity, b.angle
            out += (
                x / width,
                y / height,
                math.cos(angle),
                math.sin(angle),
                vx / speed,
                vy / speed,
                b.angular_velocity / turn_rate,
                1.0 if body.visible else 0.0,
            )
        for item in items:
            x, y = item.body.position
            out += (x / width, y / height, 1.0 if item.visible else 0.0)
        for thing in objects:
            b = thing.body
            (x, y), angle = b.position, b.angle
            out += (x / width, y / height, math.cos(angle), math.sin(angle))
        for door in doors:
            turn = door.body.angle - door.closed_angle
            out += (0.0 if door.is_open else 1.0, math.cos(turn), math.sin(turn))
        if self.words:
            out += ((np.asarray(said).ravel() + 1.0) / self.vocabulary).tolist()
        state = np.array(out, np.float32)
        return np.clip(state, self.space.low, self.space.high, out=state)
