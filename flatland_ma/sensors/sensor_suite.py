"""All agents' sensors over one world, observed with one kernel call per step.

Each step the suite picks up the fixed entities the world changed (moved, hidden, shown),
reads the moving bodies' poses, casts every ray of every ray sensor of every agent in one
kernel call, and lets each sensor read its observation from the results.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numba as nb
import numpy as np
from gymnasium import spaces

from flatland_ma.kinds.registry import ExtensionError
from flatland_ma.sensors import kernel
from flatland_ma.sensors.geometry import Geometry
from flatland_ma.sensors.lists import filled, put
from flatland_ma.sensors.scene import Outputs, Scratch, shared_eyes
from flatland_ma.sensors.semantic import kind_table
from flatland_ma.sensors.sensor import Sensor
from flatland_ma.sensors.threads import Chooser, fit_threads
from flatland_ma.world.entities import Entity
from flatland_ma.world.navigation import NavGrid
from flatland_ma.world.world import World

OUTPUTS = 5
"""Where the kernel's outputs (``Sensors.out``) sit among ``Sensors.kernel_args``."""

_KERNELS: dict[tuple, Callable] = {}
"""The compiled kernel for each layout of its arguments (in practice one per process)."""


def compiled_kernel(args: tuple, function: Callable = kernel.observe) -> Callable:
    """The ray kernel (or another compiled ``function``) compiled for these arguments'
    types.

    numba types named tuples in Python on every call (several microseconds, a tenth of a
    small world's kernel time), and typing them once costs a millisecond, too much for
    every reset: the compiled function is kept per layout of the arrays (dtype, number of
    dimensions, contiguity, writability), which is the same every episode. The arrays are
    only ever written in place, so the function stays valid for them.
    """
    arrays = [a for arg in args for a in (arg if isinstance(arg, tuple) else (arg,))]
    layout = tuple((a.dtype.str, a.ndim, a.flags.c_contiguous, a.flags.writeable) for a in arrays)
    key = (function, layout)
    if key not in _KERNELS:
        signature = tuple(nb.typeof(a) for a in args)
        _KERNELS[key] = function.compile(signature)  # type: ignore[attr-defined]
    return _KERNELS[key]


def observation_space(sensors: list[Sensor]) -> spaces.Space:
    """An agent's observation space: its one sensor's, or a ``Dict`` by sensor name."""
    if len(sensors) == 1:
        return sensors[0].space
    return spaces.Dict({s.name: s.space for s in sensors})


class Sensors:
    """Every agent's sensors; ``observe`` fills one preallocated set of results for all
    rays: ``image`` (rays, 4) float32, ``distance`` (rays,) float64 and ``hit_entity``
    (rays,) int32, sensor k's rays at ``slices[k]``; agent i's sensors are
    ``per_agent[i]``."""

    def __init__(
        self,
        world: World,
        eyes: list[Entity],
        cameras: list[Sensor],
        counts: list[int] | None = None,
        grid: NavGrid | None = None,
        rng: np.random.Generator | None = None,
    ):
        """``cameras``: every sensor, agent by agent; ``counts[i]``: how many are agent
        i's (default one each); ``eyes[k]`` carries sensor k: its agent's base or head
        (``owner`` is the agent); ``grid``: the episode's navigation grid, for sensors
        that need it; ``rng``: the env's generator, which draws sensor noise."""
        self.world = world
        self.grid = grid
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self.carriers = eyes
        """What carries each sensor: its agent's base, or head."""
        self.geometry = geo = Geometry(world)
        self.kinds = kind_table(world.entities)
        """The semantic kind of each entity by index (``hit_entity`` -1 reads the last:
        nothing)."""
        self.cameras = cameras
        counts = counts if counts is not None else [1] * len(cameras)
        firsts = [sum(counts[:i]) for i in range(len(counts) + 1)]
        self.per_agent = [list(range(a, b)) for a, b in zip(firsts[:-1], firsts[1:])]
        self.eyes = shared_eyes(
            body=[geo.body_row[e.index] for e in eyes],
            local=[(0.0, 0.0, 0.0)] * len(eyes),
            owner=[e.owner for e in eyes],
            view_range=[c.view_range for c in cameras],
            half_fov=[c.half_fov for c in cameras],
            falloff=[c.falloff for c in cameras],
            angles=[c.angles for c in cameras],
        )
        starts = self.eyes.rays
        self.slices = [slice(int(a), int(b)) for a, b in zip(starts[:-1], starts[1:])]
        self.out = Outputs.zeros(int(starts[-1]))
        self.image, self.distance, self.hit_entity = self.out
        self._args = (geo.pose, geo.shapes, geo.grid, geo.looks, self.eyes, self.out)
        self._args += (Scratch.for_shapes(geo.shapes),)
        self._kernel = compiled_kernel(self._args)
        self.readings: list[np.ndarray | None] = [None] * len(cameras)
        """The reading of each sensor last handed out (noise included), for pictures:
        the renderer draws these and never reads a sensor itself (no noise is drawn)."""
        self._unchecked = [True] * len(cameras)
        """Whether sensor k's reading is still to be checked against its space (its first
        of the episode is: a sensor's read is the same code every step)."""
        for k, sensor in enumerate(cameras):
            sensor.attach(self, k)

    def observe(self) -> None:
        """Pick up what the world changed, read the moving bodies' poses and cast every
        ray of every sensor."""
        self.prepare()
        self._kernel(*self._args)

    def prepare(self, poses: bool = True) -> None:
        """Everything ``observe`` does before casting the rays (``observe_worlds`` casts
        several worlds' rays in one call); ``poses=False`` leaves reading the moving
        bodies' poses to the caller (the batched env reads every world's at once)."""
        geo = self.geometry
        if self.world.changed:
            for entity in self.world.take_changed():
                geo.update_entity(entity)
        if poses:
            geo.refresh_poses()

    @property
    def kernel_args(self) -> tuple:
        """The ray kernel's arguments for this world, as ``observe_worlds`` takes them."""
        return self._args

    def observation(self, agent_index: int):
        """A fresh copy of the agent's observation: its one sensor's, or a dict by name."""
        own = self.per_agent[agent_index]
        if len(own) == 1:
            return self._reading(own[0])
        return {self.cameras[k].name: self._reading(k) for k in own}

    def _reading(self, k: int) -> np.ndarray:
        sensor = self.cameras[k]
        reading = sensor.read(self, k)
        if self._unchecked[k]:
            check_reading(sensor, reading, self.carriers[k].owner)
            self._unchecked[k] = False
        if sensor.noise is not None:
            reading = sensor.noise.apply(reading, sensor.space, self.rng)  # type: ignore[arg-type]
        self.readings[k] = reading
        return reading


