"""The channel's biases (baselines.channel_bias): what the listening term compares, that it
is nothing for a network deaf to the channel, the signalling term's bounds, and the runs
that refuse them."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from baselines.channel_bias import ChannelBias
from baselines.ppo import Args, Training


def _training(tmp_path, **options) -> Training:
    args = Args(
        scenario=options.pop("scenario", "signal_rooms"),
        num_envs=2,
        num_steps=8,
        total_timesteps=64,
        csv=str(tmp_path / "seed_0.csv"),
        tensorboard=False,
        checkpoint_every=0,
        **options,
    )
    return Training(args)


def _minibatch(run: Training):
    """Every entry of one collected rollout, as the update reads them."""
    rollout = run.rollout
    run.observation = rollout.collect(
        run.agent, run.env, run.observation, 0.1, run.episodes.after_step, run.learn_from
    )
    x = {k: v.reshape(-1, *v.shape[2:]) for k, v in rollout.observations.items()}
    index = torch.arange(rollout.steps * run.env.num_slots)
    return x, rollout.actions.reshape(-1, rollout.actions.shape[-1]), index


def test_the_other_speakers_words_change_and_the_rows_own_and_the_heard_flags_stay():
    bias = ChannelBias(1.0, 0.0, 4, agents_per_world=2, tokens=1, vocabulary=3, sizes=(3, 3))
    said = torch.tensor([[1.0, 1, 0, 0], [1.0, 0, 0, 1]])  # speaker 0 said word 0, 1 word 2
    messages = said.expand(5, 2, 4).clone()
    index = torch.tensor([0, 1, 2, 3, 5])  # slots 0, 1, 2, 3, 1: agents 0, 1, 0, 1, 1
    assert bias.speakers(index).tolist() == [0, 1, 0, 1, 1]
    changed = bias.changed(messages, bias.speakers(index))
    for row, agent in enumerate([0, 1, 0, 1, 1]):
        other = 1 - agent
        assert torch.equal(changed[row, agent], messages[row, agent])  # its own words
        assert changed[row, other, 0] == 1.0  # still heard
        word = int(messages[row, other, 1:].argmax())
        assert int(changed[row, other, 1:].argmax()) == (word + 1) % 3
        assert changed[row, other, 1:].sum() == 1.0


def test_the_biased_update_acts_as_the_plain_one_and_adds_the_listening_term(tmp_path):
    run = _training(tmp_path, listening=0.5, signalling=0.25)
    bias, agent = run.rollout.bias, run.agent
    assert bias is not None and bias.tokens == 1 and bias.vocabulary == 2
    x, actions, index = _minibatch(run)
    with torch.no_grad():
        plain = agent.act(x, actions)
        decided, loss, terms = bias.act(agent, x, actions, None, index)
    for a, b in zip(plain[1:], decided[1:], strict=True):
        torch.testing.assert_close(a, b)
    assert set(terms) == {"losses/listening", "losses/signalling"}
    assert 0.0 < float(terms["losses/listening"]) <= 1.0  # one move head
    assert 0.0 <= float(terms["losses/signalling"]) <= math.log(2)
    expected = -0.5 * terms["losses/listening"] - 0.25 * terms["losses/signalling"]
    torch.testing.assert_close(loss, expected)


def test_a_network_that_does_not_read_the_messages_does_not_listen(tmp_path):
    run = _training(tmp_path, listening=1.0)
    bias, agent = run.rollout.bias, run.agent
    widths = [module.features for module in agent.inputs.values()]
    start = sum(widths[: list(agent.inputs).index("messages")])
    columns = slice(start, start + agent.inputs["messages"].features)
    x, actions, index = _minibatch(run)
    _, loss, terms = bias.act(agent, x, actions, None, index)
    loss.backward()
    weight = agent.body[0].weight
    assert float(terms["losses/listening"]) > 0.0
    assert weight.grad[:, columns].abs().sum() > 0  # the term pulls on what it hears
    with torch.no_grad():
        weight[:, columns] = 0.0
        _, _, deaf = bias.act(agent, x, actions, None, index)
    assert float(deaf["losses/listening"]) == 0.0


def test_the_signalling_term_asks_each_agents_words_to_vary_not_the_roles_to_differ():
    bias = ChannelBias(0.0, 1.0, 2, agents_per_world=2, tokens=1, vocabulary=2, sizes=(3, 2))

    class Heads(torch.nn.Module):  # the network's parts the term reads, made to order
        def __init__(self, words):
            super().__init__()
            self.inputs = torch.nn.ModuleDict({"messages": torch.nn.Flatten()})
            self.words = words

        def encodings(self, observation):
            return {"messages": self.inputs["messages"](observation["messages"])}

        def join(self, encodings):
            return encodings["messages"]

        def actor(self, h):
            return torch.cat([torch.zeros(len(h), 3), self.words], dim=1)

        def decide(self, h, action, state):
            return None

    messages = torch.zeros(4, 2, 3)
    index = torch.arange(4)  # slots 0, 1, 0, 1: agents 0, 1, 0, 1
    same = Heads(torch.tensor([[0.3, -0.2]]).expand(4, 2))
    # Each agent always its own word: the words differ between the roles only.
    roles = Heads(torch.tensor([[20.0, -20.0], [-20.0, 20.0]]).repeat(2, 1))
    # Each agent says both words, one sure in each of its situations.
    varied = Heads(torch.tensor([[20.0, -20.0], [20.0, -20.0], [-20.0, 20.0], [-20.0, 20.0]]))
    for heads, expected in [(same, 0.0), (roles, 0.0), (varied, math.log(2))]:
        _, _, terms = bias.act(heads, {"messages": messages}, None, None, index)
        assert float(terms["losses/signalling"]) == pytest.approx(expected, abs=1e-5)


@pytest.mark.parametrize(
    "options, says",
    [
        ({"scenario": "fruits_poisons"}, "has none"),
        ({"no_channel": True}, "--no-channel"),
        ({"memory": "gru"}, "feed-forward"),
    ],
)
def test_the_biases_are_refused_without_a_channel_to_hear_or_with_memory(tmp_path, options, says):
    with pytest.raises(ValueError, match=says):
        _training(tmp_path, listening=0.1, **options)


def test_a_run_with_the_biases_trains_and_its_update_moves_the_parameters(tmp_path):
    run = _training(tmp_path, listening=0.1, signalling=0.1)
    before = [p.detach().clone() for p in run.agent.parameters()]
    run.iterate(1, 0.0)
    moved = [not torch.equal(a, p) for a, p in zip(before, run.agent.parameters(), strict=True)]
    assert all(moved[:2]) and np.mean(moved) > 0.5
