"""PPO with one set of parameters shared by every agent, on the batched env.

The run's worlds are one ``BatchedParallelEnv`` (``--shards K`` spreads them over K
processes): every agent of every world is one slot, one forward pass acts for all of them,
and every agent's experience trains the one policy. The network (``baselines.networks``) sees
what the agent observes, its own first-person image or map, and in a scenario with a
channel what it hears; it acts in ``Discrete`` moves, or ``MultiDiscrete`` moves and words
(one head per component). Agents whose observations differ (roles with other sensors, as in
``plate_relay`` or ``signal_rooms``) share it through one padded observation that names
each slot's role (``pad=True``, ``flatland_ma.envs.padding``); their actions must agree.
The update is CleanRL's PPO (clipped objective, GAE, value clipping,
advantage normalisation, annealed learning rate), with its default settings unless stated.

Slots whose action the env does not use on a step are left out of the update: an agent
that finished while its world plays on (``infos["active"]`` False), and every slot of a
world being reset (the batched env resets in Gymnasium's NEXT_STEP mode). A truncated
episode bootstraps from the value of its last observation, which that mode returns.

Options beyond CleanRL's, each off by default: ``--preset NAME``, settings chosen for a
task (``baselines.ppo_presets``); ``--team-reward``, every agent learns from its world's
summed reward, and ``--shaping W``, a potential-based term for delivery and goal tasks
(``baselines.shaping``); ``--curriculum FILE``, the tasks of a stream file in turn
(``baselines.curriculum``); ``--memory gru`` and ``--frames K``, a policy with memory
(``baselines.ppo_memory``). The log always keeps each agent's own, unshaped return.

Written beside the CSV log (``runs/ppo/<scenario>/seed_<seed>.csv``, one row per agent and
episode): the final checkpoint ``seed_<seed>.safetensors`` (the network's weights, its
JSON description and the optimiser's state: ``flatland_ma.policies.checkpoint``), and in
``seed_<seed>/`` a checkpoint every ``--checkpoint-every`` updates and the TensorBoard
events (``tensorboard --logdir runs``). ``flatland-ma record SCENARIO --policy
seed_0.safetensors`` plays a checkpoint.

    python -m baselines.ppo --scenario fruits_poisons_multi --seed 0 --total-timesteps 1000000
"""

from __future__ import annotations

import os
import time
import warnings
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import torch
import tyro

from baselines.common import (
    RunLog,
    calibration,
    cpu_seconds,
    default_csv,
    input_channels,
    seed_everything,
)
from baselines.curriculum import Stage, curriculum_stages
from baselines.networks import Agent
from baselines.ppo_episodes import Episodes
from baselines.ppo_learner import Overlapped, Rollout, keep_freed_memory
from baselines.ppo_memory import MemoryRollout
from baselines.ppo_presets import with_preset
from baselines.shaping import learning_reward
from baselines.writer import Scalars
from flatland_ma.envs.shards import ShardedParallelEnv
from flatland_ma.envs.vector import BatchedParallelEnv
from flatland_ma.policies.checkpoint import SUFFIX, write_checkpoint


