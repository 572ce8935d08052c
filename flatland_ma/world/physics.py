"""The one bridge to pymunk beyond its documented API: every read or write of Chipmunk's
structs by address and every step past ``Space.step`` lives here, nowhere else.

It works in one of three tiers (``tier.py``), chosen once per process (``TIER``) from what
this pymunk allows (``BEST``), each giving the same numbers to the bit:

``COMPILED``
    Compiled code reads and writes bodies' fields where Chipmunk keeps them in its
    ``cpBody`` (checked once against pymunk's own accessors on a probe body), and a
    space is stepped through Chipmunk's ``cpSpaceStep`` directly, without the Python that
    ``Space.step`` runs around it when nothing is queued (about half of a small world's
    step). Needs the struct layout and the ``Space`` internals of pymunk 7.
``BATCH``
    Poses come back a space at a time through ``pymunk.batch.get_space_bodies`` (public,
    though pymunk calls it experimental: ``poses.py``) in worlds of ``BATCH_FROM`` moving
    bodies or more, where that is cheaper than attributes; spaces step through
    ``Space.step``; each agent drives its body through pymunk's attributes.
``ATTRIBUTES``
    pymunk's documented attributes and ``Space.step`` only.

The environment variable ``FLATLAND_MA_PHYSICS`` (``compiled``, ``batch`` or
``attributes``) asks for a tier, at most ``BEST``. When the tier in use is slower than
``COMPILED``, a ``RuntimeWarning`` says so once, at import; ``flatland-ma bench`` prints
the tier (``describe``). What is built takes the tier in use when it is built (a world
its ``stepper``, a batched env its motors and pose reader).

Compiled code elsewhere reaches bodies through the ``*_at`` functions below, by the
address ``address`` gives. Numba's cache does not notice a change of a function called from
another module: after editing one of them, clear the ``__pycache__`` of their callers.
"""

from __future__ import annotations

import ctypes
import os
import warnings
from collections.abc import Callable
from typing import Any

import numba as nb
import pymunk
from numba import types
from numba.extending import intrinsic
from pymunk._chipmunk import ffi
from pymunk._chipmunk import lib as _chipmunk

from flatland_ma.world.poses import batch_found
from flatland_ma.world.tier import VARIABLE, Tier, chosen, described

# -- Chipmunk's structs ------------------------------------------------------------------

_VX, _VY, _ANGLE, _SPIN = 10, 11, 14, 15
"""Where ``cpBody`` keeps v.x, v.y, a and w, in doubles from its start (Chipmunk 7: two
function pointers, m, m_inv, i, i_inv, cog, p (the centre of gravity's), v, f, a, w)."""
_TA, _TC, _TX, _TY = 17, 19, 21, 22
"""Where it keeps its transform's a, c, tx and ty (after t): pymunk's ``position`` (the
body's origin) is ``a * 0 + c * 0 + tx``, ``b * 0 + d * 0 + ty``."""
_WORDS = 23
_QUEUES = ("_bodies_to_check", "_add_later", "_remove_later", "_post_step_callbacks")
"""What pymunk's ``Space.step`` handles around Chipmunk's step: bodies added since the
last step (checked), and what callbacks asked to add, remove or run after it."""


def address(body: pymunk.Body) -> int:
    """Where Chipmunk keeps ``body``'s struct (for the ``*_at`` functions)."""
    return int(ffi.cast("uintptr_t", body._body))


def _fields_found() -> bool:
    """Whether a body's fields lie where ``_VX`` etc. say, tried on a probe body whose
    centre of gravity is off its origin."""
    probe = pymunk.Body(1.0, 1.0)
    probe.center_of_gravity = (0.5, -0.25)
    probe.angle, probe.position = 0.625, (-1.5, 2.125)
    probe.velocity, probe.angular_velocity = (3.25, -7.5), 11.75
    words = (ctypes.c_double * _WORDS).from_address(address(probe))
    found = [words[k] for k in (_VX, _VY, _ANGLE, _SPIN)]
    x = words[_TA] * 0.0 + words[_TC] * 0.0 + words[_TX]
    y = words[_TA + 1] * 0.0 + words[_TC + 1] * 0.0 + words[_TY]
    return found == [3.25, -7.5, 0.625, 11.75] and (x, y) == tuple(probe.position)


