"""The learner's mechanics (baselines.ppo_learner) and its measurement
(baselines.benchmark.learner_speed): the same maths as the textbook forms, collection
overlapped with the update without changing what a seed gives, and torch's threads as
asked whatever the ray kernel does."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import torch
from gymnasium import spaces
from safetensors.torch import load_file

from baselines import ppo
from baselines.benchmark import learner_speed
from baselines.buffers import Gather
from baselines.networks import Agent
from baselines.ppo_learner import Overlapped, gae
from flatland_ma.envs.vector import BatchedParallelEnv

ROOT = Path(__file__).resolve().parents[2]
TINY = {"num_envs": 2, "num_steps": 16, "total_timesteps": 128}


def reference_gae(rewards, values, ends, stops, next_value, gamma, lam):
    """The recursion as written, one step at a time."""
    advantages = torch.zeros_like(rewards)
    last = torch.zeros_like(next_value)
    for t in reversed(range(len(rewards))):
        following = next_value if t == len(rewards) - 1 else values[t + 1]
        delta = rewards[t] + gamma * following * (1.0 - stops[t]) - values[t]
        advantages[t] = last = delta + gamma * lam * (1.0 - ends[t]) * last
    return advantages


def test_compiled_gae_is_the_recursion():
    g = torch.Generator().manual_seed(0)
    T, slots = 40, 7
    rewards, values = torch.randn(T, slots, generator=g), torch.randn(T, slots, generator=g)
    ends = (torch.rand(T, slots, generator=g) < 0.1).float()
    stops = ends * (torch.rand(T, slots, generator=g) < 0.5).float()  # terminated or cut
    next_value = torch.randn(slots, generator=g)
    got = gae(rewards, values, ends, stops, next_value, 0.99, 0.95)
    want = reference_gae(rewards, values, ends, stops, next_value, 0.99, 0.95)
    torch.testing.assert_close(got, want, rtol=1e-5, atol=1e-5)


def test_gather_gives_the_rows_indexed_in_buffers_it_keeps():
    generator = torch.Generator().manual_seed(0)
    tree = {
        "map": torch.randint(0, 255, (40, 6, 6, 3), generator=generator, dtype=torch.uint8),
        "camera": torch.randn((40, 8, 4), generator=generator),
    }
    gather = Gather()
    first = torch.randperm(40, generator=generator)[:10]
    got = gather(tree, first)
    for key, x in tree.items():
        assert got[key].dtype == x.dtype and torch.equal(got[key], x[first])
    buffers = [got["map"].data_ptr(), got["camera"].data_ptr()]
    shorter = torch.randperm(40, generator=generator)[:7]
    again = gather(tree, shorter)
    for key, x in tree.items():
        assert torch.equal(again[key], x[shorter])
    assert [again["map"].data_ptr(), again["camera"].data_ptr()] == buffers  # no new memory
    longer = torch.arange(39, -1, -1)
    last = gather(tree, longer)
    for key, x in tree.items():
        assert last[key].shape[0] == 40 and torch.equal(last[key], x.flip(0))
    assert torch.equal(gather(tree["camera"], first), tree["camera"][first])  # a bare tensor


@pytest.mark.parametrize("action_space", [spaces.Discrete(3), spaces.MultiDiscrete([3, 4])])
def test_heads_give_the_categorical_log_probability_and_entropy(action_space):
    agent = Agent(spaces.Box(0, 1, (64, 4), np.float32), action_space)
    x = torch.rand(32, 64, 4)
    action, logprob, entropy, _ = agent.act(x)
    with torch.no_grad():  # scaled up so that the heads are far from uniform
        agent.actor.weight.mul_(300.0)
    action, logprob, entropy, _ = agent.act(x)
    logits = agent.actor(agent.features(x)).split(agent.sizes, dim=-1)
    heads = [torch.distributions.Categorical(logits=part) for part in logits]
    want_logprob = sum(head.log_prob(action[:, k]) for k, head in enumerate(heads))
    want_entropy = sum(head.entropy() for head in heads)
    torch.testing.assert_close(logprob, want_logprob)
    torch.testing.assert_close(entropy, want_entropy)
    assert entropy.std() > 0.01  # not all uniform: the test tells heads apart


def test_sampling_follows_the_generator_and_the_probabilities():
    agent = Agent(spaces.Box(0, 1, (64, 4), np.float32), spaces.Discrete(3))
    x = torch.rand(4, 64, 4)
    draws = [agent.act(x, generator=torch.Generator().manual_seed(5))[0] for _ in range(2)]
    assert torch.equal(draws[0], draws[1])
    with torch.no_grad():  # one action all but certain
        agent.actor.weight.zero_()
        agent.actor.bias.copy_(torch.tensor([0.0, 30.0, 0.0]))
    action = agent.act(x.repeat(64, 1, 1))[0]
    assert (action == 1).all()


def test_overlapped_collection_acts_with_the_parameters_from_before_the_update():
    env = BatchedParallelEnv("fruits_poisons", num_worlds=2, copy=False, pad=True)
    observation, _ = env.reset(seed=0)
    agent = Agent(env.single_observation_space, env.single_action_space)
    optimizer = torch.optim.Adam(agent.parameters(), lr=1e-3)
    args = replace(ppo.Args(), num_steps=16)
    overlapped = Overlapped(agent, env, observation, 16, seed=0)
    observation = overlapped.collect(env, observation, 0.1, lambda *a: None)
    before = {k: v.clone() for k, v in agent.state_dict().items()}
    assert overlapped.learn(agent, optimizer, args) == {}  # nothing had finished
    # The next rollout is acted by the parameters the update started from ...
    for key, value in overlapped.behaviour.state_dict().items():
        assert torch.equal(value, before[key])
    observation = overlapped.collect(env, observation, 0.1, lambda *a: None)
    stats = overlapped.learn(agent, optimizer, args)
    assert "losses/policy" in stats
    overlapped.wait()
    # ... and the update moved the learner's own.
    assert any(not torch.equal(v, before[k]) for k, v in agent.state_dict().items())
    env.close()


def _run(tmp_path: Path, name: str, *options: str, first: str = "") -> dict:
    csv = tmp_path / name / "seed_0.csv"
    argv = [f"--{k.replace('_', '-')}={v}" for k, v in TINY.items()]
    code = (
        f"{first}\nimport sys, tyro\nfrom baselines import ppo\n"
        "ppo.main(tyro.cli(ppo.Args, args=sys.argv[1:]))"
    )
    command = [sys.executable, "-c", code, "--scenario=fruits_poisons", *argv]
    command += [f"--csv={csv}", "--no-tensorboard", "--checkpoint-every=0", *options]
    run = subprocess.run(command, cwd=ROOT, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-3000:]
    summary = json.loads(csv.with_suffix(".json").read_text())
    summary["log"] = csv.read_text().splitlines()
    summary["weights"] = load_file(csv.with_suffix(".safetensors"))
    return summary


def test_an_overlapped_run_is_the_same_for_the_same_seed_and_records_its_lag(tmp_path):
    a = _run(tmp_path, "a", "--overlap")
    b = _run(tmp_path, "b", "--overlap")
    assert a["policy_lag"] == 1
    assert [row.split(",")[:5] for row in a["log"]] == [row.split(",")[:5] for row in b["log"]]
    assert a["weights"].keys() == b["weights"].keys()
    for key, value in a["weights"].items():
        assert torch.equal(value, b["weights"][key]), key


def test_torch_runs_on_the_threads_asked_whatever_the_ray_kernel_uses(tmp_path):
    """numba's OpenMP pool and torch share one libgomp: starting the pool used to set
    torch's count to the pool's (the run asked for 1 and ran on 2)."""
    summary = _run(tmp_path, "threads", "--torch-threads=1", first="import torch")
    assert summary["threads"]["torch"] == summary["threads"]["torch_asked"] == 1
    assert summary["torch_threads"] == 1
    assert summary["setup_cpu_seconds"] > 0


def test_learner_speed_measures_every_part_and_the_loop(tmp_path):
    args = learner_speed.Args(
        num_envs=2, num_steps=16, rollouts=1, loop_timesteps=64, json=str(tmp_path / "b.json")
    )
    figures = learner_speed.main(args)
    rates = figures["parts_per_cpu_second"]
    assert set(rates) == {"env", "act", "update", "in_turn"}
    assert all(rate > 0 for rate in rates.values())
    assert figures["allowed_per_cpu_second"] < min(rates[p] for p in ("env", "act", "update"))
    # in turn: the env and the acting pass of one step each, so slower than either alone
    assert figures["allowed_in_turn_per_cpu_second"] < min(rates["in_turn"], rates["update"])
    assert set(figures["loops"]) == {"serial", "overlapped"}
    for loop in figures["loops"].values():
        assert loop["efficiency_in_turn"] == pytest.approx(
            loop["per_cpu_second"] / figures["allowed_in_turn_per_cpu_second"]
        )
    assert figures["loops"]["overlapped"]["policy_lag"] == 1
    assert json.loads((tmp_path / "b.json").read_text())["scenario"] == "fruits_poisons"
    assert "parts allow" in learner_speed.report(figures)
    assert "in turn allow" in learner_speed.report(figures)
