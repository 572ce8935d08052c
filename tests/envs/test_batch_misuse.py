"""Misuse of the envs of many worlds (batched, sharded, ``gymnasium.make_vec``): anything but
a batch of actions, sizes over the work budget and two threads at once each get a clear
error before anything changes, and the env plays on as if it had never seen them."""

import multiprocessing
import threading

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import data_equivalence

import flatland_ma
from flatland_ma.envs import worlds
from flatland_ma.envs.gym_vector import FlatlandVectorEnv
from flatland_ma.envs.registration import gym_id
from flatland_ma.envs.shards import ShardedParallelEnv
from flatland_ma.envs.vector import BatchedParallelEnv
from flatland_ma.lifelong.batched import StreamBatchedEnv
from flatland_ma.scenario import budget

JOIN_SECONDS = 60.0
"""How long a test waits for a thread it started (generous: the machine may be busy)."""


def _not_batches(n: int, agents: list[str]):
    """Things given as a batch of ``n`` actions that are not one: (value, error, what it
    says)."""
    agents = {agent: 0 for agent in agents}
    return [
        (None, TypeError, "got None"),
        (agents, TypeError, "PettingZoo-style dict"),
        (dict(enumerate([0] * n)), TypeError, "PettingZoo-style dict"),
        ("0" * n, TypeError, "got '000"),
        (np.array(0), TypeError, r"shape \(\)"),
        (3, TypeError, "got 3"),
        (set(range(n)), TypeError, "got {0"),
        (np.zeros(n + 1, np.int64), ValueError, f"one action per slot \\({n}"),
    ]


def _refuses_then_plays_as_fresh(env, fresh, n: int, agents: list[str], steps=6):
    env.reset(seed=3)
    fresh.reset(seed=3)
    for value, error, says in _not_batches(n, agents):
        with pytest.raises(error, match=says) as info:
            env.step(value)
        assert "Discrete(3)" in str(info.value) or error is ValueError
    rng = np.random.default_rng(0)
    for _ in range(steps):  # the same trajectory as an env that never saw them
        actions = rng.integers(0, 3, n)
        assert data_equivalence(env.step(actions), fresh.step(actions), exact=True)


def test_the_batched_env_says_what_a_batch_takes_and_changes_nothing():
    env = BatchedParallelEnv("fruits_poisons_multi", num_worlds=2, max_cycles=20)
    fresh = BatchedParallelEnv("fruits_poisons_multi", num_worlds=2, max_cycles=20)
    _refuses_then_plays_as_fresh(env, fresh, env.num_slots, env.possible_agents)
    with pytest.raises(TypeError, match="slot w \\* agents_per_world \\+ j"):
        env.step({"agent_0": 0})


def test_the_sharded_env_says_what_a_batch_takes_and_changes_nothing():
    env = ShardedParallelEnv("fruits_poisons_multi", 3, shards=2, max_cycles=20)
    fresh = BatchedParallelEnv("fruits_poisons_multi", num_worlds=3, max_cycles=20)
    try:
        _refuses_then_plays_as_fresh(env, fresh, env.num_slots, env.possible_agents)
    finally:
        env.close()


def test_make_vec_says_what_a_batch_takes_and_changes_nothing():
    env = gymnasium.make_vec(gym_id("fruits_poisons"), num_envs=3, max_episode_steps=20)
    fresh = gymnasium.make_vec(gym_id("fruits_poisons"), num_envs=3, max_episode_steps=20)
    _refuses_then_plays_as_fresh(env, fresh, 3, ["agent_0"])


def test_the_stream_batched_env_says_what_a_batch_takes():
    env = StreamBatchedEnv("partner_shift", num_worlds=2)
    env.reset(seed=0)
    with pytest.raises(TypeError, match="got None"):
        env.step(None)
    with pytest.raises(TypeError, match="PettingZoo-style dict"):
        env.step({agent: 0 for agent in env.possible_agents})


# -- sizes ------------------------------------------------------------------------------


def _no_world_built(monkeypatch):
    """Count the worlds a batch builds after its first."""
    built = []
    same = worlds._like
    monkeypatch.setattr(worlds, "_like", lambda first: built.append(1) or same(first))
    return built


def test_make_vec_of_a_hundred_thousand_envs_is_refused_before_allocating(monkeypatch):
    built = _no_world_built(monkeypatch)
    with pytest.raises(ValueError, match=r"num_envs=100,000 worlds .* at most [\d,]+ for") as info:
        gymnasium.make_vec(gym_id("fruits_poisons"), num_envs=100_000)
    assert "num_worlds" not in str(info.value)
    assert f"{budget.MAX_BATCH_BYTES / 2**20:,.1f} MB" in str(info.value)
    assert built == []


def test_a_batch_over_the_budget_is_refused_before_allocating(monkeypatch):
    built = _no_world_built(monkeypatch)
    spec = flatland_ma.load_scenario("fruits_poisons_multi")
    most = budget.max_worlds(spec)
    with pytest.raises(ValueError, match=f"num_worlds={most + 1:,} worlds .* at most {most:,}"):
        BatchedParallelEnv("fruits_poisons_multi", num_worlds=most + 1)
    assert built == []
    budget.check_batch(spec, most)  # the largest legal batch passes the check


