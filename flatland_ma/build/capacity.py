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
from flatland_ma.scenario.spec_agent import AgentSpec, SpawnSpec
from flatland_ma.world.placement import Placer

MAX_COVER = 0.3
"""The largest share of the free floor that discs placed at random may cover."""


@dataclass(frozen=True)
class SpawnGroup:
    """Agents that start in one spawn area with one body: those of a team with a spawn or
    a body of its own, or the rest."""

    team: int | None
    spawn: SpawnSpec
    size: int
    count_path: KeyPath
    """The key that says how many agents start there."""
    agent: AgentSpec
    """Their body."""
    spawn_path: KeyPath = ("agent", "spawn")
    """Where their ``spawn`` is written."""
    body_path: KeyPath = ("agent",)
    """Where their body is written."""

    @property
    def area_path(self) -> KeyPath | None:
        """The key of the spawn area, if one is given."""
        if self.spawn.area is None:
            return None
        return self.spawn_path + ("area",)

    def fault_path(self, k: int) -> KeyPath:
        """Where to report that its ``k``-th agent found no room."""
        if self.area_path is not None:
            return self.area_path
        return self.body_path + ("radius",) if k == 0 else self.count_path


def _own_group(team) -> bool:
    return team.spawn is not None or team.agent is not None


def spawn_groups(spec) -> list[SpawnGroup]:
    """The spawn groups of a scenario, the agents' own spawn (if anyone uses it) first."""
    own = [t for t, team in enumerate(spec.teams) if _own_group(team)]
    rest = spec.n_agents - sum(spec.teams[t].size for t in own)
    groups = [SpawnGroup(None, spec.agent.spawn, rest, ("n_agents",), spec.agent)] if rest else []
    first = 0
    for t, team in enumerate(spec.teams):
        if t in own:
            body_path = ("teams", t, "agent") if team.agent is not None else ("agent",)
            spawn_path = ("teams", t, "spawn") if team.spawn is not None else body_path + ("spawn",)
            spawn, body = spec.spawn_of(first), spec.agent_of(first)
            groups.append(
                SpawnGroup(t, spawn, team.size, ("teams", t, "size"), body, spawn_path, body_path)
            )
        first += team.size
    return groups


def spawn_group_of(spec, groups: list[SpawnGroup], agent: int) -> SpawnGroup:
    team = spec.team_of(agent)
    index = spec.teams.index(team) if team is not None and _own_group(team) else None
    return next(g for g in groups if g.team == index)


@dataclass(frozen=True)
class _Draw:
    """Discs drawn at random over the free cells of an area."""

    what: str
    n: int
    radius: float
    area: tuple | None
    area_path: KeyPath | None
    count_path: KeyPath
    radius_path: KeyPath


class _FreeCells:
    """How many cells of the placer's (free, reachable) ones lie in any rectangle, in
    constant time: a summed-area table, so that many groups over a large arena cost
    no more than one grid's worth of work."""

    def __init__(self, placer: Placer):
        grid = placer.grid
        self.table = np.zeros((grid.ny + 1, grid.nx + 1), np.int32)
        self.table[1:, 1:] = placer.mask(None).cumsum(0, dtype=np.int32).cumsum(1)
        self.xs, self.ys = grid.xs, grid.ys

    def count(self, rect: tuple) -> int:
        """Cells whose centre lies in ``rect`` (edges included, as ``NavGrid.cells_in``)."""
        x0, y0, x1, y1 = rect
        j0, j1 = np.searchsorted(self.xs, x0, "left"), np.searchsorted(self.xs, x1, "right")
        i0, i1 = np.searchsorted(self.ys, y0, "left"), np.searchsorted(self.ys, y1, "right")
        if i1 <= i0 or j1 <= j0:
            return 0
        t = self.table
        return int(t[i1, j1] - t[i0, j1] - t[i1, j0] + t[i0, j0])


_EVERYWHERE = (-math.inf, -math.inf, math.inf, math.inf)


def _overlap(a: tuple, b: tuple) -> tuple:
    return (max(a[0], b[0]), max(a[1], b[1]), min(a[2], b[2]), min(a[3], b[3]))


def check_capacity(spec, placer: Placer) -> None:
    """Raise ``SpecError`` where things placed at random would crowd their floor."""
    free_cells = _FreeCells(placer)
    rects = {}
    for d in _draws(spec):
        rects[d] = tuple(d.area) if d.area is not None else _EVERYWHERE
    sizes = {d: free_cells.count(r) for d, r in rects.items()}
    # No place at all is reported when placed.
    draws = [d for d in rects if d.n > 0 and sizes[d] > 0]
    cell_area = placer.grid.cell**2
    for d in draws:
        free = sizes[d] * cell_area
        one = math.pi * (d.radius + 0.5) ** 2
        if one > MAX_COVER * free:
            raise SpecError(
                d.area_path or d.radius_path,
                f"no room to place every {d.what}: one of radius {d.radius:g} covers "
                f"{one / free:.0%} of the free floor{_where(d)}; at most {MAX_COVER:.0%} "
                "leaves room to place things at random",
            )
    for d in draws:
        free = sizes[d] * cell_area
        shares = [
            e.n
            * math.pi
            * (e.radius + 0.5) ** 2
            * free_cells.count(_overlap(rects[e], rects[d]))
            / sizes[e]
            for e in draws
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


def _draws(spec) -> list[_Draw]:
    draws = [
        _Draw(
            "agent",
            group.size,
            footprint(group.agent, make_parts(group.agent)),
            group.spawn.area,
            group.area_path,
            group.count_path,
            group.body_path + ("radius",),
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
                    area_path,
                    ("items", g, "count"),
                    ("items", g, "radius"),
                )
            )
    return draws
