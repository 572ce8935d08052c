"""Random placement at free places that the agents can reach, driven only by the env's
generator."""

from __future__ import annotations

import numpy as np

from flatland_ma.world.navigation import NavGrid
from flatland_ma.world.world import World

MAX_TRIES = 500


class PlacementError(RuntimeError):
    """No free place was found: the area is full, walled off or out of reach."""


class Placer:
    """Draws places uniformly over the reachable free cells of an area, then checks that
    the exact disc touches nothing (agents and items included)."""

    def __init__(self, world: World, grid: NavGrid, reachable: np.ndarray | None = None):
        self.world = world
        self.grid = grid
        self.reachable = reachable
        self._cells: dict = {}

    def mask(self, area) -> np.ndarray:
        """The cells in ``area`` where a place may be drawn: free and reachable."""
        mask = self.grid.cells_in(area) & ~self.grid.blocked
        if self.reachable is not None:
            mask &= self.reachable
        return mask

    def candidates(self, area) -> np.ndarray:
        """Indices (i, j) of the cells in ``area`` where a place may be drawn."""
        key = None if area is None else tuple(area)
        if key not in self._cells:
            self._cells[key] = np.argwhere(self.mask(area))
        return self._cells[key]

    def sample(
        self, rng: np.random.Generator, radius: float, area=None, margin: float = 1.0
    ) -> tuple[float, float]:
        cells = self.candidates(area)
        if len(cells) == 0:
            raise PlacementError("no free place in the area that agents can reach")
        cell = self.grid.cell
        for _ in range(MAX_TRIES):
            i, j = cells[rng.integers(len(cells))]
            x = (j + rng.uniform()) * cell
            y = (i + rng.uniform()) * cell
            if area is not None:
                x = min(max(x, area[0]), area[2])
                y = min(max(y, area[1]), area[3])
            if self.world.is_free(x, y, radius + margin):
                return float(x), float(y)
        raise PlacementError(
            f"no free place for a disc of radius {radius:g} after {MAX_TRIES} tries"
        )