def test_a_sharded_env_over_the_budget_starts_no_process():
    before = set(multiprocessing.active_children())
    with pytest.raises(ValueError, match=r"num_worlds=100,000 worlds in 2 processes"):
        ShardedParallelEnv("fruits_poisons", 100_000, shards=2)
    with pytest.raises(ValueError, match=r"num_worlds=3,000 worlds in 3000 processes"):
        ShardedParallelEnv("fruits_poisons", 3000, shards=3000)  # each process costs too
    with pytest.raises(ValueError, match="num_envs=100,000 worlds in 2 processes"):
        gymnasium.make_vec(gym_id("fruits_poisons"), num_envs=100_000, shards=2)
    with pytest.raises(ValueError, match="num_worlds must be a positive integer, not 0"):
        ShardedParallelEnv("fruits_poisons", 0, shards=2)
    with pytest.raises(ValueError, match="shards must be a positive integer, not 0"):
        ShardedParallelEnv("fruits_poisons", 2, shards=0)
    assert set(multiprocessing.active_children()) == before


@pytest.mark.parametrize("bad", [0, -3, 2.5, True, "8"])
def test_a_bad_number_of_envs_is_named(bad):
    with pytest.raises(ValueError, match=f"num_envs must be a positive integer, not {bad!r}"):
        FlatlandVectorEnv("fruits_poisons", num_envs=bad)


def test_large_sensors_within_the_budget_batch_and_step():
    maps = [{"type": "topdown", "size": 256, "name": f"map_{i}"} for i in range(16)]
    env = BatchedParallelEnv("fruits_poisons", num_worlds=2, agent={"sensors": maps})
    observations, _ = env.reset(seed=0)
    observations, *_ = env.step(np.zeros(2, np.int64))
    assert observations["map_15"].shape == (2, 256, 256, 3)
    assert observations["map_15"].any()


# -- threads ----------------------------------------------------------------------------


def _two_threads(env, hold, actions) -> list[BaseException]:
    """Thread one steps ``env`` and, inside its step, waits at ``hold`` while thread two
    steps it too; the errors each thread raised, after both have finished."""
    inside, go_on = threading.Event(), threading.Event()
    errors: list[BaseException] = []
    original = getattr(env, hold)

    def held(*args, **kwargs):
        if threading.current_thread().name == "first":
            inside.set()
            assert go_on.wait(JOIN_SECONDS)
        return original(*args, **kwargs)

    setattr(env, hold, held)

    def play():
        try:
            env.step(actions)
        except BaseException as err:  # noqa: BLE001 - collected for the test to read
            errors.append(err)

    first = threading.Thread(target=play, name="first")
    first.start()
    assert inside.wait(JOIN_SECONDS)
    second = threading.Thread(target=play, name="second")
    second.start()
    second.join(JOIN_SECONDS)
    go_on.set()
    first.join(JOIN_SECONDS)
    assert not first.is_alive() and not second.is_alive(), "a thread is stuck"
    setattr(env, hold, original)
    return errors


def test_two_threads_stepping_one_sharded_env_get_one_runtime_error_and_no_deadlock():
    env = ShardedParallelEnv("fruits_poisons", 2, shards=2, max_cycles=20)
    fresh = BatchedParallelEnv("fruits_poisons", num_worlds=2, max_cycles=20)
    try:
        env.reset(seed=1)
        fresh.reset(seed=1)
        actions = np.zeros(2, np.int64)
        (error,) = _two_threads(env, "_collect", actions)
        assert isinstance(error, RuntimeError) and "another thread" in str(error)
        fresh.step(actions)  # the first thread's step was the only one
        assert data_equivalence(env.step(actions), fresh.step(actions), exact=True)
    finally:
        env.close()


def test_two_threads_stepping_one_batched_env_get_one_runtime_error():
    env = BatchedParallelEnv("fruits_poisons_multi", num_worlds=2, max_cycles=20)
    fresh = BatchedParallelEnv("fruits_poisons_multi", num_worlds=2, max_cycles=20)
    env.reset(seed=1)
    fresh.reset(seed=1)
    actions = np.ones(8, np.int64)
    (error,) = _two_threads(env, "_check", actions)
    assert isinstance(error, RuntimeError) and "another thread" in str(error)
    fresh.step(actions)  # the first thread's step was the only one
    assert data_equivalence(env.step(actions), fresh.step(actions), exact=True)


@pytest.mark.parametrize(
    "seed, says",
    [(-1, "world 0's seed"), ([0, -1], "world 1's seed"), ([0, "x"], "world 1's seed")],
)
def test_a_bad_seed_of_any_world_is_refused_before_any_world_resets(seed, says):
    env = BatchedParallelEnv("fruits_poisons", num_worlds=2)
    fresh = BatchedParallelEnv("fruits_poisons", num_worlds=2)
    env.reset(seed=5)
    fresh.reset(seed=5)
    with pytest.raises(ValueError, match=says):
        env.reset(seed=seed)
    actions = np.ones(2, np.int64)
    assert data_equivalence(env.step(actions), fresh.step(actions), exact=True)
