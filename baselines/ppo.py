"""PPO with one set of parameters shared by every agent of a multi-agent Flatland scenario.

Each agent of each copy of the PettingZoo parallel env is one slot of a SuperSuit vector
env; the network sees only that agent's own first-person image, so the policy is the same
for all and every agent's experience trains it. The log has one row per agent and episode.
The update is CleanRL's PPO (clipped objective, GAE, value clipping, advantage
normalisation, annealed learning rate), with its default settings unless stated.

    python -m baselines.ppo --scenario fruits_poisons_multi --seed 0 --total-timesteps 1000000
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import supersuit as ss
import torch
import tyro
from pettingzoo.utils.wrappers import BaseParallelWrapper
from torch import nn

import flatland_ma
from baselines.common import (
    RunLog,
    conv_trunk,
    default_csv,
    info_counters,
    input_channels,
    seed_everything,
    to_input,
    trunk_length,
)


@dataclass
class Args:
    scenario: str = "fruits_poisons_multi"
    """Scenario to train on; any number of agents, all with the same spaces."""
    seed: int = 0
    """Seeds torch and numpy; copy k of the env is reset with seed * num_envs + k."""
    total_timesteps: int = 1_000_000
    """Agent-steps to train for, summed over all agents and copies."""
    csv: str = ""
    """Where to write the episode log; empty means runs/ppo/<scenario>/seed_<seed>.csv."""
    use_depth: bool = False
    """Give the network the depth channel too (the paper's single-agent input is colour only)."""
    num_envs: int = 4
    """Copies of the parallel env; the vector env has num_envs * agents slots."""
    num_steps: int = 128
    """Steps per slot in each rollout (CleanRL's 128)."""
    learning_rate: float = 2.5e-4
    """Adam learning rate, annealed linearly to 0 (CleanRL's default)."""
    anneal_lr: bool = True
    """Anneal the learning rate (CleanRL's default)."""
    gamma: float = 0.99
    """Discount factor (as the paper's baselines)."""
    gae_lambda: float = 0.95
    """GAE lambda (CleanRL's default)."""
    num_minibatches: int = 4
    """Minibatches per epoch (CleanRL's default)."""
    update_epochs: int = 4
    """Epochs over each rollout (CleanRL's default)."""
    clip_coef: float = 0.2
    """PPO clipping coefficient, also used for the value (CleanRL's default)."""
    ent_coef: float = 0.01
    """Entropy bonus weight (CleanRL's default)."""
    vf_coef: float = 0.5
    """Value loss weight (CleanRL's default)."""
    max_grad_norm: float = 0.5
    """Gradients are clipped to this global norm (CleanRL's default)."""
    reward_scale: float = 0.1
    """Rewards are multiplied by this for learning (an item is worth +-1); the log keeps
    the unscaled returns."""
    hidden: int = 128
    """Units of the fully connected layer after the paper's conv trunk (as A3C's)."""


class FinalInfos(BaseParallelWrapper):
    """Empty infos on reset. SuperSuit merges an auto-reset's infos over the last step's,
    which would replace each agent's final counters with the new episode's zeros."""

    def reset(self, seed=None, options=None):
        observations, _ = self.env.reset(seed=seed, options=options)
        return observations, {agent: {} for agent in self.env.possible_agents}


def layer_init(layer: nn.Module, std: float = np.sqrt(2), bias: float = 0.0) -> nn.Module:
    nn.init.orthogonal_(layer.weight, std)
    nn.init.constant_(layer.bias, bias)
    return layer


class Agent(nn.Module):
    """The paper's conv trunk - MaxPool1D(2) - Dense(128), then policy and value heads;
    orthogonal initialisation as in CleanRL."""

    def __init__(self, channels: int, rays: int, actions: int, hidden: int):
        super().__init__()
        self.body = nn.Sequential(
            conv_trunk(channels),
            nn.MaxPool1d(2),
            nn.Flatten(),
            nn.Linear(64 * (trunk_length(rays) // 2), hidden),
            nn.ReLU(),
        )
        for layer in self.body.modules():
            if isinstance(layer, (nn.Conv1d, nn.Linear)):
                layer_init(layer)
        self.actor = layer_init(nn.Linear(hidden, actions), std=0.01)
        self.critic = layer_init(nn.Linear(hidden, 1), std=1.0)

    def value(self, x: torch.Tensor) -> torch.Tensor:
        return self.critic(self.body(x)).squeeze(-1)

    def act(self, x: torch.Tensor, action: torch.Tensor | None = None):
        h = self.body(x)
        distribution = torch.distributions.Categorical(logits=self.actor(h))
        if action is None:
            action = distribution.sample()
        return (
            action,
            distribution.log_prob(action),
            distribution.entropy(),
            self.critic(h).squeeze(-1),
        )


def main(args: Args) -> dict:
    seed_everything(args.seed)
    parallel = FinalInfos(flatland_ma.parallel_env(args.scenario))
    agents = list(parallel.possible_agents)
    probe = flatland_ma.parallel_env(args.scenario)
    counters = info_counters(probe.reset(seed=args.seed)[1][agents[0]])  # the same for all
    probe.close()
    vec = ss.concat_vec_envs_v1(
        ss.pettingzoo_env_to_vec_env_v1(parallel), args.num_envs, num_cpus=0, base_class="gymnasium"
    )
    slots, rays = vec.num_envs, vec.observation_space.shape[0]
    channels = input_channels(args.use_depth)
    batch_size = slots * args.num_steps
    minibatch_size = batch_size // args.num_minibatches
    iterations = max(1, args.total_timesteps // batch_size)
    csv_path = args.csv or default_csv("ppo", args.scenario, args.seed)
    log = RunLog("ppo", csv_path, args.seed, args, counters)

    agent = Agent(channels, rays, int(vec.action_space.n), args.hidden)
    optimizer = torch.optim.Adam(agent.parameters(), lr=args.learning_rate, eps=1e-5, fused=True)

    observations = torch.zeros((args.num_steps, slots, channels, rays))
    actions = torch.zeros((args.num_steps, slots), dtype=torch.long)
    logprobs, rewards, dones, values = (torch.zeros((args.num_steps, slots)) for _ in range(4))

    start = time.perf_counter()
    observation, _ = vec.reset(seed=args.seed * args.num_envs)
    env_seconds = time.perf_counter() - start
    next_x = torch.from_numpy(to_input(observation, args.use_depth))
    next_done = torch.zeros(slots)
    episode_returns, episodes, global_step = np.zeros(slots), 0, 0
    for iteration in range(1, iterations + 1):
        if args.anneal_lr:
            optimizer.param_groups[0]["lr"] = args.learning_rate * (
                1 - (iteration - 1) / iterations
            )
        for step in range(args.num_steps):
            global_step += slots
            observations[step], dones[step] = next_x, next_done
            with torch.no_grad():
                action, logprob, _, value = agent.act(next_x)
            actions[step], logprobs[step], values[step] = action, logprob, value
            tick = time.perf_counter()
            observation, reward, terminated, truncated, infos = vec.step(action.numpy())
            env_seconds += time.perf_counter() - tick
            terminated, truncated = terminated.astype(bool), truncated.astype(bool)
            done = terminated | truncated
            episode_returns += reward
            reward = torch.as_tensor(reward * args.reward_scale, dtype=torch.float32)
            for i in np.flatnonzero(truncated & ~terminated):
                # The step limit is a truncation: bootstrap, r + gamma V(s_T).
                final = to_input(infos[i]["terminal_observation"], args.use_depth)
                with torch.no_grad():
                    reward[i] += args.gamma * agent.value(torch.from_numpy(final)[None])[0]
            rewards[step] = reward
            next_x = torch.from_numpy(to_input(observation, args.use_depth))
            next_done = torch.as_tensor(done, dtype=torch.float32)
            for copy in sorted({i // len(agents) for i in np.flatnonzero(done)}):
                first, last = copy * len(agents), (copy + 1) * len(agents)
                for k, name in enumerate(agents):
                    log.episode(
                        global_step,
                        episode_returns[first + k],
                        infos[first + k],
                        agent=name,
                        episode=episodes,
                    )
                print(
                    f"step={global_step} episode={episodes} "
                    f"returns={episode_returns[first:last].tolist()}",
                    flush=True,
                )
                episode_returns[first:last] = 0.0
                episodes += 1

        # Generalised advantage estimation, per slot:
        #   delta_t = r_t + gamma V(s_{t+1}) (1 - done_{t+1}) - V(s_t)
        #   A_t = delta_t + gamma lambda (1 - done_{t+1}) A_{t+1},   R_t = A_t + V(s_t)
        with torch.no_grad():
            next_value = agent.value(next_x)
            advantages = torch.zeros_like(rewards)
            last = torch.zeros(slots)
            for t in reversed(range(args.num_steps)):
                not_done = 1.0 - (next_done if t == args.num_steps - 1 else dones[t + 1])
                following = next_value if t == args.num_steps - 1 else values[t + 1]
                delta = rewards[t] + args.gamma * following * not_done - values[t]
                advantages[t] = last = delta + args.gamma * args.gae_lambda * not_done * last
            returns = advantages + values

        # Clipped surrogate, clipped value loss, entropy bonus; ratio = pi(a|s) / pi_old(a|s):
        #   L = -min(ratio A, clip(ratio, 1 - eps, 1 + eps) A)
        #       + vf_coef * 1/2 max((V - R)^2, (V_old + clip(V - V_old, -eps, eps) - R)^2)
        #       - ent_coef * H
        b_x, b_actions = observations.reshape(-1, channels, rays), actions.reshape(-1)
        b_logprobs, b_advantages = logprobs.reshape(-1), advantages.reshape(-1)
        b_returns, b_values = returns.reshape(-1), values.reshape(-1)
        for _ in range(args.update_epochs):
            for index in torch.randperm(batch_size).split(minibatch_size):
                _, new_logprob, entropy, new_value = agent.act(b_x[index], b_actions[index])
                ratio = (new_logprob - b_logprobs[index]).exp()
                advantage = b_advantages[index]
                advantage = (advantage - advantage.mean()) / (advantage.std() + 1e-8)
                policy_loss = torch.max(
                    -advantage * ratio,
                    -advantage * ratio.clamp(1 - args.clip_coef, 1 + args.clip_coef),
                ).mean()
                clipped = b_values[index] + (new_value - b_values[index]).clamp(
                    -args.clip_coef, args.clip_coef
                )
                value_loss = (
                    0.5
                    * torch.max(
                        (new_value - b_returns[index]).square(),
                        (clipped - b_returns[index]).square(),
                    ).mean()
                )
                loss = policy_loss + args.vf_coef * value_loss - args.ent_coef * entropy.mean()
                optimizer.zero_grad(set_to_none=True)
                loss.backward()
                nn.utils.clip_grad_norm_(agent.parameters(), args.max_grad_norm)
                optimizer.step()

    summary = log.close(global_step, env_seconds)
    print(
        f"done: {global_step} agent-steps in {time.perf_counter() - start:.0f} s, "
        f"env {summary['env_share']:.1%} of it",
        flush=True,
    )
    vec.close()
    return summary


if __name__ == "__main__":
    main(tyro.cli(Args, description=__doc__))
