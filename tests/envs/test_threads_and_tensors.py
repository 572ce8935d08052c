"""An env used from two threads at once refuses the second instead of corrupting pymunk;
actions may be tensors (with or without a gradient)."""

import threading

import gymnasium
import numpy as np
import pytest
import torch

import flatland_ma
from flatland_ma.agents.actuators import InvalidActionError

HANG_GUARD = 600.0
"""Seconds a thread may take before the test gives up on it: a guard against a hang (a
thread that never gets the lock or the event), far above what a busy machine needs."""


def test_a_second_thread_inside_one_env_gets_a_clear_error():
    env = flatland_ma.parallel_env("fruits_poisons_multi")
    env.reset(seed=0)
    world = env.episode.world
    inside, release = threading.Event(), threading.Event()
    original = world.step

    def slow_step():
        inside.set()
        release.wait(HANG_GUARD)
        original()

    world.step = slow_step
    actions = {a: 0 for a in env.agents}
    results = []
    first = threading.Thread(target=lambda: results.append(env.step(actions)), daemon=True)
    first.start()
    assert inside.wait(HANG_GUARD)
    before = [tuple(b.body.position) for b in env.episode.bodies]
    for call in (lambda: env.step(actions), lambda: env.reset(seed=1)):
        with pytest.raises(RuntimeError, match="in use by another thread"):
            call()
    assert [tuple(b.body.position) for b in env.episode.bodies] == before  # untouched
    release.set()
    first.join(HANG_GUARD)
    assert len(results) == 1
    world.step = original
    env.step(actions)  # free again once the first call is done


def test_separate_envs_in_separate_threads_keep_working():
    def play(seed, out):
        env = flatland_ma.parallel_env("fruits_poisons_multi")
        env.reset(seed=seed)
        for t in range(200):
            if not env.agents:
                env.reset()
            env.step({a: (t + seed) % 3 for a in env.agents})
        out[seed] = [tuple(b.body.position) for b in env.episode.bodies]

    together, alone = {}, {}
    threads = [threading.Thread(target=play, args=(s, together), daemon=True) for s in (0, 1)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(HANG_GUARD)
        assert not thread.is_alive()
    for seed in (0, 1):
        play(seed, alone)
    assert together == alone  # the same trajectories as played one at a time


def test_tensor_actions_work_with_or_without_a_gradient():
    env = flatland_ma.parallel_env("fruits_poisons", agent={"actions": "continuous"})
    env.reset(seed=0)
    action = torch.tensor([0.5, 0.0, -0.25], requires_grad=True)
    env.step({"agent_0": action})
    env.step({"agent_0": action.detach()})
    discrete = flatland_ma.parallel_env("fruits_poisons")
    discrete.reset(seed=0)
    discrete.step({"agent_0": torch.tensor(2)})
    aec = flatland_ma.env("fruits_poisons")
    aec.reset(seed=0)
    aec.step(torch.tensor(1))
    gym = gymnasium.make("flatland_ma/FruitsPoisons-v0")
    gym.reset(seed=0)
    gym.step(torch.tensor(0))


def test_bad_tensor_actions_get_our_error_and_change_nothing():
    env = flatland_ma.parallel_env("fruits_poisons", agent={"actions": "continuous"})
    env.reset(seed=0)
    before = np.array(env.episode.bodies[0].body.position)
    for bad in (
        torch.tensor([2.0, 0.0, 0.0], requires_grad=True),  # out of the box
        torch.tensor([float("nan"), 0.0, 0.0]),
        torch.zeros(4),  # wrong shape
    ):
        with pytest.raises(InvalidActionError, match="agent_0"):
            env.step({"agent_0": bad})
    np.testing.assert_array_equal(env.episode.bodies[0].body.position, before)
    discrete = flatland_ma.parallel_env("fruits_poisons")
    discrete.reset(seed=0)
    for bad in (torch.tensor(3), torch.tensor([1, 2]), torch.tensor(1.0)):
        with pytest.raises(InvalidActionError, match="agent_0"):
            discrete.step({"agent_0": bad})
