"""Random placement of discs at free positions, driven only by the env's generator."""

from __future__ import annotations

import numpy as np

from flatland_ma.world.world import World

MAX_TRIES = 2000


class PlacementError(RuntimeError):
    """No free position was found: the arena is too full for what it must hold."""


def sample_free_position(
    world: World, rng: np.random.Generator, radius: float, margin: float = 1.0
) -> tuple[float, float]:
    """A uniformly drawn position where a disc of ``radius`` (+ ``margin``) touches nothing."""
    width, height = world.size
    r = radius + margin
    if 2 * r >= min(width, height):
        raise PlacementError(f"a disc of radius {radius:g} does not fit in the arena")
    lows, highs = np.array([r, r]), np.array([width - r, height - r])
    for _ in range(MAX_TRIES):
        x, y = rng.uniform(lows, highs)
        if world.is_free(float(x), float(y), r):
            return float(x), float(y)
    raise PlacementError(
        f"no free position for a disc of radius {radius:g} after {MAX_TRIES} tries"
    )
