"""What agents can reach: the free cells connected to where they start, with doors as gates.

Hinged doors, open doors and closed sliding doors (which open to a touch) are passable. A
locked door, or one worked by a switch, is a wall until something that opens it can be
reached: an item of its key group, a key object, or its switch zone. Reachability grows to
a fixed point: flood from the starts, open every gate with an opener in the flooded
region, flood again, until no more gates open.

An opener drawn at random (key items, zones placed at random) must be reachable wherever
it is drawn: every place it may be drawn must be reachable without the gates it opens.
Then every fixed item, zone and spawn area of items must be reachable.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flatland_ma.scenario.errors import KeyPath, SpecError, format_path
from flatland_ma.world.entities import Door
from flatland_ma.world.navigation import NavGrid
from flatland_ma.world.placement import OutOfBudget, ResetBudget


@dataclass(frozen=True, eq=False)
class Opener:
    """Something that opens gates: reached from any of ``cells``. One drawn at random
    (``area`` is then the key path of where it is drawn) may land on any of them."""

    path: KeyPath
    cells: np.ndarray
    area: KeyPath | None = None
    hint: str = ""
    """For one drawn at random: how to keep it out of reach of its own gates."""


@dataclass(frozen=True, eq=False)
class Gate:
    door: Door
    cells: np.ndarray
    """The cells it blocks while closed."""
    openers: tuple[Opener, ...]


def reachable_region(
    spec, grid: NavGrid, doors: list[Door], start: np.ndarray, budget: ResetBudget
) -> np.ndarray:
    """The cells agents starting in ``start`` can reach, opening gates as they go; raise
    ``SpecError`` at an opener that could be drawn behind its own gate, or at an item or a
    zone agents cannot reach. Each search of the grid is paid from ``budget``."""
    gates = [g for g in (_gate(spec, grid, d) for d in doors) if g is not None]
    try:
        region, opened = _flood(grid, start, gates, budget)
        drawn = {o.path: o for g, is_open in zip(gates, opened) if is_open for o in g.openers}
        for opener in drawn.values():
            if opener.area is not None:
                _check_drawn_opener(grid, start, gates, region, opener, budget)
        closed = [format_path(g.door.path) for g, is_open in zip(gates, opened) if not is_open]
        if closed:
            budget.searched(grid.blocked.size)
        all_open = grid.reachable(start) if closed else region
    except OutOfBudget as err:
        path = gates[0].door.path if gates else ("arena", "size")
        raise SpecError(path, f"could not check what agents can reach: {err}") from None
    _check_targets(spec, grid, region, all_open, closed)
    return region


def _flood(
    grid: NavGrid,
    start,
    gates: list[Gate],
    budget: ResetBudget,
    without: KeyPath | None = None,
):
    """The fixed point: the region reached and which gates opened (``without`` one opener)."""
    opened = [False] * len(gates)
    while True:
        budget.searched(grid.blocked.size)
        blocked = grid.blocked.copy()
        for gate, is_open in zip(gates, opened):
            if not is_open:
                blocked |= gate.cells
        trial = grid.copy()
        trial.blocked = blocked
        region = trial.reachable(start)
        changed = False
        for k, gate in enumerate(gates):
            if not opened[k] and any(
                o.path != without and (o.cells & region).any() for o in gate.openers
            ):
                opened[k] = changed = True
        if not changed:
            return region, opened


def _check_drawn_opener(grid, start, gates, region, opener: Opener, budget) -> None:
    places = opener.cells & region
    without, _ = _flood(grid, start, gates, budget, without=opener.path)
    if (places & ~without).any():
        opens = [
            format_path(g.door.path) for g in gates if any(o.path == opener.path for o in g.openers)
        ]
        raise SpecError(
            opener.area or opener.path,
            f"{format_path(opener.path)} may be drawn where agents can only go through "
            f"{', '.join(opens)}, which it opens; {opener.hint}",
        )


def _check_targets(spec, grid: NavGrid, region, all_open, closed: list[str]) -> None:
    """Every fixed item, zone and item spawn area must be reachable (``all_open``: what
    would be, were every door open, to say which doors are in the way)."""

    def fault(path, message, behind_doors: bool) -> SpecError:
        if closed and behind_doors:
            which = "it never opens" if len(closed) == 1 else "they never open"
            message += f" (behind {', '.join(closed)}: {which}, nothing that opens "
            message += f"{'it' if len(closed) == 1 else 'them'} is reachable)"
        return SpecError(path, message)

    for g, item in enumerate(spec.items):
        if item.positions is not None:
            for k, (x, y) in enumerate(item.positions):
                cell = grid.cell_of(x, y)
                if not region[cell]:
                    path = ("items", g, "positions", k)
                    raise fault(path, "agents cannot reach this place", all_open[cell])
        elif item.spawn is not None and item.count > 0:
            cells = grid.cells_in(item.spawn) & ~grid.blocked
            if not (cells & region).any():
                message = "no free place in the area that agents can reach"
                raise fault(("items", g, "spawn"), message, (cells & all_open).any())
    for z, zone in enumerate(spec.zones):
        cells, path = _zone_cells(grid, zone), ("zones", z)
        if not (cells & region).any():
            behind = (cells & all_open).any()
            if zone.rect is not None:
                raise fault(path + ("rect",), "agents cannot reach this zone", behind)
            path += ("area",) if zone.area is not None else ("size",)
            raise fault(path, "no place for the zone where agents can reach it", behind)


def _zone_cells(grid: NavGrid, zone) -> np.ndarray:
    """Cells from which an agent's centre is in the zone (for a zone placed at random: the
    cells its centre may be drawn on)."""
    if zone.rect is not None:
        return grid.cells_in(zone.rect, grow=grid.cell / 2)
    w, h = zone.size
    x0, y0, x1, y1 = zone.area or (0.0, 0.0, *grid.size)
    return grid.cells_in((x0 + w / 2, y0 + h / 2, x1 - w / 2, y1 - h / 2)) & ~grid.blocked


def _gate(spec, grid: NavGrid, door: Door) -> Gate | None:
    """The door as a gate, or None if agents pass it anyway."""
    if not door.needs_opener:
        return None
    openers = []
    key = door.gate_key
    if door.switch is not None:
        for z, zone in enumerate(spec.zones):
            if zone.name == door.switch:
                openers.append(_zone_opener(grid, z, zone))
    elif key is not None:
        for g, item in enumerate(spec.items):
            if item.key and item.name == key and item.n_items > 0:
                openers.append(_item_opener(grid, g, item))
    if key is not None:
        for o, obstacle in enumerate(spec.obstacles):
            if obstacle.key == key:
                x, y = obstacle.position
                r = obstacle.bounding_radius() + grid.clearance + grid.cell
                cells = grid.cells_in((x - r, y - r, x + r, y + r))
                openers.append(Opener(("obstacles", o), cells))
    cells = np.zeros_like(grid.blocked)
    for shape in door.shapes:
        cells |= grid.shape_mask(shape)
    return Gate(door, cells, tuple(openers))


def _item_opener(grid: NavGrid, g: int, item) -> Opener:
    if item.positions is not None:
        cells = np.zeros_like(grid.blocked)
        for x, y in item.positions:
            cells[grid.cell_of(x, y)] = True
        return Opener(("items", g), cells)
    cells = grid.cells_in(item.spawn) & ~grid.blocked
    if item.spawn is not None:
        hint = "keep its spawn area where agents can go without it"
        return Opener(("items", g), cells, ("items", g, "spawn"), hint)
    hint = "give it a 'spawn' area where agents can go without it"
    return Opener(("items", g), cells, ("items", g), hint)


def _zone_opener(grid: NavGrid, z: int, zone) -> Opener:
    cells = _zone_cells(grid, zone)
    if zone.rect is not None:
        return Opener(("zones", z), cells)
    if zone.area is not None:
        hint = "keep its area where agents can go without it"
        return Opener(("zones", z), cells, ("zones", z, "area"), hint)
    hint = "give it an 'area' where agents can go without it"
    return Opener(("zones", z), cells, ("zones", z, "size"), hint)
