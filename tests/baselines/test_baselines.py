"""The baselines, each trained for a tiny budget in a subprocess, judged by the CSV it writes,
on fruits_poisons and on key_door (no fruits, no poisons); the counters they log; the runner
and the plot on those CSVs and on CSVs from before the counters came from the scenario; and
(slow) DQN learning to beat random play."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.module_runner import run_module as forked

pytest.importorskip("torch")
pytest.importorskip("supersuit")
pytest.importorskip("tyro")

ROOT = Path(__file__).resolve().parents[2]
COUNTERS = {
    "fruits_poisons": ["score", "fruits", "poisons"],
    "key_door": ["score", "key", "goal"],
    "goals": ["score", "fruits", "goals"],
}
"""The counters each scenario's infos hold at reset, in order (key_door's ``keys`` tuple is
not one)."""
REWARDS = {"fruits_poisons": {"fruits": 10, "poisons": -10}, "key_door": {"key": 1, "goal": 10}}
"""The reward of one item of each group: the return is the sum of reward x count."""
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
HANG_GUARD = 1200.0
"""Seconds before a baseline's process is taken for hung and killed: a guard against a
hang, not a time to beat. The runs are bounded by their steps; a smoke run takes seconds
alone and minutes on a loaded 2-core machine."""


def run_module(module: str, *args: str, timeout: float = HANG_GUARD) -> str:
    """``python -m module *args``, in a process of its own forked from a server that has
    imported torch and the package (``tests.module_runner``)."""
    result = forked(module, *args, env=ENV, cwd=ROOT, timeout=timeout)
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-4000:]
    return result.stdout


def read_log(path: Path, scenario: str = "fruits_poisons") -> list[dict]:
    """The rows of a finished run's CSV, checked for the columns and their meaning."""
    columns = ["seed", "episode", "step", "agent", "return", *COUNTERS[scenario], "wall_time"]
    assert path.exists() and not path.with_name(path.name + ".part").exists()
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        assert reader.fieldnames == columns
        rows = list(reader)
    for row in rows:
        counts = {name: int(row[name]) for name in REWARDS[scenario]}
        assert min(counts.values()) >= 0
        # The counters come from the env's infos; the return is what they were worth.
        worth = sum(REWARDS[scenario][name] * n for name, n in counts.items())
        assert float(row["return"]) == worth == float(row["score"]), row
        assert float(row["wall_time"]) >= 0
    steps = [int(r["step"]) for r in rows]
    assert steps == sorted(steps)
    return rows


def summary(path: Path, scenario: str = "fruits_poisons") -> dict:
    data = json.loads(path.with_suffix(".json").read_text())
    assert data["wall_seconds"] > 0 and 0 < data["env_share"] < 1
    assert data["counters"] == COUNTERS[scenario]
    return data


def check_evaluation(data: dict, episodes: int, scenario: str = "fruits_poisons") -> None:
    """The greedy play after training, as stored in the run's JSON."""
    evaluation = data["evaluation"]
    assert evaluation["episodes"] == episodes == len(evaluation["returns"])
    assert evaluation["return"] == pytest.approx(np.mean(evaluation["returns"]))
    counters = evaluation["counters"]
    assert list(counters) == COUNTERS[scenario]
    worth = sum(reward * counters[name] for name, reward in REWARDS[scenario].items())
    assert evaluation["return"] == pytest.approx(worth) == counters["score"]
    assert evaluation["seconds"] > 0 and evaluation["epsilon"] == 0.05


def test_counters_are_the_numeric_entries_of_an_info():
    import flatland_ma
    from baselines.common import info_counters

    fruits_poisons = {"score": 20.0, "fruits": 3, "poisons": 1}
    assert info_counters(fruits_poisons) == ("score", "fruits", "poisons")
    key_door = {"score": 1.0, "key": 1, "goal": 0, "keys": ("key",)}
    assert info_counters(key_door) == ("score", "key", "goal")
    assert info_counters({"score": 0.0, "deliveries": np.int64(2), "note": "x"}) == (
        "score",
        "deliveries",
    )
    for scenario in ("fruits_poisons", "key_door"):  # what the envs' infos hold at reset
        names = COUNTERS[scenario]
        env = flatland_ma.parallel_env(scenario)
        _, infos = env.reset(seed=0)
        assert all(info_counters(info) == tuple(names) for info in infos.values())


