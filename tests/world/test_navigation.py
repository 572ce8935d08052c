"""The navigation grid's searches: steps from starts that begin at their own counts."""

from __future__ import annotations

import numpy as np

from flatland_ma.world.navigation import UNREACHED, grid_steps, grid_steps_from


def test_a_start_that_begins_later_counts_on_from_its_own_level():
    open_floor = np.zeros((7, 9), np.bool_)
    start = np.full(open_floor.shape, UNREACHED, np.int32)
    start[3, 0] = 0
    start[3, 8] = 5  # five steps behind: it wins only within two cells of itself
    got = grid_steps_from(open_floor, start)
    # On open floor a diagonal step counts one: the steps are Chebyshev distances.
    i, j = np.indices(open_floor.shape)
    want = np.minimum(np.maximum(abs(i - 3), j), 5 + np.maximum(abs(i - 3), 8 - j))
    assert (got == want).all()
    assert got[3, 8] == 5 and got[3, 6] == 6  # (3, 6): 6 from the left start, 7 from its own


def test_steps_from_offset_starts_are_the_least_over_the_starts_of_offset_plus_steps():
    rng = np.random.default_rng(0)
    for _ in range(100):
        ny, nx = rng.integers(1, 14, 2)
        blocked = rng.random((ny, nx)) < 0.3
        start = np.full((ny, nx), UNREACHED, np.int32)
        for _ in range(rng.integers(0, 5)):
            start[rng.integers(ny), rng.integers(nx)] = rng.integers(0, 10)
        want = np.full((ny, nx), UNREACHED, np.int64)
        for (i, j), begin in np.ndenumerate(start):
            if begin < UNREACHED and not blocked[i, j]:
                steps = grid_steps(blocked, np.array([[i, j]], np.int64)).astype(np.int64)
                want = np.minimum(want, np.where(steps == UNREACHED, UNREACHED, steps + begin))
        assert (grid_steps_from(blocked, start) == want).all()
