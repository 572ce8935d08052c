"""A3C on a single-agent Flatland scenario, as the paper trained it with
universe-starter-agent, and a synchronous A2C mode of the same loss.

``--mode a3c`` (the paper's): 5 actor-learner processes, each with its own environment,
its own copy of the network and its own Adam state, apply their gradients to one set of
parameters in shared memory without locks (Hogwild). Each syncs its copy, acts 20 steps,
and updates. Runs are not reproducible: the processes interleave as the OS schedules them.

``--mode a2c``: the same 5 environments stepped in lockstep in one process (5 worlds of the
batched env, one forward pass for all), one update of the same loss on all 5 x 20 steps;
reproducible from the seed. A world's step after its episode ends resets it and is left
out of the loss (the batched env's NEXT_STEP autoreset).

    python -m baselines.a3c --seed 0 --total-timesteps 250000
    python -m baselines.a3c --mode a2c --seed 0
"""

from __future__ import annotations

import queue
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import torch
import torch.multiprocessing as mp
import torch.nn.functional as F
import tyro
from torch import nn

from baselines.common import (
    RunLog,
    counters_text,
    default_csv,
    info_counters,
    input_channels,
    make_env,
    seed_everything,
    to_input,
)
from baselines.writer import Scalars
from flatland_ma.envs.vector import BatchedParallelEnv
from flatland_ma.policies.checkpoint import SUFFIX, write_checkpoint
from flatland_ma.policies.networks import ActorCritic


@dataclass
class Args:
    scenario: str = "fruits_poisons"
    """Single-agent scenario to train on."""
    seed: int = 0
    """Seeds torch and numpy; environment k of the run is reset with seed * num_workers + k."""
    total_timesteps: int = 250_000
    """Environment steps to train for, summed over all actor-learners."""
    csv: str = ""
    """Where to write the episode log; empty means runs/<mode>/<scenario>/seed_<seed>.csv."""
    mode: Literal["a3c", "a2c"] = "a3c"
    """a3c: asynchronous processes sharing parameters (Hogwild); a2c: synchronous, one process."""
    use_depth: bool = False
    """Give the network the depth channel too (the paper's input is the colour image)."""
    num_workers: int = 5
    """Actor-learners (the paper: 5 threads); in a2c mode, environments stepped together."""
    num_steps: int = 20
    """Steps between updates, t_max (the paper: 20)."""
    learning_rate: float = 1e-5
    """Adam learning rate (the paper; betas 0.9, 0.999)."""
    gamma: float = 0.99
    """Discount factor (the paper)."""
    ent_coef: float = 0.01
    """Entropy regularisation weight (the paper: 0.01)."""
    vf_coef: float = 0.5
    """Weight of the value loss 1/2 sum (R - V)^2 (universe-starter-agent's 0.5)."""
    max_grad_norm: float = 40.0
    """Gradients are clipped to this global norm (universe-starter-agent's 40)."""
    hidden: int = 128
    """Units of the fully connected layer that replaces the LSTM (the paper: 128)."""
    checkpoint_every: int = 500
    """a2c: save a checkpoint every this many updates (0: only the final one, which a3c
    saves too)."""
    tensorboard: bool = True
    """Write TensorBoard events beside the CSV."""


