"""Policies with memory: frame stacks and a GRU core carried through each episode and
restarted at its first step, in training (``baselines.ppo_memory``: the rollout acts from
the states the update replays, sequences cut where episodes begin) and in play (the
checkpoint's ``CheckpointPolicy``, ``record --policy``, ``evaluate``); checkpoints of
such policies round-trip, and older checkpoints without the fields still load."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("safetensors")

from torch.utils._pytree import tree_map  # noqa: E402

from baselines.networks import Agent  # noqa: E402
from baselines.ppo import Args  # noqa: E402
from baselines.ppo_memory import MemoryRollout  # noqa: E402
from flatland_ma.cli import main  # noqa: E402
from flatland_ma.envs.vector import BatchedParallelEnv  # noqa: E402
from flatland_ma.policies.checkpoint import CheckpointPolicy, write_checkpoint  # noqa: E402
from flatland_ma.policies.memory import (  # noqa: E402
    Memory,
    each,
    gather_stacks,
    stack_frames,
    stack_indices,
)
from tests.checkpoint_helpers import rewrite_description  # noqa: E402
from tests.module_runner import run_module  # noqa: E402

SMALL: dict = {"hidden": 16, "memory_size": 8}
"""A small network: these tests check bookkeeping, not learning."""


def test_a_frame_stack_moves_on_by_one_and_restarts_with_the_first_frame_repeated():
    first = torch.tensor([[1.0], [2.0]])
    stack = stack_frames(first, None, None, 3)
    assert stack[:, :, 0].tolist() == [[1, 1, 1], [2, 2, 2]]
    stack = stack_frames(torch.tensor([[3.0], [4.0]]), stack, torch.tensor([0.0, 1.0]), 3)
    assert stack[:, :, 0].tolist() == [[1, 1, 3], [4, 4, 4]]  # row 1 began an episode
    both = stack_frames({"a": first, "b": first * 10}, None, None, 2)
    assert both["b"][:, :, 0].tolist() == [[10, 10], [20, 20]]


def test_stacks_rebuilt_from_single_frames_are_those_played():
    """T steps of 3 slots with episodes beginning at random steps, played one step at a
    time from stacks that already held frames: every step's stack, rebuilt from the
    frames before the rollout and its single frames, is the one the policy read."""
    rng = np.random.default_rng(0)
    k, steps, slots = 4, 30, 3
    frames = torch.as_tensor(rng.normal(size=(steps, slots, 2)), dtype=torch.float32)
    starts = torch.as_tensor(rng.random((steps, slots)) < 0.15, dtype=torch.float32)
    before = stack_frames(
        torch.as_tensor(rng.normal(size=(slots, 2)), dtype=torch.float32), None, None, k
    )
    before = stack_frames(torch.ones(slots, 2), before, None, k)  # a history that differs
    played, stack = [], before
    for t in range(steps):
        stack = stack_frames(frames[t], stack, starts[t], k)
        played.append(stack)
    kept = torch.cat([before[:, 1:].transpose(0, 1), frames])
    index = stack_indices(starts, k)
    for t in range(steps):
        rebuilt = gather_stacks(kept, index[t], torch.arange(slots))
        assert torch.equal(rebuilt, played[t]), t


def _short_env(scenario="fruits_poisons_multi", steps=4, worlds=2):
    env = BatchedParallelEnv(
        scenario, num_worlds=worlds, pad=True, copy=True, episode={"max_steps": steps}
    )
    observation, _ = env.reset(seed=0)
    return env, observation


def _collect(rollout, agent, env, observation, times=2):
    """``times`` rollouts (no update between them: the weights stay those that acted)."""
    for _ in range(times):
        observation = rollout.collect(agent, env, observation, 1.0, lambda *a: None)
    return observation


def _replayed(agent, rollout, starts):
    """The log-probabilities and values of the rollout's actions, every slot's whole
    sequence replayed at once from the rollout's initial state, its episodes beginning
    where ``starts`` says."""
    steps, slots = rollout.acting.shape
    if rollout.k > 1:
        rollout.index = stack_indices(starts, rollout.k)
    t = torch.arange(steps).repeat_interleave(slots)
    inputs = rollout.stacks(t, torch.arange(slots).repeat(steps))
    inputs = each(lambda x: x.unflatten(0, (steps, slots)), inputs)
    with torch.no_grad():
        h = agent.replay(inputs, rollout.initial, starts)
        _, logprob, _, value = agent.decide(h.flatten(0, 1), rollout.actions.flatten(0, 1))
    return logprob.view(steps, slots), value.view(steps, slots)


@pytest.mark.parametrize(
    ("scenario", "options"),
    [
        ("fruits_poisons_multi", {"memory": "gru"}),
        ("plate_relay", {"memory": "gru", "frames": 3}),  # a Dict observation, stacked
        ("fruits_poisons_multi", {"frames": 3}),
    ],
)
def test_the_update_replays_the_memory_each_step_acted_from(scenario, options):
    """Two rollouts of 4-step episodes (the second starts from the state the first left):
    a slot's episode begins two steps after the one that ended the last (the step between
    returns its final observation and resets its world), and the replay of every slot's
    sequence from the rollout's initial state, cut where episodes begin, gives the
    log-probability and value of every step as acting gave them."""
    torch.manual_seed(0)
    env, observation = _short_env(scenario)
    agent = Agent(env.single_observation_space, env.single_action_space, **SMALL, **options)
    rollout = MemoryRollout(agent, env, observation, 11)
    observation = _collect(rollout, agent, env, observation, times=1)
    bootstrap = rollout.next_value.clone()
    _collect(rollout, agent, env, observation, times=1)
    # The first rollout bootstrapped from the value the second's first step acted with.
    torch.testing.assert_close(bootstrap, rollout.values[0], atol=1e-6, rtol=1e-6)
    ends, starts = rollout.ends, rollout.starts
    assert ends.any() and torch.equal(starts[2:], ends[:-2])  # NEXT_STEP: one step between
    if agent.core is not None:
        assert rollout.initial.abs().sum() > 0  # carried over from the first rollout
    logprob, value = _replayed(agent, rollout, starts)
    torch.testing.assert_close(logprob, rollout.logprobs, atol=1e-5, rtol=1e-5)
    torch.testing.assert_close(value, rollout.values, atol=1e-5, rtol=1e-5)
    # Not cut at the starts, the replay reads other states after the first reset.
    uncut, _ = _replayed(agent, rollout, torch.zeros_like(starts))
    after = starts.nonzero()[0, 0]
    assert not torch.allclose(uncut[after:], rollout.logprobs[after:], atol=1e-5)
    env.close()


def test_a_slot_acts_at_its_episodes_first_step_as_a_fresh_policy_would():
    """The memory restarts at each episode's first step: there, every slot's action
    has the log-probability a policy with no memory gives it (which fails if the reset
    is missing, as the state carried from the last episode differs)."""
    torch.manual_seed(1)
    env, observation = _short_env()
    agent = Agent(env.single_observation_space, env.single_action_space, **SMALL, memory="gru")
    rollout = MemoryRollout(agent, env, observation, 12)
    _collect(rollout, agent, env, observation, times=1)
    steps, slots = rollout.starts.nonzero(as_tuple=True)
    assert (steps > 0).any()
    with torch.no_grad():
        h, _ = agent.step(rollout.observations[steps, slots])
        fresh = agent.decide(h, rollout.actions[steps, slots])[1]
        carried = torch.zeros(len(steps), agent.memory_size) + rollout.initial.mean() + 0.5
        features = rollout.observations[steps, slots]
        h_carried, _ = agent.step(features, Memory(None, carried), torch.zeros(len(steps)))
        other = agent.decide(h_carried, rollout.actions[steps, slots])[1]
    torch.testing.assert_close(fresh, rollout.logprobs[steps, slots], atol=1e-6, rtol=1e-6)
    assert not torch.allclose(other, fresh, atol=1e-5)  # a state does change the action
    env.close()


def test_one_update_over_sequences_runs_and_moves_the_weights():
    torch.manual_seed(2)
    env, observation = _short_env()
    args = Args(num_minibatches=4, update_epochs=2)
    agent = Agent(env.single_observation_space, env.single_action_space, **SMALL, memory="gru")
    optimizer = torch.optim.Adam(agent.parameters(), lr=1e-3)
    rollout = MemoryRollout(agent, env, observation, 8)
    _collect(rollout, agent, env, observation, times=1)
    before = [p.detach().clone() for p in agent.parameters()]
    stats = rollout.learn(agent, optimizer, args)
    assert all(np.isfinite(v) for v in stats.values()) and "losses/approx_kl" in stats
    assert all(not torch.equal(a, b) for a, b in zip(before, agent.parameters()))
    env.close()


def _checkpoint(tmp_path, env, **options):
    """A network with memory, its heads made sharp (so memory changes actions), saved."""
    torch.manual_seed(3)
    agent = Agent(env.single_observation_space, env.single_action_space, **SMALL, **options)
    with torch.no_grad():
        agent.actor.weight.mul_(300.0)
    path = write_checkpoint(
        tmp_path / "memory.safetensors",
        agent,
        scenario="fruits_poisons_multi",
        observation_space=env.single_observation_space,
        action_space=env.single_action_space,
        extra={"padded": env.padding is not None},
    )
    return agent, path


def _sequence(env, steps=6):
    """Each step's observation of slot 0 under random play."""
    env.single_action_space.seed(0)
    observation, _ = env.reset(seed=0)
    out = [tree_map(lambda x: x[0].copy(), observation)]
    for _ in range(steps - 1):
        actions = np.stack([env.single_action_space.sample() for _ in range(env.num_slots)])
        observation, *_ = env.step(actions)
        out.append(tree_map(lambda x: x[0].copy(), observation))
    return out


