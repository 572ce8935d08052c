"""flatland_ma: a multi-agent, first-person 2-D world for reinforcement learning.

import flatland_ma
env = flatland_ma.parallel_env("fruits_poisons_multi")   # PettingZoo parallel
env = flatland_ma.env("fruits_poisons")                  # PettingZoo AEC
gymnasium.make("flatland_ma/FruitsPoisons-v0")           # Gymnasium, one agent

Importing the package registers the Gymnasium ids (from the shipped scenarios' index:
no file is parsed until an env is made, ``flatland_ma.envs.registration``); the scenario
loader, the physics, the compiled kernels and the PettingZoo interfaces are imported on
first use of the names that need them (``load_scenario``, ``parallel_env``, ``env``,
``check_scenario``), so that a command such as ``flatland-ma list`` starts quickly.
"""

from __future__ import annotations

import importlib
from importlib.metadata import PackageNotFoundError, version
from typing import TYPE_CHECKING

from flatland_ma.envs.registration import register_gym_ids, register_stream_ids
from flatland_ma.scenario.shipped import list_scenarios

# OpenMP's idle threads (the ray kernel's, and torch's: one library) sleep instead of
# spinning, unless the user chose otherwise. It must be set before OpenMP starts (none of
# the imports above starts it), so importing flatland_ma before torch does it; imported
# after, it warns (flatland_ma.sensors.threads).
from flatland_ma.sensors import threads as _threads  # noqa: F401

if TYPE_CHECKING:
    from flatland_ma.build.feasibility import check_scenario
    from flatland_ma.envs.aec import env
    from flatland_ma.envs.gym_vector import FlatlandVectorEnv
    from flatland_ma.envs.parallel import FlatlandParallelEnv
    from flatland_ma.envs.parallel import FlatlandParallelEnv as parallel_env
    from flatland_ma.envs.shards import ShardedParallelEnv
    from flatland_ma.envs.vector import AUTORESET_MODE, BatchedParallelEnv
    from flatland_ma.scenario.extensions import register
    from flatland_ma.scenario.loader import load_scenario

try:  # the installed distribution's version: pyproject.toml is its one source
    __version__ = version("flatland-ma")
except PackageNotFoundError:  # a source tree on sys.path, never installed
    __version__ = "0+unknown"

GYM_IDS = register_gym_ids()
"""The Gymnasium ids registered on import, one per single-agent scenario."""
STREAM_GYM_IDS = register_stream_ids()
"""The Gymnasium ids of the shipped task streams, one life each (``flatland_ma.lifelong``)."""

_LAZY = {
    "FlatlandParallelEnv": ("flatland_ma.envs.parallel", "FlatlandParallelEnv"),
    "parallel_env": ("flatland_ma.envs.parallel", "FlatlandParallelEnv"),
    "env": ("flatland_ma.envs.aec", "env"),
    "check_scenario": ("flatland_ma.build.feasibility", "check_scenario"),
    "BatchedParallelEnv": ("flatland_ma.envs.vector", "BatchedParallelEnv"),
    "ShardedParallelEnv": ("flatland_ma.envs.shards", "ShardedParallelEnv"),
    "FlatlandVectorEnv": ("flatland_ma.envs.gym_vector", "FlatlandVectorEnv"),
    "AUTORESET_MODE": ("flatland_ma.envs.vector", "AUTORESET_MODE"),
    "register": ("flatland_ma.scenario.extensions", "register"),
    "load_scenario": ("flatland_ma.scenario.loader", "load_scenario"),
}
"""Names imported on first use: ``parallel_env(scenario="fruits_poisons",
render_mode=None, max_cycles=None, **overrides)`` is the parallel env's class;
``register(spec, implementation)`` adds a sensor, rule, part or generator from your own
package (``flatland_ma.scenario.extensions``). Many worlds at once: the batched env
(``BatchedParallelEnv``, ``flatland_ma.envs.vector``, with its ``AUTORESET_MODE``), the
same worlds over processes (``ShardedParallelEnv``, ``flatland_ma.envs.shards``) and the
Gymnasium vector env of a single-agent scenario (``FlatlandVectorEnv``, what
``gymnasium.make_vec`` builds; ``flatland_ma.envs.gym_vector``)."""


def __getattr__(name: str):
    if name in _LAZY:
        module, attribute = _LAZY[name]
        value = getattr(importlib.import_module(module), attribute)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'flatland_ma' has no attribute {name!r}")


__all__ = [
    "AUTORESET_MODE",
    "GYM_IDS",
    "STREAM_GYM_IDS",
    "BatchedParallelEnv",
    "ShardedParallelEnv",
    "FlatlandParallelEnv",
    "FlatlandVectorEnv",
    "__version__",
    "check_scenario",
    "env",
    "list_scenarios",
    "load_scenario",
    "parallel_env",
    "register",
]
