"""DQN on a single-agent Flatland scenario, as the paper trained it with keras-rl.

Double DQN (keras-rl's default) with a Boltzmann policy, soft target updates after every
training step, one update of 32 transitions per environment step once 1,500 warm-up steps
are in the replay buffer, and inputs whitened by a running mean and standard deviation.

    python -m baselines.dqn --seed 0 --total-timesteps 250000
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import torch
import torch.nn.functional as F
import tyro
from torch import nn

from baselines.common import (
    RunLog,
    RunningNormalizer,
    conv_trunk,
    counters_text,
    default_csv,
    evaluate_after_training,
    info_counters,
    input_channels,
    keras_init,
    make_env,
    seed_everything,
    to_input,
    trunk_length,
)


@dataclass
class Args:
    scenario: str = "fruits_poisons"
    """Single-agent scenario to train on (its Gymnasium id is registered by flatland_ma)."""
    seed: int = 0
    """Seeds torch, numpy and the environment (``reset(seed=seed)``)."""
    total_timesteps: int = 250_000
    """Environment steps to train for (the paper: 500 episodes of 500 steps)."""
    csv: str = ""
    """Where to write the episode log; empty means runs/dqn/<scenario>/seed_<seed>.csv."""
    use_depth: bool = False
    """Give the network the depth channel too; the paper's input is the (64, 3) colour image."""
    normalize_inputs: bool = True
    """Whiten inputs with a running per-element mean and std (the paper: "normalization of
    inputs"; keras-rl's WhiteningNormalizerProcessor), updated with every new observation."""
    learning_rate: float = 1e-3
    """Adam learning rate (the paper; betas 0.9, 0.999)."""
    buffer_size: int = 500_000
    """Replay buffer capacity (the paper). It never fills within 250k steps."""
    gamma: float = 0.99
    """Discount factor (the paper)."""
    tau: float = 0.01
    """Soft target update rate after every training step (the paper: 0.01)."""
    temperature: float = 1.0
    """Boltzmann (softmax) policy temperature (the paper: 1)."""
    batch_size: int = 32
    """Transitions per update (keras-rl's default; the paper does not say)."""
    learning_starts: int = 1500
    """Warm-up steps before the first update; the Boltzmann policy acts from the start, as in
    keras-rl (the paper: 1500)."""
    train_frequency: int = 1
    """Environment steps per update (keras-rl's default ``train_interval=1``)."""
    double_q: bool = True
    """Double DQN targets (keras-rl's default ``enable_double_dqn=True``)."""
    eval_episodes: int = 10
    """Episodes played after training by the final network (argmax Q, with ``eval_epsilon``),
    on env seeds training never used; their scores go into the run's JSON (0: none)."""
    eval_epsilon: float = 0.05
    """Exploration rate of that play: 0.05, the usual test-time rate since DQN's Atari
    evaluation. At 0 a reactive policy can stall for the rest of an episode (facing a wall,
    or turning back and forth)."""