@pytest.mark.parametrize("options", [{"memory": "gru"}, {"frames": 4}])
def test_a_checkpoint_with_memory_plays_as_the_trained_network_and_forgets_on_reset(
    tmp_path, options
):
    env = BatchedParallelEnv("fruits_poisons_multi", num_worlds=1, pad=True, copy=True)
    agent, path = _checkpoint(tmp_path, env, **options)
    sequence = _sequence(env)
    memory, want = None, []
    with torch.no_grad():
        for x in sequence:
            h, memory = agent.step(torch.as_tensor(x)[None], memory)
            want.append(agent.actor(h)[0].double().numpy())
    policy = CheckpointPolicy(path, greedy=True)
    played = [policy.step_logits(x[None])[0] for x in sequence]
    np.testing.assert_allclose(played, want, rtol=1e-6, atol=1e-6)
    assert not np.allclose(played[-1], policy.logits(sequence[-1][None])[0])  # it remembers
    policy.reset()
    replayed = [policy.step_logits(x[None])[0] for x in sequence]
    np.testing.assert_allclose(replayed, want, rtol=1e-6, atol=1e-6)
    policy.reset()
    again = [policy.act(x) for x in sequence]
    assert again == [int(np.argmax(w)) for w in want]
    # Without the reset, the same observations meet what it remembers: other logits.
    assert not np.allclose(policy.step_logits(sequence[0][None])[0], want[0])
    env.close()


