"""A scripted forager that acts from its own observations only.

It reads each ray's true colour from the image (dividing out the distance falloff) and
recognises items with a positive reward (targets) and a negative one (to avoid) by their
colour. What it has seen is kept in an egocentric memory that moves with its own turns
and steps (odometry), so that a poison or a corner just out of view still counts.

It commits to the cheapest target it can reach without its body brushing a bad item or
anything solid: in a straight line, or through one intermediate point when something is in
the way. It turns to face where it is going and walks. A target that vanishes (another agent
took it, or something hides it), turns out unreachable or takes too long is dropped and
avoided for a while. With
no target it walks towards the most open direction, which soon brings new targets in view.
"""

from __future__ import annotations

import math

import numpy as np

from flatland_ma.policies.camera_view import CameraView, matches
from flatland_ma.policies.motion import BaseMotion
from flatland_ma.scenario.schema import ScenarioSpec

MEMORY_STEPS = 40
"""How many steps a point seen stays in memory once out of view."""
PATIENCE = 80
"""Steps allowed to reach a committed target before giving it up."""
BAN_STEPS = 60
"""Steps during which a given-up target is not chosen again."""
MATCH_DISTANCE = 12.0
"""How close a sighting must be to the predicted target position to be the target."""
DITHER_TURNS = 6
"""This many turns alternating left and right make the agent drop its target."""
DETOUR_HEADINGS = 36
"""Headings, evenly around the agent, tried for the first leg of a detour."""
DETOUR_LENGTHS = (20.0, 40.0, 60.0, 90.0)
"""Lengths tried for the first leg of a detour."""


