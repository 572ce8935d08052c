"""Touch against pushes set up by hand: walls at known bearings, another agent behind, an
arm against a wall; and the contracts (space, determinism, pickling, no cost without it).

In the empty 300 x 300 room an agent's motor pushes whatever it cannot move with its
``max_force`` (15000 by default), which reads 15000 / 20000 = 0.75 with the default
``max_force`` of the sensor.
"""

import math
import pickle
from typing import Any

import numpy as np
import pytest
from gymnasium import spaces
from pettingzoo.test import parallel_api_test

import flatland_ma
from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.sensors.touch import Touch
from flatland_ma.world.entities import Item

EMPTY: dict[str, Any] = {"obstacles": [], "items": []}
MOTOR_PUSH = 15_000 / 20_000


def _touch_env(touch=None, scenario="fruits_poisons", overrides: dict[str, Any] = EMPTY, **agent):
    sensors = [{"type": "touch", **(touch or {})}, {"type": "camera", "rays": 8}]
    return flatland_ma.parallel_env(scenario, **overrides, agent={"sensors": sensors, **agent})


def _start(env, *poses, seed=0):
    """Reset, then put agent i at ``poses[i]`` (x, y, heading in degrees), at rest."""
    env.reset(seed=seed)
    for body, (x, y, heading) in zip(env.running.bodies, poses):
        body.teleport(x, y, math.radians(heading))


def _run(env, actions, steps=10):
    """Step ``steps`` times with the same ``actions`` (agent -> action); the last touch
    readings by agent."""
    observations = {}
    for _ in range(steps):
        observations, *_ = env.step(actions)
    return {agent: observation["touch"] for agent, observation in observations.items()}


def _space(env) -> spaces.Box:
    """Agent 0's touch space."""
    space = env.observation_space("agent_0")
    assert isinstance(space, spaces.Dict)
    touch = space["touch"]
    assert isinstance(touch, spaces.Box)
    return touch


def _only(reading, index, value=None):
    """Everything but ``reading[index]`` is exactly zero; that one is pressed (to ``value``)."""
    others = np.delete(reading, index)
    assert not others.any(), f"pressure outside entry {index}: {reading}"
    if value is None:
        assert reading[index] > 0.5, reading
    else:
        assert reading[index] == pytest.approx(value, abs=0.01)


def test_driving_into_a_wall_ahead_presses_the_front_sector_with_the_motors_force():
    env = _touch_env()
    _start(env, (285.0, 150.0, 0.0))  # heading east, the wall's face at x = 300
    forward = env.action_index("forward")
    _only(_run(env, {"agent_0": forward})["agent_0"], 0, MOTOR_PUSH)


@pytest.mark.parametrize("sectors", [4, 8, 12])
@pytest.mark.parametrize("heading", [0, 30, 90, 120, 180, -90])
def test_a_wall_to_the_east_presses_the_sector_of_its_bearing(sectors, heading):
    """Pushed east whatever its heading, the agent feels the wall at -heading degrees:
    sector ``round(-heading * sectors / 360)`` (heading north: 3 * sectors / 4)."""
    env = _touch_env({"sectors": sectors}, actions="continuous")
    _start(env, (288.0, 150.0, heading))
    turn = math.radians(heading)
    east = np.array([math.cos(turn), -math.sin(turn), 0.0], np.float32)  # in its own frame
    reading = _run(env, {"agent_0": east})["agent_0"]
    assert reading.shape == (sectors,)
    _only(reading, round(-heading * sectors / 360) % sectors, MOTOR_PUSH)


def test_nothing_is_felt_when_free_nor_from_items():
    env = _touch_env(overrides={"obstacles": []})
    observations, _ = env.reset(seed=0)
    assert not observations["agent_0"]["touch"].any()
    env.running.bodies[0].teleport(150.0, 150.0, 0.0)
    item = env.running.world.of_type(Item)[0]
    env.running.world.move_static(item, 170.0, 150.0)  # right ahead: it is driven over
    total = 0.0
    for action in ["forward"] * 4 + ["rotate_left"] * 6 + ["forward"] * 3:
        observations, rewards, *_ = env.step({"agent_0": env.action_index(action)})
        total += rewards["agent_0"]
        assert not observations["agent_0"]["touch"].any()
    assert total != 0.0  # the item was touched, and taken


@pytest.mark.parametrize(
    ("motor", "touch_max", "expected"),
    [(5_000.0, 20_000.0, 0.25), (10_000.0, 20_000.0, 0.5), (15_000.0, 10_000.0, 1.0)],
)
def test_pressure_grows_with_the_push_and_saturates_at_one(motor, touch_max, expected):
    env = _touch_env({"max_force": touch_max}, max_force=motor)
    _start(env, (285.0, 150.0, 0.0))
    reading = _run(env, {"agent_0": env.action_index("forward")})["agent_0"]
    _only(reading, 0, expected)


def test_an_agent_pushing_from_behind_is_felt_at_the_back_and_the_front():
    env = _touch_env(actions="continuous", overrides={**EMPTY, "n_agents": 2})
    _start(env, (150.0, 150.0, 0.0), (129.0, 150.0, 0.0))  # agent 1 just behind agent 0
    still, ahead = np.zeros(3, np.float32), np.array([1.0, 0.0, 0.0], np.float32)
    readings = _run(env, {"agent_0": still, "agent_1": ahead}, steps=6)
    _only(readings["agent_0"], 4)  # 180 degrees: sector 4 of 8
    _only(readings["agent_1"], 0)
    assert readings["agent_0"][4] == pytest.approx(readings["agent_1"][0], rel=1e-6)


