"""Checkpoints of trained networks played as policies: what a saved network decides, how
sampling follows its probabilities, refusals of other spaces and of files that are not
checkpoints, and the command line playing one."""

from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch")

import flatland_ma  # noqa: E402
from flatland_ma.cli import main  # noqa: E402
from flatland_ma.policies.checkpoint import (  # noqa: E402
    CheckpointPolicy,
    read_checkpoint,
    write_checkpoint,
)
from flatland_ma.policies.named import make_policy  # noqa: E402


class Fixed(torch.nn.Module):
    """Logits that do not depend on the observation (but pass through it)."""

    def __init__(self, logits):
        super().__init__()
        self.logits = torch.nn.Parameter(torch.tensor(logits, dtype=torch.float32))

    def forward(self, observation):
        return self.logits + 0.0 * observation.sum(dim=(1, 2))[:, None]


class Brightest(torch.nn.Module):
    """Turns toward the brighter half of the image: left if the left rays are brighter."""

    def forward(self, observation):
        rgb = observation[..., :3].sum(dim=-1)
        half = rgb.shape[1] // 2
        right, left = rgb[:, :half].sum(dim=1), rgb[:, half:].sum(dim=1)
        return torch.stack([torch.zeros_like(left), 10 * (left - right), 10 * (right - left)], 1)


def _save(tmp_path, network, scenario="fruits_poisons", name="policy.pt"):
    env = flatland_ma.parallel_env(scenario)
    observations, _ = env.reset(seed=0)
    example = np.stack([observations[a] for a in env.possible_agents])
    return write_checkpoint(
        tmp_path / name,
        network,
        example,
        scenario=scenario,
        observation_space=env.observation_space("agent_0"),
        action_space=env.action_space("agent_0"),
        extra={"args": {"seed": 3}},
    )


def test_a_saved_network_plays_what_it_computes(tmp_path):
    path = _save(tmp_path, Brightest())
    policy = CheckpointPolicy(path, greedy=True)
    image = np.zeros((64, 4), np.float32)
    image[40:, :3] = 1.0  # the upper half of the rays bright
    assert policy.act(image) == 1
    image = image[::-1].copy()
    assert policy.act(image) == 2
    assert list(policy.act_batch(np.stack([image[::-1], image]))) == [1, 2]
    assert read_checkpoint(path)["args"] == {"seed": 3}


def test_sampling_follows_the_networks_probabilities_and_its_seed(tmp_path):
    logits = [0.0, np.log(3.0), np.log(6.0)]  # probabilities 0.1, 0.3, 0.6
    path = _save(tmp_path, Fixed(logits))
    policy = CheckpointPolicy(path, seed=7)
    draws = policy.act_batch(np.zeros((20_000, 64, 4), np.float32))
    frequencies = np.bincount(draws, minlength=3) / len(draws)
    assert np.allclose(frequencies, [0.1, 0.3, 0.6], atol=0.015)
    again = CheckpointPolicy(path, seed=7).act_batch(np.zeros((500, 64, 4), np.float32))
    assert np.array_equal(again, draws[:500])
    assert CheckpointPolicy(path, greedy=True).act(np.zeros((64, 4), np.float32)) == 2


def test_a_checkpoint_refuses_agents_with_other_spaces(tmp_path):
    path = _save(tmp_path, Fixed([0.0, 0.0, 1.0]))
    lidar = flatland_ma.parallel_env("fruits_poisons", agent={"sensors": [{"type": "lidar"}]})
    with pytest.raises(ValueError, match="observation space"):
        make_policy(str(path), lidar, "agent_0")
    fine = flatland_ma.parallel_env("fruits_poisons_multi")
    assert isinstance(make_policy(str(path), fine, "agent_3"), CheckpointPolicy)


