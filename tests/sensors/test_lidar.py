"""The lidar against distances worked out by hand, and beside a camera in one kernel call."""

import math

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test

import flatland_ma
from flatland_ma.scenario.errors import ScenarioError

EMPTY = {"obstacles": [], "items": []}


def _lidar_env(rays=8, range_=400.0, **agent):
    sensors = [{"type": "lidar", "rays": rays, "range": range_}]
    return flatland_ma.parallel_env("fruits_poisons", **EMPTY, agent={"sensors": sensors, **agent})


def _look(env, x, y, heading):
    env.reset(seed=0)
    episode = env.episode
    episode.world.place(episode.bodies[0], x, y, heading)
    episode.sensors.observe()
    return episode.sensors.observation(0)


def test_distances_to_the_walls_of_an_empty_room_all_around():
    """In the 300 x 300 room, from (100, 60) heading east: ray k at 45k degrees."""
    env = _lidar_env()
    distances = _look(env, 100.0, 60.0, 0.0) * 400.0
    r2 = math.sqrt(2.0)
    expected = [200, 200 * r2, 240, 100 * r2, 100, 60 * r2, 60, 60 * r2]
    assert distances == pytest.approx(expected, abs=1e-3)


def test_rays_turn_with_the_agent_and_a_wall_at_a_known_distance_is_measured():
    wall = {"start": [180, 0], "end": [180, 300], "thickness": 10}  # its face at x = 175
    env = flatland_ma.parallel_env(
        "fruits_poisons",
        **EMPTY,
        walls=[wall],
        agent={"sensors": [{"type": "lidar", "rays": 4, "range": 100}]},
    )
    # Heading north: ray 0 north (wall 300 - 150 = 150 away: out of range), ray 3 east.
    distances = _look(env, 120.0, 150.0, math.pi / 2) * 100.0
    assert distances == pytest.approx([100.0, 100.0, 100.0, 55.0], abs=1e-3)


def test_a_lidar_beside_a_camera_shares_the_kernel_call_and_gives_a_dict():
    sensors = [{"type": "camera", "rays": 16}, {"type": "lidar", "rays": 12, "range": 50}]
    env = flatland_ma.parallel_env("fruits_poisons_multi", agent={"sensors": sensors})
    space = env.observation_space("agent_0")
    assert space["camera"].shape == (16, 4) and space["lidar"].shape == (12,)
    observations, _ = env.reset(seed=3)
    assert env.episode.sensors.image.shape == (4 * (16 + 12), 4)
    for agent, observation in observations.items():
        assert env.observation_space(agent).contains(observation)
    k = env.episode.sensors.per_agent[2][1]  # agent 2's lidar
    distance = env.episode.sensors.distance[env.episode.sensors.slices[k]]
    assert np.allclose(observations["agent_2"]["lidar"], np.minimum(distance, 50.0) / 50.0)
    parallel_api_test(flatland_ma.parallel_env("fruits_poisons_multi", agent={"sensors": sensors}))


def test_lidar_faults_are_located():
    with pytest.raises(ScenarioError) as info:
        flatland_ma.load_scenario(
            "fruits_poisons", agent={"sensors": [{"type": "lidar", "rays": 0}]}
        )
    assert str(info.value.problems[0]).startswith("<overrides>: agent.sensors[0].rays:")
    with pytest.raises(ScenarioError) as info:
        flatland_ma.load_scenario("fruits_poisons", agent={"sensors": [{"type": "sonar"}]})
    assert "agent.sensors[0]" in str(info.value.problems[0])
    with pytest.raises(ScenarioError) as info:
        flatland_ma.load_scenario("fruits_poisons", agent={"sensors": [{"rays": 0}]})
    (problem,) = info.value.problems
    assert str(problem).startswith("<overrides>: agent.sensors[0]:") and "type" in str(problem)


def test_flattened_observations_pass_the_checker_and_unflatten_to_the_original():
    from flatland_ma.envs.flatten import FlattenObservations

    sensors = [{"type": "camera", "rays": 16}, {"type": "lidar", "rays": 12}]
    env = FlattenObservations(
        flatland_ma.parallel_env("fruits_poisons_multi", agent={"sensors": sensors})
    )
    space = env.observation_space("agent_0")
    assert space.shape == (16 * 4 + 12,) and space.dtype == np.float32
    observations, _ = env.reset(seed=0)
    plain = flatland_ma.parallel_env("fruits_poisons_multi", agent={"sensors": sensors})
    originals, _ = plain.reset(seed=0)
    for agent, vector in observations.items():
        assert space.contains(vector)
        back = env.unflatten(agent, vector)
        assert np.array_equal(back["camera"], originals[agent]["camera"])
        assert np.array_equal(back["lidar"], originals[agent]["lidar"])
    assert env.state_space.contains(env.state())
    parallel_api_test(
        FlattenObservations(
            flatland_ma.parallel_env("fruits_poisons_multi", agent={"sensors": sensors})
        )
    )


def test_the_greedy_forager_reads_its_camera_out_of_several_sensors():
    from flatland_ma.policies import GreedyForager, evaluate

    sensors = [{"type": "lidar"}, {"type": "camera", "name": "eyes"}]
    env = flatland_ma.parallel_env("fruits_poisons", agent={"sensors": sensors})
    plain = flatland_ma.parallel_env("fruits_poisons")
    with_lidar = evaluate(env, lambda a: GreedyForager(env.spec), episodes=1).returns
    camera_only = evaluate(plain, lambda a: GreedyForager(plain.spec), episodes=1).returns
    assert np.array_equal(with_lidar, camera_only)  # the same image, the same choices
    with pytest.raises(ValueError, match="has none"):
        GreedyForager(flatland_ma.load_scenario("fruits_poisons", agent={"sensors": sensors[:1]}))