class Actors:
    """Worlds of the batched env stepped together, with their current inputs and running
    returns. World k of the run is reset with seed ``seed * num_workers + k`` and then
    continues its own generator, as a separate env would."""

    def __init__(self, args: Args, ranks: list[int]):
        self.env = BatchedParallelEnv(args.scenario, num_worlds=len(ranks), copy=False)
        if self.env.agents_per_world != 1:
            raise ValueError(f"{args.scenario} has several agents; A3C and A2C play one")
        self.use_depth, self.gamma = args.use_depth, args.gamma
        start = time.perf_counter()
        observation, infos = self.env.reset(seed=[args.seed * args.num_workers + k for k in ranks])
        self.seconds = time.perf_counter() - start
        self.counters = [k for k in infos if k != "active" and infos[k].dtype.kind in "iuf"]
        self.x = to_input(observation, self.use_depth)
        self.acting = np.ones(len(ranks), bool)
        """Whether the env uses each world's next action (not on the step that resets it)."""
        self.returns = np.zeros(len(ranks))

    def rollout(self, model: ActorCritic, num_steps: int, on_episode):
        """Act ``num_steps`` steps in every world; ``on_episode(steps_so_far, return, info)``
        is called at each episode end. Returns inputs (K, C, L), actions (K,) and the n-step
        returns (K,) of the K steps whose action the env used (a world's first step after
        its episode ended resets it instead), bootstrapped from V of the last state and
        through the step limit (a truncation), cut at terminations."""
        n = len(self.returns)
        inputs, actions = [], []
        rewards, dones, used = np.zeros((num_steps, n)), np.zeros((num_steps, n)), []
        steps = 0
        for t in range(num_steps):
            x = torch.from_numpy(self.x)
            with torch.no_grad():
                logits, _ = model(x)
            action = torch.distributions.Categorical(logits=logits).sample()
            inputs.append(x)
            actions.append(action)
            used.append(self.acting)
            tick = time.perf_counter()
            observation, reward, terminated, truncated, infos = self.env.step(action.numpy())
            self.seconds += time.perf_counter() - tick
            self.x = to_input(observation, self.use_depth)
            self.returns += reward
            rewards[t] = reward
            # r + gamma V(s_T) for a truncation: the episode goes on unseen. The observation
            # returned with it is the episode's last (the world resets on the next step).
            for e in np.flatnonzero(truncated & ~terminated):
                with torch.no_grad():
                    last = model(torch.from_numpy(self.x[e : e + 1]))[1]
                rewards[t, e] += self.gamma * float(last)
            done = terminated | truncated
            dones[t] = done
            for e in range(n):
                steps += int(self.acting[e])
                if done[e]:
                    on_episode(steps, self.returns[e], {k: infos[k][e] for k in self.counters})
                    self.returns[e] = 0.0
            self.acting = ~done
        with torch.no_grad():
            _, next_value = model(torch.from_numpy(self.x))
        # R_t = r_t + gamma (1 - done_t) R_{t+1}, with R_T = V(s_T)
        returns, running = np.zeros((num_steps, n)), next_value.numpy().astype(np.float64)
        for t in reversed(range(num_steps)):
            running = rewards[t] + self.gamma * (1.0 - dones[t]) * running
            returns[t] = running
        keep = torch.from_numpy(np.concatenate(used))
        return (
            torch.cat(inputs)[keep],
            torch.cat(actions)[keep],
            torch.from_numpy(returns.reshape(-1)).float()[keep],
        )

    @property
    def env_seconds(self) -> float:
        return self.seconds


def a2c_loss(model: ActorCritic, x, actions, returns, args: Args) -> torch.Tensor:
    """universe-starter-agent's loss, summed over the batch (advantage A = R - V(s)):
    -sum log pi(a|s) A  +  vf_coef * 1/2 sum (R - V(s))^2  -  ent_coef * sum H(pi(.|s))."""
    logits, values = model(x)
    log_probs = F.log_softmax(logits, dim=-1)
    advantages = returns - values.detach()
    policy_loss = -(log_probs.gather(1, actions[:, None]).squeeze(1) * advantages).sum()
    value_loss = 0.5 * (returns - values).square().sum()
    entropy = -(log_probs.exp() * log_probs).sum()
    return policy_loss + args.vf_coef * value_loss - args.ent_coef * entropy


def worker(rank: int, args: Args, shape: tuple, shared_model: ActorCritic, steps, messages):
    """One A3C actor-learner: sync, act t_max steps, push gradients to the shared model."""
    seed_everything(args.seed * args.num_workers + rank)
    start = time.perf_counter()  # before the env's first reset, which its seconds include
    actors = Actors(args, [rank])
    model = ActorCritic(*shape)
    # Each actor-learner has its own Adam state, as in universe-starter-agent.
    optimizer = torch.optim.Adam(
        shared_model.parameters(), lr=args.learning_rate, betas=(0.9, 0.999), fused=True
    )

    def on_episode(offset, episode_return, info):
        messages.put(("episode", steps.value + offset, episode_return, dict(info)))

    while steps.value < args.total_timesteps:
        model.load_state_dict(shared_model.state_dict())
        x, actions, returns = actors.rollout(model, args.num_steps, on_episode)
        loss = a2c_loss(model, x, actions, returns, args)
        model.zero_grad(set_to_none=True)
        loss.backward()
        nn.utils.clip_grad_norm_(model.parameters(), args.max_grad_norm)
        for shared, local in zip(shared_model.parameters(), model.parameters()):
            shared.grad = local.grad
        optimizer.step()  # Hogwild: no lock around the shared parameters
        with steps.get_lock():
            steps.value += len(actions)
    messages.put(("done", rank, actors.env_seconds, time.perf_counter() - start))


