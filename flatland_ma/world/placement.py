"""Random placement at free places that the agents can reach, driven only by the env's
generator."""

from __future__ import annotations

import numpy as np

from flatland_ma.world.navigation import MAX_CELLS, NavGrid
from flatland_ma.world.world import World

MAX_TRIES = 500
"""Places drawn for one thing before giving up on it."""
RESET_TRIES = 200_000
"""Places a reset may draw in all (for agents, items and scattered obstacles): enough for
the most items a scenario may have in a crowded arena, and a second or two of work."""
RESET_SEARCH = 40 * MAX_CELLS
"""Grid cells a reset may search to check what agents can reach (forty searches of the
largest grid, a few seconds; a small arena's grid may be searched thousands of times)."""


class PlacementError(RuntimeError):
    """No free place was found: the area is full, walled off or out of reach."""


class OutOfBudget(PlacementError):
    """A reset spent all the work it may spend placing things."""


class ResetBudget:
    """The work one reset may spend placing things, counted (not timed, so that a reset
    does the same at every seed on every machine): places drawn and grid cells searched."""

    def __init__(self, tries: int | None = None, search: int | None = None):
        self.limits = (
            RESET_TRIES if tries is None else tries,
            RESET_SEARCH if search is None else search,
        )
        self.tries, self.search = self.limits
        self.spent = False
        """Whether it ran out (then drawing a layout again is pointless)."""

    def draw(self) -> None:
        """Spend one place drawn."""
        if self.tries <= 0:
            self.spent = True
            raise OutOfBudget(
                f"the reset drew {self.limits[0]:,} places, the most one may draw (the work budget)"
            )
        self.tries -= 1

    def searched(self, cells: int) -> None:
        """Spend a search of ``cells`` cells."""
        if self.search < cells:
            self.spent = True
            raise OutOfBudget(
                f"the reset searched {self.limits[1]:,} grid cells for what agents can "
                "reach, the most one may search (the work budget)"
            )
        self.search -= cells


class Placer:
    """Draws places uniformly over the reachable free cells of an area, then checks that
    the exact disc touches nothing (agents and items included)."""

    def __init__(
        self,
        world: World,
        grid: NavGrid,
        reachable: np.ndarray | None = None,
        budget: ResetBudget | None = None,
    ):
        self.world = world
        self.grid = grid
        self.reachable = reachable
        self.budget = budget
        """What the reset may still spend; None once the episode runs (each respawn is
        bounded by ``MAX_TRIES`` alone)."""
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
        cell, n = self.grid.cell, len(cells)
        for _ in range(MAX_TRIES):
            if self.budget is not None:
                self.budget.draw()
            k = rng.integers(n)
            # Python numbers throughout (numpy's scalar arithmetic costs about a
            # microsecond an operation), with the same doubles: random() is uniform()'s
            # draw without its argument handling (uniform(0, 1) is 0 + 1 * random()).
            x = (cells.item(k, 1) + rng.random()) * cell
            y = (cells.item(k, 0) + rng.random()) * cell
            if area is not None:
                x = min(max(x, area[0]), area[2])
                y = min(max(y, area[1]), area[3])
            if self.world.is_free(x, y, radius + margin):
                return float(x), float(y)
        raise PlacementError(
            f"no free place for a disc of radius {radius:g} after {MAX_TRIES} tries"
        )
