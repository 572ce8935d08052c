"""InertFinished (flatland_ma.integrations.inert): finished agents stay present and inert
until their world's episode ends, and the live agents play exactly as without it."""

import warnings

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test

import flatland_ma
from flatland_ma.integrations.discrete import DiscreteActions
from flatland_ma.integrations.inert import InertFinished, blank

EARLY_EXIT = {
    "zones": [{"rect": [0, 0, 100, 300], "terminal": True, "reward": 1.0}],
    "n_agents": 3,
    "episode": {"max_steps": 300},
}


def pair(**options):
    kwargs = {**EARLY_EXIT, **options}
    return (
        InertFinished(flatland_ma.parallel_env("fruits_poisons_multi", **kwargs)),
        flatland_ma.parallel_env("fruits_poisons_multi", **kwargs),
    )


@pytest.mark.parametrize("flatten", [False, True])
def test_live_agents_play_as_without_it_and_finished_ones_are_inert(flatten):
    inert, plain = pair(flatten=flatten)
    a, infos = inert.reset(seed=2)  # an agent reaches the zone at the fourth step
    b, _ = plain.reset(seed=2)
    assert all(info["active"] for info in infos.values())
    rng = np.random.default_rng(1)
    inert_steps = finishing_steps = 0
    everyone = set(inert.possible_agents)
    while plain.agents:
        actions = {agent: int(rng.integers(3)) for agent in everyone}
        gone = everyone - set(plain.agents)
        actions.update({agent: 99 for agent in gone})  # not even an action: ignored
        acting = set(plain.agents)
        a, ra, ta, ua, ia = inert.step(actions)
        b, rb, tb, ub, ib = plain.step({k: actions[k] for k in plain.agents})
        assert set(a) == set(ra) == set(ta) == set(ua) == set(ia) == everyone
        for agent in acting:  # the live agents' transitions are the env's own
            np.testing.assert_equal(a[agent], b[agent])
            assert ra[agent] == rb[agent] and ia[agent]["score"] == ib[agent]["score"]
            assert ia[agent]["active"] == (agent in plain.agents)
        if not plain.agents:  # the world's episode ends for every agent at once
            assert not inert.agents
            assert all(ta[x] or ua[x] for x in everyone)
            assert all(ta[x] for x in gone)
            break
        assert inert.agents == inert.possible_agents
        assert not any(ta.values()) and not any(ua.values())
        finishing_steps += len(acting - set(plain.agents))
        for agent in gone:  # inert: a blank observation, no reward, marked
            np.testing.assert_equal(a[agent], blank(inert.observation_space(agent)))
            assert ra[agent] == 0.0 and not ia[agent]["active"]
            assert inert.observation_space(agent).contains(a[agent])
            inert_steps += 1
    assert finishing_steps >= 1 and inert_steps >= 1
    with pytest.raises(RuntimeError, match="episode is over"):
        inert.step({})


def test_it_passes_pettingzoos_parallel_checker_with_agents_finishing_early():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        parallel_api_test(pair()[0], num_cycles=300)
        parallel_api_test(
            InertFinished(DiscreteActions(flatland_ma.parallel_env("signal_rooms"))),
            num_cycles=50,
        )


def test_a_bad_action_for_a_live_agent_still_raises():
    inert, _ = pair()
    inert.reset(seed=0)
    with pytest.raises(ValueError, match="agent_1"):
        inert.step({"agent_0": 0, "agent_1": 7, "agent_2": 0})
    with pytest.raises(ValueError, match="no action given for live agent 'agent_2'"):
        inert.step({"agent_0": 0, "agent_1": 0})


def test_a_blank_lies_inside_bounds_that_exclude_zero():
    from gymnasium import spaces

    space = spaces.Dict(
        {"a": spaces.Box(1.0, 2.0, (3,), np.float32), "b": spaces.Box(-1, 1, (2,), np.int64)}
    )
    value = blank(space)
    assert space.contains(value)
    np.testing.assert_array_equal(value["a"], [1.0, 1.0, 1.0])
    with pytest.raises(TypeError, match="Discrete"):
        blank(spaces.Discrete(3))
