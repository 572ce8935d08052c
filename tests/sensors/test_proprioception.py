"""Proprioception against motion and posture set or commanded by hand."""

import math

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test

import flatland_ma

SENSORS = {"sensors": [{"type": "camera", "rays": 8}, {"type": "proprioception"}]}


def _feel(env, k=0):
    suite = env.episode.sensors
    suite.observe()
    return dict(zip(suite.cameras[2 * k + 1].labels, suite.observation(k)["proprioception"]))


def test_velocity_is_felt_in_the_body_frame():
    env = flatland_ma.parallel_env("fruits_poisons", agent=SENSORS)
    env.reset(seed=0)
    body = env.episode.bodies[0].body
    speed, turn = env.spec.agent.max_speed, math.radians(env.spec.agent.max_turn_rate)
    body.angle = math.pi / 2  # facing north: ahead is +y, left is -x
    body.velocity, body.angular_velocity = (-44.0, 110.0), -0.5 * turn
    felt = _feel(env)
    assert felt["ahead"] == pytest.approx(110 / speed, abs=1e-6)
    assert felt["left"] == pytest.approx(44 / speed, abs=1e-6)
    assert felt["turn"] == pytest.approx(-0.5, abs=1e-6)
    assert set(felt) == {"ahead", "left", "turn"}  # no parts, nothing more


def test_a_head_turned_to_its_limits_reads_plus_and_minus_one():
    env = flatland_ma.parallel_env("tug_of_war", agent=SENSORS)
    env.reset(seed=0)
    names = env.episode.sensors.cameras[1].labels
    assert names == ("ahead", "left", "turn", "joint_0", "joint_1", "hand_0")
    agents = list(env.agents)
    stay = env.action_index("stay")

    def hold(action, steps=60):
        for _ in range(steps):
            env.step({a: (action if a == "red_0" else stay) for a in agents})
        return _feel(env)

    assert hold(env.action_index("head_left"))["joint_0"] == pytest.approx(1.0, abs=0.03)
    assert hold(env.action_index("head_right"), 120)["joint_0"] == pytest.approx(-1.0, abs=0.03)
    head = env.episode.bodies[0].links[0]
    head.body.angle = head.parent.angle  # straight ahead: the middle of its range
    assert _feel(env)["joint_0"] == pytest.approx(0.0, abs=1e-6)


def test_a_grasper_that_holds_something_is_felt():
    env = flatland_ma.parallel_env("tug_of_war", agent=SENSORS)
    env.reset(seed=0)
    agent = env.episode.bodies[0]
    assert _feel(env)["hand_0"] == 0.0
    agent.hands[0].held = env.episode.world.tagged[0]
    assert _feel(env)["hand_0"] == 1.0


def test_observations_stay_in_their_space_through_play():
    env = flatland_ma.parallel_env("tug_of_war", agent=SENSORS)
    parallel_api_test(env, num_cycles=200)
    observations, _ = env.reset(seed=1)
    for _ in range(100):
        actions = {a: env.action_space(a).sample() for a in env.agents}
        observations, *_ = env.step(actions)
        for agent, observation in observations.items():
            assert env.observation_space(agent).contains(observation)
            assert np.isfinite(observation["proprioception"]).all()
