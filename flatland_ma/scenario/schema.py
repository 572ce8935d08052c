"""The scenario schema: every field of a scenario file, its type, range and default.

Models are frozen and reject unknown keys. Numbers are strict (a quoted ``"10"`` is an
error, not a number); lengths are in world units, angles in degrees, times in seconds and
rectangles ``[x0, y0, x1, y1]``. ``docs/scenarios.md`` documents each field for authors.
The sections live in ``spec_world`` (layout), ``spec_objects`` (obstacles and items),
``spec_agent`` (agents) and ``spec_sensors`` (their sensors), tied together in
``spec_scenario``; this module adds the checks that span sections (``ScenarioSpec``).
"""

from __future__ import annotations

from pydantic import model_validator

from flatland_ma.scenario.bounds import check_bounds
from flatland_ma.scenario.budget import check_budget
from flatland_ma.scenario.checks import RESERVED_NAMES, check_names, check_teams
from flatland_ma.scenario.spec_agent import (
    AgentSpec,
    ArmSegmentSpec,
    ArmSpec,
    CameraSpec,
    ChannelSpec,
    GrasperSpec,
    HeadSpec,
    SpawnSpec,
    TeamSpec,
)
from flatland_ma.scenario.spec_objects import (
    BoxObstacle,
    CircleObstacle,
    ItemSpec,
    ObstacleBase,
    PolygonObstacle,
)
from flatland_ma.scenario.spec_reference import ReferenceSpec
from flatland_ma.scenario.spec_rules import ContactRewardSpec, RuleSpec, StepRewardSpec
from flatland_ma.scenario.spec_scenario import EpisodeSpec, PhysicsSpec, ScenarioFields
from flatland_ma.scenario.spec_world import (
    ArenaSpec,
    CorridorSpec,
    DoorSpec,
    GridRoomsSpec,
    LayoutSpec,
    MazeSpec,
    OpeningSpec,
    RandomObstaclesSpec,
    RoomSpec,
    WallSpec,
    WallStyle,
    ZoneSpec,
)
from flatland_ma.scenario.types import TextureSpec

__all__ = [
    "AgentSpec",
    "ChannelSpec",
    "ArmSegmentSpec",
    "ArmSpec",
    "GrasperSpec",
    "HeadSpec",
    "TeamSpec",
    "ArenaSpec",
    "BoxObstacle",
    "CameraSpec",
    "ContactRewardSpec",
    "RuleSpec",
    "StepRewardSpec",
    "CircleObstacle",
    "CorridorSpec",
    "DoorSpec",
    "EpisodeSpec",
    "GridRoomsSpec",
    "ItemSpec",
    "LayoutSpec",
    "MazeSpec",
    "ObstacleBase",
    "OpeningSpec",
    "PhysicsSpec",
    "PolygonObstacle",
    "RandomObstaclesSpec",
    "ReferenceSpec",
    "RoomSpec",
    "ScenarioSpec",
    "SpawnSpec",
    "TextureSpec",
    "WallSpec",
    "WallStyle",
    "ZoneSpec",
    "RESERVED_NAMES",
]


# A scenario file's contents, checked: each section by its own spec, then what spans
# sections (the work budget, bounds, names, teams). No docstring: the JSON schema would
# take it as the file's description, which json_schema.py writes.
class ScenarioSpec(ScenarioFields):
    @model_validator(mode="before")
    @classmethod
    def _team_bodies(cls, data):
        """A team's ``agent`` mapping takes the keys it leaves out from the top-level one."""
        if not isinstance(data, dict) or not isinstance(data.get("teams"), (list, tuple)):
            return data
        base = data.get("agent", {})
        if isinstance(base, AgentSpec):
            base = {key: getattr(base, key) for key in base.model_fields_set}
        if not isinstance(base, dict):
            return data  # the field's own validation reports it
        teams = []
        for team in data["teams"]:
            own = team.get("agent") if isinstance(team, dict) else None
            if isinstance(own, dict):
                team = {**team, "agent": {**base, **own}}
            teams.append(team)
        return {**data, "teams": teams}

    @model_validator(mode="after")
    def _cross_checks(self):
        check_budget(self)  # first: the other checks then run over bounded totals
        check_bounds(self)
        check_names(self)
        check_teams(self)
        return self
