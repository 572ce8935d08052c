"""The imitation probe with memory (baselines.benchmark.imitate --memory gru,
baselines.benchmark.imitate_rounds): a round is kept slot by slot with its episodes'
starts, the states training replays from are the ones the network acts from, the network
learns the solver's actions from sequences, and PPO goes on from it with its memory."""

from __future__ import annotations

import numpy as np
import torch

from baselines.benchmark import imitate
from baselines.benchmark.imitate_rounds import (
    collect_sequences,
    piece_states,
    round_length,
    train_sequences,
)
from flatland_ma.policies.checkpoint import CheckpointPolicy, load_checkpoint


def _worlds(scenario: str, worlds: int, seed: int = 0) -> imitate.Worlds:
    return imitate.Worlds(imitate.Args(scenario=scenario, worlds=worlds, seed=seed))


def _network(worlds: imitate.Worlds, hidden: int = 32, memory: int = 16) -> imitate.Agent:
    torch.manual_seed(0)
    return imitate.Agent(
        worlds.space, worlds.action_space, hidden, memory="gru", memory_size=memory
    )


def test_a_round_is_kept_slot_by_slot_with_its_episodes_starts():
    worlds = _worlds("key_door", 2, seed=2)
    try:
        got = collect_sequences(worlds, None, 1500, 777, 64)
    finally:
        worlds.close()
    seq = got["sequence"]
    length = round_length(worlds, 1500, 64)
    assert length % 64 == 0 and length * 2 >= 1500
    assert seq.starts.shape == seq.used.shape == (length, 2)
    assert seq.labels.shape[:2] == (length, 2)
    assert seq.starts[0].all() and seq.used.all()  # one agent a world: it always acts
    # each slot's episodes start where its world was reset: as many starts after the
    # first as episodes that ended, key_door's episodes ending on the goal or at 1000 steps
    assert int(seq.starts[1:].sum()) == len(got["returns"]) >= 2
    gaps = np.diff(np.flatnonzero(seq.starts[:, 0]))
    assert gaps.size and gaps.max() <= 1000
    # the solver's round plays as the feed-forward probe's: the same episodes, in order
    worlds = _worlds("key_door", 2, seed=2)
    try:
        steps = imitate.collect(worlds, None, 1500, 777)
    finally:
        worlds.close()
    first = min(len(steps["returns"]), len(got["returns"]))
    assert first >= 1 and steps["returns"][:first] == got["returns"][:first]


def test_training_replays_from_the_states_the_network_acts_from():
    worlds = _worlds("fruits_poisons", 2)
    network = _network(worlds)
    try:
        got = collect_sequences(worlds, network, 96, 0, 16)
    finally:
        worlds.close()
    seq = got["sequence"]
    assert got["agreement"] is not None and got["agreement"] < 1.0  # the network drove
    # step by step, as the network acts: the state after each step
    memory, hidden = None, []
    with torch.no_grad():
        for t in range(seq.starts.shape[0]):
            views = imitate.tree_map(lambda x, t=t: torch.from_numpy(x[t]), seq.views)
            h, memory = network.step(views, memory, torch.from_numpy(seq.starts[t]))
            hidden.append(h)
    stepped = torch.stack(hidden)  # (T, slots, memory_size)
    states = piece_states(network, [seq], 16)[0]
    before = torch.cat([torch.zeros_like(stepped[:1]), stepped[:-1]])
    torch.testing.assert_close(states, before[::16], atol=1e-5, rtol=1e-4)
    # a piece replayed from its state gives what the network read at each of its steps
    c = 32
    views = imitate.tree_map(lambda x: torch.from_numpy(x[c : c + 16]), seq.views)
    with torch.no_grad():
        replayed = network.replay(views, states[c // 16], torch.from_numpy(seq.starts[c : c + 16]))
    torch.testing.assert_close(replayed, stepped[c : c + 16], atol=1e-5, rtol=1e-4)


def test_the_recurrent_network_learns_the_solvers_actions():
    worlds = _worlds("fruits_poisons", 2)
    try:
        got = collect_sequences(worlds, None, 1024, 0, 32)
    finally:
        worlds.close()
    network = _network(worlds, 64, 64)
    optimizer = torch.optim.Adam(network.parameters(), lr=1e-3)
    labels = got["sequence"].labels.reshape(-1, got["sequence"].labels.shape[-1])
    shares = np.bincount(labels[:, 0]) / len(labels)
    marginal = -float((shares[shares > 0] * np.log(shares[shares > 0])).sum())
    args = imitate.Args(epochs=10, batch=128, sequence=32)
    loss = train_sequences(network, optimizer, [got["sequence"]], args, np.random.default_rng(0))
    assert loss < marginal - 0.1  # below the labels' own entropy, as the feed-forward probe


def test_a_recurrent_imitator_plays_and_ppo_goes_on_from_it_with_memory(tmp_path):
    path = tmp_path / "gru.safetensors"
    args = imitate.Args(
        scenario="fruits_poisons", worlds=2, rounds=1, steps=128, epochs=1, sequence=32,
        memory="gru", checkpoint=str(path), ppo_steps=2048,
    )  # fmt: skip
    figures = imitate.imitate(args)
    assert [r["driver"] for r in figures["rounds"]] == ["solver", "network"]
    per_slot = -(-args.steps // args.worlds)  # 64 steps of each world's one agent
    length = -(-per_slot // args.sequence) * args.sequence
    assert figures["rounds"][-1]["steps_kept"] == 2 * args.worlds * length  # two rounds
    description, _, _ = load_checkpoint(path)
    assert description["network"]["arguments"]["memory"] == "gru"
    assert len(figures["held_out_episodes"]) == 10  # played through CheckpointPolicy
    then = figures["then_ppo"]
    assert then["options"]["memory"] == "gru" and then["agent_steps"] >= 2048
    env = imitate.FlatlandParallelEnv("fruits_poisons")
    observations, _ = env.reset(seed=0)
    policy = CheckpointPolicy.for_agent(tmp_path / "gru_then_ppo.safetensors", env, "agent_0")
    assert env.action_space("agent_0").contains(np.asarray(policy.act(observations["agent_0"])))
    env.close()
