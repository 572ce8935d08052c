"""Seeded rollouts summarised as a digest, for determinism tests."""

from __future__ import annotations

import hashlib

import numpy as np

import flatland_ma


def actions_for(env, rng):
    return {a: env.action_space(a).sample() for a in env.agents}


def rollout_digest(scenario: str, seed: int, steps: int, **overrides) -> str:
    """Hash of every observation, reward, flag, info and body pose of a seeded rollout
    whose actions come from the action spaces seeded with ``seed``."""
    env = flatland_ma.parallel_env(scenario, **overrides)
    digest = hashlib.sha256()
    observations, infos = env.reset(seed=seed)
    for i, a in enumerate(env.possible_agents):
        env.action_space(a).seed(seed + i)
    _feed(digest, observations, infos)
    for _ in range(steps):
        if not env.agents:
            observations, infos = env.reset()
            _feed(digest, observations, infos)
            continue
        result = env.step({a: env.action_space(a).sample() for a in env.agents})
        _feed(digest, *result)
        for body in env.episode.bodies:
            digest.update(np.array([*body.body.position, body.body.angle]).tobytes())
    return digest.hexdigest()


def _feed(digest, *dicts):
    for d in dicts:
        for agent in sorted(d):
            value = d[agent]
            if isinstance(value, np.ndarray):
                digest.update(value.tobytes())
            else:
                digest.update(repr(value).encode())
