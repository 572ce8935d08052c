"""Checkpoints of trained networks played as policies: the network rebuilt from a
checkpoint computes what the trained one did (PPO on a Box, a Dict, a MultiDiscrete action,
padded roles, a centralised critic, the paper's trunk; A3C), sampling follows its
probabilities, the trainer's state comes back for resuming, other spaces are refused,
it plays without the training code, and an old checkpoint converts."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("safetensors")

import flatland_ma  # noqa: E402
from baselines.networks import Agent  # noqa: E402
from flatland_ma.cli import main  # noqa: E402
from flatland_ma.envs.padding import Padding  # noqa: E402
from flatland_ma.policies.checkpoint import (  # noqa: E402
    CheckpointPolicy,
    read_checkpoint,
    read_trainer_state,
    write_checkpoint,
)
from flatland_ma.policies.named import make_policy  # noqa: E402
from flatland_ma.policies.networks import ActorCritic  # noqa: E402
from tests.checkpoint_helpers import exported, write_old_checkpoint  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


def _batch(env, agents=None):
    """Every agent's observation after a reset, stacked (a dict of stacks for a Dict)."""
    observations, _ = env.reset(seed=0)
    agents = agents or env.possible_agents
    first = observations[agents[0]]
    if isinstance(first, dict):
        return {k: np.stack([observations[a][k] for a in agents]) for k in first}
    return np.stack([observations[a] for a in agents])


def _tensor(batch):
    if isinstance(batch, dict):
        return {k: torch.as_tensor(v) for k, v in batch.items()}
    return torch.as_tensor(batch)


def _trained(network, batch) -> torch.optim.Optimizer:
    """A few Adam steps, so that the weights and the optimiser's state are not fresh."""
    optimizer = torch.optim.Adam(network.parameters(), lr=1e-2)
    for _ in range(3):
        logits = network.logits(_tensor(batch))
        optimizer.zero_grad()
        (logits.square().mean() + sum(p.sum() * 1e-3 for p in network.parameters())).backward()
        optimizer.step()
    return optimizer


def _save(tmp_path, network, env, agent=None, space=None, **kwargs) -> Path:
    agent = agent or env.possible_agents[0]  # agents of teams are named by team
    return write_checkpoint(
        tmp_path / "policy.safetensors",
        network,
        scenario="fruits_poisons",
        observation_space=space or env.observation_space(agent),
        action_space=env.action_space(agent),
        **kwargs,
    )


def _ppo_cases():
    fruits = flatland_ma.parallel_env("fruits_poisons")
    maps = flatland_ma.parallel_env("signal_maps")
    relay = flatland_ma.parallel_env("plate_relay")
    carry = flatland_ma.parallel_env("coop_carry")
    return {
        "box": (fruits, None, {}),
        "paper_trunk_with_depth": (fruits, None, {"network": "paper", "channels": 4}),
        "dict_multidiscrete": (maps, None, {}),
        "padded_roles": (relay, Padding.of(relay), {}),
        "a_network_for_each_role": (relay, Padding.of(relay), {"roles": 2}),
        "centralised_critic": (carry, None, {"state_size": 40}),
    }


@pytest.mark.parametrize("case", list(_ppo_cases()))
def test_a_rebuilt_ppo_network_gives_the_trained_networks_logits(tmp_path, case):
    env, padding, kwargs = _ppo_cases()[case]
    first = env.possible_agents[0]  # agents of teams are named by team (scout_0, guide_0)
    space = padding.space if padding else env.observation_space(first)
    torch.manual_seed(0)
    agent = Agent(space, env.action_space(first), hidden=32, **kwargs)
    if padding:
        observations, _ = env.reset(seed=0)
        padded = [padding.pad(i, observations[a]) for i, a in enumerate(env.possible_agents)]
        batch = {k: np.stack([p[k] for p in padded]) for k in padded[0]}
    else:
        batch = _batch(env)
    optimizer = _trained(agent, batch)
    path = _save(tmp_path, agent, env, space=space, optimizer=optimizer.state_dict())
    policy = CheckpointPolicy(path)
    with torch.no_grad():
        want = agent(_tensor(batch)).double().numpy()
    np.testing.assert_array_equal(policy.logits(batch), want)
    assert read_checkpoint(path)["network"] == {"kind": "ppo", "arguments": agent.arguments()}
    # The trainer's state comes back: the model's tensors and the optimiser's.
    state = read_trainer_state(path)
    for name, tensor in agent.state_dict().items():
        assert torch.equal(state["model"][name], tensor)
    again = torch.optim.Adam(agent.parameters(), lr=1e-2)
    again.load_state_dict(state["optimizer"])
    saved, loaded = optimizer.state_dict(), again.state_dict()
    assert loaded["param_groups"] == saved["param_groups"]
    for key, entry in saved["state"].items():
        for name, tensor in entry.items():
            assert torch.equal(loaded["state"][key][name], tensor)


