"""Envs pickle mid-episode and the copy continues exactly as the original."""

import pickle

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import data_equivalence

import flatland_ma


def _same(a, b):
    assert data_equivalence(a, b, exact=True)


@pytest.mark.parametrize(
    "scenario, actions",
    [
        ("fruits_poisons_multi", "discrete"),
        ("fruits_poisons_multi", "continuous"),
        ("tug_of_war", "discrete"),
        ("tug_of_war", "continuous"),
    ],
)
def test_parallel_env_continues_identically_after_unpickling(scenario, actions):
    agent = {"actions": actions}
    if scenario == "tug_of_war":
        agent.update(head={}, camera={"mount": "head"}, arms=[{"mount": 0}])
    env = flatland_ma.parallel_env(scenario, agent=agent)
    env.reset(seed=21)
    for i, a in enumerate(env.possible_agents):
        env.action_space(a).seed(i)
    for _ in range(150):
        env.step({a: env.action_space(a).sample() for a in env.agents})
    copy = pickle.loads(pickle.dumps(env))
    rng = np.random.default_rng(0)
    while env.agents:
        if actions == "discrete":
            step = {a: int(rng.integers(env.action_space(a).n)) for a in env.agents}
        else:
            shape = env.action_space(env.possible_agents[0]).shape
            step = {a: rng.uniform(-1, 1, shape).astype(np.float32) for a in env.agents}
        _same(env.step(step), copy.step(step))
    assert copy.agents == []
    # Both draw the same next episode, too.
    _same(env.reset(), copy.reset())


def test_gym_env_continues_identically_after_unpickling():
    env = gymnasium.make("flatland_ma/FruitsPoisons-v0")
    env.reset(seed=2)
    for _ in range(90):
        env.step(env.action_space.sample())
    copy = pickle.loads(pickle.dumps(env.unwrapped))
    for t in range(200):
        action = t % 3
        _same(env.unwrapped.step(action), copy.step(action))
    assert copy.np_random is copy.parallel_env.np_random


def test_fresh_and_finished_envs_pickle():
    env = flatland_ma.parallel_env("fruits_poisons", episode={"max_steps": 5})
    assert pickle.loads(pickle.dumps(env)).agents == []
    env.reset(seed=0)
    while env.agents:
        env.step({"agent_0": 0})
    copy = pickle.loads(pickle.dumps(env))
    assert copy.agents == [] and copy.num_steps == 5


def test_render_state_is_dropped_and_rebuilt():
    env = flatland_ma.parallel_env("fruits_poisons", render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    copy = pickle.loads(pickle.dumps(env))
    assert copy._renderer is None
    np.testing.assert_array_equal(copy.render(), frame)


def test_a_copy_with_noisy_sensors_continues_exactly():
    noisy = {"sensors": [{"type": "camera", "noise": {"gaussian": 0.1, "dropout": 0.1}}]}
    env = flatland_ma.parallel_env("fruits_poisons_multi", agent=noisy)
    env.reset(seed=0)
    for _ in range(5):
        env.step({a: 0 for a in env.agents})
    copy = pickle.loads(pickle.dumps(env))
    assert copy.np_random.bit_generator.state == env.np_random.bit_generator.state
    for _ in range(5):
        actions = {a: 1 for a in env.agents}
        ours, theirs = env.step(actions)[0], copy.step(actions)[0]
        for agent in ours:
            np.testing.assert_array_equal(ours[agent], theirs[agent])