_USER_DATA, _BIAS = 23, (24, 25, 26)
"""Where ``cpBody`` keeps its user data, then v_bias and w_bias: the pseudo-velocities the
solver leaves for the next step's positions (pymunk neither shows nor clears them)."""


def _bias_found() -> bool:
    """Whether a body's user data lies at ``_USER_DATA`` (its biases follow it)."""
    probe = pymunk.Body(1.0, 1.0)
    words = (ctypes.c_size_t * (_USER_DATA + 1)).from_address(address(probe))
    user = int(ffi.cast("uintptr_t", _chipmunk.cpBodyGetUserData(probe._body)))
    return user != 0 and words[_USER_DATA] == user


def _queues_found() -> bool:
    """Whether this pymunk keeps a space's queues and lock where ``step_directly``
    expects them (pymunk 7's ``Space``)."""
    probe = pymunk.Space()
    names = (*_QUEUES, "_removed_shapes", "_locked", "_space", "threaded")
    return pymunk.version.startswith("7.") and all(hasattr(probe, n) for n in names)


def _best() -> tuple[Tier, str]:
    """The fastest tier this pymunk allows, and why not a faster one."""
    if _fields_found() and _queues_found():
        return Tier.COMPILED, ""
    why = f"pymunk {pymunk.version} keeps its bodies or spaces elsewhere than pymunk 7.3 does"
    if batch_found():
        return Tier.BATCH, why
    return Tier.ATTRIBUTES, why + ", and its pymunk.batch differs"


BEST, _WHY = _best()
"""The fastest tier this pymunk allows."""
TIER = chosen(BEST, os.environ.get(VARIABLE))
"""The tier in use in this process."""
BIAS_CLEARABLE = TIER is Tier.COMPILED and _bias_found()
"""Whether ``clear_bias`` can zero a body's pseudo-velocities in this process."""


def describe() -> str:
    """The tier in use, in words (``flatland-ma bench`` prints it)."""
    return described(TIER, BEST, _WHY, pymunk.version)


if TIER < Tier.COMPILED:
    warnings.warn(
        f"flatland_ma reaches pymunk through its {describe()} tier, slower than the "
        "compiled one (1.5-1.8x per world-step in the batched env)",
        RuntimeWarning,
        stacklevel=2,
    )


# -- stepping ----------------------------------------------------------------------------

_cp_step = _chipmunk.cpSpaceStep


def stepper() -> Callable[[pymunk.Space, float, int], None]:
    """The function that steps a space in the tier in use: ``step(space, dt, substeps)``
    is ``space.step(dt)`` ``substeps`` times (a world takes it once, when built)."""
    return _step_compiled if TIER is Tier.COMPILED else _step_plain


def _step_plain(space: pymunk.Space, dt: float, substeps: int) -> None:
    for _ in range(substeps):
        space.step(dt)


def _step_compiled(space: pymunk.Space, dt: float, substeps: int) -> None:
    """Chipmunk's step directly whenever pymunk has nothing queued around it."""
    for _ in range(substeps):
        if (
            space._bodies_to_check
            or space._add_later
            or space._remove_later
            or space._post_step_callbacks
            or space.threaded
        ):
            space.step(dt)
        else:
            step_directly(space, dt)


def step_directly(space: pymunk.Space, dt: float) -> None:
    """``space.step(dt)``: the same Chipmunk step, without the Python that pymunk runs
    around it when there is nothing for it to do. When nothing is queued (``_QUEUES``)
    pymunk's step is: lock, Chipmunk's step, forget the shapes removed before it, unlock;
    a callback that queues something during the step is then handled as pymunk does, by
    the rest of its step."""
    space._locked = True
    try:
        _cp_step(space._space, dt)
        space._removed_shapes.clear()
    finally:
        space._locked = False
    if space._add_later or space._remove_later or space._post_step_callbacks:
        _finish_step(space)


