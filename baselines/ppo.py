"""PPO with one set of parameters shared by every agent, on the batched env.

The run's worlds are one ``BatchedParallelEnv`` (``--shards K`` spreads them over K
processes): every agent of every world is one slot, one forward pass acts for all of them,
and every agent's experience trains the one policy. The network (``baselines.networks``) sees
what the agent observes, its own first-person image or map, and in a scenario with a
channel what it hears; it acts in ``Discrete`` moves, or ``MultiDiscrete`` moves and words
(one head per component). Agents whose observations differ (roles with other sensors, as in
``plate_relay`` or ``signal_rooms``) share it through one padded observation that names
each slot's role (``pad=True``, ``flatland_ma.envs.padding``); their actions must agree.
The update is CleanRL's PPO (clipped objective, GAE, value clipping, advantage
normalisation, annealed learning rate), its default settings unless stated.

Slots whose action the env does not use on a step are left out of the update: an agent
that finished while its world plays on (``infos["active"]`` False), and every slot of a
world being reset (NEXT_STEP mode: a truncated episode bootstraps from its last observation).

Options beyond CleanRL's, each off by default (``baselines.ppo_args.Args``): ``--preset``
(``baselines.ppo_presets``); ``--team-reward``, every agent learns from its world's summed
reward; ``--shaping W``, a potential-based term for delivery and goal tasks
(``baselines.shaping``); ``--novelty W``, an exploration bonus (``baselines.novelty``);
``--listening W``, ``--signalling W``, biases towards using the channel
(``baselines.channel_bias``); ``--anchor W``, a pull towards the ``--init-from`` policy
(``baselines.anchor``); ``--curriculum FILE`` (``baselines.curriculum``); ``--memory gru``,
``--frames K`` (``baselines.ppo_memory``); ``--resume`` (``baselines.ppo_resume``). The
log always keeps each agent's own, unshaped return.

Written beside the CSV log (``runs/ppo/<scenario>/seed_<seed>.csv``, one row per agent and
episode): the final checkpoint ``seed_<seed>.safetensors`` (the network's weights, its
JSON description and the optimiser's state: ``flatland_ma.policies.checkpoint``), and in
``seed_<seed>/`` a checkpoint every ``--checkpoint-every`` updates and the TensorBoard
events. ``flatland-ma record SCENARIO --policy seed_0.safetensors`` plays a checkpoint.

    python -m baselines.ppo --scenario fruits_poisons_multi --seed 0 --total-timesteps 1000000
"""

from __future__ import annotations

import os
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
import torch
import tyro

from baselines.anchor import anchor
from baselines.buffers import keep_freed_memory
from baselines.channel_bias import channel_bias
from baselines.common import (
    RunLog,
    calibration,
    cpu_seconds,
    default_csv,
    seed_everything,
    threads_used,
)
from baselines.curriculum import (
    Stage,
    curriculum_stages,
    partner_policies,
    stage_ends,
    stages_record,
)
from baselines.networks import Agent, network_options
from baselines.novelty import for_run, kept_with
from baselines.ppo_args import Args
from baselines.ppo_episodes import Episodes
from baselines.ppo_learner import Overlapped, Rollout, critic_only
from baselines.ppo_memory import MemoryRollout
from baselines.ppo_presets import with_preset
from baselines.ppo_resume import Resumed, progress, prune, start_from
from baselines.shaping import learning_reward
from baselines.writer import Scalars
from flatland_ma.envs.shards import ShardedParallelEnv
from flatland_ma.envs.vector import BatchedParallelEnv
from flatland_ma.policies.checkpoint import SUFFIX, write_checkpoint


def batched_env(args: Args, stage: Stage | None = None):
    """The run's worlds: of ``args.scenario``, or of a curriculum's ``stage``."""
    if stage is not None:
        if args.shards > 1:
            raise ValueError("a curriculum runs in one process: no --shards")
        spec = stage.spec
        if args.no_channel:  # every stage without it, validated again
            spec = type(spec).model_validate({**dict(spec), "channel": None})
        return BatchedParallelEnv(spec, num_worlds=args.num_envs, copy=False, pad=True)
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


