"""Room to place things at random, with a margin: what is drawn must cover only part of
the free floor it is drawn on.

Discs dropped one by one at random places jam long before they fill the floor (random
sequential adsorption stops near 55% cover), so a scenario whose agents and items fit at
one seed may not fit at another. ``check_capacity`` asks each group of things placed at
random (the agents of one spawn area, one item group), with the groups drawn over the same
floor counted in proportion to the overlap, to cover at most ``MAX_COVER`` of it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flatland_ma.build.bodies import footprint, make_parts
from flatland_ma.scenario.errors import KeyPath, SpecError, format_path
from flatland_ma.scenario.spec_agent import SpawnSpec
from flatland_ma.world.placement import Placer

MAX_COVER = 0.3
"""The largest share of the free floor that discs placed at random may cover."""


@dataclass(frozen=True)
class SpawnGroup:
    """Agents that start in one spawn area: those of a team with its own, or the rest."""

    team: int | None
    spawn: SpawnSpec
    size: int
    count_path: KeyPath
    """The key that says how many agents start there."""

    @property
    def area_path(self) -> KeyPath | None:
        """The key of the spawn area, if one is given."""
        if self.spawn.area is None:
            return None
        if self.team is None:
            return ("agent", "spawn", "area")
        return ("teams", self.team, "spawn", "area")

    def fault_path(self, k: int) -> KeyPath:
        """Where to report that its ``k``-th agent found no room."""
        if self.area_path is not None:
            return self.area_path
        return ("agent", "radius") if k == 0 else self.count_path


def spawn_groups(spec) -> list[SpawnGroup]:
    """The spawn groups of a scenario, the agents' own spawn (if anyone uses it) first."""
    own = [t for t, team in enumerate(spec.teams) if team.spawn is not None]
    rest = spec.n_agents - sum(spec.teams[t].size for t in own)
    groups = [SpawnGroup(None, spec.agent.spawn, rest, ("n_agents",))] if rest else []
    for t in own:
        team = spec.teams[t]
        groups.append(SpawnGroup(t, team.spawn, team.size, ("teams", t, "size")))
    return groups


def spawn_group_of(spec, groups: list[SpawnGroup], agent: int) -> SpawnGroup:
    team = spec.team_of(agent)
    index = spec.teams.index(team) if team is not None and team.spawn is not None else None
    return next(g for g in groups if g.team == index)


@dataclass(frozen=True)
class _Draw:
    """Discs drawn at random over some cells."""

    what: str
    n: int
    radius: float
    area: tuple | None
    cells: np.ndarray
    area_path: KeyPath | None
    count_path: KeyPath
    radius_path: KeyPath


def check_capacity(spec, placer: Placer) -> None:
    """Raise ``SpecError`` where things placed at random would crowd their floor."""
    draws = [d for d in _draws(spec, placer) if d.n > 0 and d.cells.any()]
    cell_area = placer.grid.cell**2
    sizes = [int(d.cells.sum()) for d in draws]  # no place at all: reported when placed
    for d, size in zip(draws, sizes):
        free = size * cell_area
        one = math.pi * (d.radius + 0.5) ** 2
        if one > MAX_COVER * free:
            raise SpecError(
                d.area_path or d.radius_path,
                f"no room to place every {d.what}: one of radius {d.radius:g} covers "
                f"{one / free:.0%} of the free floor{_where(d)}; at most {MAX_COVER:.0%} "
                "leaves room to place things at random",
            )
    for d, size in zip(draws, sizes):
        free = size * cell_area
        shares = [
            e.n * math.pi * (e.radius + 0.5) ** 2 * int((e.cells & d.cells).sum()) / other
            for e, other in zip(draws, sizes)
        ]
        cover = sum(shares)
        if cover > MAX_COVER * free:
            e = draws[shares.index(max(shares))]
            raise SpecError(
                e.area_path or (e.count_path if e.n > 1 else e.radius_path),
                f"no room to place every {e.what}: {e.n} of radius {e.radius:g}, with what "
                f"else is placed at random there, cover {cover / free:.0%} of the free "
                f"floor{_where(d)}; at most {MAX_COVER:.0%} leaves room to place them at "
                "random (use fewer or smaller ones, or a larger area)",
            )


def _where(draw) -> str:
    return f" in {format_path(draw.area_path)}" if draw.area_path else ""


def _draws(spec, placer: Placer) -> list[_Draw]:
    reach = footprint(spec.agent, make_parts(spec.agent))
    draws = [
        _Draw(
            "agent",
            group.size,
            reach,
            group.spawn.area,
            placer.mask(group.spawn.area),
            group.area_path,
            group.count_path,
            ("agent", "radius"),
        )
        for group in spawn_groups(spec)
    ]
    for g, item in enumerate(spec.items):
        if item.positions is None:
            area_path = ("items", g, "spawn") if item.spawn is not None else None
            draws.append(
                _Draw(
                    "item",
                    item.count,
                    item.radius,
                    item.spawn,
                    placer.mask(item.spawn),
                    area_path,
                    ("items", g, "count"),
                    ("items", g, "radius"),
                )
            )
    return draws