def test_files_that_are_not_checkpoints_are_refused_by_name(tmp_path):
    with pytest.raises(ValueError, match="no such checkpoint"):
        read_checkpoint(tmp_path / "absent.pt")
    text = tmp_path / "notes.pt"
    text.write_text("not a checkpoint")
    with pytest.raises(ValueError, match="notes.pt: not a checkpoint torch can read"):
        read_checkpoint(text)
    other = tmp_path / "weights.pt"
    torch.save({"weights": torch.zeros(3)}, other)
    with pytest.raises(ValueError, match="not a flatland_ma policy checkpoint"):
        read_checkpoint(other)
    newer = tmp_path / "newer.pt"
    torch.save({"format": "flatland_ma.policy", "version": 99}, newer)
    with pytest.raises(ValueError, match="version 99"):
        read_checkpoint(newer)
    with pytest.raises(ValueError, match="no policy 'nope'"):
        make_policy("nope", flatland_ma.parallel_env("fruits_poisons"), "agent_0")


def test_record_plays_a_checkpoint(tmp_path, capsys):
    path = _save(tmp_path, Fixed([0.0, 0.0, 5.0]))  # nearly always rotate right
    out = tmp_path / "spin.png"
    assert (
        main(
            ["record", "fruits_poisons", "--policy", str(path), "--steps", "10", "--out", str(out)]
        )
        == 0
    )
    assert out.exists()
    lidar = ["--agents", "1"]
    assert (
        main(
            [
                "record",
                "fruits_poisons",
                "--policy",
                str(tmp_path / "gone.pt"),
                *lidar,
                "--out",
                str(tmp_path / "x.png"),
            ]
        )
        == 2
    )
    assert "gone.pt: no such checkpoint file" in capsys.readouterr().err


class Spoken(torch.nn.Module):
    """A Dict observation (a map and the messages) to the logits of MultiDiscrete([3, 2]):
    fixed move logits; the word's logits say back the word agent_0 was heard saying."""

    def forward(self, observation):
        heard = observation["messages"][:, 0, 1:]  # agent_0's row: the one-hot word
        moves = (
            torch.tensor([0.0, np.log(3.0), np.log(6.0)])
            + 0.0 * observation["topdown"].sum(dim=(1, 2, 3))[:, None]
        )
        return torch.cat([moves, 20 * heard], dim=1)


def test_a_network_on_a_dict_observation_acts_in_a_multidiscrete_space(tmp_path):
    env = flatland_ma.parallel_env("signal_maps")
    observations, _ = env.reset(seed=0)
    example = {
        key: np.stack([observations[a][key] for a in env.possible_agents])
        for key in observations["guide_0"]
    }
    path = write_checkpoint(
        tmp_path / "spoken.pt",
        Spoken(),
        example,
        scenario="signal_maps",
        observation_space=env.observation_space("seeker_0"),
        action_space=env.action_space("seeker_0"),
    )
    assert read_checkpoint(path)["action_sizes"] == [3, 2]
    policy = make_policy(str(path), env, "seeker_0", seed=5)
    assert isinstance(policy, CheckpointPolicy)
    said = {key: value.copy() for key, value in observations["seeker_0"].items()}
    said["messages"][0, :] = [1.0, 0.0, 1.0]  # guide_0 said word 1
    action = policy.act(said)
    assert env.action_space("seeker_0").contains(action) and action[1] == 1
    batch = {key: np.repeat(value[None], 20_000, axis=0) for key, value in said.items()}
    actions = policy.act_batch(batch)
    assert actions.shape == (20_000, 2) and (actions[:, 1] == 1).all()
    frequencies = np.bincount(actions[:, 0], minlength=3) / len(actions)
    assert np.allclose(frequencies, [0.1, 0.3, 0.6], atol=0.015)
    assert list(CheckpointPolicy(path, greedy=True).act(said)) == [2, 1]
    # It plays whole episodes beside a shipped guide.
    from flatland_ma.policies.rollout import play_episode

    guide = make_policy("signaller", env, "guide_0")
    returns, _ = play_episode(env, {"guide_0": guide, "seeker_0": policy}, seed=1)
    assert set(returns) == {"guide_0", "seeker_0"}
