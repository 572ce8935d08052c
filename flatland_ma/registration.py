"""Gymnasium ids for every single-agent scenario, registered when the package is imported."""

from __future__ import annotations

import gymnasium
import yaml

from flatland_ma.scenario.loader import list_scenarios, scenario_path

NAMESPACE = "flatland_ma"


def gym_id(scenario: str) -> str:
    """``fruits_poisons`` -> ``flatland_ma/FruitsPoisons-v0``."""
    return f"{NAMESPACE}/{''.join(part.capitalize() for part in scenario.split('_'))}-v0"


def single_agent_scenarios() -> list[str]:
    """Shipped scenarios with one agent (a file that does not set ``n_agents`` has one)."""
    names = []
    for name in list_scenarios():
        n_agents = _declared_n_agents(name)
        if n_agents == 1:
            names.append(name)
    return names


def _declared_n_agents(name: str, depth: int = 0) -> object:
    data = yaml.safe_load(scenario_path(name).read_text(encoding="utf-8")) or {}
    if "n_agents" in data or "extends" not in data or depth > 8:
        return data.get("n_agents", 1)
    return _declared_n_agents(data["extends"], depth + 1)


def register_gym_ids() -> list[str]:
    ids = []
    for name in single_agent_scenarios():
        env_id = gym_id(name)
        if env_id not in gymnasium.registry:
            gymnasium.register(
                id=env_id,
                entry_point="flatland_ma.envs.gym:FlatlandGymEnv",
                kwargs={"scenario": name},
            )
        ids.append(env_id)
    return ids
