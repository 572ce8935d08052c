"""SuperSuit's vector envs run the multi-agent scenario."""

import numpy as np
import supersuit as ss

import flatland_ma


def test_supersuit_concat_vec_envs_run_fruits_poisons_multi():
    env = flatland_ma.parallel_env("fruits_poisons_multi")
    vec = ss.pettingzoo_env_to_vec_env_v1(env)
    vec = ss.concat_vec_envs_v1(vec, 2, num_cpus=0, base_class="gymnasium")
    observations, infos = vec.reset(seed=0)
    assert observations.shape == (8, 64, 4) and observations.dtype == np.float32
    total = np.zeros(8)
    for _ in range(600):  # past the 500-step episode end: the vector env resets itself
        actions = np.array([vec.action_space.sample() for _ in range(8)])
        observations, rewards, terminations, truncations, infos = vec.step(actions)
        total += rewards
    assert observations.shape == (8, 64, 4)
    assert np.isfinite(total).all()
    vec.close()


def test_supersuit_subprocess_vec_env_pickles_the_env():
    env = flatland_ma.parallel_env("fruits_poisons_multi")
    vec = ss.pettingzoo_env_to_vec_env_v1(env)
    vec = ss.concat_vec_envs_v1(vec, 2, num_cpus=2, base_class="gymnasium")
    observations, _ = vec.reset(seed=1)
    for _ in range(20):
        observations, *_ = vec.step(np.zeros(8, np.int64))
    assert observations.shape == (8, 64, 4)
    vec.close()
