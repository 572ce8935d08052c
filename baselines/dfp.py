"""Direct Future Prediction (Dosovitskiy & Koltun, 2017) on a single-agent Flatland scenario,
as the paper trained it with the Keras implementation of flyyufelix.

The agent predicts, for every action, how its measurements (score, fruits, poisons, read
from the env's ``info``) will change 1, 2, 4, 8, 16 and 32 steps ahead, and acts
epsilon-greedily on the predicted change weighted by the goal [1, 1, -1] at every offset.
Training is supervised regression on the changes actually observed in a replay buffer;
offsets that would reach past the end of an episode are left out of the loss.

    python -m baselines.dfp --seed 0 --total-timesteps 250000
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from baselines.common import (
    RunLog,
    RunningNormalizer,
    conv_trunk,
    default_csv,
    evaluate_after_training,
    input_channels,
    keras_init,
    make_env,
    parse_args,
    seed_everything,
    to_input,
    trunk_length,
)

MEASUREMENTS = ("score", "fruits", "poisons")
"""The paper's measurements, in the order of the goal."""


@dataclass
class Args:
    scenario: str = "fruits_poisons"
    """Single-agent scenario to train on; its infos must hold score, fruits and poisons."""
    seed: int = 0
    """Seeds torch, numpy and the environment (``reset(seed=seed)``)."""
    total_timesteps: int = 250_000
    """Environment steps to train for (the paper: 500 episodes of 500 steps)."""
    csv: str = ""
    """Where to write the episode log; empty means runs/dfp/<scenario>/seed_<seed>.csv."""
    use_depth: bool = False
    """Give the network the depth channel too (the paper's input is the colour image)."""
    normalize_inputs: bool = True
    """Whiten the image with a running per-element mean and std (the paper: "normalization
    of inputs"), as the DQN baseline does."""
    measurement_scale: str = "100,10,10"
    """Score, fruits and poisons are divided by these before they enter the network and the
    targets (the paper: "normalization of measurements"; the Keras implementation divides
    health by 30 and medkits by 10)."""
    goal: str = "1,1,-1"
    """Weights of the measurements' changes in the objective, the same at every offset (the
    paper's goal; the Keras implementation repeats it over the offsets)."""
    offsets: str = "1,2,4,8,16,32"
    """Temporal offsets of the predicted changes (the DFP paper and the Keras implementation)."""
    learning_rate: float = 1e-5
    """Adam learning rate (the paper; betas 0.9, 0.999)."""
    buffer_size: int = 20_000
    """Replay buffer capacity (the paper)."""
    learning_starts: int = 1000
    """Warm-up steps of random actions before training and annealing start (the paper)."""
    train_frequency: int = 3
    """Environment steps per training step (the paper: 3)."""
    batch_size: int = 32
    """Transitions per training step (the Keras implementation's 32)."""
    epsilon_start: float = 1.0
    """Initial exploration rate (the paper)."""
    epsilon_end: float = 1e-4
    """Final exploration rate (the paper)."""
    epsilon_steps: int = 300_000
    """Steps after the warm-up over which epsilon falls linearly to its end (the paper); at
    250k steps it is still about 0.17."""
    eval_episodes: int = 10
    """Episodes played after training by the final network (best action for the goal, with
    ``eval_epsilon``; training ends at epsilon 0.17 after 250k steps), on env seeds training
    never used; their scores go into the run's JSON (0: none)."""
    eval_epsilon: float = 0.05
    """Exploration rate of that play: 0.05, the usual test-time rate since DQN's Atari
    evaluation. At 0 a reactive policy can stall for the rest of an episode (facing a wall,
    or turning back and forth)."""
    keras_head: bool = False
    """Use the Keras implementation's output head: ReLU on the expectation and action
    streams, no normalisation. Off: the DFP paper's linear streams, each action stream
    minus their mean (a ReLU head cannot predict a falling score)."""


def floats(text: str) -> np.ndarray:
    return np.array([float(v) for v in text.split(",")], np.float32)