def train_a3c(args: Args, log: RunLog, shape: tuple, out: Outputs):
    """Start the actor-learners, log their episodes; return (env seconds, busy seconds,
    the shared model)."""
    shared_model = ActorCritic(*shape)
    shared_model.share_memory()
    context = mp.get_context("spawn")
    steps, messages = context.Value("q", 0), context.Queue()
    processes = [
        context.Process(target=worker, args=(rank, args, shape, shared_model, steps, messages))
        for rank in range(args.num_workers)
    ]
    for process in processes:
        process.start()
    env_seconds, busy_seconds, finished, step = 0.0, 0.0, 0, 0
    while finished < args.num_workers:
        try:
            message = messages.get(timeout=5.0)
        except queue.Empty:
            if any(p.exitcode not in (None, 0) for p in processes):
                raise RuntimeError("an actor-learner process failed") from None
            continue
        if message[0] == "episode":
            # The shared counter when the episode ended, kept monotonic: under Hogwild the
            # actor-learners read it at slightly different moments.
            step = max(step, message[1])
            _, _, episode_return, info = message
            log.episode(step, episode_return, info)
            out.scalars.add("charts/episodic_return", episode_return, step)
            print(
                f"step={step} return={episode_return:g} {counters_text(info, log.counters)}",
                flush=True,
            )
        else:
            env_seconds, busy_seconds = env_seconds + message[2], busy_seconds + message[3]
            finished += 1
    for process in processes:
        process.join()
    return env_seconds, busy_seconds, shared_model


def train_a2c(args: Args, log: RunLog, shape: tuple, out: Outputs):
    """All actors in one process, one synchronous update per rollout; returns (env
    seconds, busy seconds, the model)."""
    start = time.perf_counter()
    model = ActorCritic(*shape)
    optimizer = torch.optim.Adam(
        model.parameters(), lr=args.learning_rate, betas=(0.9, 0.999), fused=True
    )
    out.optimizer = optimizer
    actors = Actors(args, list(range(args.num_workers)))
    global_step, update = 0, 0

    def on_episode(offset, episode_return, info):  # reads global_step when called
        log.episode(global_step + offset, episode_return, info)
        out.scalars.add("charts/episodic_return", episode_return, global_step + offset)
        print(
            f"step={global_step + offset} return={episode_return:g} "
            + counters_text(info, log.counters),
            flush=True,
        )

    while global_step < args.total_timesteps:
        x, actions, returns = actors.rollout(model, args.num_steps, on_episode)
        loss = a2c_loss(model, x, actions, returns, args)
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        nn.utils.clip_grad_norm_(model.parameters(), args.max_grad_norm)
        optimizer.step()
        global_step += len(actions)
        update += 1
        out.scalars.add("losses/loss", loss.item() / max(1, len(actions)), global_step)
        if args.checkpoint_every and update % args.checkpoint_every == 0:
            out.save(model, out.run_dir / f"update_{update:05d}{SUFFIX}", update, global_step)
    return actors.env_seconds, time.perf_counter() - start, model


TRAIN = {"a3c": train_a3c, "a2c": train_a2c}
"""Mode -> its training loop."""


class Outputs:
    """What a run writes beside its CSV: TensorBoard events and checkpoints in
    ``<csv without .csv>/``, the final checkpoint as ``<csv without .csv>.safetensors``
    (``flatland_ma.policies.checkpoint``: the network's weights and description, and in
    a2c mode the optimiser's state; in a3c mode each actor-learner keeps its own Adam
    state, which is not saved)."""

    def __init__(self, args: Args, csv_path: str, spaces: tuple):
        self.args, self.spaces = args, spaces
        self.optimizer: torch.optim.Optimizer | None = None
        """The optimiser whose state checkpoints keep (a2c), set by the training loop."""
        self.final = Path(csv_path).with_suffix(SUFFIX)
        self.run_dir = Path(csv_path).with_suffix("")
        self.scalars = Scalars(self.run_dir if args.tensorboard else None)

    def save(self, model: ActorCritic, path: Path, update: int | None, steps: int) -> None:
        write_checkpoint(
            path,
            model,
            scenario=self.args.scenario,
            observation_space=self.spaces[0],
            action_space=self.spaces[1],
            optimizer=None if self.optimizer is None else self.optimizer.state_dict(),
            extra={
                "algorithm": self.args.mode,
                "args": asdict(self.args),
                "update": update,
                "agent_steps": steps,
            },
        )


def main(args: Args) -> dict:
    train = TRAIN[args.mode]
    seed_everything(args.seed)
    probe = make_env(args.scenario)
    _, info = probe.reset(seed=args.seed)
    counters = info_counters(info)
    shape = (
        input_channels(args.use_depth),
        probe.observation_space.shape[0],
        int(probe.action_space.n),
        args.hidden,
    )
    spaces = (probe.observation_space, probe.action_space)
    probe.close()
    csv_path = args.csv or default_csv(args.mode, args.scenario, args.seed)
    log = RunLog(args.mode, csv_path, args.seed, args, counters)
    out = Outputs(args, csv_path, spaces)
    env_seconds, busy_seconds, model = train(args, log, shape, out)
    out.save(model, out.final, None, args.total_timesteps)
    out.scalars.close()
    summary = log.close(args.total_timesteps, env_seconds, busy_seconds)
    print(
        f"done: {args.total_timesteps} steps in {summary['wall_seconds']:.0f} s, "
        f"env {summary['env_share']:.1%} of the actors' time",
        flush=True,
    )
    return summary


if __name__ == "__main__":
    main(tyro.cli(Args, description=__doc__))