def _finish_step(space: pymunk.Space) -> None:
    """The end of pymunk 7's ``Space.step``: what callbacks queued during it."""
    space.add(*space._add_later)
    space._add_later.clear()
    removed = set()
    while space._remove_later:
        thing, _ = space._remove_later.popitem()
        if thing not in removed:
            removed.add(thing)
            space._remove(thing)
    for key in space._post_step_callbacks:
        space._post_step_callbacks[key](space)
    space._post_step_callbacks.clear()


# -- a space put back to where it stood (resets in place) -------------------------------


def shape_counter(space: pymunk.Space, set_to: int | None = None) -> int:
    """The hash id Chipmunk gives the next shape added to ``space`` (its spatial indexes
    key their leaves by these ids, so the order of their work depends on them), after
    making it ``set_to`` if given."""
    if set_to is not None:
        _chipmunk.cpSpaceSetShapeIDCounter(space._space, set_to)
    return int(_chipmunk.cpSpaceGetShapeIDCounter(space._space))


def clear_bias(body: pymunk.Body) -> bool:
    """Zero ``body``'s pseudo-velocities as a new body's are; False (nothing done) when
    this tier cannot: the body should be made anew instead."""
    if BIAS_CLEARABLE:
        words = (ctypes.c_double * (_BIAS[-1] + 1)).from_address(address(body))
        words[_BIAS[0]] = words[_BIAS[1]] = words[_BIAS[2]] = 0.0
    return BIAS_CLEARABLE


def forget_time_step(space: pymunk.Space) -> None:
    """Make ``space``'s next step a first one for the warm start of contacts (Chipmunk
    scales the impulses it carries over by this step's length over the last's)."""
    _chipmunk.cpSpaceSetCurrentTimeStep(space._space, 0.0)


# -- bodies from compiled code (the compiled tier) ---------------------------------------


def _pointer_to_doubles(typingctx, where):
    """A pointer to the doubles at address ``where`` (an integer), in compiled code."""
    signature = types.CPointer(types.float64)(types.intp)

    def codegen(context, builder, sig, args):
        return builder.inttoptr(args[0], context.get_value_type(sig.return_type))

    return signature, codegen


_doubles_at: Any = intrinsic(_pointer_to_doubles)


@nb.njit(cache=True, inline="always")
def _struct(where):
    return nb.carray(_doubles_at(where), _WORDS)


@nb.njit(cache=True, inline="always")
def angle_at(where):
    """The angle of the body at ``where``."""
    return _struct(where)[_ANGLE]


@nb.njit(cache=True, inline="always")
def spin_at(where):
    """The angular velocity of the body at ``where``."""
    return _struct(where)[_SPIN]


@nb.njit(cache=True, inline="always")
def set_spin_at(where, w):
    _struct(where)[_SPIN] = w


@nb.njit(cache=True, inline="always")
def velocity_at(where):
    """The velocity (x, y) of the body at ``where``."""
    body = _struct(where)
    return body[_VX], body[_VY]


@nb.njit(cache=True, inline="always")
def set_velocity_at(where, vx, vy):
    """Set the body's velocity, skipping what ``cpBodySetVelocity`` adds: waking the body
    (the worlds never sleep) and a check that the values are finite."""
    body = _struct(where)
    body[_VX], body[_VY] = vx, vy


@nb.njit(cache=True, inline="always")
def read_poses_of(pose, own):
    """``pose[i] = (x, y, angle)`` of the body at ``own[i]``: exactly
    ``(*body.position, body.angle)``."""
    for i in range(own.shape[0]):
        body = _struct(own[i])
        pose[i, 0] = body[_TA] * 0.0 + body[_TC] * 0.0 + body[_TX]
        pose[i, 1] = body[_TA + 1] * 0.0 + body[_TC + 1] * 0.0 + body[_TY]
        pose[i, 2] = body[_ANGLE]


@nb.njit(cache=True)
def read_poses_at(poses, bodies, which):
    """``read_poses_of(poses[w], bodies[w])`` for each world ``which`` (typed lists of
    arrays)."""
    for k in range(which.shape[0]):
        read_poses_of(poses[which[k]], bodies[which[k]])
