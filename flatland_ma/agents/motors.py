"""Plain agents' motors: compiled code over pymunk's bodies, the one way every env drives
its plain bodies (a world's own, ``WorldLoop.act``, or every world's of a batch at once,
``Worlds``).

``AgentBody.command`` and ``AgentBody.drive`` cost a dozen pymunk attribute calls per
agent, more than the physics of its world. ``Motors`` does the same arithmetic for every
agent given in two compiled loops that read and write the bodies' fields through
``flatland_ma.world.physics`` (its compiled tier), and hands out exactly the numbers the
attribute path would: the same operations in the same order, Python's ``min``/``max``
semantics, and ``math.hypot`` itself between the loops (numba's ``hypot`` rounds
differently from CPython's in about one case in 200). So a world moves bit for bit the
same whichever env steps it, and in whichever tier.

Only plain bodies (no parts or links: a base and its motor) go this way, and only in the
physics bridge's compiled tier (``motors_of``); bodies with parts, and every body in the
slower tiers, are driven through their attributes (``Actuator.apply``).
"""

from __future__ import annotations

import math
import operator

import numba as nb
import numpy as np

from flatland_ma.agents.body import AgentBody
from flatland_ma.world import physics
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
        bodies, controls, limits = self.bodies[slots], self.controls[slots], self.limits[slots]
        self._drive(bodies, controls, limits, commands, touching)

    def drive_all(self, commands: np.ndarray) -> None:
        """``drive`` of every slot, in slot order (each slot's body placed)."""
        touching = np.fromiter(map(_TOUCHING, self._keep), bool, self.slots)
        self._drive(self.bodies, self.controls, self.limits, commands, touching)

    @staticmethod
    def _drive(bodies, controls, limits, commands, touching) -> None:
        change = np.empty((len(bodies), 2), np.float64)
        _command(bodies, controls, limits, commands, change)
        norms = np.fromiter(
            map(math.hypot, change[:, 0].tolist(), change[:, 1].tolist()),
            np.float64,
            len(bodies),
        )
        _push(bodies, limits, touching, change, norms)


def motors_of(bodies: list[AgentBody]) -> Motors | None:
    """The motors of one world's ``bodies`` (slot j: body j), or None where one of them
    cannot be driven so (``Motors.fits``)."""
    if not all(Motors.fits(body) for body in bodies):
        return None
    motors = Motors(len(bodies))
    for j, body in enumerate(bodies):
        motors.place(j, body)
    return motors