def test_each_part_is_felt_on_its_own_entry():
    env = _touch_env(actions="continuous", head={}, arms=[{"mount": 0}])
    env.reset(seed=0)
    touch = env.running.sensors.cameras[0]
    assert isinstance(touch, Touch)
    labels = touch.labels
    assert labels == tuple(f"sector_{i}" for i in range(8)) + ("head", "arm", "arm_grip")
    env.running.bodies[0].teleport(270.0, 150.0, 0.0)  # the arm's grasper 1 from the wall
    forward = np.zeros(len(env.action_names()), np.float32)
    forward[0] = 1.0
    reading = _run(env, {"agent_0": forward}, steps=5)["agent_0"]
    _only(reading, labels.index("arm_grip"))
    plain = _touch_env({"parts": False}, head={}, arms=[{"mount": 0}])
    assert _space(plain).shape == (8,)


def test_observations_keep_to_their_space_through_play():
    env = _touch_env(scenario="fruits_poisons_multi", overrides={})
    space = _space(env)
    assert _space(env) is space
    assert space.shape == (8,) and space.dtype == np.float32
    assert (space.low == 0).all() and (space.high == 1).all()
    env.reset(seed=1)
    rng = np.random.default_rng(1)
    felt = 0
    for _ in range(150):
        actions = {a: int(rng.choice(3, p=[0.8, 0.1, 0.1])) for a in env.agents}
        observations, *_ = env.step(actions)
        for observation in observations.values():
            touch = observation["touch"]
            assert touch.dtype == np.float32 and space.contains(touch)
            felt += bool(touch.any())
    assert felt > 0  # they ran into walls, obstacles or each other
    parallel_api_test(_touch_env(scenario="fruits_poisons_multi", overrides={}), num_cycles=300)


def _play(env, seed, steps, sensor="touch"):
    """One sensor's readings through a seeded rollout that mostly drives ahead, step by
    step."""
    rng = np.random.default_rng(seed)
    readings = []
    for _ in range(steps):
        actions = {a: int(rng.choice(3, p=[0.8, 0.1, 0.1])) for a in env.agents}
        observations, *_ = env.step(actions)
        readings.append({a: o[sensor] for a, o in observations.items()})
    return readings


def test_same_seed_and_actions_give_the_same_readings_also_after_pickling():
    first, second = (_touch_env(scenario="fruits_poisons_multi", overrides={}) for _ in "ab")
    first.reset(seed=4)
    second.reset(seed=4)
    for a, b in zip(_play(first, 0, 80), _play(second, 0, 80)):
        assert a.keys() == b.keys()
        for agent in a:
            np.testing.assert_array_equal(a[agent], b[agent])
    copy = pickle.loads(pickle.dumps(first))
    later, copied = _play(first, 1, 80), _play(copy, 1, 80)
    assert any(r[a].any() for r in later for a in r)
    for a, b in zip(later, copied):
        for agent in a:
            np.testing.assert_array_equal(a[agent], b[agent])


def test_feeling_changes_nothing_in_the_physics():
    sensors = {"sensors": [{"type": "camera", "rays": 8}, {"type": "lidar"}]}
    plain = flatland_ma.parallel_env("fruits_poisons_multi", agent=sensors)
    touch = _touch_env(scenario="fruits_poisons_multi", overrides={})
    plain.reset(seed=2)
    touch.reset(seed=2)
    for a, b in zip(_play(plain, 3, 100, "camera"), _play(touch, 3, 100, "camera")):
        for agent in a:
            np.testing.assert_array_equal(a[agent], b[agent])
    for a, b in zip(plain.running.bodies, touch.running.bodies):
        assert a.body.position == b.body.position and a.body.angle == b.body.angle


def test_a_world_without_touch_sensors_logs_no_pushes():
    env = flatland_ma.parallel_env("fruits_poisons", **EMPTY)
    _start(env, (285.0, 150.0, 0.0))
    world = env.running.world
    for _ in range(5):
        env.step({"agent_0": env.action_index("forward")})
        assert world.log.pushes == {}
    assert env.running.bodies[0].touching  # it does press on the wall


def test_touch_faults_are_located():
    for key, value in [("sectors", 0), ("max_force", 0.0), ("parts", "yes")]:
        with pytest.raises(ScenarioError) as info:
            flatland_ma.load_scenario(
                "fruits_poisons", agent={"sensors": [{"type": "touch", key: value}]}
            )
        assert str(info.value.problems[0]).startswith(f"<overrides>: agent.sensors[0].{key}:")


@pytest.mark.parametrize("tiny", [5e-324, 1e-300, 0.5])
def test_a_tiny_max_force_is_refused_where_it_is_written(tiny):
    with pytest.raises(ScenarioError) as info:
        flatland_ma.load_scenario(
            "fruits_poisons", agent={"sensors": [{"type": "touch", "max_force": tiny}]}
        )
    (problem,) = info.value.problems
    assert str(problem).startswith("<overrides>: agent.sensors[0].max_force:")
    assert "greater than or equal to 1" in problem.message
    with pytest.raises(ValueError, match="max_force must be finite and at least 1"):
        Touch(max_force=tiny)


def test_the_lightest_max_force_allowed_reads_a_push_as_one():
    env = _touch_env({"max_force": 1.0})
    _start(env, (285.0, 150.0, 0.0))
    reading = _run(env, {"agent_0": env.action_index("forward")})["agent_0"]
    _only(reading, 0, 1.0)
