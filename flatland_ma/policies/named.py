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
from flatland_ma.policies.signals import Follower, Heeder, Signaller
from flatland_ma.policies.sniffer import Sniffer
from flatland_ma.policies.wall_follower import WallFollower


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
    "wall_follower": lambda env, agent, seed: WallFollower(
        env.spec, env.possible_agents.index(agent)
    ),
    "planner": lambda env, agent, seed: PlannerPolicy(env, agent),
    "carrier": lambda env, agent, seed: CarrierPolicy(env, agent),
    "sniffer": lambda env, agent, seed: Sniffer(
        env.spec, seed=seed, agent=env.possible_agents.index(agent)
    ),
    "signaller": lambda env, agent, seed: Signaller(env, agent),
    "follower": lambda env, agent, seed: Follower(env, agent, seed=seed),
    "heeder": lambda env, agent, seed: Heeder(env, agent, seed=seed),
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
    return CheckpointPolicy.for_agent(name, env, agent, seed=seed)


FALLBACKS = ("greedy", "sniffer", "planner", "random")
"""What an agent plays when its scenario's reference solver does not suit it: the first
of these that does (``random`` suits every agent)."""


def solver_names(env: FlatlandParallelEnv) -> dict[str, str]:
    """The policy the scenario's reference solver gives each agent, by name (empty when
    the scenario names no reference solver)."""
    spec = env.spec
    reference = spec.reference
    if reference is None:
        return {}
    names = {}
    for i, agent in enumerate(env.possible_agents):
        team = spec.team_of(i)
        first = team is None or team is spec.teams[0]
        if reference.solver == "teams":
            assert reference.teams is not None and team is not None
            names[agent] = reference.teams[spec.teams.index(team)]
        elif reference.solver == "carrier_vs_random":
            names[agent] = "carrier" if first else "random"
        else:
            names[agent] = reference.solver
    return names


def suits(name: str, env: FlatlandParallelEnv, agent: str) -> bool:
    """Whether the shipped policy ``name`` can drive ``agent`` (it reads what the agent
    senses, or the world; made once to ask, which is cheap for every shipped one)."""
    try:
        SHIPPED[name](env, agent, 0)
    except ValueError:
        return False
    return True


def suited_policies(env: FlatlandParallelEnv, agent: str) -> list[str]:
    """The shipped policies that can drive ``agent``, in ``SHIPPED``'s order."""
    return [name for name in SHIPPED if suits(name, env, agent)]


def default_policy(env: FlatlandParallelEnv, agent: str) -> str:
    """The policy ``agent`` plays when none is chosen: its scenario's reference solver
    if that suits it, else the first of ``FALLBACKS`` that does."""
    solver = solver_names(env).get(agent)
    for name in (solver, *FALLBACKS) if solver in SHIPPED else FALLBACKS:
        if name is not None and suits(name, env, agent):
            return name
    return "random"
