"""The reference solver: the scripted play that proves a scenario solvable, and the score
it must reach. Every shipped scenario has one, and the scenario library's tests are
generated from it; the env itself never reads it."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from flatland_ma.scenario.types import Real, Spec


class ReferenceSpec(Spec):
    """How the scenario's tests prove it solvable: ``solver`` plays ``episodes`` episodes
    (seeds 0, 1, ...) and its mean score per agent must reach ``min_score``, and beat
    random play's over the same seeds by at least 0.8 x ``min_score``."""

    solver: Literal["greedy", "planner", "carrier", "carrier_vs_random", "sniffer", "teams"]
    """greedy: ``GreedyForager`` (sees only its camera). planner: ``PlannerPolicy``
    (search with full knowledge). carrier: ``CarrierPolicy`` (scripted grasping,
    pushing and carrying, with full knowledge). carrier_vs_random: the first team plays
    ``CarrierPolicy`` against random play by the others; the score is the first team's.
    sniffer: ``Sniffer`` (follows its smell sensor, sees nothing else). teams: each team
    plays the solver ``teams`` names for it (agents with different roles)."""
    teams: (
        Annotated[
            tuple[Literal["greedy", "planner", "carrier", "sniffer", "signaller", "follower"], ...],
            Field(min_length=1, max_length=64),
        ]
        | None
    ) = None
    """With ``solver: teams``: the solver of each team, in team order."""
    min_score: Real
    """The least mean score per agent (the sum of its rewards in an episode) the solver
    must reach."""
    episodes: Annotated[int, Field(strict=True, ge=1, le=1000)] = 4
    """How many episodes the solver and random play each play."""

    @model_validator(mode="after")
    def _teams(self):
        if (self.solver == "teams") != (self.teams is not None):
            raise ValueError("give 'teams' (a solver per team) exactly with 'solver: teams'")
        return self