@dataclass
class Args:
    scenario: str = "fruits_poisons_multi"
    """Scenario to train on; any number of agents, all acting alike (observations that
    differ are padded to one, with each agent's role)."""
    no_channel: bool = False
    """Play the scenario without its channel (``channel: null``): nobody speaks or hears.
    The default log is then runs/ppo/<scenario>-no-channel/."""
    seed: int = 0
    """Seeds torch and numpy; world k of the batch is reset with seed * num_envs + k."""
    total_timesteps: int = 1_000_000
    """Agent-steps to train for, summed over all agents and worlds (steps that act)."""
    csv: str = ""
    """Where to write the episode log; empty means runs/ppo/<scenario>/seed_<seed>.csv."""
    use_depth: bool = False
    """Give the network the depth channel too (the paper's single-agent input is colour only)."""
    num_envs: int = 4
    """Worlds in the batched env; it has num_envs * agents slots."""
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
    """Units of the fully connected layer after the conv trunk (as A3C's)."""
    network: Literal["strided", "paper"] = "strided"
    """The conv trunk: "paper" is the paper's (stride 1, then MaxPool1D(2)); "strided"
    strides its first two convolutions by 4 and 2 (as the Nature DQN's trunk does), about
    6x less work per step for the same three layers' reach."""
    checkpoint_every: int = 50
    """Save a checkpoint every this many updates (0: only the final one)."""
    tensorboard: bool = True
    """Write TensorBoard events beside the CSV."""
    torch_threads: int = 1
    """Threads torch may use (checked at the end of the run; the JSON records it)."""
    overlap: bool = False
    """Collect the next rollout while the network updates on the last one, in a thread
    of its own: the rollout is acted by the parameters from before that update (a policy
    lag of one update, as APPO's), which the PPO ratio corrects for. With two cores, about
    twice the agent-steps per second of wall time."""
    shards: int = 1
    """Processes the worlds are spread over (1: all in this process)."""
    critic: Literal["local", "state"] = "local"
    """What the value reads: "local", the agent's own observation (through the policy's
    layers); "state", a centralised critic of its own on the world's global state and
    which agent of the world the slot is (MAPPO)."""
    preset: str = ""
    """Named settings for a task (``baselines.ppo_presets``), applied to every option left
    at its default; empty: none."""
    team_reward: bool = False
    """Every agent learns from its team's reward, the sum of its world's rewards (the log
    keeps each agent's own return)."""
    shaping: float = 0.0
    """Weight of the potential-based shaping term (``baselines.shaping``); 0: none. The log
    keeps the scenario's return."""
    shaping_potential: Literal["auto", "delivery", "goal"] = "auto"
    """What the shaping measures: "delivery", the object's way to its zone and the agent's
    to the object; "goal", the whole way the agent still has to walk to a paying thing;
    "auto", delivery where the scenario has deliveries, else goal."""
    shaping_gamma: float = -1.0
    """The shaping term's discount, ``W (shaping_gamma Phi(s') - Phi(s))``: below 0, the
    learner's ``gamma`` (the optimal policies stay as they were); 1, the plain progress
    towards the target each step, without the bonus ``(1 - gamma) |Phi|`` a step that the
    learner's gamma pays for being far away."""
    curriculum: str = ""
    """A stream file whose tasks the run trains on in turn (``baselines.curriculum``), for
    their steps in all (``total_timesteps`` is then not used); empty: ``scenario`` alone."""
    memory: Literal["none", "gru"] = "none"
    """The policy's recurrent core: "gru", a one-layer GRU of ``memory_size`` units after
    the fully connected layer, its state carried through each episode and trained on whole
    sequences of slots (``baselines.ppo_memory``; minibatches of slots, so at most
    ``num_envs * agents`` of them); "none", a feed-forward policy."""
    memory_size: int = 128
    """Units of the recurrent core."""
    frames: int = 1
    """How many of its last observations the policy reads at once (a frame stack, the
    first observation repeated at an episode's start); 1: the current one alone."""


def batched_env(args: Args, stage: Stage | None = None):
    """The run's worlds: of ``args.scenario``, or of a curriculum's ``stage``."""
    if stage is not None:
        if args.no_channel or args.shards > 1:
            raise ValueError(
                "a curriculum runs in one process, and says channel: null in its overrides"
            )
        return BatchedParallelEnv(stage.spec, num_worlds=args.num_envs, copy=False, pad=True)
    # Agents whose observations differ (roles with other sensors) share the network
    # through one padded space that names each slot's role (flatland_ma.envs.padding).
    overrides: dict = {"pad": True}
    if args.no_channel:
        overrides["channel"] = None
    if args.shards > 1:
        return ShardedParallelEnv(
            args.scenario, args.num_envs, shards=args.shards, copy=False, **overrides
        )
    return BatchedParallelEnv(args.scenario, num_worlds=args.num_envs, copy=False, **overrides)


def run_name(args: Args) -> str:
    """The run's folder under runs/ppo/: the scenario, and whether its channel was off."""
    return args.scenario + ("-no-channel" if args.no_channel else "")


