"""The batched env returns exactly what separate envs return for the same seeds and
actions: single agent against Gymnasium's own SyncVectorEnv, several agents against
separate parallel envs, through automatic resets, Dict observations and agents that
finish early."""

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import data_equivalence

import flatland_ma
from flatland_ma.envs.gym_vector import FlatlandVectorEnv
from flatland_ma.envs.registration import gym_id
from flatland_ma.envs.vector import BatchedParallelEnv

GOALS = {
    "items": [
        {"name": "fruits", "color": "orange", "reward": 10, "count": 10},
        {"name": "goals", "color": "lime", "reward": 5, "count": 3, "terminal": True},
    ]
}
"""fruits_poisons_multi with goals that end the episode of the agent taking one."""


def test_make_vec_serves_the_batched_env_and_matches_sync_vector_env():
    """Three worlds, episodes of 30 steps, 70 steps: two automatic resets each."""
    batched = gymnasium.make_vec(gym_id("fruits_poisons"), num_envs=3, max_episode_steps=30)
    assert isinstance(batched.unwrapped, FlatlandVectorEnv)
    reference = gymnasium.make_vec(
        gym_id("fruits_poisons"),
        num_envs=3,
        vectorization_mode="sync",
        vector_kwargs={"autoreset_mode": "SameStep"},  # make_vec's default here
        max_episode_steps=30,
    )
    assert batched.metadata["autoreset_mode"] == reference.metadata["autoreset_mode"]
    assert batched.observation_space == reference.observation_space
    assert batched.action_space == reference.action_space
    assert data_equivalence(batched.reset(seed=5), reference.reset(seed=5), exact=True)
    rng = np.random.default_rng(0)
    for _ in range(70):
        actions = rng.integers(0, 3, 3)
        got, want = batched.step(actions), reference.step(actions)
        assert data_equivalence(got, want, exact=True)
        assert batched.observation_space.contains(got[0])
    batched.close()
    reference.close()


def _separate(scenario, n, seed, steps, action_of, **overrides):
    """Per step, what n separate parallel envs give: stacked observations, rewards,
    terminations, truncations, and which slots acted (worlds reset one step after their
    episode ends, without a seed, as the batched env does)."""
    envs = [flatland_ma.parallel_env(scenario, **overrides) for _ in range(n)]
    m = len(envs[0].possible_agents)
    out = []
    first = [env.reset(seed=seed + w)[0] for w, env in enumerate(envs)]
    out.append(([first[w][a] for w in range(n) for a in envs[w].possible_agents], None))
    ended = [False] * n
    for t in range(steps):
        rows = []
        for w, env in enumerate(envs):
            zero = (
                np.zeros_like(first[0]["agent_0"])
                if not isinstance(first[0]["agent_0"], dict)
                else {k: np.zeros_like(v) for k, v in first[0]["agent_0"].items()}
            )
            if ended[w]:
                obs, _ = env.reset()
                rows += [(obs[a], 0.0, False, False, True) for a in env.possible_agents]
                ended[w] = False
                continue
            live = list(env.agents)
            actions = {a: action_of(t, w * m + env.possible_agents.index(a)) for a in live}
            obs, rew, term, trunc, _ = env.step(actions)
            for a in env.possible_agents:
                if a in live:
                    rows.append((obs[a], rew[a], term[a], trunc[a], True))
                else:
                    rows.append((zero, 0.0, False, False, False))
            ended[w] = not env.agents
        out.append(rows)
    return out


def _check_against_separate(scenario, n, steps, **overrides):
    batched = BatchedParallelEnv(scenario, num_worlds=n, **overrides)
    m = batched.agents_per_world
    rng = np.random.default_rng(1)
    table = rng.integers(0, 3, (steps, n * m))
    expected = _separate(scenario, n, 11, steps, lambda t, slot: int(table[t, slot]), **overrides)
    observations, infos = batched.reset(seed=11)
    assert data_equivalence(_stack(expected[0][0]), observations, exact=True)
    assert infos["active"].all()
    finished = 0
    for t in range(steps):
        observations, rewards, terminations, truncations, infos = batched.step(table[t])
        rows = expected[t + 1]
        assert data_equivalence(_stack([r[0] for r in rows]), observations, exact=True), t
        np.testing.assert_array_equal(rewards, [r[1] for r in rows])
        np.testing.assert_array_equal(terminations, [r[2] for r in rows])
        np.testing.assert_array_equal(truncations, [r[3] for r in rows])
        np.testing.assert_array_equal(infos["active"], [r[4] for r in rows])
        assert batched.observation_space.contains(observations)
        finished += int((~infos["active"]).sum())
    return batched, finished


def _stack(observations):
    if isinstance(observations[0], dict):
        return {k: np.stack([o[k] for o in observations]) for k in observations[0]}
    return np.stack(observations)


def test_several_agents_per_world_match_separate_parallel_envs_through_resets():
    batched, _ = _check_against_separate("fruits_poisons_multi", 3, 50, max_cycles=20)
    assert batched.num_slots == 12 and batched.observation_space.shape == (12, 64, 4)


def test_dict_observations_are_stacked_per_sensor():
    sensors = [{"type": "camera"}, {"type": "lidar", "rays": 16}, {"type": "proprioception"}]
    batched, _ = _check_against_separate(
        "fruits_poisons_multi", 2, 25, max_cycles=12, agent={"sensors": sensors}
    )
    observations, *_ = batched.step(np.zeros(batched.num_slots, np.int64))
    assert set(observations) == {"camera", "lidar", "proprioception"}
    assert observations["lidar"].shape == (8, 16)


