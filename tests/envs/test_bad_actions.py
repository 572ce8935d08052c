"""Bad actions raise an error naming the agent, the value and the space, and change
nothing: not the bodies, not the step count, not the random generator."""

import gymnasium
import numpy as np
import pytest

import flatland_ma
from flatland_ma.agents.actuators import InvalidActionError


def state(env):
    bodies = [
        (
            *b.body.position,
            b.body.angle,
            *b.body.velocity,
            b.body.angular_velocity,
            *b.control.velocity,
            b.control.angular_velocity,
        )
        for b in env.episode.bodies
    ]
    return bodies, env.num_steps, list(env.agents), env.np_random.bit_generator.state, len(env._log)


@pytest.fixture
def discrete_env():
    env = flatland_ma.parallel_env("fruits_poisons_multi")
    env.reset(seed=0)
    for _ in range(5):
        env.step({a: 0 for a in env.agents})
    return env


@pytest.fixture
def continuous_env():
    env = flatland_ma.parallel_env("fruits_poisons_multi", agent={"actions": "continuous"})
    env.reset(seed=0)
    for _ in range(5):
        env.step({a: np.ones(3, np.float32) for a in env.agents})
    return env


@pytest.mark.parametrize(
    "bad, reason",
    [
        (3, "out of range"),
        (-1, "out of range"),
        (np.int64(7), "out of range"),
        (1.0, "integer is required"),
        (np.float32(1), "integer is required"),
        (float("nan"), "integer is required"),
        (True, "integer is required"),
        ("0", "integer is required"),
        (None, "integer is required"),
        (np.array([0, 1]), "integer is required"),
    ],
)
def test_bad_discrete_actions(discrete_env, bad, reason):
    before = state(discrete_env)
    actions = {a: 0 for a in discrete_env.agents}
    actions["agent_2"] = bad  # the others are fine, and must not be applied either
    with pytest.raises(InvalidActionError, match=reason) as info:
        discrete_env.step(actions)
    message = str(info.value)
    assert "agent_2" in message and repr(bad) in message and "Discrete(3)" in message
    assert state(discrete_env) == before


@pytest.mark.parametrize(
    "bad, reason",
    [
        (np.array([0.0, 0.0, 1.5], np.float32), "outside"),
        (np.array([np.nan, 0.0, 0.0], np.float32), "NaN"),
        (np.array([0.0, np.inf, 0.0]), "NaN or infinite"),
        (np.zeros(2, np.float32), "shape"),
        (np.zeros((3, 1), np.float32), "shape"),
        (0.5, "shape"),
        (["a", "b", "c"], "numbers"),
        (None, "numbers"),
    ],
)
def test_bad_continuous_actions(continuous_env, bad, reason):
    before = state(continuous_env)
    actions = {a: np.zeros(3, np.float32) for a in continuous_env.agents}
    actions["agent_1"] = bad
    with pytest.raises(InvalidActionError, match=reason) as info:
        continuous_env.step(actions)
    assert "agent_1" in str(info.value) and "Box(-1.0, 1.0, (3,), float32)" in str(info.value)
    assert state(continuous_env) == before


def test_valid_action_forms_are_accepted(discrete_env, continuous_env):
    discrete_env.step(
        {a: v for a, v in zip(discrete_env.agents, [0, np.int32(1), np.int64(2), np.array(1)])}
    )
    continuous_env.step(
        {
            a: v
            for a, v in zip(
                continuous_env.agents,
                [[0, 0, 0], (1, -1, 0.5), np.zeros(3), np.ones(3, np.float32)],
            )
        }
    )


def test_unknown_and_missing_agents(discrete_env):
    before = state(discrete_env)
    actions = {a: 0 for a in discrete_env.agents}
    with pytest.raises(ValueError, match=r"action 2 given for 'agent_9'.*not a live agent") as info:
        discrete_env.step({**actions, "agent_9": 2})
    assert "Discrete(3)" in str(info.value)
    del actions["agent_3"]
    with pytest.raises(
        ValueError, match=r"no action given for live agent 'agent_3'.*Discrete\(3\)"
    ):
        discrete_env.step(actions)
    with pytest.raises(TypeError, match="dict"):
        discrete_env.step([0, 0, 0, 0])
    assert state(discrete_env) == before


def test_stepping_a_finished_episode_is_an_error():
    env = flatland_ma.parallel_env("fruits_poisons", episode={"max_steps": 2})
    env.reset(seed=0)
    env.step({"agent_0": 0})
    env.step({"agent_0": 0})
    with pytest.raises(RuntimeError, match="reset"):
        env.step({"agent_0": 0})


def test_gym_env_validates_too():
    env = gymnasium.make("flatland_ma/FruitsPoisons-v0")
    env.reset(seed=0)
    before = state(env.unwrapped.parallel_env)
    with pytest.raises(InvalidActionError, match="agent_0.*out of range"):
        env.unwrapped.step(5)
    assert state(env.unwrapped.parallel_env) == before


def test_unknown_scenarios_and_render_modes():
    with pytest.raises(
        ValueError, match="unknown scenario 'fruit_poisons'.*did you mean 'fruits_poisons'"
    ):
        flatland_ma.parallel_env("fruit_poisons")
    with pytest.raises(ValueError, match="known scenarios: .*fruits_poisons, fruits_poisons_multi"):
        flatland_ma.env("nothing")
    with pytest.raises(ValueError, match="render_mode"):
        flatland_ma.parallel_env("fruits_poisons", render_mode="ansi")


def test_aec_env_checks_each_action_on_its_own_turn():
    aec = flatland_ma.env("fruits_poisons_multi")
    aec.reset(seed=0)
    parallel = aec.unwrapped
    for _ in range(3):  # a few whole rounds
        for _ in parallel.agents:
            aec.step(0)
    before = state(parallel)
    aec.step(1)  # agent_0 acts; the round is not over
    with pytest.raises(InvalidActionError, match="out of range") as info:
        aec.step(7)  # agent_1's turn
    assert "agent_1" in str(info.value) and "7" in str(info.value)
    assert "Discrete(3)" in str(info.value)
    assert aec.agent_selection == "agent_1" and state(parallel) == before
    for action in (2, 0, 1):  # the round goes on from where it was
        aec.step(action)
    assert parallel.num_steps == before[1] + 1
    assert aec.action_names() == ("forward", "rotate_left", "rotate_right")
    assert aec.action_index("rotate_right") == 2


def test_aec_to_parallel_gives_back_the_native_env():
    from pettingzoo.utils.conversions import aec_to_parallel

    from flatland_ma.envs.parallel import FlatlandParallelEnv

    assert type(aec_to_parallel(flatland_ma.env("fruits_poisons_multi"))) is FlatlandParallelEnv