def main(args: Args) -> dict:
    args = with_preset(args)
    if args.overlap and (args.memory != "none" or args.frames > 1):
        raise ValueError(
            "--overlap collects with feed-forward policies only (no --memory, --frames)"
        )
    setup_cpu, load_start = cpu_seconds(), os.getloadavg()
    calibrated = calibration()  # before the run's CPU time starts: not counted in it
    seed_everything(args.seed)
    torch.set_num_threads(args.torch_threads)
    keep_freed_memory()
    run = Training(args)
    if run.overlapped is not None:
        print("overlap: each rollout is acted by the policy of one update before", flush=True)
    start, cpu_start = time.perf_counter(), cpu_seconds()
    for iteration in range(1, run.iterations + 1):
        run.iterate(iteration, start)
    return run.finish(start, cpu_start, cpu_start - setup_cpu, (load_start, calibrated))


class Training:
    """One run: its worlds, network, optimiser, rollouts and log (``__init__``, the
    start-up), an update at a time (``iterate``), and its end (``finish``)."""

    def __init__(self, args: Args):
        self.args = args
        self.stages = curriculum_stages(args.curriculum) if args.curriculum else []
        total_timesteps = sum(s.steps for s in self.stages) if self.stages else args.total_timesteps
        self.ends = np.cumsum([s.steps for s in self.stages])
        self.stage = 0
        self.env = env = batched_env(args, self.stages[0] if self.stages else None)
        self.iterations = max(1, total_timesteps // (env.num_slots * args.num_steps))
        self.csv_path = Path(args.csv or default_csv("ppo", run_name(args), args.seed))
        self.run_dir = self.csv_path.with_suffix("")
        # Start-up, outside the timed run: the first reset (numba's kernels, compiled or read
        # from their cache), the network and the optimiser (its first import of torch's
        # compiler takes a second or more).
        self.observation, infos = env.reset(seed=args.seed * args.num_envs)
        self.agent = agent = Agent(
            env.single_observation_space,
            env.single_action_space,
            args.hidden,
            input_channels(args.use_depth),
            args.network,
            state_size=env.single_state_space.shape[0] + env.agents_per_world
            if args.critic == "state"
            else 0,
            memory=args.memory,
            memory_size=args.memory_size,
            frames=args.frames,
        )
        self.optimizer = torch.optim.Adam(
            agent.parameters(), lr=args.learning_rate, eps=1e-5, fused=True
        )
        # The numeric entries of the infos (not, e.g., the tuple of keys an agent holds).
        counters = tuple(k for k in infos if k != "active" and infos[k].dtype.kind in "iuf")
        self.log = RunLog("ppo", str(self.csv_path), args.seed, args, counters)
        self.scalars = Scalars(self.run_dir if args.tensorboard else None)
        self.overlapped = (
            Overlapped(agent, env, self.observation, args.num_steps, args.seed)
            if args.overlap
            else None
        )
        self.rollout = (MemoryRollout if agent.remembers else Rollout)(
            agent, env, self.observation, args.num_steps
        )
        self.space = env.single_observation_space
        """The first stage's observations, which the checkpoints describe."""
        self.learn_from = learning_reward(args, env)
        self.episodes = Episodes(
            env.num_slots,
            env.agents_per_world,
            env.possible_agents,
            counters,
            self.log,
            self.scalars,
        )
        self.began = [0]
        """The agent-step at which each stage of the curriculum began."""

    def next_stage(self) -> None:
        """The curriculum's next stage: its worlds, reset, and no episode under way."""
        args, step = self.args, self.episodes.global_step
        self.stage += 1
        self.env.close()
        self.env = batched_env(args, self.stages[self.stage])
        self.observation, _ = self.env.reset(seed=args.seed * args.num_envs)
        (self.overlapped or self.rollout).next_acting[:] = True
        self.episodes.restart()
        self.learn_from = learning_reward(args, self.env)
        self.began.append(step)
        print(f"step={step} curriculum stage {self.stages[self.stage].name}", flush=True)

    def iterate(self, iteration: int, start: float) -> None:
        """One rollout and the update on it (the learning rate annealed), its scalars, and
        every ``checkpoint_every`` updates a checkpoint."""
        args, overlapped, episodes = self.args, self.overlapped, self.episodes
        if self.stage + 1 < len(self.stages) and episodes.global_step >= self.ends[self.stage]:
            self.next_stage()
        lr = args.learning_rate * (1 - (iteration - 1) / self.iterations)
        if overlapped is None:
            self.observation = self.rollout.collect(
                self.agent,
                self.env,
                self.observation,
                args.reward_scale,
                episodes.after_step,
                self.learn_from,
            )
        else:
            self.observation = overlapped.collect(
                self.env, self.observation, args.reward_scale, episodes.after_step, self.learn_from
            )
            overlapped.wait()  # the update under way keeps its own learning rate
        if args.anneal_lr:
            self.optimizer.param_groups[0]["lr"] = lr
        if overlapped is None:
            stats = self.rollout.learn(self.agent, self.optimizer, args)
        else:
            stats = overlapped.learn(self.agent, self.optimizer, args)
        sps = episodes.global_step / (time.perf_counter() - start)
        for key, value in {
            **stats,
            "charts/learning_rate": lr,
            "charts/agent_steps_per_s": sps,
        }.items():
            self.scalars.add(key, value, episodes.global_step)
        if args.checkpoint_every and iteration % args.checkpoint_every == 0:
            if overlapped is not None:
                overlapped.wait()  # the checkpoint holds this iteration's update
            self.save(self.run_dir / f"update_{iteration:05d}{SUFFIX}", iteration)

    def save(self, path: Path, update: int) -> None:
        args = self.args
        write_checkpoint(
            path,
            self.agent,
            scenario=args.scenario,
            observation_space=self.space,
            action_space=self.env.single_action_space,
            optimizer=self.optimizer.state_dict(),
            extra={
                "algorithm": "ppo",
                "trained_with": ["self"],  # self-play: every slot is this policy
                "overrides": {"channel": None} if args.no_channel else {},
                "padded": self.env.padding is not None,
                "args": asdict(args),
                "update": update,
                "agent_steps": self.episodes.global_step,
            },
        )

    def finish(self, start: float, cpu_start: float, setup_cpu: float, machine_start) -> dict:
        """The final checkpoint, the log closed with the run's summary (its JSON), which
        is returned. ``machine_start``: the load average and the calibration (matrix
        products per CPU-second, ``common.calibration``) at the start; both are taken
        again at the end."""
        load_start, calibrated = machine_start
        overlapped, global_step = self.overlapped, self.episodes.global_step
        if overlapped is not None:
            overlapped.wait()
        self.save(self.csv_path.with_suffix(SUFFIX), self.iterations)
        self.scalars.close()
        self.env.close()
        machine = {
            "cpu_seconds": round(cpu_seconds() - cpu_start, 2),
            "setup_cpu_seconds": round(setup_cpu, 2),
            "threads": threads_used(self.args.torch_threads),
            "policy_lag": 1 if overlapped is not None else 0,
            "load_average_start": [round(x, 2) for x in load_start],
            "load_average_end": [round(x, 2) for x in os.getloadavg()],
            "calibration_matmuls_per_second": [round(calibrated, 1), round(calibration(), 1)],
        }
        if self.stages:
            machine["curriculum"] = [
                {"name": s.name, "began": step} for s, step in zip(self.stages, self.began)
            ]
        busy = time.perf_counter() - start
        env_seconds = (overlapped or self.rollout).env_seconds
        summary = self.log.close(global_step, env_seconds, busy, extra=machine)
        print(
            f"done: {global_step} agent-steps in {time.perf_counter() - start:.0f} s "
            f"({machine['cpu_seconds']:.0f} s of CPU), env {summary['env_share']:.1%} of it",
            flush=True,
        )
        return summary


def threads_used(asked: int) -> dict:
    """The threads torch and the ray kernel use at the end of the run; warns if torch's
    differ from what the run asked for."""
    import numba

    used = {
        "torch": torch.get_num_threads(),
        "torch_asked": asked,
        "kernel": numba.get_num_threads(),
    }
    if used["torch"] != asked:
        warnings.warn(f"torch ran on {used['torch']} threads, not the {asked} asked", stacklevel=2)
    return used


if __name__ == "__main__":
    main(tyro.cli(Args, description=__doc__))
