"""Agents with different bodies in one world: a team's own ``agent`` section, what it
inherits, the spaces, bodies and state that follow from it, and the clients that need
agents alike (the batched env refuses them; SuperSuit pads them)."""

import math
import pickle

import gymnasium
import numpy as np
import pytest
import supersuit
from gymnasium.utils.env_checker import data_equivalence
from pettingzoo.test import parallel_api_test

import flatland_ma
from flatland_ma.envs.padding import ROLE, Padding
from flatland_ma.envs.shards import ShardedParallelEnv
from flatland_ma.envs.vector import BatchedParallelEnv
from flatland_ma.policies import GreedyForager
from flatland_ma.scenario.errors import ScenarioError

SCOUT_AND_RUNNER = {
    "n_agents": 3,
    "agent": {"camera": {"rays": 16, "fov": 90}, "max_speed": 150, "colors": ["red"]},
    "teams": [
        {"name": "scouts", "size": 2, "agent": {"radius": 6, "camera": {"rays": 24}}},
        {
            "name": "runner",
            "agent": {"radius": 12, "actions": "continuous", "head": {}, "arms": [{}]},
        },
    ],
}


def test_a_team_body_replaces_the_keys_it_gives_and_inherits_the_rest():
    spec = flatland_ma.load_scenario("fruits_poisons", **SCOUT_AND_RUNNER)
    scout, runner = spec.agent_of(0), spec.agent_of(2)
    assert spec.agent_of(1) == scout and spec.heterogeneous
    assert (scout.radius, runner.radius, spec.agent.radius) == (6, 12, 10)
    assert scout.max_speed == runner.max_speed == 150 and scout.colors == spec.agent.colors
    # A key given is replaced whole: the scouts' camera is {rays: 24}, with the camera's
    # default fov, not the top-level camera's 90.
    assert (scout.camera.rays, scout.camera.fov) == (24, 120)
    assert (runner.camera.rays, runner.camera.fov) == (16, 90)
    assert [path for path, _, _ in spec.agent_kinds()] == [
        ("teams", 0, "agent"),
        ("teams", 1, "agent"),
    ]


def test_spaces_bodies_and_state_follow_each_agents_spec():
    env = flatland_ma.parallel_env("fruits_poisons", **SCOUT_AND_RUNNER)
    env.reset(seed=0)
    assert env.possible_agents == ["scouts_0", "scouts_1", "runner_0"]  # named by team
    assert env.observation_space("scouts_0").shape == (24, 4)
    assert env.observation_space("runner_0").shape == (16, 4)
    assert str(env.action_space("scouts_0")) == "Discrete(3)"
    runner = env.action_space("runner_0")
    assert runner.shape == (3 + 1 + 1 + 1,)  # base, head, joint, grasper
    radii = [b.shapes[0].radius for b in env.episode.bodies]
    assert radii == [6, 6, 12]
    assert [len(b.joints) for b in env.episode.bodies] == [0, 0, 1]
    assert [b.head is not None for b in env.episode.bodies] == [False, False, True]
    # The state gives each agent's velocity as a fraction of its own top speed.
    env.step({"scouts_0": 0, "scouts_1": 0, "runner_0": np.array([1, 0, 0, 0, 0, 0], np.float32)})
    labels = env.state_labels
    state = env.state()
    runner_vx = state[labels.index("runner_0.vx")] * 150
    body = env.episode.bodies[2].body
    assert runner_vx == pytest.approx(body.velocity.x, rel=1e-5, abs=1e-3)


def test_planning_grids_are_per_radius_and_the_world_grid_is_the_slimmest():
    env = flatland_ma.parallel_env("plate_relay")
    env.reset(seed=0)
    episode = env.episode
    passage = episode.grid.cell_of(120, 212)  # halfway down the passage, 20 wide
    assert episode.grid.clearance == 6 and not episode.grid.blocked[passage]
    wide = episode.grid_for(12)
    assert wide.blocked[passage] and wide is episode.grid_for(12)
    assert episode.grid_for(6) is episode.grid


@pytest.mark.parametrize("seed", [0, 5])
def test_the_roles_need_each_other(seed):
    """Either agent alone, driven by the planner while the other stands still, scores
    nothing from the goal; together they reach it (the scripted scores are in the file)."""
    from flatland_ma.policies import PlannerPolicy

    env = flatland_ma.parallel_env("plate_relay")

    def play(acting):
        observations, _ = env.reset(seed=seed)
        policies = {a: PlannerPolicy(env, a) for a in acting}
        goal = 0
        while env.agents:
            actions = {
                a: policies[a].act(observations[a]) if a in policies else 0 for a in env.agents
            }
            # A still agent: the runner turns on the spot (0 is forward for both bodies).
            actions.update({a: 1 for a in env.agents if a not in policies})
            observations, _, _, _, infos = env.step(actions)
            goal = max(goal, max(info.get("goal", 0) for info in infos.values()))
        return goal

    assert play(["scout_0"]) == 0 and play(["runner_0"]) == 0
    assert play(["scout_0", "runner_0"]) == 1