class DFPNetwork(nn.Module):
    """Perception: the paper's Conv1D(32, 8) - Conv1D(48, 4) - Conv1D(64, 3) - MaxPool1D(2),
    then the Keras implementation's Dense(512); measurements and goal: three Dense(128)
    each; then an expectation stream and one stream per action, each predicting every
    measurement at every offset. ReLU everywhere inside, Keras' initialisation."""

    def __init__(self, channels, rays, n_measurements, n_offsets, n_actions, keras_head):
        super().__init__()
        predictions, self.n_actions, self.keras_head = (
            n_measurements * n_offsets,
            n_actions,
            keras_head,
        )

        def dense_stack(inputs: int) -> nn.Sequential:
            return nn.Sequential(
                nn.Linear(inputs, 128),
                nn.ReLU(),
                nn.Linear(128, 128),
                nn.ReLU(),
                nn.Linear(128, 128),
                nn.ReLU(),
            )

        self.perception = nn.Sequential(
            conv_trunk(channels),
            nn.MaxPool1d(2),
            nn.Flatten(),
            nn.Linear(64 * (trunk_length(rays) // 2), 512),
            nn.ReLU(),
        )
        self.measurement = dense_stack(n_measurements)
        self.goal = dense_stack(predictions)
        self.expectation = nn.Linear(512 + 256, predictions)
        self.action = nn.Linear(512 + 256, n_actions * predictions)
        keras_init(self)

    def forward(self, x, measurement, goal) -> torch.Tensor:
        """Predicted changes, shape (batch, actions, offsets * measurements)."""
        h = torch.cat([self.perception(x), self.measurement(measurement), self.goal(goal)], 1)
        expectation = self.expectation(h)[:, None]
        action = self.action(h).view(len(h), self.n_actions, -1)
        if self.keras_head:
            return torch.relu(expectation) + torch.relu(action)
        return expectation + action - action.mean(1, keepdim=True)


def main(args: Args) -> dict:
    seed_everything(args.seed)
    rng = np.random.default_rng(args.seed)
    env = make_env(args.scenario)
    rays, n_actions = env.observation_space.shape[0], int(env.action_space.n)
    channels = input_channels(args.use_depth)
    scale, offsets = floats(args.measurement_scale), np.array(floats(args.offsets), np.int64)
    goal = torch.from_numpy(np.tile(floats(args.goal), len(offsets)))  # offset-major, as targets
    n_measurements = len(MEASUREMENTS)
    log = RunLog("dfp", args.csv or default_csv("dfp", args.scenario, args.seed), args.seed, args)

    network = DFPNetwork(channels, rays, n_measurements, len(offsets), n_actions, args.keras_head)
    optimizer = torch.optim.Adam(
        network.parameters(), lr=args.learning_rate, betas=(0.9, 0.999), fused=True
    )
    normalize = RunningNormalizer((channels, rays))

    capacity = args.buffer_size
    observations = np.zeros((capacity, channels, rays), np.float32)
    measurements = np.zeros((capacity, n_measurements), np.float32)  # at the state
    next_measurements = np.zeros((capacity, n_measurements), np.float32)  # after the action
    actions = np.zeros(capacity, np.int64)
    episodes = np.zeros(capacity, np.int64)

    def measure(info: dict) -> np.ndarray:
        return np.array([info[name] for name in MEASUREMENTS], np.float32) / scale

    observation, info = env.reset(seed=args.seed)
    x, m = to_input(observation, args.use_depth), measure(info)
    episode, episode_return, start = 0, 0.0, time.perf_counter()
    for global_step in range(args.total_timesteps):
        # Act: epsilon-greedy on goal . predicted change, per action.
        x_t = torch.from_numpy(x)
        if args.normalize_inputs:
            normalize.update(x_t)
        annealed = max(0, global_step - args.learning_starts) / args.epsilon_steps
        epsilon = max(
            args.epsilon_end,
            args.epsilon_start - annealed * (args.epsilon_start - args.epsilon_end),
        )
        if global_step < args.learning_starts or rng.random() < epsilon:
            action = int(rng.integers(n_actions))
        else:
            with torch.no_grad():
                x_in = normalize(x_t[None]) if args.normalize_inputs else x_t[None]
                prediction = network(x_in, torch.from_numpy(m)[None], goal[None])[0]
            action = int((prediction @ goal).argmax())
        observation, reward, terminated, truncated, info = env.step(action)
        next_m = measure(info)

        slot = global_step % capacity
        observations[slot], measurements[slot], next_measurements[slot] = x, m, next_m
        actions[slot], episodes[slot] = action, episode
        episode_return += reward
        x, m = to_input(observation, args.use_depth), next_m
        if terminated or truncated:
            log.episode(global_step + 1, episode_return, info)
            print(
                f"step={global_step + 1} return={episode_return:g} fruits={info['fruits']} "
                f"poisons={info['poisons']} epsilon={epsilon:.3f}",
                flush=True,
            )
            episode, episode_return = episode + 1, 0.0
            observation, info = env.reset()
            x, m = to_input(observation, args.use_depth), measure(info)

        written = global_step + 1
        if written <= args.learning_starts or global_step % args.train_frequency:
            continue
        # Learn. For a transition j and offset tau, the target is m_{j+tau} - m_j, where
        # m_{j+tau} is the measurement after transition j+tau-1; it counts only if that
        # transition belongs to j's episode (offsets past the episode end are masked).
        # Loss: mean squared error of the taken action's predictions over unmasked targets.
        index = rng.integers(max(0, written - capacity), written - offsets[-1] + 1, args.batch_size)
        ahead = (index[:, None] + offsets[None] - 1) % capacity
        index %= capacity
        targets = next_measurements[ahead] - measurements[index][:, None]  # (B, offsets, M)
        mask = np.repeat(episodes[ahead] == episodes[index][:, None], n_measurements, axis=1)
        s = torch.from_numpy(observations[index])
        if args.normalize_inputs:
            s = normalize(s)
        prediction = network(
            s, torch.from_numpy(measurements[index]), goal.expand(args.batch_size, -1)
        )
        taken = prediction[torch.arange(args.batch_size), torch.from_numpy(actions[index])]
        error = (taken - torch.from_numpy(targets.reshape(args.batch_size, -1))).square()
        weights = torch.from_numpy(mask.astype(np.float32))
        loss = (error * weights).sum() / weights.sum().clamp(min=1.0)
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        optimizer.step()

    total = time.perf_counter() - start

    def greedy(observation: np.ndarray, info: dict) -> int:
        x_t = torch.from_numpy(to_input(observation, args.use_depth))[None]
        m_t = torch.from_numpy(measure(info))[None]
        with torch.no_grad():
            x_in = normalize(x_t) if args.normalize_inputs else x_t
            return int((network(x_in, m_t, goal[None])[0] @ goal).argmax())

    evaluation = evaluate_after_training(args, greedy)
    summary = log.close(args.total_timesteps, env.seconds, evaluation=evaluation)
    print(
        f"done: {args.total_timesteps} steps in {total:.0f} s, "
        f"env {summary['env_share']:.1%} of it",
        flush=True,
    )
    env.close()
    return summary


if __name__ == "__main__":
    main(parse_args(Args))
