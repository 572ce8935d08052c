"""A search-based solver that knows the whole world (privileged: it reads the env's state,
not its observation). It proves a scenario solvable and gives a reference score.

Each step it plans on the occupancy grid: walls and fixed obstacles block, and so do
doors it cannot open now and the surroundings of anything with a negative reward. It
walks the shortest path to the nearest thing worth having (a positive item or zone);
when nothing is reachable it fetches what opens the way: the key of a locked door, or the
switch zone of a closed one.
"""

from __future__ import annotations

import math

import numpy as np

from flatland_ma.policies.motion import BaseMotion
from flatland_ma.world.entities import Item
from flatland_ma.world.navigation import UNREACHED

LOOKAHEAD = 3
"""Grid steps along the path to the point the agent aims at."""
KEEP_MARGIN = 8
"""A target stays chosen unless another is this many grid steps nearer."""
STUCK_STEPS = 12
"""Forward steps with no progress before the agent turns away to get unstuck."""


class PlannerPolicy:
    def __init__(self, env, agent: str):
        self.env = env
        self.index = env.possible_agents.index(agent)
        spec = env.spec
        body = spec.agent_of(self.index)
        self.discrete = body.actions == "discrete"
        self.motion = BaseMotion(body, spec.channel)
        self.radius = body.radius
        self.turn_step = math.radians(body.max_turn_rate) * spec.physics.dt
        self.aim = self.turn_step * 0.6
        self.reset()

    def reset(self) -> None:
        self._target: tuple | None = None
        self._stuck = 0
        self._escape = 0
        self._escape_turn = 1.0
        self._last = None

    def act(self, observation=None):
        forward, turn = self._decide()
        return self.motion.action(forward, turn)

    def _decide(self) -> tuple[float, float]:
        episode = self.env.episode
        me = episode.bodies[self.index].body
        x, y = me.position
        self._check_progress((x, y, me.angle))
        if self._escape > 0:
            self._escape -= 1
            turn = self._escape_turn
            return (0.0, turn) if self._escape > 2 else (1.0, 0.0)
        for avoid in (True, False):  # hemmed in by bad things: go through them
            grid = self._planning_grid(episode, avoid)
            here = grid.cell_of(x, y)
            _free_around(grid, here)
            from_me = grid.distances(mask_at(grid, [here]))
            goal = self._choose(episode, grid, from_me)
            if goal is not None:
                break
        else:
            return 0.0, 1.0  # nothing to do: look around
        to_goal = grid.distances(goal)
        # LOOKAHEAD steps of a grid made for this agent (cells half its radius): on the
        # finer grid of a slimmer agent's scenario, as far in units.
        steps = max(LOOKAHEAD, round(LOOKAHEAD * self.radius / (2 * grid.cell)))
        waypoint = descend(to_goal, here, steps)
        wx, wy = grid.centre(*waypoint) if waypoint != here else self._target_point
        angle = wrap_angle(math.atan2(wy - y, wx - x) - me.angle)
        if abs(angle) > self.aim:
            self._escape_turn = -1.0 if angle > 0 else 1.0  # if stuck, try the other way
            return (
                (0.0, 1.0 if angle > 0 else -1.0)
                if self.discrete
                else (0.3, np.clip(angle / self.turn_step, -1, 1))
            )
        self._escape_turn = 1.0
        return 1.0, 0.0

    def _check_progress(self, pose) -> None:
        """Count the steps in which the agent neither moved nor turned; past
        ``STUCK_STEPS`` of them, turn away and step off to get free."""
        last = self._last
        if (
            last is not None
            and math.dist(pose[:2], last[:2]) < 0.5
            and abs(pose[2] - last[2]) < 0.02
        ):
            self._stuck += 1
            if self._stuck >= STUCK_STEPS:
                self._stuck, self._escape = 0, 6
        else:
            self._stuck = 0
        self._last = pose

    def _planning_grid(self, episode, avoid: bool):
        keys = episode.task.records[self.index].keys
        grid = round_doors(episode.grid_for(self.radius), episode.doors, keys)
        if not avoid:
            return grid
        for item in episode.world.of_type(Item):
            if item.visible and item.reward < 0:
                grid.block_shape(item.shapes[0], extra=1.0)
        for zone in episode.world.zones:
            if zone.reward < 0:
                grid.blocked |= grid.cells_in(zone.rect)
        return grid

    def _choose(self, episode, grid, from_me):
        """Cells of the goal to walk to: the nearest worthwhile target, else what opens
        the way to one."""
        record = episode.task.records[self.index]
        wanted = []
        for item in episode.world.of_type(Item):
            if item.visible and (item.reward > 0 or self._needed_key(episode, item, record)):
                wanted.append((("item", item.index), item.body.position, None))
        zones = episode.world.zones
        for z, zone in enumerate(zones):
            if zone.reward > 0 and not (zone.once and z in record.visited):
                wanted.append((("zone", z), None, zone.rect))
        switch_zones = {d.switch for d in episode.doors if d.switch and not d.is_open}
        for z, zone in enumerate(zones):
            if zone.name in switch_zones:
                wanted.append((("switch", z), None, zone.rect))
        best, best_d, kept = None, UNREACHED, None
        for key, point, rect in wanted:
            mask = mask_at(grid, [grid.cell_of(*point)]) if rect is None else grid.cells_in(rect)
            d = from_me[mask].min(initial=UNREACHED)
            if d == UNREACHED:
                continue
            if key[0] == "switch" and best is not None and best[0][0] != "switch":
                continue  # a switch only matters when nothing better is in reach
            if best is None or d < best_d or (best[0][0] == "switch" and key[0] != "switch"):
                best, best_d = (key, mask, point, rect), d
            if key == self._target:
                kept = (key, mask, point, rect, d)
        if best is None:
            self._target = None
            return None
        if kept is not None and kept[4] <= best_d + KEEP_MARGIN:
            best = kept[:4]
        self._target = best[0]
        point, rect = best[2], best[3]
        self._target_point = (
            point if rect is None else ((rect[0] + rect[2]) / 2, (rect[1] + rect[3]) / 2)
        )
        return best[1]

    def _needed_key(self, episode, item: Item, record) -> bool:
        group = item.group
        if not group.key or group.name in record.keys:
            return False
        return any(d.gate_key == group.name and not d.is_open for d in episode.doors)