def learner_slots(args: Args, env, stage: Stage | None = None) -> np.ndarray:
    """Which of ``env``'s slots learn: every one, those of the team ``args.learners``
    (``ValueError`` naming the scenario's teams if it has no such team), or a curriculum
    stage's focal agents."""
    m = env.agents_per_world
    if args.learners and args.curriculum:
        raise ValueError("--learners trains one team of one scenario: not with --curriculum")
    if stage is not None and stage.focal is not None:
        own = np.zeros(m, bool)
        own[list(stage.focal)] = True
        return np.tile(own, env.num_slots // m)
    if not args.learners:
        return np.ones(env.num_slots, bool)
    teams = [team.name for team in env.spec.teams or ()]
    if args.learners not in teams:
        raise ValueError(
            f"--learners {args.learners}: {args.scenario} has no such team"
            + (f" (its teams: {', '.join(teams)})" if teams else " (it has no teams)")
        )
    own = [env.spec.team_of(j).name == args.learners for j in range(m)]
    return np.tile(np.array(own, bool), env.num_slots // m)


def run_iterations(args: Args, stages: list[Stage], env, learns: np.ndarray, total: int) -> int:
    """Updates in the run: the budget over the agent-steps an update collects; with
    stages where only some agents learn, each stage's own steps over its own."""
    if not any(stage.focal is not None for stage in stages):
        return max(1, total // (int(learns.sum()) * args.num_steps))
    per_update = [int(learner_slots(args, env, stage).sum()) * args.num_steps for stage in stages]
    return max(1, sum(-(-stage.steps // n) for stage, n in zip(stages, per_update, strict=True)))


def trained_with(args: Args, stages: list[Stage]) -> list[str]:
    """Who the policy played beside in training: itself, random play (``--learners``)
    and any curriculum stage's background policy."""
    partners = sorted({stage.background for stage in stages if stage.background})
    return ["self", *(["random"] if args.learners else []), *partners]


def run_name(args: Args) -> str:
    """The run's folder under runs/ppo/: the scenario, and whether its channel was off."""
    return args.scenario + ("-no-channel" if args.no_channel else "")


def main(args: Args) -> dict:
    args = with_preset(args)
    if args.overlap and (args.memory != "none" or args.frames > 1):
        raise ValueError(
            "--overlap collects with feed-forward policies only (no --memory, --frames)"
        )
    if args.critic_warmup < 0 or (args.critic_warmup and args.overlap):
        raise ValueError("--critic-warmup N: N >= 0 updates, and not with --overlap")
    setup_cpu, load_start = cpu_seconds(), os.getloadavg()
    calibrated = calibration()  # before the run's CPU time starts: not counted in it
    seed_everything(args.seed)
    torch.set_num_threads(args.torch_threads)
    keep_freed_memory()
    run = Training(args)
    if run.overlapped is not None:
        print("overlap: each rollout is acted by the policy of one update before", flush=True)
    start, cpu_start = run.started = time.perf_counter(), cpu_seconds()
    for iteration in range(run.first_iteration, run.iterations + 1):
        run.iterate(iteration, start)
    return run.finish(start, cpu_start, cpu_start - setup_cpu, (load_start, calibrated))


class Training:
    """One run: its worlds, network, optimiser, rollouts and log (``__init__``, the
    start-up), an update at a time (``iterate``), and its end (``finish``)."""

    def __init__(self, args: Args):
        self.args = args
        self.stages = curriculum_stages(args.curriculum) if args.curriculum else []
        total_timesteps = sum(s.steps for s in self.stages) if self.stages else args.total_timesteps
        self.csv_path = Path(args.csv or default_csv("ppo", run_name(args), args.seed))
        self.run_dir = self.csv_path.with_suffix("")
        self.resumed = resumed = Resumed.find(args, self.run_dir) if args.resume else None
        seed, self.stage = args.seed, 0
        if resumed is not None:  # new generators and episodes from here on
            seed, self.stage = resumed.seed(args.seed), len(resumed.began) - 1
            seed_everything(seed)
            torch.set_num_threads(args.torch_threads)
        stage = self.stages[self.stage] if self.stages else None
        self.env = env = batched_env(args, stage)
        self.learns = learner_slots(args, env, stage)
        """The slots that learn (all but with ``--learners`` or a stage's ``focal``)."""
        self.iterations = run_iterations(args, self.stages, env, self.learns, total_timesteps)
        # Start-up, outside the timed run: the first reset (numba's kernels compiled or read),
        # the network and the optimiser (its first import of torch's compiler takes a second).
        self.observation, infos = env.reset(seed=seed * args.num_envs)
        self.agent = agent = Agent(
            env.single_observation_space, env.single_action_space, **network_options(args, env)
        )
        self.optimizer = torch.optim.Adam(
            agent.parameters(), lr=args.learning_rate, eps=1e-5, fused=True
        )
        if resumed is not None:
            resumed.load(agent, self.optimizer)
        elif args.init_from:
            start_from(agent, args.init_from)
        # The numeric entries of the infos (not, e.g., the tuple of keys an agent holds).
        counters = tuple(k for k in infos if k != "active" and infos[k].dtype.kind in "iuf")
        self.overlapped = (
            Overlapped(agent, env, self.observation, args.num_steps, seed) if args.overlap else None
        )
        self.rollout = (MemoryRollout if agent.remembers else Rollout)(
            agent, env, self.observation, args.num_steps
        )
        self.space = env.single_observation_space
        """The first stage's observations, which the checkpoints describe."""
        self.novelty = novelty = for_run(args, env, self.observation, seed, resumed)
        bias = channel_bias(args, env, agent) or anchor(args, agent, self.iterations, resumed)
        for rollout in self.rollouts:
            rollout.novelty = novelty
            rollout.learns = self.learns
            rollout.background = np.random.default_rng([seed, 1])
            rollout.partners = partner_policies(env, stage, seed)
            rollout.bias = bias
        self.learn_from = learning_reward(args, env)
        self._bookkeeping(counters)

    @property
    def rollouts(self) -> list:
        """The rollouts the run collects into (two when collection overlaps the update)."""
        return [self.rollout, *(self.overlapped.rollouts if self.overlapped else [])]

    def _bookkeeping(self, counters: tuple[str, ...]) -> None:
        """The log, the scalars and the episodes' counts, from the start or from where the
        resumed run stood; where the run begins (its update, its clock)."""
        args, resumed = self.args, self.resumed
        going_on = None if resumed is None else (resumed.agent_steps, resumed.wall_seconds)
        self.log = RunLog("ppo", str(self.csv_path), args.seed, args, counters, going_on)
        self.scalars = Scalars(self.run_dir if args.tensorboard else None)
        self.episodes = Episodes(
            self.env.num_slots,
            self.env.agents_per_world,
            self.env.possible_agents,
            counters,
            self.log,
            self.scalars,
        )
        self.episodes.logged = self.learns[: self.env.agents_per_world].tolist()
        self.began = [0] if resumed is None else list(resumed.began)
        """The agent-step at which each stage of the curriculum began."""
        self.ends = stage_ends(self.stages, self.began)
        """The agent-step at which each stage's steps run out (``curriculum.stage_ends``)."""
        if self.stages:
            self.episodes.restart(self.stages[self.stage].over)
        self.first_iteration = 1 if resumed is None else resumed.update + 1
        self.started = (time.perf_counter(), cpu_seconds())
        """When and at what CPU time the timed run began (``main`` sets it)."""
        if resumed is not None:
            self.episodes.global_step = resumed.agent_steps
            self.episodes.episodes = resumed.episodes
            print(f"resumed from {resumed.path} at step={resumed.agent_steps}", flush=True)

    def next_stage(self) -> None:
        """The curriculum's next stage: its worlds, reset, and no episode under way."""
        args, step = self.args, self.episodes.global_step
        self.stage += 1
        self.env.close()
        self.env = batched_env(args, self.stages[self.stage])
        self.observation, _ = self.env.reset(seed=args.seed * args.num_envs)
        (self.overlapped or self.rollout).next_acting[:] = True
        stage = self.stages[self.stage]
        self.learns = learner_slots(args, self.env, stage)
        for rollout in self.rollouts:
            rollout.learns = self.learns
            rollout.partners = partner_policies(self.env, stage, args.seed * 1000 + self.stage)
        self.episodes.logged = self.learns[: self.env.agents_per_world].tolist()
        self.episodes.restart(stage.over)
        self.learn_from = learning_reward(args, self.env)
        self.began.append(step)
        self.ends = stage_ends(self.stages, self.began)
        print(f"step={step} curriculum stage {self.stages[self.stage].name}", flush=True)

    def iterate(self, iteration: int, start: float) -> None:
        """One rollout and the update on it (the learning rate annealed), its scalars, and
        every ``checkpoint_every`` updates a checkpoint."""
        args, overlapped, episodes = self.args, self.overlapped, self.episodes
        if self.stage + 1 < len(self.stages) and (
            episodes.global_step >= self.ends[self.stage]
            or self.stages[self.stage].reached(episodes.recent)
        ):
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
            with critic_only(self.agent, iteration <= args.critic_warmup):
                stats = self.rollout.learn(self.agent, self.optimizer, args)
        else:
            stats = overlapped.learn(self.agent, self.optimizer, args)
        sps = episodes.global_step / (time.perf_counter() - start)
        for key, value in {
            **stats,
            **(self.novelty.stats if self.novelty is not None else {}),
            "charts/learning_rate": lr,
            "charts/agent_steps_per_s": sps,
        }.items():
            self.scalars.add(key, value, episodes.global_step)
        if args.checkpoint_every and iteration % args.checkpoint_every == 0:
            if overlapped is not None:
                overlapped.wait()  # the checkpoint holds this iteration's update
            self.save(self.run_dir / f"update_{iteration:05d}{SUFFIX}", iteration)
            prune(self.run_dir, args.keep_checkpoints)

    def save(self, path: Path, update: int) -> None:
        args, (start, cpu_start), resumed = self.args, self.started, self.resumed
        before = (0.0, 0.0) if resumed is None else (resumed.cpu_seconds, resumed.wall_seconds)
        cpu, wall = before[0] + cpu_seconds() - cpu_start, before[1] + time.perf_counter() - start
        resumed_at = [] if resumed is None else resumed.resumed_at
        write_checkpoint(
            path,
            self.agent,
            scenario=args.scenario,
            observation_space=self.space,
            action_space=self.env.single_action_space,
            optimizer=kept_with(self.optimizer.state_dict(), self.novelty),
            extra={
                "algorithm": "ppo",
                # self-play: every slot is this policy, or its team beside random play
                "trained_with": trained_with(args, self.stages),
                "overrides": {"channel": None} if args.no_channel else {},
                "padded": self.env.padding is not None,
                "args": asdict(args),
                "update": update,
                "agent_steps": self.episodes.global_step,
                "progress": progress(self.episodes.episodes, cpu, wall, resumed_at, self.began),
            },
        )

    def finish(self, start: float, cpu_start: float, setup_cpu: float, machine_start) -> dict:
        """The final checkpoint, the log closed with the run's summary (its JSON), which
        is returned. ``machine_start``: the load average and the calibration (matrix
        products per CPU-second, ``common.calibration``) at the start, taken again here."""
        load_start, calibrated = machine_start
        overlapped, global_step = self.overlapped, self.episodes.global_step
        if overlapped is not None:
            overlapped.wait()
        self.save(self.csv_path.with_suffix(SUFFIX), self.iterations)
        self.scalars.close()
        self.env.close()
        before = 0.0 if self.resumed is None else self.resumed.cpu_seconds
        machine = {
            "cpu_seconds": round(before + cpu_seconds() - cpu_start, 2),
            "setup_cpu_seconds": round(setup_cpu, 2),
            "threads": threads_used(self.args.torch_threads),
            "policy_lag": 1 if overlapped is not None else 0,
            "load_average_start": [round(x, 2) for x in load_start],
            "load_average_end": [round(x, 2) for x in os.getloadavg()],
            "calibration_matmuls_per_second": [round(calibrated, 1), round(calibration(), 1)],
        }
        if self.resumed is not None:  # the earlier processes' share of the seconds above
            machine["resumed_at"] = self.resumed.resumed_at
            machine["earlier_seconds"] = {
                "cpu": self.resumed.cpu_seconds,
                "wall": self.resumed.wall_seconds,
            }
        if self.stages:
            machine["curriculum"] = stages_record(self.stages, self.began)
        busy = time.perf_counter() - start
        env_seconds = (overlapped or self.rollout).env_seconds
        summary = self.log.close(global_step, env_seconds, busy, extra=machine)
        print(
            f"done: {global_step} agent-steps in {time.perf_counter() - start:.0f} s "
            f"({machine['cpu_seconds']:.0f} s of CPU), env {summary['env_share']:.1%} of it",
            flush=True,
        )
        return summary


if __name__ == "__main__":
    main(tyro.cli(Args, description=__doc__))
