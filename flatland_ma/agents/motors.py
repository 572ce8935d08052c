"""Many plain agents' motors at once: compiled code over pymunk's bodies.

``AgentBody.command`` and ``AgentBody.drive`` cost a dozen pymunk attribute calls per
agent, more than the physics of its world. ``Motors`` does the same arithmetic for every
agent of every world of a batch in two compiled loops that read and write the bodies'
fields where Chipmunk keeps them, and hands out exactly the numbers the attribute path
would: the same operations in the same order, Python's ``min``/``max`` semantics, and
``math.hypot`` itself between the loops (numba's ``hypot`` rounds differently from
CPython's in about one case in 200). So the batched env's worlds move bit for bit as
separate envs do.

Only plain bodies (no parts or links: a base and its motor) go this way. Chipmunk's
``cpBody`` is opaque to pymunk's ffi, so where its fields lie is checked once per process
against pymunk's own accessors (``FIELDS_FOUND``); when they are not where expected the
batched env keeps the attribute path.

Writing a body's velocity directly skips what ``cpBodySetVelocity`` adds: waking the body
(a no-op, the worlds never sleep) and a sanity assertion (the values are finite: bounded
commands of finite velocities).
"""

from __future__ import annotations

import ctypes
import math
import operator
from typing import Any

import numba as nb
import numpy as np
import pymunk
from numba import types
from numba.extending import intrinsic
from pymunk._chipmunk import ffi

from flatland_ma.agents.body import AgentBody
from flatland_ma.sensors.lists import filled, put

_VX, _VY, _ANGLE, _SPIN = 10, 11, 14, 15
"""Where ``cpBody`` keeps v.x, v.y, a and w, in doubles from its start (Chipmunk 7: two
function pointers, m, m_inv, i, i_inv, cog, p (the centre of gravity's), v, f, a, w)."""
_TA, _TC, _TX, _TY = 17, 19, 21, 22
"""Where it keeps its transform's a, c, tx and ty (after t): pymunk's ``position`` (the
body's origin) is ``a * 0 + c * 0 + tx``, ``b * 0 + d * 0 + ty``."""
_WORDS = 23
_TOUCHING = operator.attrgetter("touching")


def address(body: pymunk.Body) -> int:
    """Where Chipmunk keeps ``body``'s struct."""
    return int(ffi.cast("uintptr_t", body._body))


def _fields_found() -> bool:
    """Whether the fields lie where ``_VX`` etc. say, tried on a probe body whose centre
    of gravity is off its origin."""
    probe = pymunk.Body(1.0, 1.0)
    probe.center_of_gravity = (0.5, -0.25)
    probe.angle, probe.position = 0.625, (-1.5, 2.125)
    probe.velocity, probe.angular_velocity = (3.25, -7.5), 11.75
    words = (ctypes.c_double * _WORDS).from_address(address(probe))
    found = [words[k] for k in (_VX, _VY, _ANGLE, _SPIN)]
    x = words[_TA] * 0.0 + words[_TC] * 0.0 + words[_TX]
    y = words[_TA + 1] * 0.0 + words[_TC + 1] * 0.0 + words[_TY]
    return found == [3.25, -7.5, 0.625, 11.75] and (x, y) == tuple(probe.position)


FIELDS_FOUND = _fields_found()
"""Whether this pymunk keeps a body's fields where ``Motors`` reads and writes them."""


def _pointer_to_doubles(typingctx, where):
    """A pointer to the doubles at address ``where`` (an integer), in compiled code."""
    signature = types.CPointer(types.float64)(types.intp)

    def codegen(context, builder, sig, args):
        return builder.inttoptr(args[0], context.get_value_type(sig.return_type))

    return signature, codegen


_doubles_at: Any = intrinsic(_pointer_to_doubles)


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
        body = nb.carray(_doubles_at(bodies[k]), _WORDS)
        control = nb.carray(_doubles_at(controls[k]), _WORDS)
        max_speed, max_turn_rate, max_dw = limits[k, 0], limits[k, 1], limits[k, 3]
        forward, lateral, turn = commands[k, 0], commands[k, 1], commands[k, 2]
        angle = body[_ANGLE]
        c, s = math.cos(angle), math.sin(angle)
        vx = max_speed * (forward * c - lateral * s)
        vy = max_speed * (forward * s + lateral * c)
        w = max_turn_rate * turn
        control[_VX], control[_VY], control[_SPIN] = vx, vy, w
        spin = body[_SPIN]
        dw = _py_max(-max_dw, _py_min(max_dw, w - spin))
        body[_SPIN] = spin + dw
        change[k, 0] = vx - body[_VX]
        change[k, 1] = vy - body[_VY]


@nb.njit(cache=True)
def _push(bodies, limits, touching, change, norms):
    """The rest of ``drive``: untouched bases get the change of velocity, at most
    ``max_dv`` long (``norms``: each change's length, by ``math.hypot``)."""
    for k in range(bodies.shape[0]):
        if touching[k]:
            continue
        body = nb.carray(_doubles_at(bodies[k]), _WORDS)
        max_dv = limits[k, 2]
        dvx, dvy, dv = change[k, 0], change[k, 1], norms[k]
        if dv > max_dv:
            dvx, dvy = dvx * max_dv / dv, dvy * max_dv / dv
        body[_VX] = body[_VX] + dvx
        body[_VY] = body[_VY] + dvy


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
    def fits(body: AgentBody) -> bool:
        """Whether ``body`` can be driven here: a plain base, on this pymunk."""
        return FIELDS_FOUND and not body.links and not body.parts

    def place(self, slot: int, body: AgentBody) -> None:
        self._keep[slot] = body
        self.bodies[slot] = address(body.body)
        self.controls[slot] = address(body.control)
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


@nb.njit(cache=True)
def _read_poses(poses, bodies, which):
    """``poses[w][i] = (x, y, angle)`` of body ``bodies[w][i]``, for each world ``which``."""
    for k in range(which.shape[0]):
        pose, own = poses[which[k]], bodies[which[k]]
        for i in range(own.shape[0]):
            body = nb.carray(_doubles_at(own[i]), _WORDS)
            pose[i, 0] = body[_TA] * 0.0 + body[_TC] * 0.0 + body[_TX]
            pose[i, 1] = body[_TA + 1] * 0.0 + body[_TC + 1] * 0.0 + body[_TY]
            pose[i, 2] = body[_ANGLE]


class Poses:
    """Many worlds' moving bodies' poses, read back in one call: ``place(w, pose,
    bodies)`` when world ``w`` gets a new episode (``pose``: its (bodies, 3) array, filled
    as ``Geometry.refresh_poses`` fills it), ``read(which)`` for the worlds ``which``."""

    def __init__(self, worlds: int):
        self._poses = filled(np.zeros((0, 3), np.float64), worlds)
        self._bodies = filled(np.zeros(0, np.intp), worlds)
        self._keep: list[list] = [[] for _ in range(worlds)]
        """Each world's bodies: their structs live while they are referenced here."""

    @staticmethod
    def fits() -> bool:
        return FIELDS_FOUND

    def place(self, w: int, pose: np.ndarray, bodies: list[pymunk.Body]) -> None:
        self._keep[w] = list(bodies)
        put(self._poses, w, pose)
        put(self._bodies, w, np.array([address(b) for b in bodies], np.intp))

    def read(self, which: np.ndarray) -> None:
        _read_poses(self._poses, self._bodies, which)