def test_dfp_goal_defaults_to_the_papers_on_fruits_poisons_and_the_rewards_signs_elsewhere():
    from baselines.dfp import by_counter, default_goal, default_scale

    fruits_poisons = tuple(COUNTERS["fruits_poisons"])
    assert list(default_goal("fruits_poisons", fruits_poisons).values()) == [1, 1, -1]
    assert default_scale(fruits_poisons) == {"score": 100, "fruits": 10, "poisons": 10}
    key_door = tuple(COUNTERS["key_door"])
    assert default_goal("key_door", key_door) == {"score": 1, "key": 1, "goal": 1}
    # A counter that is no item group's count (deliveries) is worth +1.
    push_box = default_goal("push_box", ("score", "deliveries"))
    assert push_box == {"score": 1, "deliveries": 1}
    # A flag overrides the counters it names and keeps the others' defaults...
    goal = by_counter({"key": 0.0}, default_goal("key_door", key_door), "--goal")
    assert goal == {"score": 1, "key": 0, "goal": 1}
    # ... and names only the scenario's counters.
    with pytest.raises(ValueError, match="poisons"):
        by_counter({"poisons": -1.0}, default_goal("key_door", key_door), "--goal")


def test_evaluation_plays_whole_episodes_on_seeds_training_never_uses():
    from baselines.common import EVAL_SEED, evaluate_policy, make_env

    seen = []

    def forward(observation, info):
        seen.append(observation.copy())
        return 0

    evaluation = evaluate_policy("fruits_poisons", forward, episodes=2, seed=3)
    assert len(seen) == 2 * 500 and evaluation["episodes"] == 2
    counters = evaluation["counters"]
    assert evaluation["return"] == pytest.approx(10 * (counters["fruits"] - counters["poisons"]))
    env = make_env("fruits_poisons")
    np.testing.assert_array_equal(seen[0], env.reset(seed=EVAL_SEED + 3)[0])
    assert not np.array_equal(seen[0], env.reset(seed=3)[0])  # training's first observation
    # The second episode continues the evaluation env's stream rather than starting over.
    assert not np.array_equal(seen[500], seen[0])


def test_evaluation_takes_random_actions_at_its_epsilon():
    from baselines.common import evaluate_policy

    def views(epsilon):
        seen = []

        def turn(observation, info):
            seen.append(observation.copy())
            return 1  # rotate left: on the spot, so nothing is ever eaten

        evaluation = evaluate_policy("fruits_poisons", turn, episodes=1, seed=0, epsilon=epsilon)
        return np.array(seen), evaluation

    still, evaluation = views(0.0)
    assert evaluation["counters"] == {"score": 0, "fruits": 0, "poisons": 0}
    assert evaluation["epsilon"] == 0.0
    # Turning on the spot, a full turn later the agent sees the same view again.
    period = next(k for k in range(1, 500) if np.allclose(still[k], still[0], atol=1e-6))
    assert np.allclose(still[period : 2 * period], still[:period], atol=1e-6)
    moved, _ = views(0.5)
    assert not np.allclose(moved, still)


def test_dqn_trains_and_logs_each_episode(tmp_path):
    out = tmp_path / "seed_3.csv"
    stdout = run_module(
        "baselines.dqn",
        "--seed",
        "3",
        "--total-timesteps",
        "1000",
        "--learning-starts",
        "900",
        "--eval-episodes",
        "2",
        "--csv",
        str(out),
    )
    rows = read_log(out)
    assert [int(r["step"]) for r in rows] == [500, 1000]
    assert {r["seed"] for r in rows} == {"3"} and {r["agent"] for r in rows} == {"agent_0"}
    assert [r["episode"] for r in rows] == ["0", "1"]
    assert summary(out)["steps"] == 1000
    assert "done: 1000 steps" in stdout
    check_evaluation(summary(out), episodes=2)


@pytest.mark.slow  # a variant of the DQN smoke test (~10 s): make test-slow
def test_dqn_with_the_depth_channel(tmp_path):
    out = tmp_path / "seed_0.csv"
    run_module(
        "baselines.dqn",
        "--use-depth",
        "--total-timesteps",
        "500",
        "--learning-starts",
        "450",
        "--csv",
        str(out),
    )
    assert len(read_log(out)) == 1
    assert summary(out)["args"]["use_depth"] is True


@pytest.mark.slow  # three processes or more (~20 s): make test-slow
def test_a3c_processes_share_one_run_log(tmp_path):
    out = tmp_path / "seed_0.csv"
    run_module(
        "baselines.a3c", "--num-workers", "2", "--total-timesteps", "3000", "--csv", str(out)
    )
    rows = read_log(out)
    # However the two processes share the 3000 steps, whole 500-step episodes of theirs add
    # up to at least (3000 - 2 x 499) / 500 of them.
    assert len(rows) >= 5
    assert max(int(r["step"]) for r in rows) <= 3000 + 2 * 20  # the last updates overshoot
    assert summary(out)["algorithm"] == "a3c"


