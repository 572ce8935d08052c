"""A scenario's sections put together: the physics, the episode, and every field of a
scenario file (``ScenarioFields``), with the questions the builder and the checks ask of
them. ``flatland_ma.scenario.schema`` adds the checks that span sections (its
``ScenarioSpec``, what files load into)."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field

from flatland_ma.scenario.errors import KeyPath, ScenarioError, SpecError, located
from flatland_ma.scenario.spec_agent import AgentSpec, ChannelSpec, SpawnSpec, TeamSpec
from flatland_ma.scenario.spec_objects import ItemSpec, Obstacle
from flatland_ma.scenario.spec_reference import ReferenceSpec
from flatland_ma.scenario.spec_rules import RuleSpec
from flatland_ma.scenario.spec_world import (
    ArenaSpec,
    CorridorSpec,
    DoorSpec,
    LayoutSpec,
    RoomSpec,
    WallSpec,
    ZoneSpec,
)
from flatland_ma.scenario.types import MAX_GROUPS, FileSpec, Flag, Name, Spec

MIN_DT, MAX_DT = 1e-3, 1.0
"""The shortest and longest simulated step, in seconds (the default is 1/30)."""


class PhysicsSpec(Spec):
    dt: Annotated[float, Field(strict=True, ge=MIN_DT, le=MAX_DT)] = 1.0 / 30.0
    """Simulated seconds per environment step."""
    substeps: Annotated[int, Field(strict=True, ge=1, le=32)] = 2
    """pymunk steps per environment step (each of ``dt / substeps`` seconds)."""
    iterations: Annotated[int, Field(strict=True, ge=1, le=100)] = 10
    """Constraint-solver iterations per pymunk step."""


class EpisodeSpec(Spec):
    max_steps: Annotated[int, Field(strict=True, ge=1, le=10_000_000)] = 500
    """Episode length in environment steps; reaching it is reported as truncation."""
    shared_end: Flag = False
    """When one agent's episode ends (a goal, a terminal zone), everyone's does."""
    end_when_eaten: Name | None = None
    """End everyone's episode once no item of this group is left (with ``respawn: never``)."""