def round_doors(grid, doors, keys: set[str]):
    """A copy of ``grid`` with the doors that stop an agent holding ``keys`` blocked
    (e.g. locked, or a hinged one swung aside)."""
    grid = grid.copy()
    for door in doors:
        if door.blocks(keys):
            grid.block_shape(door.shapes[0])
    return grid


def _free_around(grid, cell, cells: int = 2) -> None:
    """Unblock the cells next to the agent: it is there, so it can move a little (the grid
    is coarse, and being shoved into a corner must not leave it without a way out)."""
    i, j = cell
    grid.blocked[max(0, i - cells) : i + cells + 1, max(0, j - cells) : j + cells + 1] = False


def mask_at(grid, cells) -> np.ndarray:
    mask = np.zeros_like(grid.blocked)
    for i, j in cells:
        mask[i, j] = True
    return mask


def descend(dist: np.ndarray, cell: tuple[int, int], steps: int) -> tuple[int, int]:
    """Follow the distance field down from ``cell`` for ``steps`` cells."""
    ny, nx = dist.shape
    i, j = cell
    for _ in range(steps):
        best = (dist[i, j], i, j)
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                a, b = i + di, j + dj
                if 0 <= a < ny and 0 <= b < nx and dist[a, b] < best[0]:
                    best = (dist[a, b], a, b)
        if (best[1], best[2]) == (i, j):
            break
        i, j = best[1], best[2]
    return i, j


def wrap_angle(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi
