"""Agents: their bodies, motors, cameras, action mode and where they start."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from flatland_ma.scenario.types import Color, Positive, Real, Rect, Spec, int_range


class CameraSpec(Spec):
    rays: int_range(1, 4096) = 64
    """Number of rays, i.e. the width of the 1-D image."""
    fov: Annotated[float, Field(strict=True, gt=0, le=360, allow_inf_nan=False)] = 120.0
    """Field of view in degrees, centred on the heading."""
    range: Positive = 300.0
    """Farthest distance a ray sees; depth is normalised by it."""
    falloff: Literal["linear", "none"] = "linear"
    """How colour intensity falls with distance: ``linear`` is ``1 - d / range``."""


class SpawnSpec(Spec):
    area: Rect | None = None
    """Where agents start (uniformly, at free places reachable from each other);
    None: anywhere free in the arena."""
    heading: Real | None = None
    """Starting heading in degrees (counter-clockwise from +x); None: uniformly random."""


class AgentSpec(Spec):
    radius: Positive = 10.0
    """Agents are discs of this radius."""
    mass: Positive = 1.0
    """Mass of an agent's body."""
    colors: Annotated[tuple[Color, ...], Field(min_length=1)] = (
        "blue",
        "red",
        "green",
        "yellow",
        "cyan",
        "magenta",
        "teal",
        "brown",
    )
    """Agent i is drawn (and seen by other agents) in ``colors[i % len(colors)]``."""
    actions: Literal["discrete", "continuous"] = "discrete"
    """``discrete``: Discrete(3) forward / rotate left / rotate right; ``continuous``:
    Box(-1, 1, (3,)) longitudinal, lateral, angular."""
    max_speed: Positive = 200.0
    """Top linear speed, units per second."""
    max_turn_rate: Positive = 300.0
    """Top angular speed, degrees per second."""
    max_force: Positive = 15_000.0
    """Largest force the agent's motor applies to reach its commanded velocity."""
    max_torque: Positive = 100_000.0
    """Largest torque the agent's motor applies to reach its commanded turn rate."""
    camera: CameraSpec = CameraSpec()
    """The first-person camera."""
    spawn: SpawnSpec = SpawnSpec()
    """Where and how agents start."""