@pytest.mark.slow  # three processes or more (~20 s): make test-slow
def test_a2c_reproduces_exactly_from_a_seed(tmp_path):
    logs = []
    for name in ("first", "second"):
        out = tmp_path / name / "seed_5.csv"
        run_module(
            "baselines.a3c",
            "--mode",
            "a2c",
            "--seed",
            "5",
            "--num-workers",
            "2",
            "--learning-rate",
            "1e-3",
            "--total-timesteps",
            "2000",
            "--csv",
            str(out),
        )
        logs.append(
            [
                (r["episode"], r["step"], r["return"], r["fruits"], r["poisons"])
                for r in read_log(out)
            ]
        )
    assert len(logs[0]) == 4  # 2 environments x 2 episodes
    assert logs[0] == logs[1]
    other = tmp_path / "other" / "seed_6.csv"
    run_module(
        "baselines.a3c",
        "--mode",
        "a2c",
        "--seed",
        "6",
        "--num-workers",
        "2",
        "--learning-rate",
        "1e-3",
        "--total-timesteps",
        "2000",
        "--csv",
        str(other),
    )
    assert [(r["fruits"], r["poisons"]) for r in read_log(other)] != [x[3:] for x in logs[0]]


def test_a2c_saves_checkpoints_that_compute_what_the_trained_network_computes(tmp_path):
    import torch

    from flatland_ma.policies.checkpoint import (
        CheckpointPolicy,
        read_checkpoint,
        read_trainer_state,
    )
    from flatland_ma.policies.networks import ActorCritic

    out = tmp_path / "seed_0.csv"
    run_module(
        "baselines.a3c",
        *("--mode", "a2c", "--num-workers", "2", "--total-timesteps", "240"),
        *("--checkpoint-every", "2", "--csv", str(out)),
    )
    run = tmp_path / "seed_0"
    names = sorted(p.name for p in run.glob("*.safetensors"))
    assert names == [f"update_0000{k}.safetensors" for k in (2, 4, 6)]
    assert list(run.glob("events.out.tfevents.*"))
    saved = read_checkpoint(tmp_path / "seed_0.safetensors")
    assert saved["algorithm"] == "a2c" and saved["network"]["kind"] == "a3c"
    model = ActorCritic(3, 64, 3, 128)
    state = read_trainer_state(tmp_path / "seed_0.safetensors")
    model.load_state_dict(state["model"])
    assert state["optimizer"]["state"]  # a2c keeps its Adam state for resuming
    env = __import__("flatland_ma").parallel_env("fruits_poisons")
    observation = env.reset(seed=4)[0]["agent_0"]
    x = torch.from_numpy(observation[:, :3].T.copy())[None]
    want = torch.softmax(model(x)[0], dim=1)[0].detach().numpy()
    policy = CheckpointPolicy(tmp_path / "seed_0.safetensors", seed=1)
    draws = policy.act_batch(np.repeat(observation[None], 4000, axis=0))
    assert np.allclose(np.bincount(draws, minlength=3) / 4000, want, atol=0.03)
    logits = policy.logits(observation[None])
    assert np.array_equal(logits, model(x)[0].detach().double().numpy())


def test_dfp_trains_on_the_measurements(tmp_path):
    out = tmp_path / "seed_1.csv"
    run_module(
        "baselines.dfp",
        "--seed",
        "1",
        "--total-timesteps",
        "1500",
        "--learning-starts",
        "1000",
        "--eval-episodes",
        "1",
        "--csv",
        str(out),
    )
    rows = read_log(out)
    assert [int(r["step"]) for r in rows] == [500, 1000, 1500]
    data = summary(out)
    check_evaluation(data, episodes=1)
    # The paper's goal and measurement scales, by the counters' names.
    assert data["args"]["goal"] == {"score": 1, "fruits": 1, "poisons": -1}
    assert data["args"]["measurement_scale"] == {"score": 100, "fruits": 10, "poisons": 10}