class ScenarioFields(FileSpec):
    """Every section of a scenario and what they answer (agents' names and specs, every
    door); ``ScenarioSpec`` (``flatland_ma.scenario.schema``) is this with the checks that
    span sections, and is what files load into. The checks read this class, so that they
    and the schema do not import each other."""

    description: Annotated[str, Field(strict=True, max_length=200)] = ""
    """One line shown by ``flatland-ma list``."""
    version: Annotated[int, Field(strict=True, ge=0, le=999)] = 0
    """The task's version. A change of the file, or of the library, that changes the task's
    dynamics, rewards or observations bumps it (and says so in the changelog). Gymnasium
    ids name it (``flatland_ma/FruitsPoisons-v0``), benchmark results record it and are
    never mixed across versions. A file that ``extends`` another inherits its version
    unless it gives its own: a change of the file it extends changes it too."""
    n_agents: Annotated[int, Field(strict=True, ge=1, le=64)] = 1
    """How many agents share the world (named agent_0, agent_1, ..., or by team: see
    ``agent_names``)."""
    episode: EpisodeSpec = EpisodeSpec()
    """Episode length and how episodes end."""
    physics: PhysicsSpec = PhysicsSpec()
    """Time step and solver settings."""
    arena: ArenaSpec = ArenaSpec()
    """The playing area and its boundary walls."""
    walls: tuple[WallSpec, ...] = ()
    """Straight walls anywhere in the arena."""
    rooms: tuple[RoomSpec, ...] = ()
    """Rectangles of walls, with openings."""
    corridors: tuple[CorridorSpec, ...] = ()
    """Passages between walls; they open the room walls they run through."""
    doors: tuple[DoorSpec, ...] = ()
    """Doors on their own (doors in room openings are given there)."""
    zones: Annotated[tuple[ZoneSpec, ...], Field(max_length=MAX_GROUPS)] = ()
    """Areas of floor that act when agents enter them."""
    layout: LayoutSpec = LayoutSpec()
    """Generated walls and obstacles, drawn per episode or once."""
    obstacles: tuple[Obstacle, ...] = ()
    """Obstacles at fixed places: circles, boxes, convex polygons."""
    items: Annotated[tuple[ItemSpec, ...], Field(max_length=MAX_GROUPS)] = ()
    """Groups of items that agents take by touching them."""
    agent: AgentSpec = AgentSpec()
    """What every agent is: body, motor, camera, actions, start."""
    teams: Annotated[tuple[TeamSpec, ...], Field(max_length=MAX_GROUPS)] = ()
    """Teams of agents, in agent order; their sizes add up to ``n_agents``."""
    channel: ChannelSpec | None = None
    """A channel the agents talk on (see its section); none: they cannot signal."""
    rules: Annotated[tuple[RuleSpec, ...], Field(max_length=MAX_GROUPS)] = ()
    """Rules added to the task, applied in order after what items, zones, doors and
    deliveries do, and before the episode's ending is decided."""
    reference: ReferenceSpec | None = None
    """The scripted solver that proves the task solvable and the score it must reach
    (every shipped scenario has one; the env does not read it)."""

    def __eq__(self, other) -> bool:
        """Specs are equal when their fields are; where they were read from does not count."""
        if not isinstance(other, ScenarioFields):
            return NotImplemented
        return self.__dict__ == other.__dict__

    def locate(self, err: SpecError) -> ScenarioError:
        """A fault found while building this scenario, located in the file it came from."""
        return located(err, self.marks, self.source)

    def team_of(self, agent_index: int) -> TeamSpec | None:
        """The team of an agent (teams take agents in order), or None without teams."""
        first = 0
        for team in self.teams:
            if agent_index < first + team.size:
                return team
            first += team.size
        return None

    @property
    def agent_names(self) -> tuple[str, ...]:
        """Every agent's name, in agent order: ``agent_0, agent_1, ...``; with teams, by
        team, numbered within it (``scout_0, runner_0, runner_1``), as clients group
        agents by the name's prefix."""
        if not self.teams:
            return tuple(f"agent_{i}" for i in range(self.n_agents))
        return tuple(f"{team.name}_{k}" for team in self.teams for k in range(team.size))

    def agent_of(self, agent_index: int) -> AgentSpec:
        """The body, sensors and actions of an agent: its team's ``agent``, else ``agent``."""
        team = self.team_of(agent_index)
        return team.agent if team is not None and team.agent is not None else self.agent

    @property
    def agent_specs(self) -> tuple[AgentSpec, ...]:
        """Every agent's spec, in agent order."""
        return tuple(self.agent_of(i) for i in range(self.n_agents))

    def agent_kinds(self) -> list[tuple[KeyPath, AgentSpec, int]]:
        """Each distinct agent spec with the key path it is written at and how many agents
        have it: the top-level ``agent`` (for agents of teams without their own), then each
        team with an ``agent`` of its own."""
        own = [(("teams", i, "agent"), t.agent, t.size) for i, t in enumerate(self.teams)]
        own = [(path, agent, size) for path, agent, size in own if agent is not None]
        rest = self.n_agents - sum(size for _, _, size in own)
        return ([(("agent",), self.agent, rest)] if rest > 0 else []) + own

    @property
    def heterogeneous(self) -> bool:
        """Whether some team's agents differ from the top-level ``agent``."""
        return any(t.agent is not None and t.agent != self.agent for t in self.teams)

    def spawn_of(self, agent_index: int) -> SpawnSpec:
        team = self.team_of(agent_index)
        if team is not None and team.spawn is not None:
            return team.spawn
        return self.agent_of(agent_index).spawn

    def all_doors(self) -> list[tuple[KeyPath, DoorSpec]]:
        """Every door with its key path: standalone ones and those in room openings."""
        doors: list[tuple[KeyPath, DoorSpec]] = [
            (("doors", i), d) for i, d in enumerate(self.doors)
        ]
        for r, room in enumerate(self.rooms):
            for o, opening in enumerate(room.openings):
                if opening.door is not None:
                    doors.append((("rooms", r, "openings", o, "door"), opening.door))
        return doors
