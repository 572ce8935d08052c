"""The benchmark's held-out play: each method's policies on a task's held-out episodes
(a scenario's, or each task's of a stream), and their scores. Training is elsewhere
(``baselines.benchmark.train``); this plays what a method has, as ``flatland_ma`` plays
policies."""

from __future__ import annotations

import numpy as np

from baselines.benchmark.settings import BenchmarkConfig
from flatland_ma.envs.parallel import FlatlandParallelEnv
from flatland_ma.policies.named import make_policy
from flatland_ma.policies.rollout import play_episode
from flatland_ma.policies.scores_header import solver_names

STREAM_EVALUATION_STRIDE = 1000
"""``baselines.lifelong`` seeds task i's evaluation worlds from EVALUATION_SEED + 1000 i."""


def list_tasks() -> list[tuple[str, str]]:
    """Every shipped (name, kind): the scenarios, then the streams."""
    import flatland_ma
    from flatland_ma.lifelong import list_streams

    return [(n, "scenario") for n in flatland_ma.list_scenarios()] + [
        (n, "stream") for n in list_streams()
    ]


def scored_agents(env: FlatlandParallelEnv) -> list[str]:
    """The agents whose returns the scenario's reference counts: the first team's against
    random play (``carrier_vs_random``), otherwise every agent."""
    reference = env.spec.reference
    if reference is not None and reference.solver == "carrier_vs_random":
        first = env.spec.teams[0]
        return [a for i, a in enumerate(env.possible_agents) if env.spec.team_of(i) is first]
    return list(env.possible_agents)


def policy_names(env: FlatlandParallelEnv, method: str, checkpoint: str = "") -> dict[str, str]:
    """The policy each agent plays under ``method``; agents the score does not count play
    at random, as in the reference."""
    scored = scored_agents(env)
    if method == "random":
        return dict.fromkeys(env.possible_agents, "random")
    if method == "scripted":
        return solver_names(env)
    if method == "open_loop":
        checkpoint = "open_loop"
    return {a: checkpoint if a in scored else "random" for a in env.possible_agents}


UNSEEDED = frozenset({"greedy", "planner", "carrier"})
"""Shipped solvers that draw no random numbers: every seed of theirs plays alike, so a task
played by these alone is scored for one scripted seed."""


def scripted_seeds(name: str, kind: str, config: BenchmarkConfig) -> int:
    """Seeds of the scripted method on a task: one if every agent's solver is unseeded."""
    if kind == "scenario":
        worlds = [FlatlandParallelEnv(name)]
    else:
        worlds = [env for _, env, _ in stream_parts(name, config)]
    try:
        seeded = any(set(solver_names(env).values()) - UNSEEDED for env in worlds)
    finally:
        for env in worlds:
            env.close()
    return config.seeds if seeded else 1


def play_episodes(env: FlatlandParallelEnv, names: dict[str, str], seeds, seed: int) -> list[float]:
    """The score of each episode (reset with each of ``seeds``): the mean return of the
    scored agents, every agent playing its policy from ``names`` (seeded from ``seed``)."""
    agents = env.possible_agents
    policies = {
        a: make_policy(names[a], env, a, seed=seed * 1000 + agents.index(a)) for a in agents
    }
    return play_policies(env, policies, seeds)


def play_policies(env: FlatlandParallelEnv, policies: dict, seeds) -> list[float]:
    """The score of each episode (reset with each of ``seeds``), ``policies[agent]``
    acting for each agent."""
    scored = scored_agents(env)
    out = []
    for s in seeds:
        totals, _ = play_episode(env, policies, int(s))
        out.append(float(np.mean([totals[a] for a in scored])))
    return out