class GreedyForager:
    def __init__(self, spec: ScenarioSpec, agent: int = 0):
        """Drives agent number ``agent`` of ``spec`` (its body, camera and actions)."""
        body = spec.agent_of(agent)
        self.view = view = CameraView(spec, agent, "the greedy forager")
        self.angles = view.angles
        self.half_fov = view.half_fov
        self.ux, self.uy = np.cos(self.angles), np.sin(self.angles)
        self.range = view.range
        self.discrete = body.actions == "discrete"
        self.motion = BaseMotion(body, spec.channel)
        self.good = np.array([i.color for i in spec.items if i.reward > 0], np.float64)
        self.bad = np.array([i.color for i in spec.items if i.reward < 0], np.float64)
        self.neutral = np.array([i.color for i in spec.items if i.reward == 0], np.float64)
        self.item_radius = max((i.radius for i in spec.items), default=0.0)
        self.radius = body.radius
        self.turn_step = math.radians(body.max_turn_rate) * spec.physics.dt
        self.step_length = body.max_speed * spec.physics.dt
        ray_spacing = math.radians(view.spec.fov) / view.spec.rays
        self.aim_tolerance = self.turn_step / 2 + ray_spacing
        """Facing a point this closely is enough: ray sampling can't place it better."""
        self.full_turn = math.ceil(2 * math.pi / self.turn_step)
        headings = np.linspace(-math.pi, math.pi, DETOUR_HEADINGS, endpoint=False)
        lengths = np.array(DETOUR_LENGTHS)
        self._detour_heading = np.repeat(headings, len(lengths))
        self._detour_points = np.stack(
            [
                np.outer(np.cos(headings), lengths).ravel(),
                np.outer(np.sin(headings), lengths).ravel(),
            ],
            axis=1,
        )
        self.reset()

    def reset(self) -> None:
        """Forget everything; call at the start of each episode."""
        self._memory = np.zeros((0, 4))  # blocking points: x, y (agent frame), age, half-width
        self._banned = np.zeros((0, 3))  # given-up targets: x, y, age
        self._target: np.ndarray | None = None
        self._via: np.ndarray | None = None
        self._target_age = 0
        self._waypoint: np.ndarray | None = None
        self._turn_sign = 1
        self._scanning = 0
        self._last = (0.0, 0.0)
        self._turns: list[float] = []

    def act(self, observation):
        """The action for one observation: the camera's image (rays, channels), or a
        ``Dict`` holding it."""
        forward, turn = self._decide(self.view.image(observation))
        self._last = (forward, turn)
        self._turns = self._turns[-DITHER_TURNS:] + [np.sign(turn)]
        return self.motion.action(forward, turn)

    # -- perception and memory --------------------------------------------------------

    def _decide(self, obs: np.ndarray) -> tuple[float, float]:
        self._move_memory()
        depth = obs[:, 3]
        distance = depth * self.range
        colour, readable = self.view.colours(obs)
        good = readable & matches(colour, self.good)
        bad = readable & matches(colour, self.bad)
        solid = (depth < 1.0) & ~good & ~bad & ~matches(colour, self.neutral)
        px, py = distance * self.ux, distance * self.uy
        seen = [
            _points(px[bad], py[bad], self.radius + self.item_radius + 1.0),
            _points(px[solid], py[solid], self.radius - 1.0),
        ]
        self._memory = np.concatenate([self._memory] + seen)
        targets = _item_centres(good, px, py, self.item_radius)

        if self._target is not None:
            self._follow_target(targets)
        if self._target is None:
            self._pick_target(targets)
        if self._target is not None:
            self._scanning = 0
            self._waypoint = None
            goal = self._via if self._via is not None else self._target
            if self._via is not None and np.hypot(*goal) < self.step_length:
                self._via = None
                goal = self._target
            return self._go_to(goal)
        return self._explore()

    def _move_memory(self) -> None:
        """Move remembered points by the agent's last action; forget old or visible ones."""
        forward, turn = self._last
        a = -turn * self.turn_step
        c, s = math.cos(a), math.sin(a)

        def move(points: np.ndarray) -> np.ndarray:
            points = np.array(points, np.float64, ndmin=2)
            x = points[:, 0] - forward * self.step_length
            y = points[:, 1].copy()
            points[:, 0], points[:, 1] = c * x - s * y, s * x + c * y
            return points

        memory = move(self._memory)
        memory[:, 2] += 1
        bearing = np.abs(np.arctan2(memory[:, 1], memory[:, 0]))
        # Points inside the body can only come from odometry drift (walking into a wall).
        outside = np.hypot(memory[:, 0], memory[:, 1]) > self.radius
        keep = (bearing > self.half_fov) & (memory[:, 2] <= MEMORY_STEPS) & outside
        self._memory = memory[keep]
        banned = move(self._banned)
        banned[:, 2] += 1
        self._banned = banned[banned[:, 2] <= BAN_STEPS]
        for name in ("_target", "_via", "_waypoint"):
            point = getattr(self, name)
            if point is not None:
                setattr(self, name, move(point)[0, :2])

    # -- targets ------------------------------------------------------------------------

    def _follow_target(self, targets: np.ndarray) -> None:
        assert self._target is not None, "no target to follow"
        self._target_age += 1
        x, y = self._target
        if len(targets):
            gaps = np.hypot(targets[:, 0] - x, targets[:, 1] - y)
            nearest = int(np.argmin(gaps))
            if gaps[nearest] < MATCH_DISTANCE:
                self._target = targets[nearest].copy()
            elif self._in_view(x, y):
                self._give_up()  # it should be in view but is gone, or hidden
                return
        elif self._in_view(x, y):
            self._give_up()
            return
        if self._target_age > PATIENCE or self._dithering():
            self._give_up()
            return
        target = self._target
        assert target is not None
        route = self._route(target, keep=self._via)
        if route is None:
            self._give_up()
        else:
            self._via = route[0]

    def _pick_target(self, targets: np.ndarray) -> None:
        best, best_cost = None, math.inf
        for target in targets:
            if len(self._banned):
                if np.hypot(*(self._banned[:, :2] - target).T).min() < MATCH_DISTANCE:
                    continue
            route = self._route(target)
            if route is not None and route[1] < best_cost:
                best, best_cost = (target.copy(), route[0]), route[1]
        self._target_age = 0
        self._target, self._via = best if best is not None else (None, None)

    def _route(self, target: np.ndarray, keep: np.ndarray | None = None):
        """(via point or None, cost in distance units) to reach ``target``, or None."""
        origin = np.zeros((1, 2))
        if (
            keep is not None
            and self._clear(origin, keep[None])[0]
            and self._clear(keep[None], target[None])[0]
        ):
            return keep, self._cost(keep, target)  # stay on the chosen detour
        if self._clear(origin, target[None])[0]:
            return None, self._cost(np.zeros(2), target)
        points = self._detour_points
        ok = self._clear(np.zeros_like(points), points) & self._clear(
            points, np.broadcast_to(target, points.shape)
        )
        if not ok.any():
            return None
        costs = np.array([self._cost(p, target) if o else math.inf for p, o in zip(points, ok)])
        k = int(np.argmin(costs))
        return points[k].copy(), costs[k]

    def _cost(self, via: np.ndarray, target: np.ndarray) -> float:
        """Walking distance plus turning, both in distance units."""
        first = via if np.any(via) else target
        turn = abs(math.atan2(first[1], first[0]))
        length = np.hypot(*first)
        if np.any(via):
            leg = target - via
            turn += abs(_wrap(math.atan2(leg[1], leg[0]) - math.atan2(via[1], via[0])))
            length += np.hypot(*leg)
        return float(length + turn / self.turn_step * self.step_length)

    def _dithering(self) -> bool:
        """Turning left and right in alternation: the aim is not settling."""
        turns = self._turns[-DITHER_TURNS:]
        return len(turns) == DITHER_TURNS and all(a != b for a, b in zip(turns, turns[1:]))

    def _give_up(self) -> None:
        assert self._target is not None, "no target to give up"
        self._banned = np.concatenate([self._banned, [[*self._target[:2], 0.0]]])
        self._target = self._via = None

    # -- moving -------------------------------------------------------------------------

    def _go_to(self, goal: np.ndarray) -> tuple[float, float]:
        angle = math.atan2(goal[1], goal[0])
        if abs(angle) > self.aim_tolerance:
            self._turn_sign = 1 if angle > 0 else -1
            if self.discrete:
                return 0.0, float(self._turn_sign)
            return 0.5, float(np.clip(angle / self.turn_step, -1.0, 1.0))
        return 1.0, 0.0

    def _explore(self) -> tuple[float, float]:
        """Walk towards the most open direction; turn on the spot if there is none."""
        if self._waypoint is not None:
            angle = math.atan2(self._waypoint[1], self._waypoint[0])
            near = np.hypot(*self._waypoint) < self.step_length
            if near or self._clear_distances(np.array([angle]))[0] < 2 * self.radius:
                self._waypoint = None
        if self._waypoint is None:
            clear = self._clear_distances(self.angles)
            best = int(np.argmax(clear))
            if clear[best] > 3.0 * self.radius or self._scanning > self.full_turn:
                d = 0.6 * clear[best]
                self._waypoint = np.array([d * self.ux[best], d * self.uy[best]])
                self._scanning = 0
        if self._waypoint is not None:
            return self._go_to(self._waypoint)
        self._scanning += 1
        return 0.0, float(self._turn_sign)

    # -- geometry in the agent frame ------------------------------------------------

    def _in_view(self, x: float, y: float) -> bool:
        bearing = abs(math.atan2(y, x))
        return bearing < self.half_fov - self.turn_step and math.hypot(x, y) < self.range

    def _clear(self, start: np.ndarray, end: np.ndarray) -> np.ndarray:
        """For each pair of rows: can the body walk from ``start`` to within touching
        distance of ``end`` without brushing a remembered point?"""
        m = self._memory
        leg = end - start
        length = np.hypot(leg[:, 0], leg[:, 1])
        ux = leg[:, 0] / np.maximum(length, 1e-9)
        uy = leg[:, 1] / np.maximum(length, 1e-9)
        rx = m[None, :, 0] - start[:, 0:1]
        ry = m[None, :, 1] - start[:, 1:2]
        along = rx * ux[:, None] + ry * uy[:, None]
        across = np.abs(ry * ux[:, None] - rx * uy[:, None])
        stop = (length - self.item_radius)[:, None]
        return ~np.any((along > 0.0) & (along < stop) & (across < m[None, :, 3]), axis=1)

    def _clear_distances(self, angles: np.ndarray) -> np.ndarray:
        """How far the agent can walk in each direction before brushing anything."""
        m = self._memory
        ux, uy = np.cos(angles)[:, None], np.sin(angles)[:, None]
        along = m[None, :, 0] * ux + m[None, :, 1] * uy
        across = np.abs(m[None, :, 1] * ux - m[None, :, 0] * uy)
        hits = (along > 0.0) & (across < m[None, :, 3])
        return np.where(hits, along, self.range).min(axis=1, initial=self.range)


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


def _points(x: np.ndarray, y: np.ndarray, half_width: float) -> np.ndarray:
    return np.stack([x, y, np.zeros_like(x), np.full_like(x, half_width)], axis=1)


def _item_centres(mask: np.ndarray, px: np.ndarray, py: np.ndarray, radius: float) -> np.ndarray:
    """One point per run of neighbouring rays that hit a target at about the same
    distance: its middle ray's hit, pushed back by the item radius to approximate the
    centre."""
    idx = np.flatnonzero(mask)
    if len(idx) == 0:
        return np.zeros((0, 2))
    d = np.hypot(px[idx], py[idx])
    breaks = (np.diff(idx) > 1) | (np.abs(np.diff(d)) > radius)
    centres = []
    for run in np.split(idx, np.flatnonzero(breaks) + 1):
        k = run[len(run) // 2]
        d = math.hypot(px[k], py[k])
        scale = (d + radius) / d if d > 1e-9 else 1.0
        centres.append((px[k] * scale, py[k] * scale))
    return np.array(centres)
