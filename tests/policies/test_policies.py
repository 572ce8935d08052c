"""The calibration of the paper's task: random play averages near 0; the shipped greedy
policy averages at least 200 over 20 episodes."""

import numpy as np
from scipy import stats

import flatland_ma
from flatland_ma.policies import GreedyForager, RandomPolicy, evaluate


def test_greedy_forager_scores_at_least_200_on_fruits_poisons():
    env = flatland_ma.parallel_env("fruits_poisons")
    scores = evaluate(env, lambda agent: GreedyForager(env.spec), episodes=20)
    assert scores.mean >= 200.0, scores.returns
    poisons = sum(info["agent_0"]["poisons"] for info in scores.infos)
    fruits = sum(info["agent_0"]["fruits"] for info in scores.infos)
    assert poisons < 0.1 * fruits


def test_uniform_random_play_averages_near_zero():
    env = flatland_ma.parallel_env("fruits_poisons")
    scores = evaluate(env, lambda agent: RandomPolicy(env.action_space(agent), seed=1), episodes=60)
    returns = np.array(scores.returns)
    # Less than one item either way on average, and no evidence of a bias at the 1% level.
    assert abs(returns.mean()) < 10.0, returns
    low, high = stats.t.interval(0.99, len(returns) - 1, returns.mean(), stats.sem(returns))
    assert low < 0.0 < high, (low, high)
    fruits = sum(info["agent_0"]["fruits"] for info in scores.infos)
    poisons = sum(info["agent_0"]["poisons"] for info in scores.infos)
    assert fruits > 20 and poisons > 20  # it does eat things, of both kinds


def test_greedy_foragers_share_the_multi_agent_room():
    env = flatland_ma.parallel_env("fruits_poisons_multi")
    scores = evaluate(env, lambda agent: GreedyForager(env.spec), episodes=3)
    per_agent = [info[a]["score"] for info in scores.infos for a in info]
    assert min(per_agent) > 0 and scores.mean > 50.0


def test_greedy_forager_drives_continuous_bodies():
    env = flatland_ma.parallel_env("fruits_poisons", agent={"actions": "continuous"})
    scores = evaluate(env, lambda agent: GreedyForager(env.spec), episodes=3)
    assert scores.mean > 100.0


def test_scripted_policies_act_in_any_body_s_action_space():
    from flatland_ma.policies import PlannerPolicy

    for actions in ("discrete", "continuous"):
        env = flatland_ma.parallel_env(
            "fruits_poisons", agent={"actions": actions, "head": {}, "arms": [{}]}
        )
        observations, _ = env.reset(seed=0)
        greedy, planner = GreedyForager(env.spec), PlannerPolicy(env, "agent_0")
        space = env.action_space("agent_0")
        for _ in range(30):
            for policy in (greedy, planner):
                assert space.contains(policy.act(observations["agent_0"]))
            observations, *_ = env.step({"agent_0": planner.act(observations["agent_0"])})
