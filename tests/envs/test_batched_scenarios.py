"""Every scenario whose agents share one space, batched, returns exactly what separate
parallel envs return for the same seeds and actions, through automatic resets:
observations, rewards, terminations, truncations, which slots act, and every info entry.
The batched env drives plain bodies, reads poses and writes observations and counters
for all worlds at once (``flatland_ma.agents.motors``); separate envs go agent by agent
through pymunk's attribute setters, so this holds the two paths to the same numbers."""

import numpy as np
import pytest
from gymnasium.utils.env_checker import data_equivalence

import flatland_ma
from flatland_ma.agents.motors import Motors
from flatland_ma.envs.vector import BatchedParallelEnv


def _alike(scenario: str) -> bool:
    env = flatland_ma.parallel_env(scenario)
    agents = env.possible_agents
    spaces = {(str(env.observation_space(a)), str(env.action_space(a))) for a in agents}
    env.close()
    return len(spaces) == 1


ALIKE = [s for s in flatland_ma.list_scenarios() if _alike(s)]
"""The scenarios whose agents share one observation and action space, which a batch takes
unpadded (the others it takes padded: tests/test_heterogeneous.py)."""
WORLDS, STEPS, CYCLES = 3, 24, 9
"""Three worlds for 24 steps of 9-step episodes: each world resets twice or more."""


def _zero_like(observation):
    if isinstance(observation, dict):
        return {k: np.zeros_like(v) for k, v in observation.items()}
    return np.zeros_like(observation)


def _stack(observations):
    if isinstance(observations[0], dict):
        return {k: np.stack([o[k] for o in observations]) for k in observations[0]}
    return np.stack(observations)


@pytest.mark.parametrize("scenario", ALIKE)
def test_a_batch_plays_what_separate_envs_play_through_resets(scenario):
    batch = BatchedParallelEnv(scenario, num_worlds=WORLDS, max_cycles=CYCLES)
    envs = [flatland_ma.parallel_env(scenario, max_cycles=CYCLES) for _ in range(WORLDS)]
    m = batch.agents_per_world
    batch.single_action_space.seed(4)
    plan = [[batch.single_action_space.sample() for _ in range(batch.num_slots)]]
    plan += [[batch.single_action_space.sample() for _ in range(batch.num_slots)]]
    observations, infos = batch.reset(seed=20)
    separate = [env.reset(seed=20 + w) for w, env in enumerate(envs)]
    zero = _zero_like(separate[0][0][envs[0].possible_agents[0]])
    want = [o[a] for o, _ in separate for a in envs[0].possible_agents]
    assert data_equivalence(observations, _stack(want), exact=True)
    ended = [False] * WORLDS
    resets = 0
    for t in range(STEPS):
        actions = plan[t % 2]
        observations, rewards, terminations, truncations, infos = batch.step(actions)
        rows = []
        for w, env in enumerate(envs):
            if ended[w]:
                obs, info = env.reset()
                rows += [(obs[a], 0.0, False, False, True, info[a]) for a in env.possible_agents]
                ended[w], resets = False, resets + 1
                continue
            live = list(env.agents)
            own = {a: actions[w * m + j] for j, a in enumerate(env.possible_agents) if a in live}
            obs, rew, term, trunc, info = env.step(own)
            for a in env.possible_agents:
                if a in live:
                    rows.append((obs[a], rew[a], term[a], trunc[a], True, info[a]))
                else:
                    rows.append((zero, 0.0, False, False, False, None))
            ended[w] = not env.agents
        assert data_equivalence(observations, _stack([r[0] for r in rows]), exact=True), t
        np.testing.assert_array_equal(rewards, [r[1] for r in rows])
        np.testing.assert_array_equal(terminations, [r[2] for r in rows])
        np.testing.assert_array_equal(truncations, [r[3] for r in rows])
        np.testing.assert_array_equal(infos["active"], [r[4] for r in rows])
        for slot, row in enumerate(rows):
            for key, value in (row[5] or {}).items():
                assert infos[key][slot] == value, (t, slot, key)
    assert resets >= WORLDS
    batch.close()


def test_the_fields_of_pymunk_bodies_are_where_the_compiled_motors_look():
    """On the pinned pymunk the batched env takes the compiled path (if it did not, the
    test above would compare the attribute path with itself)."""
    assert Motors.available()
    batch = BatchedParallelEnv("fruits_poisons_multi", num_worlds=2)
    batch.reset(seed=0)
    assert batch.core.motors is not None and batch.core.poses is not None and batch.core.whole_image
