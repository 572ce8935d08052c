"""Every shipped scenario replays its recorded trajectories (``tests/trajectories.py``)
bit for bit: through one parallel env, through the batched env (each world's slots
against that world's recording) and through the sharded env (two processes), across
resets. The observations and the bodies' poses and velocities are held to their hashes,
rewards to their exact float64 values, and every agent's ending to its status."""

import pytest

import flatland_ma
from flatland_ma.envs.shards import ShardedParallelEnv
from flatland_ma.envs.vector import BatchedParallelEnv
from tests.trajectories import DATA, MAX_CYCLES, load, own_spaces, replay_batch, replay_single

pytestmark = pytest.mark.pymunk_bridge

SCENARIOS = flatland_ma.list_scenarios()


def test_every_shipped_scenario_has_its_recording_of_its_version():
    assert sorted(p.stem for p in DATA.glob("*.json")) == sorted(SCENARIOS)
    for scenario in SCENARIOS:
        version = flatland_ma.load_scenario(scenario).version
        assert load(scenario)["version"] == version, f"{scenario} v{version}: record it again"


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_one_parallel_env_replays_the_recording(scenario):
    replay_single(scenario)


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_a_batch_replays_each_worlds_recording_in_its_slots(scenario):
    recording = load(scenario)
    n = len(recording["worlds"])
    batch = BatchedParallelEnv(scenario, num_worlds=n, max_cycles=MAX_CYCLES, pad=True)
    replay_batch(batch, recording, own_spaces(scenario), bodies=True)
    batch.close()


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_two_shards_replay_each_worlds_recording_in_its_slots(scenario):
    recording = load(scenario)
    n = len(recording["worlds"])
    sharded = ShardedParallelEnv(scenario, n, shards=2, max_cycles=MAX_CYCLES, pad=True)
    try:
        replay_batch(sharded, recording, own_spaces(scenario), bodies=False)
    finally:
        sharded.close()