def test_ppo_logs_every_agent_of_every_episode_and_saves_what_plays(tmp_path):
    out = tmp_path / "seed_0.csv"
    scenario = tmp_path / "short.yaml"  # the room of four with 100-step episodes
    scenario.write_text("extends: fruits_poisons_multi\nepisode: {max_steps: 100}\n")
    run_module(
        "baselines.ppo",
        *("--scenario", str(scenario), "--num-envs", "1", "--num-steps", "32"),
        *("--total-timesteps", "1024", "--checkpoint-every", "4", "--csv", str(out)),
    )
    rows = read_log(out)
    assert [(r["episode"], r["agent"]) for r in rows] == [
        (str(e), f"agent_{k}") for e in range(2) for k in range(4)
    ]
    # Agent-steps that acted: the step that resets the world between episodes is not one.
    assert [int(r["step"]) for r in rows] == [400] * 4 + [800] * 4
    assert summary(out)["steps"] == 1024 - 2 * 4  # two resets
    assert sum(int(r["fruits"]) + int(r["poisons"]) for r in rows) > 0
    # Checkpoints every 4 of the 8 updates and at the end, and TensorBoard events.
    run = tmp_path / "seed_0"
    names = sorted(p.name for p in run.glob("*.safetensors"))
    assert names == ["update_00004.safetensors", "update_00008.safetensors"]
    assert list(run.glob("events.out.tfevents.*"))
    from flatland_ma.policies.checkpoint import CheckpointPolicy, read_checkpoint

    saved = read_checkpoint(tmp_path / "seed_0.safetensors")
    assert saved["algorithm"] == "ppo" and saved["update"] == 8 and saved["agent_steps"] == 1016
    policy = CheckpointPolicy(tmp_path / "seed_0.safetensors", seed=0)
    env = __import__("flatland_ma").parallel_env("fruits_poisons_multi")
    policy.check(env.observation_space("agent_0"), env.action_space("agent_0"))
    observations, _ = env.reset(seed=0)
    assert policy.act(observations["agent_0"]) in range(3)


@pytest.mark.parametrize("channel", [True, False])
def test_ppo_hears_and_speaks_where_the_scenario_has_a_channel(tmp_path, channel):
    """signal_maps: a Dict observation (the map and the messages) and MultiDiscrete
    actions (a move and a word); without its channel, one map and Discrete moves."""
    run_module(
        "baselines.ppo",
        *("--scenario", "signal_maps", "--num-envs", "1", "--num-steps", "64"),
        *("--total-timesteps", "256", "--checkpoint-every", "0", "--no-tensorboard"),
        *(() if channel else ("--no-channel",)),
        *("--csv", str(tmp_path / "seed_0.csv")),
    )
    from flatland_ma.policies.checkpoint import read_checkpoint
    from flatland_ma.policies.named import make_policy

    env = __import__("flatland_ma").parallel_env(
        "signal_maps", **({} if channel else {"channel": None})
    )
    saved = read_checkpoint(tmp_path / "seed_0.safetensors")
    assert saved["overrides"] == ({} if channel else {"channel": None})
    assert saved["action_sizes"] == ([3, 2] if channel else [3])
    policy = make_policy(str(tmp_path / "seed_0.safetensors"), env, "seeker_0", seed=0)
    observations, _ = env.reset(seed=0)
    assert env.action_space("seeker_0").contains(policy.act(observations["seeker_0"]))
    if channel:  # the other way round, the checkpoint does not fit
        silent = __import__("flatland_ma").parallel_env("signal_maps", channel=None)
        with pytest.raises(ValueError, match="space"):
            make_policy(str(tmp_path / "seed_0.safetensors"), silent, "seeker_0")


@pytest.mark.parametrize(
    "scenario", [pytest.param("plate_relay", marks=pytest.mark.slow), "signal_rooms"]
)
def test_ppo_shares_one_network_between_roles_that_observe_differently(tmp_path, scenario):
    """The scout's 64 rays and the runner's 32 (plate_relay), the guide's map and the
    seeker's camera (signal_rooms): one padded observation naming the role; the
    checkpoint plays either role, padding its observation as in training."""
    import flatland_ma
    from flatland_ma.envs.padding import Padding
    from flatland_ma.policies.checkpoint import read_checkpoint
    from flatland_ma.policies.named import make_policy

    run_module(
        "baselines.ppo",
        *("--scenario", scenario, "--num-envs", "1", "--num-steps", "32"),
        *("--total-timesteps", "64", "--checkpoint-every", "0", "--no-tensorboard"),
        *("--csv", str(tmp_path / "seed_0.csv")),
    )
    path = str(tmp_path / "seed_0.safetensors")
    env = flatland_ma.parallel_env(scenario)
    padding = Padding.of(env)
    assert padding is not None
    saved = read_checkpoint(path)
    assert saved["padded"] and saved["observation_space"] == str(padding.space)
    observations, _ = env.reset(seed=0)
    for index, agent in enumerate(env.possible_agents):
        policy = make_policy(path, env, agent, seed=0)
        action = policy.act(observations[agent])
        assert env.action_space(agent).contains(action)
        greedy = make_policy(path, env, agent)
        greedy.greedy = True
        padded = {k: v[None] for k, v in padding.pad(index, observations[agent]).items()}
        np.testing.assert_array_equal(greedy.act(observations[agent]), greedy.act_batch(padded)[0])
    with pytest.raises(ValueError, match="space"):
        make_policy(path, flatland_ma.parallel_env("fruits_poisons_multi"), "agent_0")


