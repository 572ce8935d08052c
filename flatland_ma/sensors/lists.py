"""Numba typed lists made and written by compiled functions that numba caches.

Making a ``numba.typed.List`` from Python, or setting one of its items, compiles the list's
methods for its item type in every new process: seconds for the tuples of arrays the ray
kernel and the pose reader take. The same work inside ``cache=True`` functions is loaded
from numba's cache instead, so a new process builds its batched env at once."""

from __future__ import annotations

import numba as nb
from numba.typed import List


@nb.njit(cache=True)
def filled(item, n: int) -> List:
    """A typed list of ``n`` references to ``item``."""
    items = List()  # type: ignore[operator]  # a class at runtime
    for _ in range(n):
        items.append(item)
    return items


@nb.njit(cache=True)
def put(items, i: int, item) -> None:
    """``items[i] = item``."""
    items[i] = item