def test_a_rebuilt_a3c_network_gives_the_trained_networks_logits(tmp_path):
    env = flatland_ma.parallel_env("fruits_poisons")
    torch.manual_seed(0)
    model = ActorCritic(3, 64, 3, 32)
    batch = _batch(env)
    _trained(model, batch)
    path = _save(tmp_path, model, env, extra={"algorithm": "a2c"})
    x = torch.as_tensor(batch[..., :3]).transpose(-1, -2)
    with torch.no_grad():
        want = model(x)[0].double().numpy()
    np.testing.assert_array_equal(CheckpointPolicy(path).logits(batch), want)
    assert read_checkpoint(path)["algorithm"] == "a2c"
    assert read_trainer_state(path)["optimizer"] is None


def test_greedy_play_takes_the_most_likely_action(tmp_path):
    env = flatland_ma.parallel_env("fruits_poisons_multi")
    torch.manual_seed(1)
    agent = Agent(env.observation_space("agent_0"), env.action_space("agent_0"), hidden=16)
    with torch.no_grad():
        agent.actor.weight.mul_(300.0)  # logits far apart: the argmax differs by agent
    path = _save(tmp_path, agent, env, extra={"args": {"seed": 3}})
    batch = _batch(env)
    with torch.no_grad():
        want = agent(torch.as_tensor(batch)).argmax(dim=1).numpy()
    policy = CheckpointPolicy(path, greedy=True)
    assert list(policy.act_batch(batch)) == list(want)
    assert [policy.act(row) for row in batch] == list(want)
    assert read_checkpoint(path)["args"] == {"seed": 3}


def _fixed(env, logits) -> Agent:
    """A network whose logits are ``logits`` whatever it sees."""
    agent = Agent(env.observation_space("agent_0"), env.action_space("agent_0"), hidden=8)
    with torch.no_grad():
        agent.actor.weight.zero_()
        agent.actor.bias.copy_(torch.tensor(logits))
    return agent


def test_sampling_follows_the_networks_probabilities_and_its_seed(tmp_path):
    env = flatland_ma.parallel_env("fruits_poisons")
    path = _save(tmp_path, _fixed(env, [0.0, np.log(3.0), np.log(6.0)]), env)
    policy = CheckpointPolicy(path, seed=7)
    observations = np.repeat(_batch(env), 20_000, axis=0)
    draws = policy.act_batch(observations)
    frequencies = np.bincount(draws, minlength=3) / len(draws)
    assert np.allclose(frequencies, [0.1, 0.3, 0.6], atol=0.015)
    again = CheckpointPolicy(path, seed=7).act_batch(observations[:500])
    assert np.array_equal(again, draws[:500])
    assert CheckpointPolicy(path, greedy=True).act(observations[0]) == 2


def test_a_multidiscrete_network_acts_in_its_space_beside_a_shipped_guide(tmp_path):
    env = flatland_ma.parallel_env("signal_maps")
    agent = Agent(env.observation_space("seeker_0"), env.action_space("seeker_0"), hidden=16)
    path = _save(tmp_path, agent, env, agent="seeker_0")
    assert read_checkpoint(path)["action_sizes"] == [3, 2]
    policy = make_policy(str(path), env, "seeker_0", seed=5)
    observations, _ = env.reset(seed=0)
    action = policy.act(observations["seeker_0"])
    assert env.action_space("seeker_0").contains(action)
    from flatland_ma.policies.rollout import play_episode

    guide = make_policy("signaller", env, "guide_0")
    returns, _ = play_episode(env, {"guide_0": guide, "seeker_0": policy}, seed=1)
    assert set(returns) == {"guide_0", "seeker_0"}


def test_a_checkpoint_refuses_agents_with_other_spaces(tmp_path):
    env = flatland_ma.parallel_env("fruits_poisons")
    path = _save(tmp_path, _fixed(env, [0.0, 0.0, 1.0]), env)
    lidar = flatland_ma.parallel_env("fruits_poisons", agent={"sensors": [{"type": "lidar"}]})
    with pytest.raises(ValueError, match="observation space"):
        make_policy(str(path), lidar, "agent_0")
    fine = flatland_ma.parallel_env("fruits_poisons_multi")
    assert isinstance(make_policy(str(path), fine, "agent_3"), CheckpointPolicy)


def test_record_plays_a_checkpoint_and_names_a_missing_one(tmp_path, capsys):
    env = flatland_ma.parallel_env("fruits_poisons")
    path = _save(tmp_path, _fixed(env, [0.0, 0.0, 5.0]), env)  # nearly always rotate right
    out = tmp_path / "spin.png"
    argv = ["record", "fruits_poisons", "--policy", str(path), "--steps", "10"]
    assert main([*argv, "--out", str(out)]) == 0
    assert out.exists()
    gone = str(tmp_path / "gone.safetensors")
    argv = ["record", "fruits_poisons", "--policy", gone, "--out", str(tmp_path / "x.png")]
    assert main(argv) == 2
    assert "gone.safetensors" in capsys.readouterr().err