def check_reading(sensor: Sensor, reading: Any, agent: int) -> None:
    """Raise ``ExtensionError`` naming the sensor if ``reading`` (what its ``read``
    returned for agent ``agent``) is not an array of its space's shape and dtype: the
    envs copy readings into buffers of the space's shape, where a wrong one would fail
    far from the sensor, or pass unseen."""
    space = sensor.space
    shape, dtype = getattr(space, "shape", None), getattr(space, "dtype", None)
    if isinstance(reading, np.ndarray) and reading.shape == shape and reading.dtype == dtype:
        return
    cls = type(sensor)
    got = (
        f"an array of shape {reading.shape} and dtype {reading.dtype}"
        if isinstance(reading, np.ndarray)
        else f"a {type(reading).__name__}"
    )
    raise ExtensionError(
        f"sensor {sensor.name!r} (kind {getattr(cls, 'kind', '?')!r}, class "
        f"{cls.__module__}.{cls.__qualname__}) of agent {agent}: its read returned {got}, "
        f"but its space is {space}; read must return a fresh numpy array of the space's "
        f"shape {shape} and dtype {dtype}"
    )


@nb.njit(parallel=True, cache=True)
def _observe_worlds(worlds, which):
    """The ray kernel over the worlds ``worlds[which[k]]``, spread over numba's threads
    (each world writes only its own outputs: the results are those of one call each)."""
    for k in nb.prange(which.shape[0]):
        a = worlds[which[k]]
        kernel.observe(a[0], a[1], a[2], a[3], a[4], a[5], a[6])


@nb.njit(cache=True)
def _observe_worlds_serial(worlds, which):
    """``_observe_worlds`` on one thread."""
    for k in range(which.shape[0]):
        a = worlds[which[k]]
        kernel.observe(a[0], a[1], a[2], a[3], a[4], a[5], a[6])


class WorldsKernel:
    """One kernel call for the rays of many worlds of one scenario: ``set(w, suite)`` when
    world ``w`` gets a new episode's sensors, ``prepare`` each world's suite, then
    ``observe(which)`` casts the rays of the worlds ``which`` at once. When ``parallel``,
    over numba's threads (as many as the CPUs this process may use) or on this thread,
    whichever is faster as the machine's load changes (``threads.Chooser``); else always
    on this thread (a process forked from one that ran numba's threads must not start its
    own). Both give the same results."""

    def __init__(self, n: int, parallel: bool = True):
        self.n = n
        self.parallel = parallel
        self.worlds = None
        self._function: Callable | None = None

    def set(self, w: int, suite: Sensors, image: np.ndarray | None = None) -> None:
        """World ``w``'s sensors from now on; ``image``: where its rays write their RGB
        and depth instead of ``suite.image`` (an array of the same shape and type, e.g.
        the world's rows of a batch's observations)."""
        args = suite.kernel_args
        if image is not None:
            assert image.shape == suite.image.shape and image.dtype == suite.image.dtype
            assert args[OUTPUTS] is suite.out
            args = (*args[:OUTPUTS], suite.out.with_image(image), *args[OUTPUTS + 1 :])
        if self.worlds is None:
            self.worlds = filled(args, self.n)
        else:
            put(self.worlds, w, args)

    def observe(self, which: np.ndarray) -> None:
        if self._function is None:
            signature = (nb.typeof(self.worlds), nb.typeof(which))
            serial = _compiled(_observe_worlds_serial, signature)
            if self.parallel:
                threads = fit_threads()
                parallel = _compiled(_observe_worlds, signature) if threads > 1 else serial
                self._function = Chooser(parallel, serial, threads)
            else:
                self._function = serial
        self._function(self.worlds, which)

    @property
    def function(self) -> Callable | None:
        """The compiled function ``observe`` calls (a ``threads.Chooser`` when
        ``parallel``); None before the first call."""
        return self._function


def _compiled(function: Callable, signature: tuple) -> Callable:
    key = (function, signature)
    if key not in _KERNELS:
        _KERNELS[key] = function.compile(signature)  # type: ignore[attr-defined]
    return _KERNELS[key]
