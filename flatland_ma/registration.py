"""Gymnasium ids for every single-agent scenario, registered when the package is imported.

Each id is registered with its scenario's ``episode.max_steps`` as ``max_episode_steps``,
so ``gymnasium.make``'s ``TimeLimit`` truncates there unless ``max_episode_steps=N`` says
otherwise; the env is built with ``time_limit=False`` so that it does not truncate too.
"""

from __future__ import annotations

import gymnasium

from flatland_ma.scenario.loader import list_scenarios, load_scenario

NAMESPACE = "flatland_ma"


def gym_id(scenario: str) -> str:
    """``fruits_poisons`` -> ``flatland_ma/FruitsPoisons-v0``."""
    return f"{NAMESPACE}/{''.join(part.capitalize() for part in scenario.split('_'))}-v0"


def single_agent_scenarios() -> dict[str, int]:
    """Shipped scenarios with one agent, each with its ``episode.max_steps``."""
    limits = {}
    for name in list_scenarios():
        spec = load_scenario(name)  # the file alone: nothing is built
        if spec.n_agents == 1:
            limits[name] = spec.episode.max_steps
    return limits


def register_gym_ids() -> list[str]:
    ids = []
    for name, max_steps in single_agent_scenarios().items():
        env_id = gym_id(name)
        if env_id not in gymnasium.registry:
            gymnasium.register(
                id=env_id,
                entry_point="flatland_ma.envs.gym:FlatlandGymEnv",
                vector_entry_point="flatland_ma.envs.gym_vector:make_vector",
                max_episode_steps=max_steps,
                kwargs={"scenario": name, "time_limit": False},
            )
        ids.append(env_id)
    return ids
