"""Policies by name, for the command line and evaluation suites: the shipped ones, or a
checkpoint's path. Every one of them is a ``Policy``."""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

from flatland_ma.envs.parallel import FlatlandParallelEnv
from flatland_ma.policies.carrier import CarrierPolicy
from flatland_ma.policies.checkpoint import CheckpointPolicy
from flatland_ma.policies.greedy import GreedyForager
from flatland_ma.policies.idle import IdlePolicy
from flatland_ma.policies.planner import PlannerPolicy
from flatland_ma.policies.rollout import RandomPolicy
from flatland_ma.policies.signals import Follower, Signaller
from flatland_ma.policies.sniffer import Sniffer


@runtime_checkable
class Policy(Protocol):
    """What drives one agent: ``act`` maps the agent's observation (as the env gives it)
    to an action of its space. A policy that keeps memory within an episode also has
    ``reset()``, which the runners call at every reset. Scripted policies, random play,
    ``idle`` and saved checkpoints (``CheckpointPolicy``) all are; ``make_policy`` makes
    any of them by name."""

    def act(self, observation: Any) -> Any: ...


SHIPPED: dict[str, Callable] = {
    "greedy": lambda env, agent, seed: GreedyForager(env.spec, env.possible_agents.index(agent)),
    "planner": lambda env, agent, seed: PlannerPolicy(env, agent),
    "carrier": lambda env, agent, seed: CarrierPolicy(env, agent),
    "sniffer": lambda env, agent, seed: Sniffer(
        env.spec, seed=seed, agent=env.possible_agents.index(agent)
    ),
    "signaller": lambda env, agent, seed: Signaller(env, agent),
    "follower": lambda env, agent, seed: Follower(env, agent, seed=seed),
    "random": lambda env, agent, seed: RandomPolicy(env.action_space(agent), seed=seed),
    "idle": lambda env, agent, seed: IdlePolicy(env, agent),
}
"""The shipped policies: name -> maker(env, agent, seed)."""


def is_checkpoint(name: str) -> bool:
    """Whether ``name`` is meant as a checkpoint file rather than a shipped policy (a
    ``.pt`` file of the old format is one too: loading it says how to convert it)."""
    suffixes = (".safetensors", ".pt")
    return name not in SHIPPED and (name.endswith(suffixes) or os.path.lexists(name))


def make_policy(name: str, env: FlatlandParallelEnv, agent: str, seed: int | None = None):
    """The policy ``name`` (a shipped one, or the path of a checkpoint written by the
    baselines) for ``agent`` of ``env``; ``ValueError`` if there is none by that name or
    the checkpoint was trained for other spaces than the agent's."""
    if name in SHIPPED:
        return SHIPPED[name](env, agent, seed)
    if not is_checkpoint(name):
        raise ValueError(
            f"no policy {name!r}: one of {', '.join(SHIPPED)}, or a checkpoint file (.safetensors)"
        )
    policy = CheckpointPolicy(name, seed=seed)
    policy.bind(env, agent)
    return policy
