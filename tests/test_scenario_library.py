"""The scenario library, generated from the folder: every file plays whole episodes, is
solvable well above random play, and is documented."""

from pathlib import Path

import numpy as np
import pytest

import flatland_ma
from flatland_ma.policies import (
    CarrierPolicy,
    GreedyForager,
    PlannerPolicy,
    RandomPolicy,
    evaluate,
)
from flatland_ma.scenario.loader import scenario_dir
from flatland_ma.scenario.reference import render

ROOT = Path(__file__).resolve().parent.parent
SCENARIOS = flatland_ma.list_scenarios()

# The solver that proves each task solvable, and the mean it must reach over 4 episodes
# (seeds 0-3). The 20-episode figures are in each file's header comment.
SOLVERS = {
    "corridor_rooms": ("planner", 150),
    "explore_goal": ("planner", 80),
    "forage_rooms_multi": ("planner", 120),
    "fruits_poisons": ("greedy", 150),
    "fruits_poisons_multi": ("greedy", 120),
    "hinged_doors": ("planner", 100),
    "key_door": ("planner", 9),
    "maze_goal": ("planner", 9),
    "maze_large": ("planner", 70),
    "obstacle_forest": ("planner", 130),
    "seek_avoid_rooms": ("planner", 180),
    "switch_door": ("planner", 9),
    "textured_fruits": ("planner", 120),
    "push_box": ("carrier", 9),
    "fetch_object": ("carrier", 9),
    "key_carry": ("carrier", 9),
    "coop_carry": ("carrier", 9),
    "tug_of_war": ("carrier_vs_random", 5),
}


def test_every_scenario_has_a_solver():
    assert sorted(SOLVERS) == SCENARIOS
    assert len(SCENARIOS) >= 10


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_a_whole_episode_plays_out(scenario):
    env = flatland_ma.parallel_env(scenario)
    observations, infos = env.reset(seed=0)
    for i, agent in enumerate(env.possible_agents):
        env.action_space(agent).seed(i)
    steps = 0
    while env.agents:
        actions = {a: env.action_space(a).sample() for a in env.agents}
        observations, rewards, terminations, truncations, infos = env.step(actions)
        steps += 1
        for agent, obs in observations.items():
            assert env.observation_space(agent).contains(obs)
            assert type(rewards[agent]) is float and np.isfinite(rewards[agent])
    assert steps <= env.spec.episode.max_steps
    assert all(terminations[a] or truncations[a] for a in terminations)


def first_team_return(env, make_first, make_others, episodes=4) -> float:
    """Mean return of the first team's agents, the teams playing different policies."""
    first = env.spec.teams[0].name
    total, count = 0.0, 0
    for k in range(episodes):
        observations, _ = env.reset(seed=k)
        policies = {
            a: (make_first if env.spec.team_of(i).name == first else make_others)(a)
            for i, a in enumerate(env.possible_agents)
        }
        while env.agents:
            actions = {a: policies[a].act(observations[a]) for a in env.agents}
            observations, rewards, *_ = env.step(actions)
            for i, a in enumerate(env.possible_agents):
                if a in rewards and env.spec.team_of(i).name == first:
                    total += rewards[a]
        count += env.spec.teams[0].size
    return total / count


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_the_solver_beats_random_play_by_far(scenario):
    kind, minimum = SOLVERS[scenario]
    env = flatland_ma.parallel_env(scenario)

    def random(agent):
        return RandomPolicy(env.action_space(agent), seed=int(agent.split("_")[1]))

    if kind == "carrier_vs_random":
        solved = first_team_return(env, lambda a: CarrierPolicy(env, a), random)
        baseline = first_team_return(env, random, random)
    else:
        makers = {
            "planner": lambda agent: PlannerPolicy(env, agent),
            "greedy": lambda agent: GreedyForager(env.spec),
            "carrier": lambda agent: CarrierPolicy(env, agent),
        }
        solved = evaluate(env, makers[kind], episodes=4).mean
        baseline = evaluate(env, random, episodes=4).mean
    assert solved >= minimum, solved
    assert solved >= baseline + 0.8 * minimum, (solved, baseline)


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_each_file_says_what_it_is_and_how_random_and_scripted_play_score(scenario):
    text = (scenario_dir() / f"{scenario}.yaml").read_text()
    header = "\n".join(line for line in text.splitlines() if line.startswith("#"))
    assert text.startswith(f"# {scenario}: ")
    assert "Hard" in header or "hard" in header
    solver = SOLVERS[scenario][0].split("_")[0]
    assert "random" in header and solver in header and "Scores" in header
    assert flatland_ma.load_scenario(scenario).description


def test_the_format_reference_matches_the_schema():
    """docs/scenarios.md is written from the schema: regenerate it with ``make docs``."""
    assert (ROOT / "docs" / "scenarios.md").read_text() == render()


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_every_scenario_has_a_picture(scenario):
    """Pictures come from ``make docs``."""
    assert (ROOT / "docs" / "images" / "scenarios" / f"{scenario}.png").is_file()
