"""What one world of a scenario costs in memory and rays, counted from its spec alone.

The work budget (``flatland_ma.scenario.budget``) holds a file to these figures before
anything is built, and the batched envs hold ``num_worlds`` copies of them to the batch's
limit before allocating (``budget.check_batch``). They are estimates from above, by sensor
kind: what each sensor's observation takes (float32 entries, held about ``OBS_COPIES``
times over), the buffers it keeps besides (a top-down map's pixel ids, a smell sensor's
scent grid) and the rays it casts each step. A sensor kind registered from outside, whose
spec this module does not know, is counted as ``UNKNOWN_SENSOR_BYTES`` without rays.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from flatland_ma.scenario.errors import KeyPath

if TYPE_CHECKING:
    from flatland_ma.scenario.spec_agent import AgentSpec
    from flatland_ma.scenario.spec_scenario import ScenarioFields

FLOAT_BYTES = 4
"""Every sensor's observation is float32."""
OBS_COPIES = 4
"""How many arrays of an observation's size exist per sensor: its space's ``low`` and
``high``, the sensor's own buffer and the observation handed out."""
PIXEL_ID_BYTES = 4
"""A top-down map keeps one int32 id per pixel besides its image."""
SCENT_CELLS = 500_000
"""The most cells a scent field spreads over, all channels together (the smell sensor
coarsens its grid to stay within; ``flatland_ma.sensors.scent.MAX_CELLS``)."""
SCENT_CELL_BYTES = 72
"""Bytes per scent cell and channel: distances, pivots and bases per channel, and the
blocked grid, its summed table and the search queue per cell."""
RAY_BYTES = 48
"""Bytes the ray kernel keeps per ray: angles, colours, distances, hits."""
UNKNOWN_SENSOR_BYTES = 64 * 1024
"""What a sensor kind this module does not know is counted as."""
SEMANTIC_WIDTHS = {"id": 1, "onehot": 6}
CAMERA_WIDTHS = {"rgb": 3, "depth": 1}
TOPDOWN_WIDTHS = {"rgb": 3, "visibility": 1}


@dataclass(frozen=True)
class SensorSize:
    """One sensor's cost: the entries of its observation, bytes kept besides, rays per step."""

    entries: int
    extra_bytes: int = 0
    rays: int = 0
    shared_bytes: int = 0
    """Bytes kept once per world by every sensor of the same ``shared_key`` (a scent field
    serves every smell sensor that asks for the same one)."""
    shared_key: tuple | None = None

    @property
    def memory(self) -> int:
        """Bytes each such sensor holds of its own in one world."""
        return self.entries * FLOAT_BYTES * OBS_COPIES + self.extra_bytes + self.rays * RAY_BYTES


def _width(channels: tuple[str, ...], widths: dict[str, int], semantic: str) -> int:
    return sum(widths.get(c, SEMANTIC_WIDTHS[semantic]) for c in channels)


def _parts(agent: AgentSpec) -> int:
    """The body parts after the base: head, arm segments, graspers, and the entries of
    ``parts`` (kinds registered from outside, counted one each)."""
    return (
        (agent.head is not None)
        + sum(len(arm.segments) + (arm.grasper is not None) for arm in agent.arms)
        + len(agent.parts)
    )


def _camera(sensor: Any, agent: AgentSpec, area: float) -> SensorSize:
    width = _width(sensor.channels, CAMERA_WIDTHS, sensor.semantic)
    return SensorSize(sensor.rays * width, rays=sensor.rays)


def _lidar(sensor: Any, agent: AgentSpec, area: float) -> SensorSize:
    return SensorSize(sensor.rays, rays=sensor.rays)


def _topdown(sensor: Any, agent: AgentSpec, area: float) -> SensorSize:
    pixels = sensor.size * sensor.size
    width = _width(sensor.channels, TOPDOWN_WIDTHS, sensor.semantic)
    return SensorSize(pixels * width, extra_bytes=pixels * PIXEL_ID_BYTES)


def _touch(sensor: Any, agent: AgentSpec, area: float) -> SensorSize:
    return SensorSize(sensor.sectors + (_parts(agent) if sensor.parts else 0))


def _proprioception(sensor: Any, agent: AgentSpec, area: float) -> SensorSize:
    return SensorSize(3 + _parts(agent))


def _smell(sensor: Any, agent: AgentSpec, area: float) -> SensorSize:
    channels = len(sensor.sources) if sensor.sources else 1
    cell = sensor.cell if sensor.cell is not None else agent.radius
    cells = min(area * channels / (cell * cell), SCENT_CELLS)
    key = ("smell", cell, sensor.sources, sensor.range)
    return SensorSize(2 * channels, shared_bytes=int(cells * SCENT_CELL_BYTES), shared_key=key)


SENSOR_SIZES: dict[str, Callable[[Any, AgentSpec, float], SensorSize]] = {
    "camera": _camera,
    "lidar": _lidar,
    "topdown": _topdown,
    "touch": _touch,
    "proprioception": _proprioception,
    "smell": _smell,
}
"""The cost of each sensor kind shipped, from its spec, its agent and the arena's area."""


def sensor_size(sensor: Any, agent: AgentSpec, area: float) -> SensorSize:
    """What ``sensor`` (a spec, on ``agent``, in an arena of ``area``) costs in one world."""
    size = SENSOR_SIZES.get(getattr(sensor, "type", ""))
    if size is None:
        return SensorSize(0, extra_bytes=UNKNOWN_SENSOR_BYTES)
    return size(sensor, agent, area)


@dataclass(frozen=True)
class Written:
    """A sensor as written in a file: where, its cost, how many agents carry it, and the
    bytes it adds to one world (its own memory on each agent, and what it shares, once)."""

    path: KeyPath
    size: SensorSize
    count: int
    memory: int


def sensor_sizes(spec: ScenarioFields) -> list[Written]:
    """Every sensor written in ``spec``, in agent-kind order; the channel's ``messages``
    (heard by every agent) as one more."""
    width, height = spec.arena.size
    area = float(width) * float(height)
    written: list[tuple[KeyPath, SensorSize, int]] = []
    for path, agent, count in spec.agent_kinds():
        if agent.sensors is None:
            written.append((path + ("camera",), sensor_size(agent.camera, agent, area), count))
        for s, sensor in enumerate(agent.sensors or ()):
            written.append((path + ("sensors", s), sensor_size(sensor, agent, area), count))
    if spec.channel is not None:
        heard = spec.n_agents * (1 + spec.channel.tokens * spec.channel.vocabulary)
        written.append((("channel",), SensorSize(heard), spec.n_agents))
    out, shared = [], set()
    for path, size, count in written:
        memory = size.memory * count
        if size.shared_key not in shared:
            memory += size.shared_bytes
            shared.add(size.shared_key)
        out.append(Written(path, size, count, memory))
    return out


def observation_bytes(spec: ScenarioFields) -> int:
    """Bytes of one step's observations of every agent of one world (float32 entries)."""
    return sum(w.size.entries * w.count for w in sensor_sizes(spec)) * FLOAT_BYTES


def rays_per_step(spec: ScenarioFields) -> int:
    """Rays one world casts each step, every agent's sensors together."""
    return sum(w.size.rays * w.count for w in sensor_sizes(spec))


def sensor_bytes(spec: ScenarioFields) -> int:
    """Bytes every sensor of every agent of one world holds, together."""
    return sum(w.memory for w in sensor_sizes(spec))
