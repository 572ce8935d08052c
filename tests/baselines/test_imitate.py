"""The imitation probe (baselines.benchmark.imitate): the solver plays its first round as
it plays alone, the labels are the solver's actions whoever drives, the network learns
them, and the checkpoint it writes plays every agent of a task of two roles."""

from __future__ import annotations

import json

import numpy as np
import pytest

from baselines.benchmark import imitate
from flatland_ma.envs.parallel import FlatlandParallelEnv
from flatland_ma.policies.checkpoint import CheckpointPolicy, load_checkpoint
from flatland_ma.policies.named import make_policy
from flatland_ma.policies.rollout import play_episode
from flatland_ma.policies.scores_header import solver_names


def test_the_solvers_round_plays_as_the_solver_alone():
    args = imitate.Args(scenario="key_door", worlds=1, steps=900, seed=2)
    worlds = imitate.Worlds(args)
    try:
        got = imitate.collect(worlds, None, args.steps, 777)
    finally:
        worlds.close()
    env = FlatlandParallelEnv("key_door")
    names = solver_names(env)
    want = []
    for k in range(len(got["returns"])):
        policies = {a: make_policy(names[a], env, a, 2000) for a in env.possible_agents}
        totals, _ = play_episode(env, policies, 777 + k)
        want.append(float(np.mean(list(totals.values()))))
    env.close()
    assert len(got["returns"]) >= 2
    assert got["returns"] == want
    assert max(want) > 0  # the solver is paid: these are its episodes
    assert got["agreement"] is None


def test_the_labels_are_the_solvers_actions_while_the_network_drives(monkeypatch):
    args = imitate.Args(scenario="fruits_poisons", worlds=2, steps=64, seed=0)
    worlds = imitate.Worlds(args)
    asked = []
    for policies in worlds.experts:
        for policy in policies.values():
            act = policy.act

            def spy(observation, act=act):
                asked.append(act(observation))
                return asked[-1]

            monkeypatch.setattr(policy, "act", spy)
    network = imitate.Agent(worlds.space, worlds.action_space, 16)
    try:
        got = imitate.collect(worlds, network, args.steps, 0)
    finally:
        worlds.close()
    assert [int(label[0]) for label in got["labels"]] == [
        int(a) for a in asked[: len(got["labels"])]
    ]
    assert got["agreement"] is not None and got["agreement"] < 1.0  # the network drove


def test_the_network_learns_the_solvers_actions_from_what_the_agent_sees():
    args = imitate.Args(scenario="fruits_poisons", worlds=2, steps=1024, epochs=10, seed=0)
    worlds = imitate.Worlds(args)
    try:
        got = imitate.collect(worlds, None, args.steps, 0)
    finally:
        worlds.close()
    imitate.torch.manual_seed(0)
    network = imitate.Agent(worlds.space, worlds.action_space, 64)
    optimizer = imitate.torch.optim.Adam(network.parameters(), lr=1e-3)
    labels = np.stack(got["labels"])
    shares = np.bincount(labels[:, 0]) / len(labels)
    marginal = -float((shares[shares > 0] * np.log(shares[shares > 0])).sum())
    loss = imitate.train(
        network, optimizer, np.stack(got["views"]), labels, args, np.random.default_rng(0)
    )
    # below the labels' own entropy: the camera tells the greedy forager's turns apart
    assert loss < marginal - 0.1


def test_a_two_role_task_is_imitated_and_its_checkpoint_plays_both_roles(tmp_path):
    path = tmp_path / "signal.safetensors"
    args = imitate.Args(
        scenario="signal_rooms",
        worlds=2,
        rounds=1,
        steps=128,
        epochs=1,
        checkpoint=str(path),
        json=str(tmp_path / "i.json"),
    )
    figures = imitate.main(args)
    assert [r["driver"] for r in figures["rounds"]] == ["solver", "network"]
    assert figures["rounds"][-1]["steps_kept"] >= 256
    assert len(figures["held_out_episodes"]) == 10
    assert json.loads((tmp_path / "i.json").read_text())["checkpoint"] == str(path)
    env = FlatlandParallelEnv("signal_rooms")
    observations, _ = env.reset(seed=0)
    for agent in env.possible_agents:
        action = CheckpointPolicy.for_agent(path, env, agent, seed=0).act(observations[agent])
        assert env.action_space(agent).contains(np.asarray(action))
    env.close()


def test_ppo_goes_on_from_the_imitator_in_the_tasks_standard_configuration(tmp_path):
    path = tmp_path / "fp.safetensors"
    args = imitate.Args(
        scenario="fruits_poisons", worlds=2, rounds=0, steps=256, epochs=1,
        checkpoint=str(path), ppo_steps=2048,
    )  # fmt: skip
    figures = imitate.imitate(args)
    then = figures["then_ppo"]
    assert then["agent_steps"] >= 2048
    assert then["options"]["preset"] == "" and then["options"]["ent_coef"] == 0.03  # its preset
    final = tmp_path / "fp_then_ppo.safetensors"
    description, network, _ = load_checkpoint(final)
    assert description["args"]["init_from"] == str(path)
    start = load_checkpoint(path)[2]["model"]
    moved = [k for k, v in network.state_dict().items() if not imitate.torch.equal(v, start[k])]
    assert moved  # PPO updated the imitator's weights
    assert len(then["held_out_episodes"]) == 10


def test_ppo_from_the_imitator_may_be_pulled_towards_it(tmp_path):
    args = imitate.Args(scenario="fruits_poisons", ppo_steps=4096, ppo_anchor=0.1)
    run = imitate.standard_args(args, tmp_path / "log.csv", tmp_path / "imitator.safetensors")
    assert run.anchor == 0.1 and run.init_from == str(tmp_path / "imitator.safetensors")
    assert imitate.standard_args(imitate.Args(scenario="fruits_poisons")).anchor == 0.0


def test_a_scenario_without_a_solver_is_refused(tmp_path):
    scenario = tmp_path / "plain.yaml"
    scenario.write_text("arena: {size: [200, 200]}\n")
    with pytest.raises(ValueError, match="reference"):
        imitate.Worlds(imitate.Args(scenario=str(scenario), worlds=1))


def test_a_teacher_replaces_the_solver():
    from flatland_ma.policies.wall_follower import WallFollower

    args = imitate.Args(scenario="maze_goal", worlds=2, steps=64, teacher="wall_follower")
    worlds = imitate.Worlds(args)
    try:
        assert all(isinstance(p, WallFollower) for w in worlds.experts for p in w.values())
    finally:
        worlds.close()
    with pytest.raises(ValueError, match="no policy 'nobody'"):
        imitate.Worlds(imitate.Args(scenario="maze_goal", worlds=1, teacher="nobody"))
    with pytest.raises(ValueError, match="leave out --teacher"):
        imitate.main(imitate.Args(scenario="maze_goal", teacher="wall_follower", record=True))
