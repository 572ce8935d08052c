"""The batched env spread over processes returns exactly what one batched env returns:
several agents, early finishers, automatic resets, Dict observations and non-numeric
infos, on every scenario whose agents are alike; bad actions change nothing in any process;
a dead process is named."""

import os
import signal

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import data_equivalence

from flatland_ma.envs.gym_vector import FlatlandVectorEnv
from flatland_ma.envs.registration import gym_id
from flatland_ma.envs.shards import ShardedParallelEnv
from flatland_ma.envs.vector import BatchedParallelEnv
from tests.envs.test_batched_scenarios import ALIKE

GOALS = {
    "items": [
        {"name": "fruits", "color": "orange", "reward": 10, "count": 10},
        {"name": "goals", "color": "lime", "reward": 5, "count": 3, "terminal": True},
    ]
}


def _same_as_one_batch(scenario, n, shards, steps, context=None, **kwargs):
    sharded = ShardedParallelEnv(scenario, n, shards=shards, context=context, **kwargs)
    single = BatchedParallelEnv(scenario, num_worlds=n, **kwargs)
    try:
        assert sharded.observation_space == single.observation_space
        assert sharded.action_space == single.action_space
        assert sharded.state_space == single.state_space
        assert data_equivalence(sharded.reset(seed=7), single.reset(seed=7), exact=True)
        sharded.single_action_space.seed(3)
        inert = 0
        for t in range(steps):
            actions = np.array(
                [sharded.single_action_space.sample() for _ in range(single.num_slots)]
            )
            got, want = sharded.step(actions), single.step(actions)
            assert data_equivalence(got, want, exact=True), t
            np.testing.assert_array_equal(sharded.state(), single.state())
            inert += int((~got[4]["active"]).sum())
        return inert
    finally:
        sharded.close()
        single.close()


def test_worlds_over_two_processes_match_one_batch_through_resets_and_early_finishers():
    inert = _same_as_one_batch("fruits_poisons_multi", 5, 2, 120, max_cycles=50, **GOALS)
    assert inert > 0  # some agent took a goal while its world played on


def test_spawned_processes_with_dict_observations():
    sensors = [{"type": "camera"}, {"type": "lidar", "rays": 16}, {"type": "touch"}]
    _same_as_one_batch(
        "fruits_poisons", 3, 2, 30, context="spawn", max_cycles=12, agent={"sensors": sensors}
    )


def test_infos_that_are_not_numbers_come_back_too():
    _same_as_one_batch("key_door", 3, 3, 10)


def test_a_bad_action_changes_nothing_in_any_process():
    sharded = ShardedParallelEnv("fruits_poisons_multi", 4, shards=2, max_cycles=10)
    single = BatchedParallelEnv("fruits_poisons_multi", num_worlds=4, max_cycles=10)
    sharded.reset(seed=0)
    single.reset(seed=0)
    bad = np.zeros(16, np.int64)
    bad[13] = 7
    with pytest.raises(ValueError, match=r"world 3, slot 13: .*7.*agent_1.*Discrete\(3\)"):
        sharded.step(bad)
    with pytest.raises(ValueError, match="one action per slot"):
        sharded.step(np.zeros(5, np.int64))
    nan: list = [0] * 16
    nan[2] = float("nan")
    with pytest.raises(ValueError, match=r"world 0, slot 2: .*nan"):
        sharded.step(nan)
    for _ in range(12):  # the same trajectory as an env that never saw them
        actions = np.ones(16, np.int64)
        assert data_equivalence(sharded.step(actions), single.step(actions), exact=True)
    sharded.close()


def test_a_dead_process_is_named_and_close_stops_the_others():
    sharded = ShardedParallelEnv("fruits_poisons", 4, shards=2)
    sharded.reset(seed=0)
    os.kill(sharded._processes[1].pid, signal.SIGKILL)
    sharded._processes[1].join()
    with pytest.raises(RuntimeError, match="shard 1 .* stopped"):
        sharded.step(np.zeros(4, np.int64))
    processes = list(sharded._processes)
    sharded.close()
    assert not any(p.is_alive() for p in processes)


def test_step_before_reset_and_shared_arrays():
    sharded = ShardedParallelEnv("fruits_poisons", 2, shards=2, copy=False)
    with pytest.raises(RuntimeError, match="reset"):
        sharded.step(np.zeros(2, np.int64))
    first, _ = sharded.reset(seed=0)
    second, *_ = sharded.step(np.zeros(2, np.int64))
    assert first is second  # the shared array itself, overwritten by each step
    sharded.close()


def test_make_vec_spreads_worlds_over_processes():
    sharded = gymnasium.make_vec(gym_id("fruits_poisons"), num_envs=3, shards=2)
    assert isinstance(sharded.unwrapped, FlatlandVectorEnv)
    reference = gymnasium.make_vec(gym_id("fruits_poisons"), num_envs=3, vectorization_mode="sync")
    assert data_equivalence(sharded.reset(seed=2), reference.reset(seed=2), exact=True)
    for _ in range(20):
        actions = np.array([0, 1, 2])
        assert data_equivalence(sharded.step(actions), reference.step(actions), exact=True)
    sharded.close()
    reference.close()


@pytest.mark.parametrize("scenario", ALIKE)
def test_every_scenario_over_two_processes_matches_one_batch(scenario):
    # One batch matches separate envs on each of these (tests/envs/test_batched_scenarios.py);
    # this closes the chain for the processes: 3 worlds of 9-step episodes, 24 steps.
    _same_as_one_batch(scenario, 3, 2, 24, context="fork", max_cycles=9)
