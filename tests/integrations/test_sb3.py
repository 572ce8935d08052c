"""The Stable-Baselines3 adapter: every agent of every world a slot, SB3's resets with the
terminal observation in the infos and no made-up transition, equal to separate parallel
envs step for step (an agent that finishes ends its world's episode), episode returns as
the envs give them, and PPO trains through it."""

import numpy as np
import pytest

import flatland_ma

sb3 = pytest.importorskip("stable_baselines3")

from stable_baselines3.common.vec_env import VecMonitor  # noqa: E402

from flatland_ma.integrations.sb3 import SB3VecEnv  # noqa: E402

GOALS = {
    "items": [
        {"name": "fruits", "color": "orange", "reward": 10, "count": 10},
        {"name": "goals", "color": "lime", "reward": 5, "count": 3, "terminal": True},
    ]
}
"""fruits_poisons_multi with goals that end the episode of the agent taking one."""


def _separate(n, seed, steps, table, **overrides):
    """Per step what separate parallel envs give under the adapter's rule (the first agent
    to finish ends its world's episode; the others are cut there): observations after
    resets, rewards, dones, terminal observations, whether each was cut, and returns of
    the episodes that ended (slot -> list)."""
    envs = [flatland_ma.parallel_env("fruits_poisons_multi", **overrides) for _ in range(n)]
    names = envs[0].possible_agents
    m = len(names)
    current = [env.reset(seed=seed + w)[0] for w, env in enumerate(envs)]
    running = np.zeros(n * m)
    returns: dict[int, list] = {}
    rows = []
    for t in range(steps):
        obs, rew, done, terminal, cut = [], [], [], {}, {}
        for w, env in enumerate(envs):
            out, rewards, terms, truncs, _ = env.step(
                {a: int(table[t, w * m + j]) for j, a in enumerate(names)}
            )
            ended = any(terms[a] or truncs[a] for a in names)
            fresh = env.reset()[0] if ended else out
            for j, a in enumerate(names):
                slot = w * m + j
                running[slot] += rewards[a]
                rew.append(rewards[a])
                done.append(ended)
                obs.append(fresh[a])
                if ended:
                    terminal[slot] = out[a]
                    cut[slot] = not terms[a]
                    returns.setdefault(slot, []).append(running[slot])
                    running[slot] = 0.0
            current[w] = fresh
        rows.append((np.stack(obs), rew, done, terminal, cut))
    return rows, returns


@pytest.mark.parametrize("overrides", [{"max_cycles": 15}, {"max_cycles": 60, **GOALS}])
def test_the_adapter_equals_separate_envs_and_its_returns_are_theirs(overrides):
    n, steps = 2, 70
    table = np.random.default_rng(3).integers(0, 3, (steps, n * 4))
    expected, returns = _separate(n, 5, steps, table, **overrides)
    env = VecMonitor(SB3VecEnv("fruits_poisons_multi", n, **overrides))
    assert env.num_envs == 8
    env.seed(5)
    first = env.reset()
    assert first.shape == (8, 64, 4)
    monitored: dict[int, list] = {}
    cuts = terminals = 0
    for t in range(steps):
        observations, rewards, dones, infos = env.step(table[t])
        obs, rew, done, terminal, cut = expected[t]
        np.testing.assert_array_equal(observations, obs, err_msg=str(t))
        np.testing.assert_allclose(rewards, rew, rtol=1e-6)
        np.testing.assert_array_equal(dones, done)
        for slot, info in enumerate(infos):
            assert ("terminal_observation" in info) == (slot in terminal)
            if slot in terminal:
                np.testing.assert_array_equal(info["terminal_observation"], terminal[slot])
                assert info["TimeLimit.truncated"] == cut[slot]
                monitored.setdefault(slot, []).append(info["episode"]["r"])
                cuts += cut[slot]
                terminals += not cut[slot]
    assert monitored.keys() == returns.keys()
    for slot in returns:
        np.testing.assert_allclose(monitored[slot], returns[slot], rtol=1e-5)
    assert cuts > 0
    if "items" in overrides:
        assert terminals > 0  # agents took goals: their worlds' others were cut there
    env.close()


def test_dict_observations_and_ppo_learns_for_a_tiny_budget():
    from stable_baselines3 import PPO

    sensors = [{"type": "camera", "rays": 16}, {"type": "proprioception"}]
    env = SB3VecEnv("fruits_poisons_multi", 2, max_cycles=32, agent={"sensors": sensors})
    observations = env.reset()
    assert set(observations) == {"camera", "proprioception"}
    model = PPO("MultiInputPolicy", env, n_steps=64, batch_size=64, n_epochs=1, seed=0)
    model.learn(512)
    assert model.num_timesteps >= 512
    flat = SB3VecEnv("fruits_poisons_multi", 1, max_cycles=16, flatten=True)
    assert flat.observation_space.shape == (256,)
    PPO("MlpPolicy", flat, n_steps=32, batch_size=32, n_epochs=1, seed=0).learn(128)
    env.close()
    flat.close()


def test_sb3s_own_vec_env_checks_pass():
    from stable_baselines3.common.vec_env import VecCheckNan

    env = VecCheckNan(SB3VecEnv("fruits_poisons_multi", 2, max_cycles=5), raise_exception=True)
    env.reset()
    for t in range(12):  # through two resets
        env.step(np.full(8, t % 3))
    env.close()


def test_attributes_images_and_refusals():
    env = SB3VecEnv("fruits_poisons_multi", 2, render_mode="rgb_array")
    assert env.get_attr("num_worlds") == [2] * 8 and env.env_is_wrapped(object) == [False] * 8
    env.reset()
    images = env.get_images()
    assert len(images) == 8 and images[0] is images[3] and images[0] is not images[4]
    with pytest.raises(TypeError, match="autoreset_mode"):
        SB3VecEnv("fruits_poisons_multi", 1, autoreset_mode="SameStep")
    with pytest.raises(RuntimeError, match="step_async"):
        env.step_wait()
    env.close()