def test_a_checkpoint_written_before_memory_existed_loads_as_feed_forward(tmp_path):
    env = BatchedParallelEnv("fruits_poisons", num_worlds=1, copy=True)
    agent, path = _checkpoint(tmp_path, env)

    def older(description):
        for key in ("memory", "memory_size", "frames"):
            del description["network"]["arguments"][key]

    rewrite_description(path, older)
    policy = CheckpointPolicy(path)
    assert policy.data["network"]["arguments"]["frames"] == 1
    assert not policy.network.remembers
    observation = _sequence(env, 1)[0][None]
    with torch.no_grad():
        want = agent.logits(torch.as_tensor(observation)).double().numpy()
    np.testing.assert_allclose(policy.logits(observation), want, rtol=1e-6, atol=1e-6)
    env.close()


def _train(tmp_path, *options) -> Path:
    """Two updates of ``baselines.ppo`` on fruits_poisons_multi with ``options``; its
    final checkpoint."""
    csv = tmp_path / "seed_0.csv"
    run = ["--scenario", "fruits_poisons_multi", "--num-envs", "1", "--num-steps", "32"]
    run += ["--total-timesteps", "256", "--hidden", "32", "--checkpoint-every", "0"]
    run += ["--no-tensorboard", "--csv", str(csv), *options]
    result = run_module("baselines.ppo", *run)
    assert result.returncode == 0, result.stderr[-3000:]
    summary = json.loads(csv.with_suffix(".json").read_text())
    assert summary["steps"] == 256  # two updates of 4 agents x 32 steps
    return csv.with_suffix(".safetensors")