def play_open_loop(env: FlatlandParallelEnv, seeds, seed: int, config, first_seed: int):
    """Open-loop play (``baselines.open_loop``): the scored agents' best schedule (drawn
    from ``seed``) on training episodes from ``first_seed``, the others at random; (its
    score on each of ``seeds``, the search's record)."""
    from baselines.open_loop import OpenLoopPolicy, best_of

    agents = env.possible_agents
    names = policy_names(env, "open_loop")
    others = {
        a: make_policy(names[a], env, a, seed=seed * 1000 + agents.index(a))
        for a in agents
        if names[a] != "open_loop"
    }
    planned = [a for a in agents if names[a] == "open_loop"]

    def play(policies: dict, episode_seeds) -> list[float]:
        return play_policies(env, {**others, **policies}, episode_seeds)

    plan, search = best_of(env, planned, play, config.open_loop, seed, first_seed)
    return play({a: OpenLoopPolicy(s) for a, s in plan.items()}, seeds), search


def scenario_seeds(config: BenchmarkConfig) -> list[int]:
    return list(range(config.eval_seed, config.eval_seed + config.episodes))


def stream_parts(name: str, config: BenchmarkConfig):
    """Each task of stream ``name``: (label, its world, its held-out seeds)."""
    from baselines.lifelong import EVALUATION_SEED
    from flatland_ma.lifelong import load_stream, task_env

    stream = load_stream(name)
    for i, label in enumerate(stream.task_labels):
        env = task_env(stream, i)
        if stream.never_ending:
            env.step_limit = config.never_ending_steps
        first = EVALUATION_SEED + STREAM_EVALUATION_STRIDE * i
        yield label, env, list(range(first, first + config.episodes))


def play_task(name: str, kind: str, method: str, seed: int, config, checkpoint: str = ""):
    """(score, each episode's score, each stream task's score) of ``method`` on a task
    (not ``open_loop``: ``play_open_loop_task``). A checkpoint plays the scenario as it was
    trained on it (its ``overrides``: ``baselines.ppo --no-channel``'s has no channel)."""
    if kind == "scenario":
        env = FlatlandParallelEnv(name, **trained_overrides(checkpoint))
        try:
            episodes = play_episodes(
                env, policy_names(env, method, checkpoint), scenario_seeds(config), seed
            )
        finally:
            env.close()
        return float(np.mean(episodes)), episodes, {}
    parts: dict[str, float] = {}
    episodes = []
    for label, env, seeds in stream_parts(name, config):
        try:
            scores = play_episodes(env, policy_names(env, method, checkpoint), seeds, seed)
        finally:
            env.close()
        parts[label] = float(np.mean(scores))
        episodes += scores
    return float(np.mean(list(parts.values()))), episodes, parts


def trained_overrides(checkpoint: str) -> dict:
    """The scenario overrides a checkpoint was trained with (none without one)."""
    if not checkpoint:
        return {}
    from flatland_ma.policies.checkpoint import read_checkpoint

    return dict(read_checkpoint(checkpoint).get("overrides") or {})


def play_open_loop_task(name: str, kind: str, seed: int, config):
    """(score, each episode's score, each stream task's score, each search's record) of
    open-loop play on a task: a stream's tasks each searched on their own episodes."""
    from baselines.open_loop import OPEN_LOOP_SEED

    if kind == "scenario":
        env = FlatlandParallelEnv(name)
        try:
            episodes, search = play_open_loop(
                env, scenario_seeds(config), seed, config, OPEN_LOOP_SEED
            )
        finally:
            env.close()
        return float(np.mean(episodes)), episodes, {}, {name: search}
    parts: dict[str, float] = {}
    searches: dict[str, dict] = {}
    episodes = []
    for i, (label, env, seeds) in enumerate(stream_parts(name, config)):
        try:
            first = OPEN_LOOP_SEED + STREAM_EVALUATION_STRIDE * i
            scores, searches[label] = play_open_loop(env, seeds, seed, config, first)
        finally:
            env.close()
        parts[label] = float(np.mean(scores))
        episodes += scores
    return float(np.mean(list(parts.values()))), episodes, parts, searches
