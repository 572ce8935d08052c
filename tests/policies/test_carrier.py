"""The scripted carrier: what it proves about the object tasks (one agent cannot carry
the crate of coop_carry, two can) and which bodies it drives."""

import math

import pytest

import flatland_ma
from flatland_ma.policies import CarrierPolicy, evaluate
from flatland_ma.world.entities import Obstacle

SEGMENT = {"length": 16, "min_angle": -60, "max_angle": 60}


def carry_crate(n_agents: int, episodes: int = 3):
    """Per episode: the agents' mean return and how far the crate ever got from its start."""
    env = flatland_ma.parallel_env("coop_carry", n_agents=n_agents)
    policies = {a: CarrierPolicy(env, a) for a in env.possible_agents}
    results = []
    for k in range(episodes):
        observations, _ = env.reset(seed=k)
        (crate,) = [e for e in env.episode.world.entities if isinstance(e, Obstacle)]
        start, farthest, total, held = tuple(crate.body.position), 0.0, 0.0, 0
        while env.agents:
            actions = {a: policies[a].act(observations[a]) for a in env.agents}
            observations, rewards, *_ = env.step(actions)
            total += sum(rewards.values()) / n_agents
            farthest = max(farthest, math.dist(start, crate.body.position))
            held += sum(h.held is crate for b in env.episode.bodies for h in b.hands)
        results.append((total, farthest, held))
    return results


def test_one_agent_cannot_carry_the_crate_two_can():
    # The crate drags with 20,000; one agent's motor gives 15,000 and its grasp 12,000.
    for total, farthest, held in carry_crate(n_agents=1):
        assert total == 0.0 and farthest < 1.0, (total, farthest)
        assert held > 300  # it did get hold of the crate and pulled, for most of the episode
    for total, farthest, _ in carry_crate(n_agents=2):
        assert total == 10.0 and farthest > 100.0, (total, farthest)


def test_it_carries_with_the_forward_hand_of_several():
    arms = [{"mount": 0, "segments": [SEGMENT]}, {"mount": -90, "segments": [SEGMENT]}]
    env = flatland_ma.parallel_env("fetch_object", agent={"arms": arms})
    assert {"arm0_grasp", "arm1_grasp"} <= set(env.action_names())
    assert "grasp" not in env.action_names()
    scores = evaluate(env, lambda agent: CarrierPolicy(env, agent), episodes=4)
    assert scores.returns == [10.0] * 4
    # The forward arm need not be the first.
    arms = [{"mount": 90, "segments": [SEGMENT]}, {"mount": 0, "segments": [SEGMENT]}]
    env = flatland_ma.parallel_env("fetch_object", agent={"arms": arms})
    policy = CarrierPolicy(env, "agent_0")
    assert policy.ids["grasp"] == env.action_index("arm1_grasp")
    assert policy.ids["release"] == env.action_index("arm1_release")
    # One grasper among several arms keeps the plain names.
    arms = [{"mount": 0, "segments": [SEGMENT]}, {"mount": 90, "grasper": None}]
    env = flatland_ma.parallel_env("fetch_object", agent={"arms": arms})
    assert CarrierPolicy(env, "agent_0").ids["grasp"] == env.action_index("grasp")


def test_it_says_it_drives_discrete_bodies_only():
    env = flatland_ma.parallel_env("push_box", agent={"actions": "continuous"})
    with pytest.raises(ValueError, match=r"discrete bodies only .* Box\(-1.0, 1.0, \(3,\)"):
        CarrierPolicy(env, "agent_0")