def test_a_heterogeneous_scenario_passes_the_checker_and_pickles():
    env = flatland_ma.parallel_env("plate_relay")
    parallel_api_test(env, num_cycles=200)
    env.reset(seed=3)
    for _ in range(40):
        env.step({a: env.action_space(a).sample() for a in env.agents})
    copy = pickle.loads(pickle.dumps(env))
    for _ in range(40):
        actions = {a: env.action_space(a).sample() for a in env.agents}
        assert data_equivalence(env.step(actions), copy.step(actions), exact=True)


def test_faults_in_a_team_body_are_located_there(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text(
        "n_agents: 2\nteams:\n  - {name: a}\n  - name: b\n    agent:\n      radius: -3\n"
    )
    with pytest.raises(ScenarioError) as err:
        flatland_ma.load_scenario(str(path))
    assert "teams[1].agent.radius" in str(err.value) and ":6" in str(err.value)
    path.write_text(
        "n_agents: 2\narena: {size: [100, 100]}\n"
        "teams: [{name: a}, {name: b, agent: {radius: 60}}]\n"
    )
    with pytest.raises(ScenarioError, match=r"teams\[1\]\.agent\.radius"):
        flatland_ma.load_scenario(str(path))


def test_the_work_budget_counts_each_teams_parts():
    from flatland_ma.scenario.budget import _shapes

    arm = {"segments": [{}, {}, {}, {}]}  # 4 segments and a grasper
    teams = [{"name": "a", "size": 3}, {"name": "b", "size": 2, "agent": {"arms": [arm] * 2}}]
    spec = flatland_ma.load_scenario("fruits_poisons", n_agents=5, teams=teams)
    parts = _shapes(spec).parts
    assert parts[("n_agents",)] == 3 * 1 and parts[("teams", 1, "agent")] == 2 * (1 + 2 * 5)


def test_the_batched_env_refuses_agents_of_different_spaces_and_names_them():
    with pytest.raises(ValueError, match=r"runner_0 observes Box.*\(32, 4\).*scout_0.*\(64, 4\)"):
        BatchedParallelEnv("plate_relay", num_worlds=2)
    # Bodies that differ but observe and act alike batch as one.
    alike = {"teams": [{"name": "a", "size": 2}, {"name": "b", "size": 2, "agent": {"radius": 8}}]}
    batch = BatchedParallelEnv("fruits_poisons_multi", num_worlds=2, **alike)
    observations, _ = batch.reset(seed=0)
    assert observations.shape == (8, 64, 4)


def test_padding_puts_each_role_in_the_corner_of_one_space_with_its_role_named():
    env = flatland_ma.parallel_env("signal_rooms")
    padding = Padding.of(env)
    assert padding is not None and padding.roles == 2 and padding.role_of == [0, 1]
    space = padding.space.spaces
    assert set(space) == {"camera", "messages", "topdown", ROLE}
    assert space["topdown"].shape == (64, 64, 3) and space["camera"].shape == (64, 4)
    observations, _ = env.reset(seed=4)
    guide, seeker = (
        padding.pad(0, observations["guide_0"]),
        padding.pad(1, observations["seeker_0"]),
    )
    assert padding.space.contains(guide) and padding.space.contains(seeker)
    np.testing.assert_array_equal(guide["topdown"], observations["guide_0"]["topdown"])
    assert not guide["camera"].any() and not seeker["topdown"].any()
    np.testing.assert_array_equal(guide[ROLE], [1, 0])
    np.testing.assert_array_equal(seeker[ROLE], [0, 1])
    # Boxes of one rank pad along each axis: the runner's 32 rays, then zeros.
    relay = flatland_ma.parallel_env("plate_relay")
    padding = Padding.of(relay)
    assert padding is not None and padding.space["observation"].shape == (64, 4)
    observations, _ = relay.reset(seed=0)
    runner = padding.pad(1, observations["runner_0"])["observation"]
    np.testing.assert_array_equal(runner[:32], observations["runner_0"])
    assert not runner[32:].any()
    assert Padding.of(flatland_ma.parallel_env("fruits_poisons_multi")) is None
    ranked = Padding([gymnasium.spaces.Box(0, 1, (4,)), gymnasium.spaces.Box(0, 1, (2, 2))])
    assert set(ranked.space.spaces) == {"observation_1d", "observation_2d", ROLE}
    Dict = gymnasium.spaces.Dict  # one entry of two ranks cannot be padded
    with pytest.raises(ValueError, match="ranks"):
        Padding(
            [Dict(x=gymnasium.spaces.Box(0, 1, (4,))), Dict(x=gymnasium.spaces.Box(0, 1, (2, 2)))]
        )


@pytest.mark.parametrize("scenario", ["plate_relay", "signal_rooms"])
def test_a_padded_batch_gives_what_separate_envs_give_padded(scenario):
    n, steps, seed = 2, 40, 5
    batch = BatchedParallelEnv(scenario, num_worlds=n, max_cycles=15, pad=True)
    envs = [flatland_ma.parallel_env(scenario, max_cycles=15) for _ in range(n)]
    padding = batch.padding
    assert padding is not None and batch.single_observation_space == padding.space
    agents = envs[0].possible_agents
    inert = {k: np.zeros(b.shape, b.dtype) for k, b in padding.space.spaces.items()}

    def padded(rows):
        return {k: np.stack([row[k] for row in rows]) for k in padding.space.spaces}

    got, _ = batch.reset(seed=seed)
    firsts = [env.reset(seed=seed + w)[0] for w, env in enumerate(envs)]
    want = padded([padding.pad(j, firsts[w][a]) for w in range(n) for j, a in enumerate(agents)])
    assert data_equivalence(got, want, exact=True)
    batch.action_space.seed(3)
    ended, resets = [False] * n, 0
    for _ in range(steps):
        actions = batch.action_space.sample()
        got, rewards, *_ = batch.step(actions)
        rows, expected_rewards = [], []
        for w, env in enumerate(envs):
            if ended[w]:
                observations, _ = env.reset()
                rows += [padding.pad(j, observations[a]) for j, a in enumerate(agents)]
                expected_rewards += [0.0] * len(agents)
                ended[w], resets = False, resets + 1
                continue
            live = list(env.agents)
            step = env.step({a: actions[w * len(agents) + agents.index(a)] for a in live})
            for j, a in enumerate(agents):
                rows.append(padding.pad(j, step[0][a]) if a in live else inert)
                expected_rewards.append(step[1][a] if a in live else 0.0)
            ended[w] = not env.agents
        assert data_equivalence(got, padded(rows), exact=True)
        np.testing.assert_array_equal(rewards, expected_rewards)
        assert batch.observation_space.contains(got)
    assert resets >= n  # every world went through a reset
    sharded = ShardedParallelEnv(scenario, n, shards=2, max_cycles=15, pad=True)
    try:
        assert data_equivalence(sharded.reset(seed=seed)[0], batch.reset(seed=seed)[0], exact=True)
    finally:
        sharded.close()


def test_padding_keeps_observations_of_different_ranks_in_entries_of_their_own():
    """signal_rooms without its channel: the signaller sees a map, the follower a camera,
    each one Box, which no one entry can hold."""
    env = flatland_ma.parallel_env("signal_rooms", channel=None)
    spaces_ = [env.observation_space(a) for a in env.possible_agents]
    assert [len(s.shape) for s in spaces_] == [3, 2]
    padding = Padding(spaces_)
    assert set(padding.space.spaces) == {"observation_3d", "observation_2d", ROLE}
    observations, _ = env.reset(seed=0)
    for i, agent in enumerate(env.possible_agents):
        padded = padding.pad(i, observations[agent])
        own, other = ("observation_3d", "observation_2d")[:: 1 if i == 0 else -1]
        np.testing.assert_array_equal(padded[own], observations[agent])
        assert not padded[other].any() and padded[ROLE][i] == 1.0
        assert padding.space.contains(padded)


def test_padding_pads_observations_but_not_actions():
    mixed = {
        "teams": [
            {"name": "a", "size": 1},
            {"name": "b", "size": 1, "agent": {"actions": "continuous"}},
        ]
    }
    with pytest.raises(ValueError, match="actions must agree"):
        BatchedParallelEnv("fruits_poisons_multi", num_worlds=1, pad=True, n_agents=2, **mixed)


def test_supersuit_pads_them_to_one_space_for_parameter_sharing():
    env = supersuit.pad_action_space_v0(
        supersuit.pad_observations_v0(flatland_ma.parallel_env("plate_relay"))
    )
    spaces = {str(env.observation_space(a)) for a in env.possible_agents}
    assert len(spaces) == 1 and env.observation_space("runner_0").shape == (64, 4)
    parallel_api_test(env, num_cycles=50)
    observations, _ = env.reset(seed=0)
    assert not observations["runner_0"][32:].any()  # the runner's 32 rays, then zeros


def test_scripted_policies_drive_the_agent_they_are_given():
    spec = flatland_ma.load_scenario("plate_relay")
    assert len(GreedyForager(spec, 0).angles) == 64 and len(GreedyForager(spec, 1).angles) == 32
    assert GreedyForager(spec, 1).radius == 12
    assert GreedyForager(spec, 1).step_length == pytest.approx(250 * spec.physics.dt)
    assert math.isclose(GreedyForager(spec, 0).range, 300)
