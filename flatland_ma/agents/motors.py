"""Many plain agents' motors at once: compiled code over pymunk's bodies.

``AgentBody.command`` and ``AgentBody.drive`` cost a dozen pymunk attribute calls per
agent, more than the physics of its world. ``Motors`` does the same arithmetic for every
agent of every world of a batch in two compiled loops that read and write the bodies'
fields through ``flatland_ma.world.physics`` (its compiled tier), and hands out exactly
the numbers the attribute path would: the same operations in the same order, Python's
``min``/``max`` semantics, and ``math.hypot`` itself between the loops (numba's ``hypot``
rounds differently from CPython's in about one case in 200). So the batched env's worlds
move bit for bit as separate envs do.

Only plain bodies (no parts or links: a base and its motor) go this way, and only in the
physics bridge's compiled tier; otherwise the batched env keeps the attribute path.
``Poses`` reads many worlds' moving bodies' poses at once, in the compiled tier or a space
at a time through ``pymunk.batch``.
"""

from __future__ import annotations

import math
import operator

import numba as nb
import numpy as np
import pymunk

from flatland_ma.agents.body import AgentBody
from flatland_ma.sensors.lists import filled, put
from flatland_ma.world import physics, poses
from flatland_ma.world.physics import (
    angle_at,
    set_spin_at,
    set_velocity_at,
    spin_at,
    velocity_at,
)

_TOUCHING = operator.attrgetter("touching")


@nb.njit(cache=True)
def _py_min(a, b):
    return b if b < a else a  # Python's min: the first of equals


@nb.njit(cache=True)
def _py_max(a, b):
    return b if b > a else a


@nb.njit(cache=True)
def _command(bodies, controls, limits, commands, change):
    """``AgentBody.command`` and the first half of ``drive`` for each row: the control
    body's velocity, the base's new spin, and (untouched bases) the change of velocity
    wanted, into ``change``."""
    for k in range(bodies.shape[0]):
        body, control = bodies[k], controls[k]
        max_speed, max_turn_rate, max_dw = limits[k, 0], limits[k, 1], limits[k, 3]
        forward, lateral, turn = commands[k, 0], commands[k, 1], commands[k, 2]
        angle = angle_at(body)
        c, s = math.cos(angle), math.sin(angle)
        vx = max_speed * (forward * c - lateral * s)
        vy = max_speed * (forward * s + lateral * c)
        w = max_turn_rate * turn
        set_velocity_at(control, vx, vy)
        set_spin_at(control, w)
        spin = spin_at(body)
        dw = _py_max(-max_dw, _py_min(max_dw, w - spin))
        set_spin_at(body, spin + dw)
        body_vx, body_vy = velocity_at(body)
        change[k, 0] = vx - body_vx
        change[k, 1] = vy - body_vy


@nb.njit(cache=True)
def _push(bodies, limits, touching, change, norms):
    """The rest of ``drive``: untouched bases get the change of velocity, at most
    ``max_dv`` long (``norms``: each change's length, by ``math.hypot``)."""
    for k in range(bodies.shape[0]):
        if touching[k]:
            continue
        max_dv = limits[k, 2]
        dvx, dvy, dv = change[k, 0], change[k, 1], norms[k]
        if dv > max_dv:
            dvx, dvy = dvx * max_dv / dv, dvy * max_dv / dv
        vx, vy = velocity_at(bodies[k])
        set_velocity_at(bodies[k], vx + dvx, vy + dvy)


class Motors:
    """The motors of ``slots`` plain agents: ``place(slot, body)`` when a slot gets a new
    episode's body; ``drive(slots, commands, touching)`` commands the bodies of ``slots``
    (forward, lateral, turn: fractions of the top speeds, one row each) and gives each
    its motors' change of velocity for one substep, as ``command`` then ``drive`` do."""

    def __init__(self, slots: int):
        self.slots = slots
        self.bodies = np.zeros(slots, np.intp)
        self.controls = np.zeros(slots, np.intp)
        self.limits = np.zeros((slots, 4), np.float64)
        """max_speed, max_turn_rate, max_dv, max_dw of each slot's body."""
        self._keep: list[AgentBody | None] = [None] * slots
        """The bodies placed: their structs live while they are referenced here."""

    @staticmethod
    def available() -> bool:
        """Whether the physics bridge's tier in use lets compiled code drive bodies."""
        return physics.TIER is physics.Tier.COMPILED

    @staticmethod
    def fits(body: AgentBody) -> bool:
        """Whether ``body`` can be driven here: a plain base, on this pymunk."""
        return Motors.available() and not body.links and not body.parts

    def place(self, slot: int, body: AgentBody) -> None:
        self._keep[slot] = body
        self.bodies[slot] = physics.address(body.body)
        self.controls[slot] = physics.address(body.control)
        self.limits[slot] = (body.max_speed, body.max_turn_rate, body.max_dv, body.max_dw)

    def drive(self, slots: np.ndarray, commands: np.ndarray, touching: np.ndarray) -> None:
        bodies, limits = self.bodies[slots], self.limits[slots]
        change = np.empty((len(slots), 2), np.float64)
        _command(bodies, self.controls[slots], limits, commands, change)
        norms = np.fromiter(
            map(math.hypot, change[:, 0].tolist(), change[:, 1].tolist()),
            np.float64,
            len(slots),
        )
        _push(bodies, limits, touching, change, norms)

    def drive_all(self, commands: np.ndarray) -> None:
        """``drive`` of every slot, in slot order (each slot's body placed)."""
        touching = np.fromiter(map(_TOUCHING, self._keep), bool, self.slots)
        self.drive(np.arange(self.slots), commands, touching)


class Poses:
    """Many worlds' moving bodies' poses, read back at once: ``place(w, pose, bodies)``
    when world ``w`` gets a new episode (``pose``: its (bodies, 3) array, filled as
    ``Geometry.refresh_poses`` fills it), ``read(which)`` for the worlds ``which``: in the
    physics bridge's compiled tier in one compiled call, in its batch tier world by world
    (``poses.poses_of``). ``fits()``: whether the tier in use reads poses."""

    def __init__(self, worlds: int):
        self._compiled = physics.TIER is physics.Tier.COMPILED
        self._poses = filled(np.zeros((0, 3), np.float64), worlds)
        self._bodies = filled(np.zeros(0, np.intp), worlds)
        self._keep: list[list] = [[] for _ in range(worlds)]
        """Each world's bodies: their structs live while they are referenced here."""
        self._spaces: list[poses.SpacePoses | poses.AttributePoses | None] = [None] * worlds

    @staticmethod
    def fits() -> bool:
        return physics.TIER >= physics.Tier.BATCH

    def place(self, w: int, pose: np.ndarray, bodies: list[pymunk.Body]) -> None:
        if not self._compiled:
            self._spaces[w] = poses.poses_of(pose, bodies)
            return
        self._keep[w] = list(bodies)
        put(self._poses, w, pose)
        put(self._bodies, w, np.array([physics.address(b) for b in bodies], np.intp))

    def read(self, which: np.ndarray) -> None:
        if self._compiled:
            physics.read_poses_at(self._poses, self._bodies, which)
            return
        for w in which.tolist():
            space = self._spaces[w]
            if space is not None:
                space.read()
