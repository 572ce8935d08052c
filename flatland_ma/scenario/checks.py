"""Checks that span sections of a scenario: names that refer to each other (keys, switches,
teams, tags) and team sizes."""

from __future__ import annotations

from typing import TYPE_CHECKING

from flatland_ma.scenario.errors import KeyPath, SpecError

if TYPE_CHECKING:
    from flatland_ma.scenario.spec_scenario import ScenarioFields

RESERVED_NAMES = ("score", "keys", "deliveries")
"""Keys of ``infos[agent]`` that item groups may not take."""


def check_teams(spec: ScenarioFields) -> None:
    if spec.channel is not None and spec.channel.team and not spec.teams:
        raise SpecError(("channel", "team"), "a channel for teammates only needs 'teams'")
    if not spec.teams:
        for i, zone in enumerate(spec.zones):
            if zone.team is not None:
                raise SpecError(("zones", i, "team"), f"no team {zone.team!r}: no teams")
        return
    names = [t.name for t in spec.teams]
    for i, name in enumerate(names):
        if name in names[:i]:
            raise SpecError(("teams", i, "name"), f"team name {name!r} used twice")
    total = sum(t.size for t in spec.teams)
    if total != spec.n_agents:
        raise SpecError(("n_agents",), f"the teams have {total} agents, not {spec.n_agents}")
    for i, zone in enumerate(spec.zones):
        if zone.team is not None and zone.team not in names:
            raise SpecError(("zones", i, "team"), f"no team {zone.team!r}; teams: {names}")


def check_names(spec: ScenarioFields) -> None:
    groups = [item.name for item in spec.items]
    for i, name in enumerate(groups):
        if name in groups[:i]:
            raise SpecError(("items", i, "name"), f"item name {name!r} used twice")
        if name in RESERVED_NAMES:
            raise SpecError(("items", i, "name"), f"{name!r} is reserved for infos")
    zones = [z.name for z in spec.zones if z.name is not None]
    for i, zone in enumerate(spec.zones):
        if zone.name is not None and zones.count(zone.name) > 1:
            raise SpecError(("zones", i, "name"), f"zone name {zone.name!r} used twice")
    keys = {item.name for item in spec.items if item.key}
    keys |= {o.key for o in spec.obstacles if o.key is not None}
    door_names: list[str] = []
    for path, door in spec.all_doors():
        if door.key is not None and door.key not in keys:
            raise SpecError(
                path + ("key",),
                f"no key item group or key object {door.key!r}; keys: {sorted(keys)}",
            )
        if door.switch is not None and door.switch not in zones:
            raise SpecError(path + ("switch",), f"no zone named {door.switch!r}; zones: {zones}")
        if door.name is not None:
            if door.name in door_names:
                raise SpecError(path + ("name",), f"door name {door.name!r} used twice")
            door_names.append(door.name)
    for path, door in spec.all_doors():
        if path[0] == "doors" and door.start is None:
            raise SpecError(path, "a door outside a room opening needs 'start' and 'end'")
    tags = {o.tag for o in spec.obstacles if o.tag is not None}
    for i, zone in enumerate(spec.zones):
        if zone.accepts is not None and zone.accepts not in tags:
            raise SpecError(
                ("zones", i, "accepts"),
                f"no object with tag {zone.accepts!r}; tags: {sorted(tags)}",
            )
    eaten = spec.episode.end_when_eaten
    if eaten is not None and eaten not in groups:
        raise SpecError(
            ("episode", "end_when_eaten"),
            f"no item group {spec.episode.end_when_eaten!r}; groups: {groups}",
        )
    for path, agent, _ in spec.agent_kinds():
        for k, sensor in enumerate(agent.sensor_specs):
            for j, source in enumerate(getattr(sensor, "sources", None) or ()):
                if source not in groups:
                    raise SpecError(
                        path + ("sensors", k, "sources", j),
                        f"no item group {source!r} to smell; groups: {groups}",
                    )


def wall_thicknesses(spec: ScenarioFields) -> list[tuple[KeyPath, float]]:
    """Every wall thickness a scenario sets, with its key path (the arena's first)."""
    walls: list[tuple[KeyPath, float]] = [
        (("arena", "wall", "thickness"), spec.arena.wall.thickness)
    ]
    for key in ("walls", "rooms", "corridors"):
        for i, piece in enumerate(getattr(spec, key)):
            if piece.thickness is not None:
                walls.append(((key, i, "thickness"), piece.thickness))
    for gen_index, gen in enumerate(spec.layout.generators):
        thickness = getattr(gen, "thickness", None)  # not every generator draws walls
        if thickness is not None:
            walls.append((("layout", "generators", gen_index, "thickness"), thickness))
    return walls
