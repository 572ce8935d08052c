"""Surface textures: the colour at a distance ``u`` along a surface (or at a world point).

Kinds are numbered for the ray kernel; ``shade`` is compiled and inlined into it.
"""

from __future__ import annotations

import math

import numba as nb

UNIFORM, STRIPES, TILES, CHECKERS, GRADIENT, NOISE = range(6)
KINDS = {"uniform": UNIFORM, "stripes": STRIPES, "tiles": TILES, "checkers": CHECKERS,
         "gradient": GRADIENT, "noise": NOISE}  # fmt: skip


@nb.njit(cache=True, inline="always")
def _hash01(seed, cell):
    """A number in [0, 1) that depends only on (seed, cell): splitmix64 of their mix."""
    x = nb.uint64(seed) * nb.uint64(0x9E3779B97F4A7C15) + nb.uint64(cell & 0xFFFFFFFFFFFF)
    x = (x ^ (x >> nb.uint64(30))) * nb.uint64(0xBF58476D1CE4E5B9)
    x = (x ^ (x >> nb.uint64(27))) * nb.uint64(0x94D049BB133111EB)
    x = x ^ (x >> nb.uint64(31))
    return float(x >> nb.uint64(11)) / 9007199254740992.0


@nb.njit(cache=True, inline="always")
def shade(kind, period, duty, seed, u, hx, hy):
    """Weight of the second colour (0: all the first, 1: all the second) at the hit."""
    if kind == UNIFORM:
        return 0.0
    if kind == STRIPES:
        f = u / period - math.floor(u / period)
        return 0.0 if f < duty else 1.0
    if kind == TILES:
        f = u / period - math.floor(u / period)
        return 1.0 if f < duty else 0.0
    if kind == CHECKERS:
        parity = (int(math.floor(hx / period)) + int(math.floor(hy / period))) & 1
        return float(parity)
    if kind == GRADIENT:
        f = u / period - 2.0 * math.floor(u / (2.0 * period))
        return f if f < 1.0 else 2.0 - f
    cell = int(math.floor(u / period))
    return _hash01(int(seed), cell)