def test_a_centralised_critic_values_the_world_state_and_which_agent_it_is(tmp_path):
    """MAPPO's critic: each slot's input is its world's state and a one-hot of the agent;
    the value moves with the state, not with the observation; the policy plays alone."""
    import torch

    from baselines.networks import Agent
    from baselines.ppo_learner import slot_states
    from flatland_ma.envs.vector import BatchedParallelEnv
    from flatland_ma.policies.checkpoint import read_checkpoint, read_trainer_state
    from flatland_ma.policies.named import make_policy

    batch = BatchedParallelEnv("coop_carry", num_worlds=3)
    batch.reset(seed=0)
    batch.step(np.zeros(batch.num_slots, np.int64))
    rows, states, m = slot_states(batch), batch.state(), batch.agents_per_world
    assert rows.shape == (batch.num_slots, states.shape[1] + m) and rows.dtype == np.float32
    for slot in range(batch.num_slots):
        np.testing.assert_array_equal(rows[slot, : states.shape[1]], states[slot // m])
        np.testing.assert_array_equal(rows[slot, states.shape[1] :], np.eye(m)[slot % m])
    space = batch.single_observation_space
    agent = Agent(space, batch.single_action_space, state_size=rows.shape[1])
    observations = torch.as_tensor(np.stack([space.sample() for _ in range(4)]))
    state = torch.as_tensor(rows[:4])
    with torch.no_grad():
        value = agent.value(observations, state)
        assert torch.equal(agent.value(torch.zeros_like(observations), state), value)
        assert not torch.equal(agent.value(observations, state + 0.5), value)
        assert torch.equal(agent.act(observations, None, state)[3], value)

    run_module(
        "baselines.ppo",
        *("--scenario", "coop_carry", "--critic", "state", "--num-envs", "2"),
        *("--num-steps", "32", "--total-timesteps", "256", "--checkpoint-every", "0"),
        *("--no-tensorboard", "--csv", str(tmp_path / "seed_0.csv")),
    )
    saved = read_checkpoint(tmp_path / "seed_0.safetensors")
    assert saved["args"]["critic"] == "state"
    assert saved["network"]["arguments"]["state_size"] == rows.shape[1]
    state = read_trainer_state(tmp_path / "seed_0.safetensors")
    assert state["model"]["critic.0.weight"].shape[1] == rows.shape[1]
    env = __import__("flatland_ma").parallel_env("coop_carry")
    policy = make_policy(str(tmp_path / "seed_0.safetensors"), env, "agent_0", seed=0)
    observations, _ = env.reset(seed=0)
    assert env.action_space("agent_0").contains(policy.act(observations["agent_0"]))


def test_ppo_advantages_match_a_hand_computation():
    """Two slots, three steps: slot 0 is truncated at step 1 (its next observation is the
    episode's last, whose value bootstraps), slot 1 terminates at step 0."""
    import torch

    from baselines.ppo_learner import gae

    gamma, lam = 0.9, 0.5
    rewards = torch.tensor([[1.0, 2.0], [0.0, 0.0], [3.0, 1.0]])
    values = torch.tensor([[0.5, 1.0], [0.2, 0.4], [0.7, 0.3]])
    ends = torch.tensor([[0.0, 1.0], [1.0, 0.0], [0.0, 0.0]])
    stops = torch.tensor([[0.0, 1.0], [0.0, 0.0], [0.0, 0.0]])
    next_value = torch.tensor([0.6, 0.8])
    got = gae(rewards, values, ends, stops, next_value, gamma, lam)
    # Slot 0: t=2 bootstraps from next_value; t=1 truncated: from values[2] (the last
    # observation's value), no carry; t=0 carries t=1's advantage.
    a02 = 3.0 + gamma * 0.6 - 0.7
    a01 = 0.0 + gamma * 0.7 - 0.2
    a00 = 1.0 + gamma * 0.2 - 0.5 + gamma * lam * a01
    # Slot 1: t=0 terminated: no bootstrap, no carry.
    a12 = 1.0 + gamma * 0.8 - 0.3
    a11 = 0.0 + gamma * 0.3 - 0.4 + gamma * lam * a12
    a10 = 2.0 - 1.0
    want = torch.tensor([[a00, a10], [a01, a11], [a02, a12]])
    assert torch.allclose(got, want)


def test_ppo_learns_only_from_slots_that_acted(tmp_path):
    """Goals end the episode of the agent taking one while its world plays on: its slot
    is inert until the world resets, and its rows are written when the world's episode
    ends."""
    scenario = tmp_path / "goals.yaml"
    scenario.write_text(
        "extends: fruits_poisons_multi\n"
        "episode: {max_steps: 100}\n"
        "items:\n"
        "  - {name: fruits, color: orange, reward: 10, count: 10}\n"
        "  - {name: goals, color: lime, reward: 5, count: 12, terminal: true}\n"
    )
    out = tmp_path / "seed_1.csv"
    run_module(
        "baselines.ppo",
        *("--scenario", str(scenario), "--seed", "1", "--num-envs", "2"),
        *("--num-steps", "64", "--total-timesteps", "2048", "--csv", str(out)),
    )
    with open(out, newline="") as f:
        rows = list(csv.DictReader(f))
    assert rows and len(rows) % 4 == 0
    for e in range(len(rows) // 4):  # one row per agent per world's episode
        assert [r["agent"] for r in rows[4 * e : 4 * e + 4]] == [f"agent_{k}" for k in range(4)]
        assert {r["episode"] for r in rows[4 * e : 4 * e + 4]} == {str(e)}
    early = [r for r in rows if r["goals"] == "1"]
    assert early, "some agent took a goal and left its world early"
    for r in rows:
        assert float(r["return"]) == 10 * int(r["fruits"]) + 5 * int(r["goals"])
    # Fewer agent-steps acted than slots were stepped: inert slots and resets don't count.
    assert len(rows) // 4 == 4  # two episodes of each of the two worlds
    assert summary(out, "goals")["steps"] < 2048 - 4 * (len(rows) // 4)


KEY_DOOR_BUDGETS = {
    "dqn": ["--total-timesteps", "500", "--learning-starts", "450", "--eval-episodes", "1"],
    "a3c": ["--num-workers", "1", "--total-timesteps", "500"],
    "dfp": ["--total-timesteps", "600", "--learning-starts", "500", "--eval-episodes", "1"],
    "ppo": ["--num-envs", "1", "--num-steps", "128", "--total-timesteps", "512"],
}
"""Just over one 500-step key_door episode each, with short warm-ups."""


@pytest.mark.parametrize(
    "algorithm",
    # DQN logs through the RunLog and info_counters that DFP's default run checks here.
    [
        pytest.param(a, marks=pytest.mark.slow) if a == "dqn" else a
        for a in sorted(KEY_DOOR_BUDGETS)
    ],
)
def test_every_baseline_logs_the_counters_of_a_scenario_without_fruits(tmp_path, algorithm):
    out = tmp_path / "seed_2.csv"
    budget = KEY_DOOR_BUDGETS[algorithm]
    run_module(
        f"baselines.{algorithm}",
        "--scenario",
        "key_door",
        "--seed",
        "2",
        *budget,
        "--csv",
        str(out),
    )
    rows = read_log(out, "key_door")
    total = int(budget[budget.index("--total-timesteps") + 1])
    assert rows and [r["episode"] for r in rows] == [str(k) for k in range(len(rows))]
    assert 0 < int(rows[-1]["step"]) <= total
    assert {r["seed"] for r in rows} == {"2"} and {r["agent"] for r in rows} == {"agent_0"}
    assert all(int(r["key"]) <= 1 and int(r["goal"]) <= 1 for r in rows)  # one of each
    data = summary(out, "key_door")
    assert data["args"]["scenario"] == "key_door"
    if "--eval-episodes" in budget:
        check_evaluation(data, episodes=1, scenario="key_door")
    if algorithm == "dfp":  # +1 on the score and on both items, rewarded +1 and +10
        assert data["args"]["goal"] == {"score": 1, "key": 1, "goal": 1}


def test_plot_reads_logs_from_before_and_after_the_counters_came_from_the_scenario(tmp_path):
    from baselines.benchmark.plot import load_runs, summarise, table

    def write(path, header, rows):
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("\n".join(",".join(map(str, line)) for line in [header, *rows]) + "\n")

    fixed = ["seed", "episode", "step", "agent", "return"]
    old = tmp_path / "fruits_poisons"
    write(
        old / "seed_0.csv",
        [*fixed, "fruits", "poisons", "wall_time"],
        [[0, 0, 500, "agent_0", 10, 2, 1, 1.0], [0, 1, 1000, "agent_0", 30, 4, 1, 2.0]],
    )
    # A later seed in the same directory, written since: the score is a column too.
    write(
        old / "seed_1.csv",
        [*fixed, "score", "fruits", "poisons", "wall_time"],
        [[1, 0, 500, "agent_0", 0, 0, 1, 1, 1.0], [1, 1, 1000, "agent_0", 50, 50, 6, 1, 2.0]],
    )
    runs = load_runs(old)
    assert list(runs[0].counters) == ["fruits", "poisons"]
    assert list(runs[1].counters) == ["score", "fruits", "poisons"]
    row = summarise("dqn", runs, window=1, final=0.5)
    assert row["counters"] == {"fruits": 5.0, "poisons": 1.0}
    key_door = tmp_path / "key_door"
    write(
        key_door / "seed_0.csv",
        [*fixed, "score", "key", "goal", "wall_time"],
        [[0, 0, 500, "agent_0", 1, 1, 1, 0, 1.0], [0, 1, 812, "agent_0", 11, 11, 1, 1, 2.0]],
    )
    key_row = summarise("dfp", load_runs(key_door), window=1, final=0.5)
    assert key_row["counters"] == {"score": 11.0, "key": 1.0, "goal": 1.0}

    lines = table([row], []).splitlines()
    assert "| fruits / poisons per episode (final) |" in lines[0]  # as in docs/results.md
    assert "| 5.0 / 1.0 |" in lines[2]
    lines = table([key_row], []).splitlines()
    assert "| key / goal per episode (final) |" in lines[0] and "| 1.0 / 1.0 |" in lines[2]


@pytest.mark.slow  # three processes or more (~20 s): make test-slow
def test_runner_resumes_and_plot_draws_the_figure(tmp_path):
    args = [
        "dqn",
        "--seeds",
        "2",
        "--workers",
        "2",
        "--steps",
        "500",
        "--out",
        str(tmp_path),
        "--",
        "--learning-starts",
        "450",
        "--eval-episodes",
        "1",
    ]
    run_module("baselines.run", *args)
    directory = tmp_path / "dqn" / "fruits_poisons"
    for seed in (0, 1):
        assert len(read_log(directory / f"seed_{seed}.csv")) == 1
        assert "done: 500 steps" in (directory / f"seed_{seed}.log").read_text()
    stamp = (directory / "seed_0.csv").stat().st_mtime_ns
    out = run_module("baselines.run", *args)
    assert "2 of 2 seeds already complete" in out
    assert (directory / "seed_0.csv").stat().st_mtime_ns == stamp

    png = tmp_path / "figure.png"
    table = run_module(
        "baselines.benchmark.plot", str(directory), "--smooth", "1", "--out", str(png)
    )
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    (row,) = [line for line in table.splitlines() if line.startswith("| dqn |")]
    assert "| 2 x 0.5k (1) |" in row
    greedy = [json.loads((directory / f"seed_{k}.json").read_text())["evaluation"] for k in (0, 1)]
    assert f"| {np.mean([g['return'] for g in greedy]):.1f} ± " in row


@pytest.mark.slow
def test_dqn_beats_random_play(tmp_path):
    """30k steps (60 episodes) of the paper's DQN: its last 10 training episodes score
    clearly more than 10 episodes of uniform random actions."""
    from scipy import stats

    import flatland_ma
    from flatland_ma.policies import RandomPolicy, evaluate

    out = tmp_path / "seed_0.csv"
    run_module("baselines.dqn", "--total-timesteps", "30000", "--csv", str(out), timeout=1800)
    dqn = np.array([float(r["return"]) for r in read_log(out)][-10:])
    env = flatland_ma.parallel_env("fruits_poisons")
    random_play = np.array(
        evaluate(env, lambda a: RandomPolicy(env.action_space(a), seed=0), episodes=10).returns
    )
    test = stats.ttest_ind(dqn, random_play, equal_var=False, alternative="greater")
    assert dqn.mean() > random_play.mean() + 30 and test.pvalue < 0.01, (dqn, random_play)


def test_steps_to_80_percent_count_from_where_the_curve_stays_up():
    from baselines.benchmark.plot import Run, summarise

    def run(seed, returns):
        returns = np.array(returns, float)
        steps = 500 * np.arange(1, len(returns) + 1)
        none = np.zeros_like(returns)
        return Run(seed, steps, returns, {"fruits": none}, {"agent_0": returns}, {})

    # Touches 80% of the final return by chance at episode 2, stays up only from episode 6.
    curve = [0, 90, 10, 20, 40, 85, 95, 100, 100, 100]
    row = summarise("x", [run(0, curve), run(1, curve)], window=1, final=0.3)
    assert row["final"][0] == pytest.approx(100.0)
    assert row["steps_to_80"] == 6 * 500
    # A flat noisy curve is up only at the very end, where its final return is measured...
    flat = [0, 10, 0, 10, 0, 10, 0, 10, 0, 10]
    assert summarise("y", [run(0, flat)], window=1, final=0.2)["steps_to_80"] == 10 * 500
    # ... and a curve that ends below 80% of its final mean never got there.
    falling = [0, 10, 0, 10, 0, 10, 0, 10, 10, 0]
    assert summarise("z", [run(0, falling)], window=1, final=0.2)["steps_to_80"] is None


def test_step_counts_in_the_table_keep_three_significant_figures():
    from baselines.benchmark.plot import thousands

    assert [thousands(n) for n in (500, 49_000, 250_000)] == ["0.5k", "49k", "250k"]
    # A multi-agent run that stops a little short of 1M is not rounded up to it.
    assert thousands(999_424) == "999k"
    assert [thousands(n) for n in (1_000_000, 2_500_000)] == ["1M", "2.5M"]


def test_lifelong_learners_write_what_the_report_reads(tmp_path):
    """Fine-tuning, cloning from replay and the reference learner on a tiny stream of
    three short tasks; the report then reads the folder."""
    task, rollout = 128, 2 * 32  # agent-steps of a task (and between evaluations), a rollout
    stream = tmp_path / "tiny.yaml"
    short = "overrides: {episode: {max_steps: 40}}"
    stream.write_text(
        f"eval: {{every: {task}, episodes: 1}}\ntasks:\n"
        + "".join(
            f"  - {{name: {name}, scenario: fruits_poisons, steps: {task}, {short}}}\n"
            for name in "abc"
        )
    )
    out = tmp_path / "run"
    for method in ("finetune", "replay", "reference"):
        run_module(
            "baselines.lifelong",
            *("--stream", str(stream), "--method", method, "--out", str(out)),
            *("--num-envs", "2", "--num-steps", "32", "--replay-size", "100"),
        )
    data = json.loads((out / "stream.json").read_text())
    assert data["tasks"] == ["a", "b", "c"]
    assert data["segments"] == [[k, k * task, (k + 1) * task] for k in range(3)]
    with open(out / "replay" / "seed_0" / "evaluations.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    steps = sorted({int(r["step"]) for r in rows})
    # A block after the first rollout that passes each multiple of the task's agent-steps
    # (a rollout: at most 2 worlds x 32 steps), and one at the end of the life.
    assert len(steps) == 4 and steps[0] == 0 and len(rows) == 4 * 3
    assert all(task * k <= s < task * k + rollout for k, s in enumerate(steps[1:], start=1))
    with open(out / "reference" / "seed_0" / "evaluations.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["task"] for r in rows] == ["0", "0", "1", "1", "2", "2"]
    assert all(task <= int(r["step"]) < task + rollout for r in rows[1::2])
    result = subprocess.run(
        [sys.executable, "-m", "flatland_ma.cli", "lifelong", "report", str(out), "--no-plot"],
        cwd=ROOT,
        env=ENV,
        capture_output=True,
        text=True,
        timeout=HANG_GUARD,
    )
    assert result.returncode == 0 and "finetune (1)" in result.stdout, result.stderr


def test_the_lifelong_learner_refuses_ppo_options_it_does_not_use():
    result = forked(
        "baselines.lifelong", "--critic", "state", "--shards", "2", env=ENV, timeout=HANG_GUARD
    )
    assert result.returncode == 1
    assert "does not take --shards, --critic (options of baselines.ppo)" in result.stderr
    from baselines.lifelong import Args, untaken

    assert untaken(Args(learning_rate=1e-3, num_envs=4, tensorboard=False)) == ""
    # Each option a life would leave unused is named, not ignored.
    assert untaken(Args(shaping=1.0, team_reward=True, memory="gru", anneal_lr=True)) == (
        "--anneal-lr, --team-reward, --shaping, --memory"
    )