def test_agents_that_finish_early_become_inert_slots_while_their_world_plays_on():
    _, inert = _check_against_separate("fruits_poisons_multi", 2, 150, max_cycles=60, **GOALS)
    assert inert > 0  # some agent took a goal before its world's episode ended


def test_a_bad_action_names_world_slot_and_space_and_changes_nothing():
    batched = BatchedParallelEnv("fruits_poisons_multi", num_worlds=2, max_cycles=10)
    batched.reset(seed=0)
    before = [env.episode.bodies[0].body.position for env in batched.worlds]
    actions = np.zeros(8, np.int64)
    actions[6] = 7
    with pytest.raises(ValueError, match=r"world 1, slot 6: .*7.*agent_2.*Discrete\(3\)"):
        batched.step(actions)
    with pytest.raises(ValueError, match="one action per slot"):
        batched.step(np.zeros(5, np.int64))
    after = [env.episode.bodies[0].body.position for env in batched.worlds]
    assert before == after and all(env.num_steps == 0 for env in batched.worlds)


def test_buffers_are_copies_unless_asked_otherwise():
    copied = BatchedParallelEnv("fruits_poisons", num_worlds=2)
    first, _ = copied.reset(seed=0)
    second, *_ = copied.step(np.zeros(2, np.int64))
    assert first is not second and not np.array_equal(first, second)
    shared = BatchedParallelEnv("fruits_poisons", num_worlds=2, copy=False)
    first, _ = shared.reset(seed=0)
    second, *_ = shared.step(np.zeros(2, np.int64))
    assert first is second


@pytest.mark.parametrize("bad", [0, -1, 2.5, True])
def test_a_bad_number_of_worlds_is_refused(bad):
    with pytest.raises(ValueError, match="num_worlds"):
        BatchedParallelEnv("fruits_poisons", num_worlds=bad)


def test_multi_agent_scenarios_are_refused_by_the_gymnasium_vector_env():
    with pytest.raises(ValueError, match="BatchedParallelEnv"):
        FlatlandVectorEnv("fruits_poisons_multi", num_envs=2)


ALIKE = [s for s in flatland_ma.list_scenarios() if not flatland_ma.load_scenario(s).heterogeneous]
"""Scenarios whose agents share one body (a batch needs one space for every slot;
tests/test_heterogeneous.py checks that the others are refused)."""


@pytest.mark.parametrize("scenario", ALIKE)
def test_every_scenario_batches_with_the_infos_of_separate_envs(scenario):
    """Two worlds, three steps: every info entry of every slot is the separate env's,
    numbers in number arrays and anything else (key_door's tuple of keys) as objects."""
    batch = BatchedParallelEnv(scenario, num_worlds=2)
    envs = [flatland_ma.parallel_env(scenario) for _ in range(2)]
    m = batch.agents_per_world
    _, infos = batch.reset(seed=3)
    separate = [env.reset(seed=3 + w)[1] for w, env in enumerate(envs)]
    batch.single_action_space.seed(1)
    for _ in range(3):
        for w, env in enumerate(envs):
            for j, agent in enumerate(env.possible_agents):
                for key, value in separate[w][agent].items():
                    got = infos[key][w * m + j]
                    assert got == value, (key, got, value)
                    if isinstance(value, int | float) and not isinstance(value, bool):
                        assert infos[key].dtype.kind in "if"
        actions = [batch.single_action_space.sample() for _ in range(batch.num_slots)]
        _, _, _, _, infos = batch.step(actions)
        separate = [
            env.step({a: actions[w * m + j] for j, a in enumerate(env.possible_agents)})[4]
            for w, env in enumerate(envs)
        ]
    batch.close()


def test_the_batched_envs_are_reachable_from_the_package():
    import flatland_ma as vector

    assert flatland_ma.BatchedParallelEnv is vector.BatchedParallelEnv is BatchedParallelEnv
    assert flatland_ma.ShardedParallelEnv is vector.ShardedParallelEnv
    assert vector.FlatlandVectorEnv is FlatlandVectorEnv


def test_one_kernel_call_on_one_thread_gives_what_the_threads_give():
    threads = BatchedParallelEnv("fruits_poisons_multi", num_worlds=3, max_cycles=20)
    one = BatchedParallelEnv("fruits_poisons_multi", num_worlds=3, max_cycles=20, parallel=False)
    assert data_equivalence(threads.reset(seed=2), one.reset(seed=2), exact=True)
    rng = np.random.default_rng(4)
    for _ in range(45):
        actions = rng.integers(0, 3, 12)
        assert data_equivalence(threads.step(actions), one.step(actions), exact=True)


def test_each_worlds_global_state_is_what_a_separate_env_gives_through_resets():
    n, seed = 3, 21
    batch = BatchedParallelEnv("fruits_poisons_multi", num_worlds=n, max_cycles=6)
    envs = [flatland_ma.parallel_env("fruits_poisons_multi", max_cycles=6) for _ in range(n)]
    with pytest.raises(RuntimeError, match="reset"):
        batch.state()
    batch.reset(seed=seed)
    for w, env in enumerate(envs):
        env.reset(seed=seed + w)
    assert batch.state_space == gymnasium.vector.utils.batch_space(envs[0].state_space, n)
    m, ended, rng = batch.agents_per_world, [False] * n, np.random.default_rng(0)
    for _ in range(20):  # episodes of 6 steps: every world resets twice or more
        actions = rng.integers(0, 3, batch.num_slots)
        batch.step(actions)
        for w, env in enumerate(envs):
            if ended[w]:
                env.reset()
            else:
                env.step({a: actions[w * m + env.possible_agents.index(a)] for a in env.agents})
            ended[w] = not env.agents
        state = batch.state()
        assert batch.state_space.contains(state)
        np.testing.assert_array_equal(state, np.stack([env.state() for env in envs]))