PLAY_WITHOUT_BASELINES = """
import sys
sys.modules["baselines"] = None  # any import of the training code now fails
import numpy as np
import flatland_ma
from flatland_ma.policies.named import make_policy
env = flatland_ma.parallel_env("fruits_poisons_multi")
observations, _ = env.reset(seed=0)
policy = make_policy(sys.argv[1], env, "agent_2", seed=0)
print(policy.act(observations["agent_2"]))
print(sorted(m for m in sys.modules if m.split(".")[0] == "baselines" and sys.modules[m]))
"""


def test_a_checkpoint_plays_without_the_training_code(tmp_path):
    env = flatland_ma.parallel_env("fruits_poisons_multi")
    path = _save(tmp_path, _fixed(env, [0.0, 0.0, 50.0]), env)
    command = [sys.executable, "-c", PLAY_WITHOUT_BASELINES, str(path)]
    done = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split("\n")[:2] == ["2", "[]"]


class Logits(torch.nn.Module):
    """The network's logits from raw observations: what version 1 exported."""

    def __init__(self, network):
        super().__init__()
        self.network = network

    def forward(self, observation):
        return self.network.logits(observation)


def _old(tmp_path, network, env, batch, **entries) -> Path:
    """``network`` saved as version 1 saved it (program, model, spaces as text)."""
    return write_old_checkpoint(
        tmp_path / "old.pt",
        exported(Logits(network), batch),
        scenario=entries.pop("scenario", "fruits_poisons"),
        observation_space=str(entries.pop("space", env.observation_space("agent_0"))),
        action_space=str(env.action_space("agent_0")),
        action_sizes=[3],
        model=network.state_dict(),
        **entries,
    )


def test_an_old_checkpoint_is_refused_and_converts_to_the_same_network(tmp_path, capsys):
    env = flatland_ma.parallel_env("fruits_poisons")
    batch = _batch(env)
    torch.manual_seed(2)
    agent = Agent(env.observation_space("agent_0"), env.action_space("agent_0"), hidden=16)
    optimizer = _trained(agent, batch)
    args = {"hidden": 16, "use_depth": False, "network": "strided", "critic": "local"}
    old = _old(
        tmp_path,
        agent,
        env,
        batch,
        algorithm="ppo",
        args=args,
        trained_with=["self"],
        optimizer=optimizer.state_dict(),
    )
    with pytest.raises(ValueError, match="old torch format.*checkpoint convert"):
        CheckpointPolicy(old)
    new = tmp_path / "new.safetensors"
    assert main(["checkpoint", "convert", str(old), str(new)]) == 0
    with torch.no_grad():
        want = agent(torch.as_tensor(batch)).double().numpy()
    np.testing.assert_array_equal(CheckpointPolicy(new).logits(batch), want)
    saved = read_checkpoint(new)
    assert saved["trained_with"] == ["self"] and saved["args"] == args
    assert read_trainer_state(new)["optimizer"]["param_groups"][0]["lr"] == 1e-2
    # An A2C one converts too; a second conversion onto the same file needs --force.
    model = ActorCritic(3, 64, 3, 16)
    a2c = _old(tmp_path, model, env, batch, algorithm="a2c", args={"hidden": 16})
    assert main(["checkpoint", "convert", str(a2c), str(new)]) == 2
    assert "exists" in capsys.readouterr().err
    assert main(["checkpoint", "convert", str(a2c), str(new), "--force"]) == 0
    x = torch.as_tensor(batch[..., :3]).transpose(-1, -2)
    with torch.no_grad():
        want = model(x)[0].double().numpy()
    np.testing.assert_array_equal(CheckpointPolicy(new).logits(batch), want)
    assert main(["checkpoint", "show", str(new)]) == 0
    assert '"kind": "a3c"' in capsys.readouterr().out


def test_conversion_refuses_what_it_cannot_rebuild(tmp_path, capsys):
    env = flatland_ma.parallel_env("fruits_poisons")
    batch = _batch(env)
    agent = Agent(env.observation_space("agent_0"), env.action_space("agent_0"), hidden=16)
    new = str(tmp_path / "new.safetensors")
    wrong_size = _old(tmp_path, agent, env, batch, algorithm="ppo", args={"hidden": 32})
    assert main(["checkpoint", "convert", str(wrong_size), new]) == 2
    assert "old.pt: model: its weights do not fit the ppo network" in capsys.readouterr().err
    other = _old(tmp_path, agent, env, batch, algorithm="dqn", args={"hidden": 16})
    assert main(["checkpoint", "convert", str(other), new]) == 2
    assert "algorithm 'dqn'" in capsys.readouterr().err
    elsewhere = _old(tmp_path, agent, env, batch, algorithm="ppo", scenario="coop_carry")
    assert main(["checkpoint", "convert", str(elsewhere), new]) == 2
    assert "no agent of coop_carry has the spaces" in capsys.readouterr().err
    assert main(["checkpoint", "convert", str(elsewhere), str(tmp_path / "new.pt")]) == 2
    assert "must be a .safetensors file" in capsys.readouterr().err
    assert not Path(new).exists()
