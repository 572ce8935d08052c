"""The tiers the physics bridge (``physics.py``) works in, and the choice among them: the
fastest this pymunk allows unless the environment variable ``FLATLAND_MA_PHYSICS`` asks
for a slower one. Pure Python: which tiers this pymunk allows is found by the bridge."""

from __future__ import annotations

from enum import IntEnum

VARIABLE = "FLATLAND_MA_PHYSICS"
"""The environment variable that asks for a tier."""


class Tier(IntEnum):
    """How pymunk is reached, slowest first (see ``physics.py``'s docstring)."""

    ATTRIBUTES = 1
    BATCH = 2
    COMPILED = 3


def chosen(best: Tier, asked: str | None) -> Tier:
    """The tier to use: ``asked`` (a tier's name, any case; None or empty: ``best``), at
    most ``best``. ValueError, naming the variable, for a name that is no tier's."""
    if not asked:
        return best
    names = {tier.name.lower(): tier for tier in Tier}
    if asked.lower() not in names:
        raise ValueError(f"{VARIABLE}={asked!r}: one of {', '.join(names)}")
    return min(best, names[asked.lower()])


def described(tier: Tier, best: Tier, why: str, version: str) -> str:
    """``tier`` in words, for pymunk ``version``: why it is not ``best`` (asked for), or
    why not the compiled tier (``why``)."""
    text = f"{tier.name.lower()} (pymunk {version}"
    if tier < best:
        text += f"; {VARIABLE} asked for it, {best.name.lower()} is possible"
    elif tier < Tier.COMPILED:
        text += f"; {why}"
    return text + ")"