def test_ppo_trains_a_frame_stack_and_saves_it(tmp_path):
    path = _train(tmp_path, "--frames", "4")
    arguments = CheckpointPolicy(path).data["network"]["arguments"]
    assert (arguments["frames"], arguments["memory"]) == (4, "none")


def test_ppo_trains_a_gru_and_record_and_evaluate_play_it(tmp_path, capsys):
    pytest.importorskip("scipy")
    path = _train(tmp_path, "--memory", "gru", "--memory-size", "16")
    arguments = CheckpointPolicy(path).data["network"]["arguments"]
    assert (arguments["memory"], arguments["memory_size"]) == ("gru", 16)
    gif = tmp_path / "play.gif"
    assert main(["record", "fruits_poisons_multi", "--policy", str(path), "--steps", "20",
                 "--out", str(gif)]) == 0  # fmt: skip
    assert gif.stat().st_size > 1000
    suite = tmp_path / "tiny.yaml"
    suite.write_text(
        'description: "foraging"\ntasks:\n'
        "  - scenario: fruits_poisons_multi\n    focal: [agent_0]\n"
        "    background: [idle]\n    scripted: [planner]\n    episodes: 2\n"
        "    overrides: {episode: {max_steps: 30}}\n"
    )
    out = tmp_path / "report"
    assert main(["evaluate", str(path), "--suite", str(suite), "--out", str(out), "--no-plot"]) == 0
    result = json.loads((out / "evaluation.json").read_text())
    assert len(result["tasks"][0]["normalised"]) == 2  # two episodes, each scored


def test_the_studio_watch_plays_a_recurrent_checkpoint_with_its_memory(tmp_path):
    """Watch drives an agent by the checkpoint's ``act``: the same actions as the policy
    played by hand on the same observations, its memory carried from step to step."""
    import flatland_ma
    from flatland_ma.studio.episodes import Watch

    env = BatchedParallelEnv("fruits_poisons_multi", num_worlds=1, pad=True, copy=True)
    _, path = _checkpoint(tmp_path, env, memory="gru")
    env.close()
    watch = Watch(flatland_ma.load_scenario("fruits_poisons_multi"), 5, {"agent_0": str(path)})
    played, seen, chosen = watch.policies["agent_0"], [], []

    class Recorder:
        def act(self, observation):
            seen.append(observation)
            chosen.append(played.act(observation))
            return chosen[-1]

    watch.policies["agent_0"] = Recorder()
    for _ in range(12):
        watch.advance()
    by_hand = CheckpointPolicy(path, seed=5)  # the seed Watch gives agent_0
    assert chosen == [by_hand.act(observation) for observation in seen]
    # After the same steps both remember the same; a fresh policy reads the next otherwise.
    following = seen[-1][None]
    remembered = played.step_logits(following)
    np.testing.assert_allclose(remembered, by_hand.step_logits(following), rtol=1e-6, atol=1e-9)
    assert not np.allclose(remembered, played.logits(following))
    watch.close()


def test_a_replay_over_spans_is_the_same_as_stepping_one_step_at_a_time():
    """Episodes beginning at different steps in different rows: the core runs over the
    spans between them, and reads at each step the state stepping reaches."""
    from flatland_ma.policies.networks import BOX, PPONetwork

    torch.manual_seed(4)
    network = PPONetwork({BOX: (5,)}, [3], hidden=8, memory="gru", memory_size=6)
    observations = torch.randn(20, 3, 5)
    starts = torch.zeros(20, 3)
    starts[[3, 4, 11, 11, 17], [0, 2, 1, 2, 0]] = 1.0
    hidden = torch.randn(3, 6)
    memory, stepped = Memory(None, hidden), []
    with torch.no_grad():
        for t in range(20):
            h, memory = network.step(observations[t], memory, starts[t])
            stepped.append(h)
        replayed = network.replay(observations, hidden, starts)
    torch.testing.assert_close(replayed, torch.stack(stepped), atol=1e-6, rtol=1e-6)


def test_overlapped_collection_is_refused_for_a_policy_with_memory():
    from baselines.ppo import main as train

    with pytest.raises(ValueError, match="--overlap collects with feed-forward policies only"):
        train(Args(overlap=True, memory="gru"))
    with pytest.raises(ValueError, match="--overlap collects with feed-forward policies only"):
        train(Args(overlap=True, frames=2))
