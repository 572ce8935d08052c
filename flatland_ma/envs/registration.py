"""Gymnasium ids for every single-agent scenario, registered when the package is imported.

An id names its scenario and the scenario's ``version`` (``fruits_poisons`` at version 0
is ``flatland_ma/FruitsPoisons-v0``); only the current version of each is registered, so
an id of an older version fails in ``gymnasium.make``, which names the versions there are.

The ids are registered from the shipped scenarios' index (``flatland_ma.scenario.shipped``:
each one's version, number of agents and episode length, read without parsing the files);
a scenario is parsed and validated when an env is made. Should the files no longer match
the index, they are parsed here instead.

Each id is registered with its scenario's ``episode.max_steps`` as ``max_episode_steps``,
so ``gymnasium.make``'s ``TimeLimit`` truncates there unless ``max_episode_steps=N`` says
otherwise; the env is built with ``time_limit=False`` so that it does not truncate too.

Each shipped task stream has an id too (``cross_objective`` ->
``flatland_ma/CrossObjectiveStream-v0``): one life through it for a learner that drives
one agent (``flatland_ma.lifelong.StreamGymEnv``), with no time limit of Gymnasium's: the
stream's worlds truncate their own episodes and the stream switches task.
``gymnasium.make_vec`` on a stream id builds the stream's batched env
(``flatland_ma.lifelong.gym_vector``: its worlds live one life together).
"""

from __future__ import annotations

import gymnasium

from flatland_ma.scenario.shipped import list_scenarios, list_streams, read_index

NAMESPACE = "flatland_ma"


def _camel(name: str) -> str:
    return "".join(part.capitalize() for part in name.split("_"))


def gym_id(scenario: str, version: int | None = None) -> str:
    """``fruits_poisons`` at version 0 -> ``flatland_ma/FruitsPoisons-v0``; without
    ``version``, the shipped scenario's own (its file's ``version``)."""
    if version is None:
        version = _entries()[scenario]["version"]
    return f"{NAMESPACE}/{_camel(scenario)}-v{version}"


def stream_gym_id(stream: str) -> str:
    """``cross_objective`` -> ``flatland_ma/CrossObjectiveStream-v0``."""
    return f"{NAMESPACE}/{_camel(stream)}Stream-v0"


def _entries() -> dict[str, dict[str, int]]:
    """Each shipped scenario's version, number of agents and episode length: from the
    index, or from the files if they changed since it was written."""
    index = read_index()
    if index is not None and sorted(index) == list_scenarios():
        return index
    from flatland_ma.scenario.index import index_of_files

    return index_of_files()["scenarios"]


def single_agent_scenarios() -> dict[str, tuple[int, int]]:
    """Shipped scenarios with one agent, each with its ``version`` and ``episode.max_steps``."""
    return {
        name: (entry["version"], entry["max_steps"])
        for name, entry in _entries().items()
        if entry["n_agents"] == 1
    }


def register_gym_ids() -> list[str]:
    return [
        _register(
            gym_id(name, version),
            entry_point="flatland_ma.envs.gym:FlatlandGymEnv",
            vector_entry_point="flatland_ma.envs.gym_vector:make_vector",
            max_episode_steps=max_steps,
            kwargs={"scenario": name, "time_limit": False},
        )
        for name, (version, max_steps) in single_agent_scenarios().items()
    ]


def register_stream_ids() -> list[str]:
    return [
        _register(
            stream_gym_id(name),
            entry_point="flatland_ma.lifelong.envs:StreamGymEnv",
            vector_entry_point="flatland_ma.lifelong.gym_vector:make_stream_vector",
            kwargs={"stream": name},
        )
        for name in list_streams()
    ]


def _register(env_id: str, **spec) -> str:
    """Register ``env_id`` unless it already is (the package imported again)."""
    if env_id not in gymnasium.registry:
        gymnasium.register(id=env_id, **spec)
    return env_id
