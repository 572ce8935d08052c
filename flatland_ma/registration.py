"""Gymnasium ids for every single-agent scenario, registered when the package is imported.

An id names its scenario and the scenario's ``version`` (``fruits_poisons`` at version 0
is ``flatland_ma/FruitsPoisons-v0``); only the current version of each is registered, so
an id of an older version fails in ``gymnasium.make``, which names the versions there are.

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

from flatland_ma.scenario.loader import list_scenarios, list_streams, load_scenario

NAMESPACE = "flatland_ma"


def _camel(name: str) -> str:
    return "".join(part.capitalize() for part in name.split("_"))


def gym_id(scenario: str, version: int | None = None) -> str:
    """``fruits_poisons`` at version 0 -> ``flatland_ma/FruitsPoisons-v0``; without
    ``version``, the shipped scenario's own (its file's ``version``)."""
    if version is None:
        version = load_scenario(scenario).version
    return f"{NAMESPACE}/{_camel(scenario)}-v{version}"


def stream_gym_id(stream: str) -> str:
    """``cross_objective`` -> ``flatland_ma/CrossObjectiveStream-v0``."""
    return f"{NAMESPACE}/{_camel(stream)}Stream-v0"


def single_agent_scenarios() -> dict[str, tuple[int, int]]:
    """Shipped scenarios with one agent, each with its ``version`` and ``episode.max_steps``."""
    found = {}
    for name in list_scenarios():
        spec = load_scenario(name)  # the file alone: nothing is built
        if spec.n_agents == 1:
            found[name] = (spec.version, spec.episode.max_steps)
    return found


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