class QNetwork(nn.Module):
    """The paper's DQN: Conv1D(32, 8) - Conv1D(48, 4) - Conv1D(64, 3) - MaxPool1D(2) -
    Dense(actions), ReLU after each convolution, Keras' initialisation."""

    def __init__(self, channels: int, rays: int, actions: int):
        super().__init__()
        self.trunk = conv_trunk(channels)
        self.pool = nn.MaxPool1d(2)
        self.head = nn.Linear(64 * (trunk_length(rays) // 2), actions)
        keras_init(self)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.head(self.pool(self.trunk(x)).flatten(1))


def boltzmann(q_values: np.ndarray, temperature: float, rng: np.random.Generator) -> int:
    """Sample an action with probability proportional to exp(Q / temperature)."""
    logits = q_values / temperature
    p = np.exp(logits - logits.max())
    return int(rng.choice(len(p), p=p / p.sum()))


class Replay:
    """The replay memory: the last ``capacity`` transitions, each overwriting the oldest."""

    def __init__(self, capacity: int, channels: int, rays: int):
        self.capacity = capacity
        self.observations = np.zeros((capacity, channels, rays), np.float32)
        self.next_observations = np.zeros((capacity, channels, rays), np.float32)
        self.actions = np.zeros(capacity, np.int64)
        self.rewards = np.zeros(capacity, np.float32)
        self.terminateds = np.zeros(capacity, np.float32)

    def store(self, step: int, x, next_x, action: int, reward: float, terminated: bool) -> None:
        """Step ``step``'s transition. The step limit is a truncation, not stored: the
        target bootstraps through it."""
        slot = step % self.capacity
        self.observations[slot], self.next_observations[slot] = x, next_x
        self.actions[slot], self.rewards[slot] = action, reward
        self.terminateds[slot] = float(terminated)

    def sample(self, rng: np.random.Generator, step: int, size: int) -> tuple[torch.Tensor, ...]:
        """A uniform minibatch of the transitions stored by step ``step``: (observations,
        next observations, actions, rewards, 1 - terminated)."""
        index = rng.integers(0, min(step + 1, self.capacity), size)
        return (
            torch.from_numpy(self.observations[index]),
            torch.from_numpy(self.next_observations[index]),
            torch.from_numpy(self.actions[index]),
            torch.from_numpy(self.rewards[index]),
            1.0 - torch.from_numpy(self.terminateds[index]),
        )


def learn(args: Args, q_network, target_network, optimizer, normalize, batch) -> None:
    """One double-DQN step on a minibatch, then a soft target update."""
    s, s_next, a, r, not_done = batch
    if args.normalize_inputs:
        s, s_next = normalize(s), normalize(s_next)
    with torch.no_grad():
        q_next_target = target_network(s_next)
        if args.double_q:
            a_next = q_network(s_next).argmax(1, keepdim=True)
        else:
            a_next = q_next_target.argmax(1, keepdim=True)
        # y = r + gamma * Q_target(s', a*), a* = argmax_a Q_online(s', a) (double DQN)
        y = r + args.gamma * not_done * q_next_target.gather(1, a_next).squeeze(1)
    q_taken = q_network(s).gather(1, a[:, None]).squeeze(1)
    loss = 0.5 * F.mse_loss(q_taken, y)  # keras-rl: Huber with infinite clip = 1/2 x^2
    optimizer.zero_grad(set_to_none=True)
    loss.backward()
    optimizer.step()
    with torch.no_grad():  # target <- (1 - tau) target + tau online
        for target_param, param in zip(target_network.parameters(), q_network.parameters()):
            target_param.lerp_(param, args.tau)


def main(args: Args) -> dict:
    seed_everything(args.seed)
    rng = np.random.default_rng(args.seed)
    env = make_env(args.scenario)
    rays, n_actions = env.observation_space.shape[0], int(env.action_space.n)
    channels = input_channels(args.use_depth)
    observation, info = env.reset(seed=args.seed)
    csv_path = args.csv or default_csv("dqn", args.scenario, args.seed)
    log = RunLog("dqn", csv_path, args.seed, args, info_counters(info))

    q_network = QNetwork(channels, rays, n_actions)
    target_network = QNetwork(channels, rays, n_actions)
    target_network.load_state_dict(q_network.state_dict())
    optimizer = torch.optim.Adam(
        q_network.parameters(), lr=args.learning_rate, betas=(0.9, 0.999), fused=True
    )
    normalize = RunningNormalizer((channels, rays))
    replay = Replay(min(args.buffer_size, args.total_timesteps), channels, rays)

    x = to_input(observation, args.use_depth)
    episode_return, start = 0.0, time.perf_counter()
    for global_step in range(args.total_timesteps):
        # Act: Boltzmann over the online network's Q-values.
        x_t = torch.from_numpy(x)
        if args.normalize_inputs:
            normalize.update(x_t)
        with torch.no_grad():
            q = q_network(normalize(x_t[None]) if args.normalize_inputs else x_t[None])[0]
        action = boltzmann(q.numpy(), args.temperature, rng)
        observation, reward, terminated, truncated, info = env.step(action)
        next_x = to_input(observation, args.use_depth)
        replay.store(global_step, x, next_x, action, reward, terminated)
        episode_return += reward
        x = next_x
        if terminated or truncated:
            log.episode(global_step + 1, episode_return, info)
            print(
                f"step={global_step + 1} return={episode_return:g} "
                + counters_text(info, log.counters),
                flush=True,
            )
            episode_return = 0.0
            observation, info = env.reset()
            x = to_input(observation, args.use_depth)
        if global_step + 1 < args.learning_starts or global_step % args.train_frequency:
            continue
        batch = replay.sample(rng, global_step, args.batch_size)
        learn(args, q_network, target_network, optimizer, normalize, batch)
    return finish(args, q_network, normalize, env, log, time.perf_counter() - start)


def finish(args: Args, q_network, normalize, env, log: RunLog, total: float) -> dict:
    """The final network's play after training, and the run's summary (its JSON)."""

    def greedy(observation: np.ndarray, info: dict) -> int:
        x_t = torch.from_numpy(to_input(observation, args.use_depth))[None]
        with torch.no_grad():
            return int(q_network(normalize(x_t) if args.normalize_inputs else x_t)[0].argmax())

    evaluation = evaluate_after_training(args, greedy)
    summary = log.close(args.total_timesteps, env.seconds, evaluation=evaluation)
    print(
        f"done: {args.total_timesteps} steps in {total:.0f} s "
        f"({1000 * total / args.total_timesteps:.2f} s per 1k steps), "
        f"env {summary['env_share']:.1%} of it",
        flush=True,
    )
    env.close()
    return summary


if __name__ == "__main__":
    main(tyro.cli(Args, description=__doc__))
