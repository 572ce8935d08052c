"""How surfaces look: a plain colour, or a texture whose colour varies along the surface."""

from __future__ import annotations

from dataclasses import dataclass

RGB = tuple[float, float, float]
"""A colour as three floats in [0, 1]."""


@dataclass(frozen=True)
class Texture:
    """A pattern of two colours along a surface (see ``sensors/textures.py``).

    ``kind`` is one of uniform, stripes, tiles, checkers, gradient, noise; ``period`` is
    the length in world units of one repeat, ``duty`` the share of a period in the first
    colour (stripes) or in grout (tiles), ``seed`` the seed of the noise pattern.
    """

    kind: str
    colors: tuple[RGB, RGB]
    period: float = 10.0
    duty: float = 0.5
    seed: int = 0

    @property
    def plain(self) -> bool:
        """Whether it is one colour all over (the first)."""
        return self.kind == "uniform"
