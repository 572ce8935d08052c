"""flatland_ma: a multi-agent, first-person 2-D world for reinforcement learning.

import flatland_ma
env = flatland_ma.parallel_env("fruits_poisons_multi")   # PettingZoo parallel
env = flatland_ma.env("fruits_poisons")                  # PettingZoo AEC
gymnasium.make("flatland_ma/FruitsPoisons-v0")           # Gymnasium, one agent
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

from flatland_ma.build.feasibility import check_scenario
from flatland_ma.envs.aec import env
from flatland_ma.envs.parallel import FlatlandParallelEnv
from flatland_ma.registration import register_gym_ids
from flatland_ma.scenario.loader import list_scenarios, load_scenario

try:  # the installed distribution's version: pyproject.toml is its one source
    __version__ = version("flatland-ma")
except PackageNotFoundError:  # a source tree on sys.path, never installed
    __version__ = "0+unknown"

parallel_env = FlatlandParallelEnv
"""``parallel_env(scenario="fruits_poisons", render_mode=None, max_cycles=None, **overrides)``."""

GYM_IDS = register_gym_ids()
"""The Gymnasium ids registered on import, one per single-agent scenario."""

__all__ = [
    "GYM_IDS",
    "FlatlandParallelEnv",
    "__version__",
    "check_scenario",
    "env",
    "list_scenarios",
    "load_scenario",
    "parallel_env",
]
