"""The reference solver: the scripted play that proves a scenario solvable, and the score
it must reach. Every shipped scenario has one, and the scenario library's tests are
generated from it; the env itself never reads it."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from flatland_ma.scenario.types import Real, Spec


class ReferenceSpec(Spec):
    """How the scenario's tests prove it solvable: ``solver`` plays ``episodes`` episodes
    (seeds 0, 1, ...) and its mean score per agent must reach ``min_score``, and beat
    random play's over the same seeds by at least 0.8 x ``min_score``."""

    solver: Literal["greedy", "planner", "carrier", "carrier_vs_random", "sniffer"]
    """greedy: ``GreedyForager`` (sees only its camera). planner: ``PlannerPolicy``
    (search with full knowledge). carrier: ``CarrierPolicy`` (scripted grasping,
    pushing and carrying, with full knowledge). carrier_vs_random: the first team plays
    ``CarrierPolicy`` against random play by the others; the score is the first team's.
    sniffer: ``Sniffer`` (follows its smell sensor, sees nothing else)."""
    min_score: Real
    """The least mean score per agent (the sum of its rewards in an episode) the solver
    must reach."""
    episodes: Annotated[int, Field(strict=True, ge=1, le=1000)] = 4
    """How many episodes the solver and random play each play."""
