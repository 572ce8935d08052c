"""Running policies for whole episodes and summarising their scores."""

from __future__ import annotations

from dataclasses import dataclass

import gymnasium
import numpy as np

from flatland_ma.envs.parallel import FlatlandParallelEnv


class RandomPolicy:
    """Uniform random actions from the agent's action space (seeded)."""

    def __init__(self, space: gymnasium.Space, seed: int | None = None):
        self.space = space
        self.space.seed(seed)

    def act(self, observation):
        return self.space.sample()


@dataclass
class EpisodeScores:
    returns: list[float]
    """Per episode, the mean over agents of each agent's return."""
    infos: list[dict]
    """Per episode, each agent's final counters."""

    @property
    def mean(self) -> float:
        return float(np.mean(self.returns))

    @property
    def std(self) -> float:
        return float(np.std(self.returns))


def evaluate(env: FlatlandParallelEnv, make_policy, episodes: int, seed: int = 0) -> EpisodeScores:
    """Play ``episodes`` episodes; ``make_policy(agent)`` gives each agent its policy.

    Episode k is reset with seed ``seed + k``.
    """
    policies = {a: make_policy(a) for a in env.possible_agents}
    returns, infos = [], []
    for k in range(episodes):
        total, info = play_episode(env, policies, seed + k)
        returns.append(float(np.mean(list(total.values()))))
        infos.append(info)
    return EpisodeScores(returns, infos)


def play_episode(env: FlatlandParallelEnv, policies: dict, seed: int) -> tuple[dict, dict]:
    """One whole episode from ``reset(seed=seed)``, ``policies[agent]`` acting for each
    agent (each reset first, if it has ``reset``): every agent's return, and the infos
    of the last step."""
    observations, info = env.reset(seed=seed)
    for policy in policies.values():
        reset = getattr(policy, "reset", None)
        if reset is not None:
            reset()
    total = dict.fromkeys(env.possible_agents, 0.0)
    while env.agents:
        actions = {a: policies[a].act(observations[a]) for a in env.agents}
        observations, rewards, _, _, info = env.step(actions)
        for a, r in rewards.items():
            total[a] += r
    return total, info
