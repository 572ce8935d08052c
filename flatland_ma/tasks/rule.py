"""The rule interface: what every reward rule of a task is, and what it works on.

A task is an ordered list of rules (``task.Task``). Each step, after the physics, every
rule's ``apply`` runs in order over one ``Step``: the world's contact log (items touched,
doors touched, keys at doors, zones entered, zones occupied, objects delivered), every
agent's record, and this step's rewards and terminations, which rules add to. A rule may
also ask to end everyone's episode. At each reset every rule's ``reset`` runs with the
``TaskContext`` (the world, the bodies, where things may be placed, the teams); a rule
adds its counters to each agent's ``infos`` in ``info``.

A new rule is one subclass, named by its ``kind`` in the class statement (the ``rule``
its scenario spec carries), plus that spec; the builder finds it in ``RULE_KINDS`` and
passes the spec's other fields as keyword arguments:

    class StepReward(Rule, kind="step_reward"):
        def __init__(self, reward: float):
            self.reward = reward

        def apply(self, step: Step) -> None:
            for i in step.live:
                step.rewards[i] += self.reward

Required: ``apply``. Optional: ``reset``, ``info``.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import numpy as np

from flatland_ma.agents.body import AgentBody
from flatland_ma.agents.grasp import Hands
from flatland_ma.kinds.registry import Kinded, Kinds
from flatland_ma.world.contacts import ContactLog
from flatland_ma.world.entities import ItemGroup, Rect
from flatland_ma.world.placement import Placer
from flatland_ma.world.world import World

RULE_KINDS = Kinds("flatland_ma.tasks", "rule")
"""Every rule class that scenario files can name, by its kind."""


@dataclass
class AgentRecord:
    """One agent's episode so far, shared by the rules."""

    score: float = 0.0
    keys: set[str] = field(default_factory=set)
    """Names of the keys it holds."""
    visited: set[int] = field(default_factory=set)
    """Indices of the zones it has entered."""
    done: bool = False
    """Its episode has ended (it left the world)."""


@dataclass(frozen=True)
class Spawn:
    """Where an agent (re)starts: an area (None: anywhere free) and a heading in degrees
    (None: at random)."""

    area: Rect | None = None
    heading: float | None = None


@dataclass
class TaskContext:
    """What rules may look at and act on in one episode."""

    world: World
    bodies: list[AgentBody]
    placer: Placer
    """Draws free places that agents can reach."""
    hands: Hands
    rng: np.random.Generator
    groups: list[ItemGroup]
    """Every item group, in the scenario's order (groups may have no item)."""
    teams: list[str | None]
    """Each agent's team (None without teams)."""
    spawns: list[Spawn]
    """Each agent's start area and heading (for rules that move agents)."""
    records: list[AgentRecord]
    """Each agent's record (the same objects every ``Step`` carries)."""


@dataclass
class Step:
    """One step being judged: what happened, and what the rules decide."""

    log: ContactLog
    records: list[AgentRecord]
    rewards: list[float]
    terminated: list[bool]
    rng: np.random.Generator
    t: int
    """Steps since the reset, this one included."""
    end_all: bool = False
    """Set by a rule to end every agent's episode."""

    @property
    def live(self) -> list[int]:
        """The agents whose episode goes on."""
        return [i for i, record in enumerate(self.records) if not record.done]


class Rule(Kinded, ABC):
    """Base of every rule (see the module docstring)."""

    KINDS = RULE_KINDS

    def reset(self, ctx: TaskContext) -> None:
        """Set up for a new episode (nothing to set up by default)."""
        return None

    @abstractmethod
    def apply(self, step: Step) -> None:
        """Add this step's rewards and terminations, update the records."""

    def info(self, agent: int, out: dict) -> None:
        """Add the agent's counters to its ``infos`` entry (none by default)."""
        return None

    def columns(self, agents: list[int], out: dict[str, list]) -> None:
        """Add the counters of ``agents`` to ``out``, one list per key with an entry per
        agent, as ``info`` gives them (the batched env reads every agent's at once). By
        default from ``info``, agent by agent; a rule whose counters are arrays may give
        them as slices."""
        rows: list[dict] = [{} for _ in agents]
        for agent, row in zip(agents, rows):
            self.info(agent, row)
        for key in rows[0] if rows else ():
            out[key] = [row[key] for row in rows]
