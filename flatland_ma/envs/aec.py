"""The PettingZoo AEC environment, derived from the parallel one (no logic of its own)."""

from __future__ import annotations

from pettingzoo import AECEnv
from pettingzoo.utils.conversions import parallel_to_aec

from flatland_ma.envs.parallel import FlatlandParallelEnv


def env(scenario="fruits_poisons", render_mode: str | None = None, **overrides) -> AECEnv:
    """AEC view of ``FlatlandParallelEnv``: agents act in turn, physics runs once all have."""
    return parallel_to_aec(FlatlandParallelEnv(scenario, render_mode=render_mode, **overrides))
