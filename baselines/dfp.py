"""Direct Future Prediction (Dosovitskiy & Koltun, 2017) on a single-agent Flatland scenario,
as the paper trained it with the Keras implementation of flyyufelix.

The agent predicts, for every action, how its measurements (the scenario's counters read
from the env's ``info``: score, fruits and poisons on fruits_poisons) will change 1, 2, 4,
8, 16 and 32 steps ahead, and acts epsilon-greedily on the predicted change weighted by the
goal at every offset: [1, 1, -1] on fruits_poisons, as in the paper; elsewhere +1 on the
score and the sign of each item group's reward on its count (``default_goal``). Training is
supervised regression on the changes actually observed in a replay buffer; offsets that
would reach past the end of an episode are left out of the loss.

    python -m baselines.dfp --seed 0 --total-timesteps 250000
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np
import torch
import tyro
from torch import nn

import flatland_ma
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
    """Single-agent scenario to train on; its counters (``info_counters``) are the
    measurements."""
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
    measurement_scale: dict[str, float] = field(default_factory=dict)
    """Divisors of the measurements before they enter the network and the targets, by
    counter name (``--measurement-scale score 100 goal 1``); a counter not named keeps
    ``default_scale``: the score 100, every count 10, the paper's scales on fruits_poisons
    ("normalization of measurements"; the Keras implementation divides health by 30 and
    medkits by 10)."""
    goal: dict[str, float] = field(default_factory=dict)
    """Weights of the measurements' changes in the objective, the same at every offset, by
    counter name (``--goal score 1 fruits 1 poisons -1``); a counter not named keeps
    ``default_goal``'s weight: the paper's [1, 1, -1] on fruits_poisons. The Keras
    implementation repeats the goal over the offsets, as here."""
    offsets: tuple[int, ...] = (1, 2, 4, 8, 16, 32)
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


def default_goal(scenario: str, counters: tuple[str, ...]) -> dict[str, float]:
    """+1 on the score; on an item group's count, the sign of that group's reward (fruits
    +1, poisons -1: with the score, the paper's goal [1, 1, -1] on fruits_poisons); +1 on any
    other counter (``deliveries``, which the delivery zones reward)."""
    rewards = {item.name: item.reward for item in flatland_ma.load_scenario(scenario).items}
    return {name: float(np.sign(rewards[name])) if name in rewards else 1.0 for name in counters}


def default_scale(counters: tuple[str, ...]) -> dict[str, float]:
    """The score divided by 100, every count by 10: the paper's scales on fruits_poisons."""
    return {name: 100.0 if name == "score" else 10.0 for name in counters}


def by_counter(given: dict[str, float], default: dict[str, float], flag: str) -> dict:
    """``default`` with the entries of ``given`` over it; a name that is not a counter of the
    scenario is an error."""
    unknown = sorted(set(given) - set(default))
    if unknown:
        raise ValueError(f"{flag} names {unknown}; the scenario's counters: {list(default)}")
    return {**default, **given}


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


class Replay:
    """The replay memory: the last ``capacity`` transitions, each overwriting the oldest,
    with the measurements before and after each and the episode it belongs to."""

    def __init__(self, capacity: int, channels: int, rays: int, n_measurements: int):
        self.capacity = capacity
        self.observations = np.zeros((capacity, channels, rays), np.float32)
        self.measurements = np.zeros((capacity, n_measurements), np.float32)  # at the state
        self.next_measurements = np.zeros((capacity, n_measurements), np.float32)  # after
        self.actions = np.zeros(capacity, np.int64)
        self.episodes = np.zeros(capacity, np.int64)

    def store(self, step: int, x, m, next_m, action: int, episode: int) -> None:
        slot = step % self.capacity
        self.observations[slot] = x
        self.measurements[slot], self.next_measurements[slot] = m, next_m
        self.actions[slot], self.episodes[slot] = action, episode

    def sample(self, rng: np.random.Generator, written: int, offsets: np.ndarray, size: int):
        """A uniform minibatch of the ``written`` transitions so far: (index, targets,
        mask). For a transition j and offset tau, the target is m_{j+tau} - m_j, where
        m_{j+tau} is the measurement after transition j+tau-1; it counts only if that
        transition belongs to j's episode (offsets past the episode end are masked)."""
        capacity = self.capacity
        index = rng.integers(max(0, written - capacity), written - offsets[-1] + 1, size)
        ahead = (index[:, None] + offsets[None] - 1) % capacity
        index %= capacity
        targets = self.next_measurements[ahead] - self.measurements[index][:, None]
        same = self.episodes[ahead] == self.episodes[index][:, None]
        mask = np.repeat(same, self.measurements.shape[1], axis=1)
        return index, targets, mask  # targets: (B, offsets, M)


class Learner:
    """The network, its optimiser and input normaliser, the goal and the measurements'
    scale: how the agent acts (``act``, ``greedy``) and learns (``learn``)."""

    def __init__(self, args: Args, counters: tuple[str, ...], channels, rays, n_actions):
        self.args, self.counters, self.n_actions = args, counters, n_actions
        self.scale = np.array([args.measurement_scale[name] for name in counters], np.float32)
        self.offsets = np.array(args.offsets, np.int64)
        weights = np.array([args.goal[name] for name in counters], np.float32)
        self.goal = torch.from_numpy(np.tile(weights, len(self.offsets)))  # offset-major
        print(f"measurements {list(counters)}, goal {weights.tolist()}", flush=True)
        self.network = DFPNetwork(
            channels, rays, len(counters), len(self.offsets), n_actions, args.keras_head
        )
        self.optimizer = torch.optim.Adam(
            self.network.parameters(), lr=args.learning_rate, betas=(0.9, 0.999), fused=True
        )
        self.normalize = RunningNormalizer((channels, rays))

    def measure(self, info: dict) -> np.ndarray:
        return np.array([info[name] for name in self.counters], np.float32) / self.scale

    def epsilon(self, step: int) -> float:
        args = self.args
        annealed = max(0, step - args.learning_starts) / args.epsilon_steps
        return max(
            args.epsilon_end,
            args.epsilon_start - annealed * (args.epsilon_start - args.epsilon_end),
        )

    def act(self, x: np.ndarray, m: np.ndarray, step: int, rng: np.random.Generator) -> int:
        """Epsilon-greedy on goal . predicted change, per action (at random before
        ``learning_starts``); the normaliser learns from ``x``."""
        args, goal = self.args, self.goal
        x_t = torch.from_numpy(x)
        if args.normalize_inputs:
            self.normalize.update(x_t)
        if step < args.learning_starts or rng.random() < self.epsilon(step):
            return int(rng.integers(self.n_actions))
        with torch.no_grad():
            x_in = self.normalize(x_t[None]) if args.normalize_inputs else x_t[None]
            prediction = self.network(x_in, torch.from_numpy(m)[None], goal[None])[0]
        return int((prediction @ goal).argmax())

    def greedy(self, observation: np.ndarray, info: dict) -> int:
        x_t = torch.from_numpy(to_input(observation, self.args.use_depth))[None]
        m_t = torch.from_numpy(self.measure(info))[None]
        with torch.no_grad():
            x_in = self.normalize(x_t) if self.args.normalize_inputs else x_t
            return int((self.network(x_in, m_t, self.goal[None])[0] @ self.goal).argmax())

    def learn(self, replay: Replay, written: int, rng: np.random.Generator) -> None:
        """One step on a minibatch: the mean squared error of the taken action's
        predictions over the unmasked targets."""
        size = self.args.batch_size
        index, targets, mask = replay.sample(rng, written, self.offsets, size)
        s = torch.from_numpy(replay.observations[index])
        if self.args.normalize_inputs:
            s = self.normalize(s)
        prediction = self.network(
            s, torch.from_numpy(replay.measurements[index]), self.goal.expand(size, -1)
        )
        taken = prediction[torch.arange(size), torch.from_numpy(replay.actions[index])]
        error = (taken - torch.from_numpy(targets.reshape(size, -1))).square()
        weights = torch.from_numpy(mask.astype(np.float32))
        loss = (error * weights).sum() / weights.sum().clamp(min=1.0)
        self.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        self.optimizer.step()


def main(args: Args) -> dict:
    seed_everything(args.seed)
    rng = np.random.default_rng(args.seed)
    env = make_env(args.scenario)
    rays, n_actions = env.observation_space.shape[0], int(env.action_space.n)
    channels = input_channels(args.use_depth)
    observation, info = env.reset(seed=args.seed)
    counters = info_counters(info)
    # The run's JSON records the goal and scales used, defaults filled in.
    args = dataclasses.replace(
        args,
        goal=by_counter(args.goal, default_goal(args.scenario, counters), "--goal"),
        measurement_scale=by_counter(
            args.measurement_scale, default_scale(counters), "--measurement-scale"
        ),
    )
    log = RunLog(
        "dfp", args.csv or default_csv("dfp", args.scenario, args.seed), args.seed, args, counters
    )
    learner = Learner(args, counters, channels, rays, n_actions)
    replay = Replay(args.buffer_size, channels, rays, len(counters))

    x, m = to_input(observation, args.use_depth), learner.measure(info)
    episode, episode_return, start = 0, 0.0, time.perf_counter()
    for global_step in range(args.total_timesteps):
        action = learner.act(x, m, global_step, rng)
        observation, reward, terminated, truncated, info = env.step(action)
        next_m = learner.measure(info)
        replay.store(global_step, x, m, next_m, action, episode)
        episode_return += reward
        x, m = to_input(observation, args.use_depth), next_m
        if terminated or truncated:
            log.episode(global_step + 1, episode_return, info)
            print(
                f"step={global_step + 1} return={episode_return:g} "
                f"{counters_text(info, counters)} epsilon={learner.epsilon(global_step):.3f}",
                flush=True,
            )
            episode, episode_return = episode + 1, 0.0
            observation, info = env.reset()
            x, m = to_input(observation, args.use_depth), learner.measure(info)

        written = global_step + 1
        if written <= args.learning_starts or global_step % args.train_frequency:
            continue
        learner.learn(replay, written, rng)

    total = time.perf_counter() - start
    evaluation = evaluate_after_training(args, learner.greedy)
    summary = log.close(args.total_timesteps, env.seconds, evaluation=evaluation)
    print(
        f"done: {args.total_timesteps} steps in {total:.0f} s, "
        f"env {summary['env_share']:.1%} of it",
        flush=True,
    )
    env.close()
    return summary


if __name__ == "__main__":
    main(tyro.cli(Args, description=__doc__))
