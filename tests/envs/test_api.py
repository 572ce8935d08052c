"""The ecosystem's own checkers, run over every shipped scenario and Gymnasium id."""

import warnings

import gymnasium
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import api_test, parallel_api_test, render_test, seed_test, state_test

import flatland_ma
from flatland_ma.envs.registration import gym_id

SCENARIOS = flatland_ma.list_scenarios()
SINGLE_AGENT = [s for s in SCENARIOS if flatland_ma.load_scenario(s).n_agents == 1]


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_parallel_api(scenario):
    parallel_api_test(flatland_ma.parallel_env(scenario), num_cycles=600)


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_aec_api(scenario):
    env = flatland_ma.env(scenario)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the checker's warnings are failures here
        if isinstance(env.observation_space(env.possible_agents[0]), gymnasium.spaces.Dict):
            # but these two: the checker says them of every Dict observation (its own
            # environments with one are listed by name), and several sensors give one.
            warnings.filterwarnings("ignore", "Observation is not a NumPy array")
            warnings.filterwarnings("ignore", "Observation space for each agent probably")
        if env.unwrapped.spec.channel is not None:
            # and this, said of MultiDiscrete: a move and words (the channel's actions).
            warnings.filterwarnings("ignore", "Action space for each agent probably")
        if env.unwrapped.spec.heterogeneous:
            # and this one, which is what a scenario of different bodies means.
            warnings.filterwarnings("ignore", "Agents have different observation space sizes")
            warnings.filterwarnings("ignore", "Agents have different action space sizes")
            warnings.filterwarnings("ignore", "Observations are different shapes")
        api_test(env, num_cycles=100)


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_global_state(scenario):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the checker's warnings are failures here
        state_test(flatland_ma.env(scenario), flatland_ma.parallel_env(scenario), num_cycles=50)


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_aec_seed(scenario):
    seed_test(lambda: flatland_ma.env(scenario), num_cycles=100)


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_render_rgb_array_and_human(scenario):
    def make(render_mode=None):
        return flatland_ma.env(scenario, render_mode=render_mode)

    render_test(make)


@pytest.mark.parametrize("scenario", SINGLE_AGENT)
def test_gymnasium_check_env(scenario):
    env = gymnasium.make(gym_id(scenario), render_mode="rgb_array")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped)
    env.close()


def test_every_single_agent_scenario_has_a_gym_id():
    assert flatland_ma.GYM_IDS == [gym_id(s) for s in SINGLE_AGENT]
    for env_id in flatland_ma.GYM_IDS:
        assert env_id in gymnasium.registry
    assert "flatland_ma/FruitsPoisons-v0" in flatland_ma.GYM_IDS


def test_gym_env_refuses_a_multi_agent_scenario():
    with pytest.raises(ValueError, match="4 agents"):
        gymnasium.make("flatland_ma/FruitsPoisons-v0", scenario="fruits_poisons_multi")


def test_spaces_follow_the_scenario():
    env = flatland_ma.parallel_env("fruits_poisons", agent={"camera": {"rays": 32}})
    assert env.observation_space("agent_0").shape == (32, 4)
    assert env.action_space("agent_0") == gymnasium.spaces.Discrete(3)
    assert env.action_names() == ("forward", "rotate_left", "rotate_right")
    env = flatland_ma.parallel_env("fruits_poisons", agent={"actions": "continuous"})
    space = env.action_space("agent_0")
    assert space.shape == (3,) and space.dtype.name == "float32"
    assert (space.low == -1).all() and (space.high == 1).all()
    assert env.action_names() == ("longitudinal", "lateral", "angular")


def test_continuous_scenario_passes_the_checkers():
    parallel_api_test(
        flatland_ma.parallel_env("fruits_poisons_multi", agent={"actions": "continuous"}),
        num_cycles=100,
    )
    env = gymnasium.make("flatland_ma/FruitsPoisons-v0", agent={"actions": "continuous"})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped)


def test_close_is_safe_twice_and_no_window_without_human_mode():
    env = flatland_ma.parallel_env("fruits_poisons", render_mode="rgb_array")
    env.reset(seed=0)
    env.render()
    assert env._renderer._window is None
    env.close()
    env.close()


def test_agents_whose_episode_ends_early_pass_the_checkers():
    # Terminal zones end agents one by one; the others play on.
    kwargs = dict(
        zones=[{"rect": [0, 0, 100, 300], "terminal": True, "reward": 1.0}],
        n_agents=3,
        episode={"max_steps": 300},
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        parallel_api_test(
            flatland_ma.parallel_env("fruits_poisons_multi", **kwargs), num_cycles=300
        )
        api_test(flatland_ma.env("fruits_poisons_multi", **kwargs), num_cycles=300)
    seed_test(lambda: flatland_ma.env("fruits_poisons_multi", **kwargs), num_cycles=300)
