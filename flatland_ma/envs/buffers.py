"""The arrays of the batched envs: stacked observations (a dict of them for a ``Dict``
space), one slot per agent of every world, the info counters, and each world's seed."""

from __future__ import annotations

from typing import Any, TypeGuard

import gymnasium
import numpy as np


def stacked(space: gymnasium.Space, n: int) -> Any:
    """Zeros for ``n`` stacked values of ``space`` (a dict of them for a ``Dict``)."""
    if isinstance(space, gymnasium.spaces.Dict):
        return {key: stacked(sub, n) for key, sub in space.spaces.items()}
    assert space.shape is not None, f"{space} has no shape to stack"
    return np.zeros((n, *space.shape), space.dtype)


def put(buffer, slot: int, value) -> None:
    if isinstance(buffer, dict):
        for key, sub in buffer.items():
            sub[slot] = value[key]
    else:
        buffer[slot] = value


def clear(buffer, slot: int) -> None:
    if isinstance(buffer, dict):
        for sub in buffer.values():
            sub[slot] = 0
    else:
        buffer[slot] = 0


def copied(buffer) -> Any:
    if isinstance(buffer, dict):
        return {key: sub.copy() for key, sub in buffer.items()}
    return buffer.copy()


def counter_array(value, n: int) -> np.ndarray:
    """Room for one info entry per slot: integers, other numbers, or anything else (such
    as the tuple of keys held) as objects."""
    if isinstance(value, bool | np.bool_):
        return np.zeros(n, bool)
    if isinstance(value, int | np.integer):
        return np.zeros(n, np.int64)
    if isinstance(value, float | np.floating):
        return np.zeros(n, np.float64)
    return np.empty(n, object)


def put_column(counter: np.ndarray, rows, base: int, live: list[int], values: list) -> None:
    """Write one info entry of a world's ``live`` agents (slots ``rows``: a slice, or
    ``base + i`` for each) into its array; objects (tuples of keys) one by one, as numpy
    would read a list of tuples as rows."""
    if counter.dtype != object:
        counter[rows] = values
        return
    for i, value in zip(live, values):
        counter[base + i] = value


def world_seeds(seed: int | list[int | None] | None, n: int) -> list[int | None]:
    """Each world's seed, all checked before any world resets."""
    if seed is None:
        return [None] * n
    if _whole(seed):
        seeds: list = [int(seed) + w for w in range(n)]
    elif isinstance(seed, list | tuple):
        seeds = list(seed)
        if len(seeds) != n:
            raise ValueError(f"expected {n} seeds, one per world, got {len(seeds)}")
    else:
        raise TypeError(f"seed must be an integer or a list of one per world, not {seed!r}")
    for w, value in enumerate(seeds):
        if value is not None and not (_whole(value) and value >= 0):
            raise ValueError(
                f"world {w}'s seed must be a non-negative integer or None, not {value!r}"
            )
    return [None if value is None else int(value) for value in seeds]


def _whole(value) -> TypeGuard[int | np.integer]:
    return isinstance(value, int | np.integer) and not isinstance(value, bool | np.bool_)
